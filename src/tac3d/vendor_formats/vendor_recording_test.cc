#include "tac3d/vendor_formats/vendor_recording.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string VendorFileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

NpyArray CountingDoubles(std::vector<std::int64_t> shape, double first) {
  NpyArray a;
  a.shape = std::move(shape);
  std::vector<double> values(static_cast<std::size_t>(a.elements()));
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = first + 0.1 * static_cast<double>(i);
  a.data.assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  return a;
}

// A small recording: 4 frames of 6 markers.
VendorRecording SmallRecording() {
  VendorRecording r;
  r.serial_number = "AD2-0065L";
  r.positions = CountingDoubles({4, 6, 3}, 1.0);
  r.displacements = CountingDoubles({4, 6, 3}, -0.3);
  r.forces = CountingDoubles({4, 6, 3}, 0.0);
  r.resultant_force = CountingDoubles({4, 1, 3}, -5.0);
  r.resultant_moment = CountingDoubles({4, 1, 3}, 0.25);
  r.send_timestamp = CountingDoubles({4}, 1455.025456);
  r.index.type = NpyType::kInt64;
  r.index.shape = {4};
  const std::int64_t index[] = {39715, 39716, 39717, 39719};
  r.index.data.assign(reinterpret_cast<const char*>(index), sizeof(index));
  return r;
}

std::string RecordingRefusalOf(const std::string& folder) {
  try {
    ReadVendorRecording(folder);
  } catch (const Error& e) {
    return e.what();
  }
  return "accepted";
}

TEST(VendorRecording, RoundTripsBitForBit) {
  const std::string dir = testing::MakeTempDir("recording");
  const VendorRecording r = SmallRecording();
  WriteVendorRecording(r, dir);
  const VendorRecording back = ReadVendorRecording(dir);  // the recording folder
  EXPECT_EQ(back, r);
  EXPECT_EQ(ReadVendorRecording(dir + "/AD2-0065L"), r);  // its <SN> folder
  EXPECT_EQ(back.frames(), 4);
  EXPECT_EQ(back.markers(), 6);
  EXPECT_EQ(back.ReferencePositions(1)(0, 0), VendorRecording::Frame(r.positions, 1)(0, 0) -
                                                  VendorRecording::Frame(r.displacements, 1)(0, 0));
  EXPECT_DOUBLE_EQ(VendorRecording::Frame(r.positions, 1)(2, 1), 1.0 + 0.1 * (18 + 6 + 1));
  // A field stored in Fortran order gives the same frames.
  NpyArray fortran = r.positions;
  fortran.fortran_order = true;
  const std::vector<double> c_order = r.positions.Float64Values();
  for (std::int64_t f = 0; f < 4; ++f) {
    for (std::int64_t i = 0; i < 6; ++i) {
      for (std::int64_t k = 0; k < 3; ++k) {
        std::memcpy(fortran.data.data() + (f + 4 * (i + 6 * k)) * sizeof(double), &c_order[(f * 6 + i) * 3 + k],
                    sizeof(double));
      }
    }
  }
  EXPECT_EQ(fortran.Float64Values(), c_order);
  EXPECT_EQ(VendorRecording::Frame(fortran, 2), VendorRecording::Frame(r.positions, 2));
  const std::string csv = VendorFileBytes(fs::path(dir) / "AD2-0065L" / "overview.csv");
  EXPECT_THAT(csv, ::testing::StartsWith("index,timestamp,FRx,FRy,FRz,MRx,MRy,MRz\r\n39715,1455.025456,-5.0,-4.9,-4.8,"
                                         "0.25,0.35,0.45\r\n"));
}

TEST(VendorRecording, RefusesMissingTruncatedAndMisshapenFields) {
  const VendorRecording good = SmallRecording();
  const auto written = [&](const VendorRecording& r) {
    const std::string dir = testing::MakeTempDir("recording");
    WriteVendorRecording(r, dir);
    return dir + "/AD2-0065L";
  };
  std::string folder = written(good);
  fs::resize_file(fs::path(folder) / "3D_Forces.npy", fs::file_size(fs::path(folder) / "3D_Forces.npy") - 8);
  EXPECT_THAT(RecordingRefusalOf(folder), HasSubstr("3D_Forces.npy': 568 data bytes where shape (4, 6, 3) of '<f8' needs 576 "
                                           "(truncated)"));
  folder = written(good);
  fs::remove(fs::path(folder) / "sendTimestamp.npy");
  EXPECT_THAT(RecordingRefusalOf(folder), HasSubstr("sendTimestamp.npy' is missing"));

  VendorRecording r = good;
  r.displacements = CountingDoubles({4, 5, 3}, 0.0);
  const std::string dir = testing::MakeTempDir("misshapen");
  EXPECT_THROW(WriteVendorRecording(r, dir), Error);  // never writes what it could not read
  fs::create_directories(dir + "/SN");
  for (const char* field : kVendorRecordingFields) {
    fs::copy(fs::path(written(good)) / (std::string(field) + ".npy"), fs::path(dir) / "SN" / (std::string(field) + ".npy"));
  }
  WriteNpy(dir + "/SN/3D_Displacements.npy", CountingDoubles({4, 5, 3}, 0.0));
  EXPECT_THAT(RecordingRefusalOf(dir), HasSubstr("3D_Displacements.npy': shape (4, 5, 3), expected (4, 6, 3)"));
  WriteNpy(dir + "/SN/3D_Displacements.npy", good.displacements);
  WriteNpy(dir + "/SN/index.npy", CountingDoubles({4}, 0.0));
  EXPECT_THAT(RecordingRefusalOf(dir), HasSubstr("index.npy': dtype '<f8', a vendor recording's index is '<i8'"));
  WriteNpy(dir + "/SN/index.npy", good.index);
  WriteNpy(dir + "/SN/3D_ResultantForce.npy", CountingDoubles({4, 3}, 0.0));
  EXPECT_THAT(RecordingRefusalOf(dir), HasSubstr("3D_ResultantForce.npy': shape (4, 3), expected (4, 1, 3)"));
  EXPECT_THAT(RecordingRefusalOf(testing::MakeTempDir("empty")), HasSubstr("holds no vendor recording"));
  WriteNpy(dir + "/SN/3D_ResultantForce.npy", good.resultant_force);
  std::vector<double> time = good.send_timestamp.Float64Values();
  time[2] = std::numeric_limits<double>::infinity();
  WriteNpy(dir + "/SN/sendTimestamp.npy", CountingDoubles({4}, 0.0));
  EXPECT_EQ(RecordingRefusalOf(dir), "accepted");
  WriteNpy(dir + "/SN/sendTimestamp.npy", NpyType::kFloat64, {4}, time.data());
  EXPECT_THAT(RecordingRefusalOf(dir), HasSubstr("sendTimestamp.npy': frame 2's time is inf"));
  r = good;
  r.serial_number = "../x";
  EXPECT_THROW(WriteVendorRecording(r, testing::MakeTempDir("sn")), Error);
}

TEST(VendorRecording, AFolderOfSeveralSensorsIsReadWholeOrRefusedForOne) {
  const std::string dir = testing::MakeTempDir("several");
  VendorRecording right = SmallRecording();
  right.serial_number = "AD2-0065R";
  WriteVendorRecording(right, dir);
  WriteVendorRecording(SmallRecording(), dir);
  fs::create_directories(dir + "/notes");  // a folder without index.npy is not a sensor's
  EXPECT_EQ(FindVendorRecordingFolders(dir),
            (std::vector<std::string>{dir + "/AD2-0065L", dir + "/AD2-0065R"}));
  EXPECT_EQ(FindVendorRecordingFolders(dir + "/AD2-0065R"), std::vector<std::string>{dir + "/AD2-0065R"});
  const std::vector<VendorRecording> both = ReadVendorRecordings(dir);
  ASSERT_EQ(both.size(), 2u);
  EXPECT_EQ(both[0], SmallRecording());
  EXPECT_EQ(both[1], right);
  EXPECT_THAT(RecordingRefusalOf(dir), HasSubstr("holds the recordings of 2 sensors (AD2-0065L, AD2-0065R): give one "
                                                 "<SN> folder"));
}

TEST(VendorRecording, MaxReferenceShiftIsHowFarTheZeroPointMoved) {
  VendorRecording r = SmallRecording();
  EXPECT_LT(r.MaxReferenceShiftMm(), 1e-12);  // P - D is 1.3 everywhere (to rounding)
  // Frame 2's marker 5 drawn 0.03 mm along x and 0.04 mm along z from its reference.
  std::vector<double> d = r.displacements.Float64Values();
  d[(2 * 6 + 5) * 3 + 0] -= 0.03;
  d[(2 * 6 + 5) * 3 + 2] -= 0.04;
  r.displacements.data.assign(reinterpret_cast<const char*>(d.data()), d.size() * sizeof(double));
  EXPECT_NEAR(r.MaxReferenceShiftMm(), 0.05, 1e-12);
}

TEST(VendorRecording, FramesWithANonFiniteResultantAreCounted) {
  VendorRecording r = SmallRecording();
  EXPECT_EQ(r.FramesWithNonFiniteResultant(), 0);
  std::vector<double> force = r.resultant_force.Float64Values();
  std::vector<double> moment = r.resultant_moment.Float64Values();
  force[1 * 3 + 2] = std::numeric_limits<double>::quiet_NaN();
  moment[3 * 3 + 0] = -std::numeric_limits<double>::infinity();
  moment[1 * 3 + 1] = std::numeric_limits<double>::infinity();  // frame 1 again: counted once
  r.resultant_force.data.assign(reinterpret_cast<const char*>(force.data()), force.size() * sizeof(double));
  r.resultant_moment.data.assign(reinterpret_cast<const char*>(moment.data()), moment.size() * sizeof(double));
  EXPECT_EQ(r.FramesWithNonFiniteResultant(), 2);
}

// The vendor's own files: read, and written back byte for byte (every .npy and overview.csv).
TEST(VendorRecording, RealRecordingsRoundTripByteForByte) {
  TAC3D_REQUIRE_REALDATA(realdata);
  const std::string recordings[] = {
      realdata + "/tac3d/HDL1-0001/recording/Tac3D_Record_20241227_161029/HDL1-0001",
      realdata + "/tac3d/YA1-007/recording/example/YA1-007"};
  const std::int64_t frames[] = {64, 168};
  for (int k = 0; k < 2; ++k) {
    const VendorRecording r = ReadVendorRecording(recordings[k]);
    EXPECT_EQ(r.frames(), frames[k]);
    EXPECT_EQ(r.markers(), 400);
    const std::string out = testing::MakeTempDir("out" + std::to_string(k));
    WriteVendorRecording(r, out);
    for (const char* field : kVendorRecordingFields) {
      const std::string file = std::string(field) + ".npy";
      EXPECT_EQ(VendorFileBytes(fs::path(out) / r.serial_number / file), VendorFileBytes(fs::path(recordings[k]) / file)) << file;
    }
    EXPECT_EQ(VendorFileBytes(fs::path(out) / r.serial_number / "overview.csv"), VendorFileBytes(fs::path(recordings[k]) / "overview.csv"));
    EXPECT_EQ(ReadVendorRecording(out), r);
  }
  // HDL1-0001 pressed and held: the resultant of frame 0 is about (-0.02, 0.06, -5.35) N.
  const VendorRecording hdl1 = ReadVendorRecording(recordings[0]);
  EXPECT_NEAR(VendorRecording::Frame(hdl1.resultant_force, 0)(0, 2), -5.345, 0.01);
}

}  // namespace
}  // namespace tac3d
