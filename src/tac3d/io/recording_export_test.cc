#include "tac3d/io/recording_export.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <gmock/gmock.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/testing/npy_reader.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::LoadNpy;

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kExportRows = 4, kExportCols = 5, kExportMarkers = kExportRows * kExportCols;

// Frame t of the test recording: synthetic 4 x 5, the lost marker's position and
// displacement NaN (as the pipeline leaves them), some flags, progress 50 on frame 0.
TactileFrame ExportFrame(int t) {
  TactileFrame f = MakeSyntheticTactileFrame("AD2-0065L", 100 + t, kExportRows, kExportCols);
  const std::size_t lost = static_cast<std::size_t>(f.index % kExportMarkers);
  f.positions_mm[lost] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  f.displacements_mm[lost] = f.positions_mm[lost];
  if (t == 0) {
    f.initialize_progress = 50;
    f.set(FrameFlag::kInitializing);
  }
  if (t == 3) f.set(FrameFlag::kForceOutOfRange);
  // A slip estimate on the frames after the first (the first keeps "unknown", NaNs).
  if (t > 0) {
    f.slip.state = t % 2 == 0 ? SlipState::kGrossSlip : SlipState::kPartialSlip;
    f.slip.fraction = 0.1 * t;
    f.slip.friction = 0.5 + 0.01 * t;
    f.slip.friction_sigma = 0.02;
    f.slip.margin = 0.3 - 0.01 * t;
    f.slip.margin_sigma = 0.05;
    f.slip.least_normal_force_n = 1.5 + t;
  }
  return f;
}

std::string WriteExportRecording(const std::string& path, int frames) {
  RecordingWriter writer(path);
  for (int t = 0; t < frames; ++t) {
    writer.Write(ExportFrame(t), t % 2 == 0 ? cv::Mat(6, 8, CV_8UC1, cv::Scalar(t)) : cv::Mat());
  }
  return path;
}

// Bit-exact equality, NaN equal to NaN.
bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void ExpectVectors(const testing::NpyArray& a,
                   int frames,
                   const std::vector<Eigen::Vector3d> TactileFrame::*field,
                   const char* name) {
  EXPECT_EQ(a.descr, "<f8") << name;
  EXPECT_FALSE(a.fortran_order) << name;
  ASSERT_EQ(a.shape, (std::vector<std::int64_t>{frames, kExportMarkers, 3})) << name;
  for (int t = 0; t < frames; ++t) {
    const TactileFrame f = ExportFrame(t);
    for (int i = 0; i < kExportMarkers; ++i) {
      for (int k = 0; k < 3; ++k) {
        ASSERT_TRUE(Same(a.at<double>((t * kExportMarkers + i) * 3 + k), (f.*field)[i][k]))
            << name << "[" << t << "][" << i << "][" << k << "]";
      }
    }
  }
}

std::vector<std::string> Lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  for (std::string field; std::getline(ss, field, ',');) fields.push_back(field);
  return fields;
}

std::vector<std::string> Listing(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(RecordingExport, NpyHoldsEveryFieldExactly) {
  const std::string dir = testing::MakeTempDir("export");
  const std::string rec = WriteExportRecording(dir + "/rec.tac3d", 7);
  const RecordingExportResult result = ExportRecording(rec, dir + "/out");
  EXPECT_EQ(result.frames, 7);
  EXPECT_EQ(result.rows, kExportRows);
  EXPECT_EQ(result.cols, kExportCols);
  EXPECT_EQ(result.status, RecordingStatus::kComplete);
  ASSERT_EQ(result.files.size(), 20u);
  EXPECT_EQ(result.images, 4);  // the even frames'
  auto names = RecordingExportFileNames(RecordingExportFormat::kNpy);
  names.push_back("images");
  std::sort(names.begin(), names.end());
  EXPECT_EQ(Listing(dir + "/out"), names);  // and no .tmp left

  const std::string out = dir + "/out/";
  ExpectVectors(LoadNpy(out + "positions_mm.npy"), 7, &TactileFrame::positions_mm, "positions");
  ExpectVectors(
      LoadNpy(out + "displacements_mm.npy"), 7, &TactileFrame::displacements_mm, "displacements");
  ExpectVectors(LoadNpy(out + "forces_n.npy"), 7, &TactileFrame::forces_n, "forces");
  ExpectVectors(LoadNpy(out + "normals.npy"), 7, &TactileFrame::normals, "normals");
  const auto valid = LoadNpy(out + "valid.npy");
  const auto contact = LoadNpy(out + "contact.npy");
  EXPECT_EQ(valid.descr, "|b1");
  EXPECT_EQ(valid.shape, (std::vector<std::int64_t>{7, kExportMarkers}));
  EXPECT_EQ(contact.shape, (std::vector<std::int64_t>{7, kExportMarkers}));
  const auto timestamp = LoadNpy(out + "timestamp_s.npy");
  const auto index = LoadNpy(out + "index.npy");
  const auto flags = LoadNpy(out + "flags.npy");
  const auto progress = LoadNpy(out + "initialize_progress.npy");
  const auto force = LoadNpy(out + "resultant_force_n.npy");
  const auto moment = LoadNpy(out + "resultant_moment_nmm.npy");
  EXPECT_EQ(timestamp.descr, "<f8");
  EXPECT_EQ(index.descr, "<i8");
  EXPECT_EQ(flags.descr, "<u4");
  EXPECT_EQ(progress.descr, "<i8");
  for (const auto* a : {&timestamp, &index, &flags, &progress}) {
    EXPECT_EQ(a->shape, (std::vector<std::int64_t>{7}));
  }
  EXPECT_EQ(force.shape, (std::vector<std::int64_t>{7, 3}));
  EXPECT_EQ(moment.shape, (std::vector<std::int64_t>{7, 3}));
  for (int t = 0; t < 7; ++t) {
    const TactileFrame f = ExportFrame(t);
    for (int i = 0; i < kExportMarkers; ++i) {
      EXPECT_EQ(valid.data[t * kExportMarkers + i], f.valid[i] ? 1 : 0) << t << " " << i;
      EXPECT_EQ(contact.data[t * kExportMarkers + i], f.contact[i] ? 1 : 0) << t << " " << i;
    }
    EXPECT_EQ(timestamp.at<double>(t), f.timestamp_s);
    EXPECT_EQ(index.at<std::int64_t>(t), f.index);
    EXPECT_EQ(flags.at<std::uint32_t>(t), f.flags);
    EXPECT_EQ(progress.at<std::int64_t>(t), f.initialize_progress);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(force.at<double>(t * 3 + k), f.resultant_force_n[k]);
      EXPECT_EQ(moment.at<double>(t * 3 + k), f.resultant_moment_nmm[k]);
    }
  }
  // The slip estimate and the images, every recorded field.
  const auto state = LoadNpy(out + "slip_state.npy");
  const auto has_image = LoadNpy(out + "has_image.npy");
  EXPECT_EQ(state.descr, "<u4");
  EXPECT_EQ(has_image.descr, "|b1");
  const std::pair<const char*, double FrameSlip::*> slip_fields[] = {
      {"slip_fraction.npy", &FrameSlip::fraction},   {"friction.npy", &FrameSlip::friction},
      {"friction_sigma.npy", &FrameSlip::friction_sigma}, {"margin.npy", &FrameSlip::margin},
      {"margin_sigma.npy", &FrameSlip::margin_sigma}, {"least_normal_force_n.npy", &FrameSlip::least_normal_force_n}};
  for (int t = 0; t < 7; ++t) {
    const TactileFrame f = ExportFrame(t);
    EXPECT_EQ(state.at<std::uint32_t>(t), static_cast<std::uint32_t>(f.slip.state)) << t;
    for (const auto& [file, field] : slip_fields) {
      const auto a = LoadNpy(out + file);
      ASSERT_EQ(a.shape, (std::vector<std::int64_t>{7})) << file;
      EXPECT_TRUE(Same(a.at<double>(t), f.slip.*field)) << file << " " << t;
    }
    EXPECT_EQ(has_image.data[t], t % 2 == 0 ? 1 : 0) << t;
    const std::string png = fmt::format("{}images/frame_{:06d}.png", out, t);
    EXPECT_EQ(fs::exists(png), t % 2 == 0) << png;
    if (t % 2 == 0) {
      const cv::Mat image = cv::imread(png, cv::IMREAD_UNCHANGED);
      ASSERT_EQ(image.size(), cv::Size(8, 6));
      EXPECT_EQ(cv::countNonZero(image != t), 0) << png;
    }
  }
  // Some marker is out of contact and some in, so the bools are not all one value.
  EXPECT_NE(contact.data.find('\x01'), std::string::npos);
  EXPECT_NE(contact.data.find('\x00'), std::string::npos);
}

TEST(RecordingExport, CsvHasOneRowPerFrameAndPerFrameAndMarker) {
  const std::string dir = testing::MakeTempDir("export");
  const std::string rec = WriteExportRecording(dir + "/rec.tac3d", 3);
  const auto result = ExportRecording(rec, dir + "/csv", {.format = RecordingExportFormat::kCsv});
  EXPECT_EQ(Listing(dir + "/csv"), (std::vector<std::string>{"frames.csv", "images", "markers.csv"}));
  EXPECT_EQ(result.frames, 3);

  const auto frames = Lines(dir + "/csv/frames.csv");
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[0],
            "frame,index,timestamp_s,sn,rows,cols,initialize_progress,flags,flag_names,"
            "valid_markers,contact_markers,image_rows,image_cols,fx_n,fy_n,fz_n,mx_nmm,my_nmm,"
            "mz_nmm,slip_state,slip_fraction,friction,friction_sigma,margin,margin_sigma,"
            "least_normal_force_n,image");
  const auto f0 = Split(frames[1]);
  ASSERT_EQ(f0.size(), 27u);
  const TactileFrame first = ExportFrame(0);
  EXPECT_EQ(f0[0], "0");
  EXPECT_EQ(f0[1], "100");
  EXPECT_EQ(std::stod(f0[2]), first.timestamp_s);  // shortest round-trip text
  EXPECT_EQ(f0[3], "AD2-0065L");
  EXPECT_EQ(f0[6], "50");
  EXPECT_EQ(f0[8], "markers_lost initializing");
  EXPECT_EQ(f0[9], std::to_string(kExportMarkers - 1));
  EXPECT_EQ(f0[11], "6");  // image 6 x 8 on even frames
  EXPECT_EQ(Split(frames[2])[11], "0");
  EXPECT_EQ(f0[19], "unknown");
  EXPECT_EQ(f0[21], "nan");
  EXPECT_EQ(f0[26], "images/frame_000000.png");
  const auto f1 = Split(frames[2]);
  const TactileFrame second = ExportFrame(1);
  EXPECT_EQ(f1[19], "partial_slip");
  EXPECT_EQ(std::stod(f1[20]), second.slip.fraction);
  EXPECT_EQ(std::stod(f1[21]), second.slip.friction);
  EXPECT_EQ(std::stod(f1[22]), second.slip.friction_sigma);
  EXPECT_EQ(std::stod(f1[23]), second.slip.margin);
  EXPECT_EQ(std::stod(f1[24]), second.slip.margin_sigma);
  EXPECT_EQ(std::stod(f1[25]), second.slip.least_normal_force_n);
  EXPECT_EQ(f1.size(), 26u);  // no image: the last field empty
  EXPECT_TRUE(fs::exists(dir + "/csv/images/frame_000002.png"));
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(std::stod(f0[13 + k]), first.resultant_force_n[k]);
    EXPECT_EQ(std::stod(f0[16 + k]), first.resultant_moment_nmm[k]);
  }

  const auto markers = Lines(dir + "/csv/markers.csv");
  ASSERT_EQ(markers.size(), 1u + 3 * kExportMarkers);
  EXPECT_EQ(markers[0],
            "frame,index,timestamp_s,marker,row,col,valid,contact,x_mm,y_mm,z_mm,dx_mm,dy_mm,"
            "dz_mm,fx_n,fy_n,fz_n,nx,ny,nz");
  // Frame 2, marker 13 (row 2, col 3); and frame 2's lost marker, NaN where the pipeline leaves it.
  const TactileFrame f2 = ExportFrame(2);
  const auto m = Split(markers[1 + 2 * kExportMarkers + 13]);
  ASSERT_EQ(m.size(), 20u);
  EXPECT_EQ(m[0], "2");
  EXPECT_EQ(m[1], "102");
  EXPECT_EQ(m[3], "13");
  EXPECT_EQ(m[4], "2");
  EXPECT_EQ(m[5], "3");
  EXPECT_EQ(m[6], f2.valid[13] ? "1" : "0");
  EXPECT_EQ(m[7], f2.contact[13] ? "1" : "0");
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(std::stod(m[8 + k]), f2.positions_mm[13][k]);
    EXPECT_EQ(std::stod(m[11 + k]), f2.displacements_mm[13][k]);
    EXPECT_EQ(std::stod(m[14 + k]), f2.forces_n[13][k]);
    EXPECT_EQ(std::stod(m[17 + k]), f2.normals[13][k]);
  }
  const int lost = static_cast<int>(f2.index % kExportMarkers);
  const auto l = Split(markers[1 + 2 * kExportMarkers + lost]);
  EXPECT_EQ(l[6], "0");
  EXPECT_EQ(l[8], "nan");
}

TEST(RecordingExport, TruncatedRecordingExportsItsGoodFrames) {
  const std::string dir = testing::MakeTempDir("export");
  const std::string rec = WriteExportRecording(dir + "/rec.tac3d", 6);
  std::int64_t cut = 0;
  {
    RecordingReader reader(rec);
    for (int i = 0; i < 4; ++i) reader.Next();
    cut = reader.offset() + 7;  // inside the fifth record's header
  }
  fs::resize_file(rec, static_cast<std::uintmax_t>(cut));
  const auto result = ExportRecording(rec, dir + "/out");
  EXPECT_EQ(result.frames, 4);
  EXPECT_EQ(result.status, RecordingStatus::kTruncated);
  EXPECT_THAT(result.message, HasSubstr("truncated after 4 frames"));
  EXPECT_EQ(LoadNpy(dir + "/out/positions_mm.npy").shape,
            (std::vector<std::int64_t>{4, kExportMarkers, 3}));
  EXPECT_EQ(LoadNpy(dir + "/out/index.npy").at<std::int64_t>(3), 103);
}

TEST(RecordingExport, ChecksTheFolderBeforeWritingAndLeavesNoPartialFile) {
  const std::string dir = testing::MakeTempDir("export");
  const std::string rec = WriteExportRecording(dir + "/rec.tac3d", 2);
  // A file the export would replace: refused, the folder left as it was.
  fs::create_directories(dir + "/out");
  std::ofstream(dir + "/out/flags.npy") << "mine";
  try {
    ExportRecording(rec, dir + "/out");
    ADD_FAILURE() << "replaced an existing file";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("flags.npy' already exists"));
  }
  EXPECT_EQ(Listing(dir + "/out"), std::vector<std::string>{"flags.npy"});
  EXPECT_EQ(ExportRecording(rec, dir + "/out", {.overwrite = true}).frames, 2);
  EXPECT_EQ(Listing(dir + "/out").size(), 21u);  // 20 arrays and images/
  // An images/ folder is the export's too: refused without overwrite, and never a link.
  try {
    ExportRecording(rec, dir + "/out", {.format = RecordingExportFormat::kCsv});
    ADD_FAILURE() << "replaced an earlier export's images";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("images' already exists"));
  }
  fs::create_directories(dir + "/elsewhere");
  fs::create_symlink(dir + "/elsewhere", dir + "/linked_images");
  fs::create_directories(dir + "/linked");
  fs::rename(dir + "/linked_images", dir + "/linked/images");
  EXPECT_THROW(ExportRecording(rec, dir + "/linked", {.overwrite = true}), Error);
  EXPECT_TRUE(fs::is_symlink(dir + "/linked/images"));
  // The output is a file.
  EXPECT_THROW(ExportRecording(rec, rec), Error);
  // No good frame: nothing written.
  { RecordingWriter empty(dir + "/empty.tac3d"); }
  try {
    ExportRecording(dir + "/empty.tac3d", dir + "/none");
    ADD_FAILURE() << "exported an empty recording";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("nothing to export"));
  }
  EXPECT_TRUE(Listing(dir + "/none").empty());
  // Not a recording.
  EXPECT_THROW(ExportRecording(dir + "/out/flags.npy", dir + "/x"), Error);
  EXPECT_THROW(ParseRecordingExportFormat("hdf5"), Error);
  EXPECT_EQ(ParseRecordingExportFormat("csv"), RecordingExportFormat::kCsv);
}

TEST(RecordingExport, GridChangeIsRefusedForNpyWithoutLeavingFiles) {
  const std::string dir = testing::MakeTempDir("export");
  {
    RecordingWriter writer(dir + "/rec.tac3d");
    writer.Write(MakeSyntheticTactileFrame("S", 0, 4, 5));
    writer.Write(MakeSyntheticTactileFrame("S", 1, 5, 4));
  }
  try {
    ExportRecording(dir + "/rec.tac3d", dir + "/out");
    ADD_FAILURE() << "exported two grids into one array";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("frame 1 (index 1) has a 5 x 4 marker grid, the first a 4 x 5"));
  }
  EXPECT_TRUE(Listing(dir + "/out").empty());
  // CSV has a row per marker with its grid, so it takes both.
  const auto csv =
      ExportRecording(dir + "/rec.tac3d", dir + "/csv", {.format = RecordingExportFormat::kCsv});
  EXPECT_EQ(csv.frames, 2);
  EXPECT_EQ(Lines(dir + "/csv/markers.csv").size(), 41u);
}

// numpy (when installed: Debian's python3-numpy) loads every array with the documented
// shape and dtype and the recorded values, and reads markers.csv to the same numbers.
TEST(RecordingExport, NumpyLoadsTheArrays) {
  if (std::system("/usr/bin/python3 -c 'import numpy' >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "/usr/bin/python3 with numpy is not installed (apt-get install python3-numpy)";
  }
  const std::string dir = testing::MakeTempDir("numpy");
  const std::string rec = WriteExportRecording(dir + "/rec.tac3d", 5);
  ExportRecording(rec, dir + "/npy");
  ExportRecording(rec, dir + "/csv", {.format = RecordingExportFormat::kCsv});
  const TactileFrame f3 = ExportFrame(3);
  const int m = 7;  // a valid marker of frame 3 (its lost one is 103 % 20 = 3)
  ASSERT_TRUE(f3.valid[m]);
  const std::string script = fmt::format(
      R"(import sys
import numpy as np
d = sys.argv[1]
def load(name, dtype, shape):
    a = np.load(d + '/npy/' + name + '.npy', allow_pickle=False)
    assert a.dtype == np.dtype(dtype), (name, a.dtype)
    assert a.shape == shape, (name, a.shape)
    assert a.flags['C_CONTIGUOUS'], name
    return a
T, N = 5, {n}
p = load('positions_mm', '<f8', (T, N, 3))
dd = load('displacements_mm', '<f8', (T, N, 3))
f = load('forces_n', '<f8', (T, N, 3))
nn = load('normals', '<f8', (T, N, 3))
v = load('valid', '?', (T, N))
c = load('contact', '?', (T, N))
t = load('timestamp_s', '<f8', (T,))
i = load('index', '<i8', (T,))
fl = load('flags', '<u4', (T,))
pr = load('initialize_progress', '<i8', (T,))
F = load('resultant_force_n', '<f8', (T, 3))
M = load('resultant_moment_nmm', '<f8', (T, 3))
assert list(i) == [100, 101, 102, 103, 104], i
assert t[3] == {t3}, t[3]
assert fl[0] == {fl0} and fl[3] == {fl3}, fl
assert pr[0] == 50 and pr[1] == 100, pr
assert p[3, {m}, 0] == {px} and p[3, {m}, 2] == {pz}, p[3, {m}]
assert f[3, {m}, 1] == {fy}, f[3, {m}]
assert nn[3, {m}, 2] == {nz}, nn[3, {m}]
assert np.isnan(p[3, 3]).all() and not v[3, 3] and v[3, {m}]
assert v.sum() == T * (N - 1), v.sum()
assert c.sum() == {contacts}, c.sum()
assert F[3, 2] == {Fz} and M[3, 0] == {Mx}, (F[3], M[3])
assert np.allclose(f.sum(axis=1), F, rtol=0, atol=1e-12)
rows = np.loadtxt(d + '/csv/markers.csv', delimiter=',', skiprows=1)
assert rows.shape == (T * N, 20), rows.shape
assert np.array_equal(rows[:, 8:11], p.reshape(-1, 3), equal_nan=True)
assert np.array_equal(rows[:, 11:14], dd.reshape(-1, 3), equal_nan=True)
assert np.array_equal(rows[:, 14:17], f.reshape(-1, 3))
assert np.array_equal(rows[:, 17:20], nn.reshape(-1, 3))
assert np.array_equal(rows[:, 6].astype(bool), v.reshape(-1))
print('numpy', np.__version__, 'ok')
)",
      fmt::arg("n", kExportMarkers),
      fmt::arg("m", m),
      fmt::arg("t3", f3.timestamp_s),
      fmt::arg("fl0", ExportFrame(0).flags),
      fmt::arg("fl3", f3.flags),
      fmt::arg("px", f3.positions_mm[m].x()),
      fmt::arg("pz", f3.positions_mm[m].z()),
      fmt::arg("fy", f3.forces_n[m].y()),
      fmt::arg("nz", f3.normals[m].z()),
      fmt::arg("contacts",
               [] {
                 int n = 0;
                 for (int t = 0; t < 5; ++t) {
                   for (const bool b : ExportFrame(t).contact) n += b;
                 }
                 return n;
               }()),
      fmt::arg("Fz", f3.resultant_force_n.z()),
      fmt::arg("Mx", f3.resultant_moment_nmm.x()));
  std::ofstream(dir + "/check.py") << script;
  const std::string log = dir + "/check.log";
  const int status =
      std::system(fmt::format("/usr/bin/python3 {}/check.py {} > {} 2>&1", dir, dir, log).c_str());
  std::ifstream in(log);
  const std::string output(std::istreambuf_iterator<char>(in), {});
  EXPECT_EQ(status, 0) << output;
  EXPECT_THAT(output, HasSubstr("ok"));
}

}  // namespace
}  // namespace tac3d
