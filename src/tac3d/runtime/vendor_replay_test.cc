// `vendor:DIR` (docs/real-sensors.md): a vendor recording's sensors replayed as recorded, several
// interleaved on their one clock, normals and contact made as tac3d makes them, a broken file
// refused naming it. Small recordings written here; the real ones where ../shared is present.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <vector>

#include "tac3d/eval/vendor_evaluation.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/runtime/sensor_stream.h"
#include "tac3d/vendor_formats/vendor_gel.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"
#include "tac3d/vendor_formats/vendor_recording.h"

namespace tac3d::runtime {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kSide = 3;
constexpr int kFrames = 4;
constexpr int kPressed = 4;  // the middle marker, pressed from frame 1 on

NpyArray Doubles(std::vector<std::int64_t> shape, const std::vector<double>& values) {
  NpyArray a;
  a.shape = std::move(shape);
  a.data.assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  return a;
}

// A flat 3 x 3 grid at z = 5 mm whose middle marker is pushed 0.1 mm in by 0.5 N from frame 1
// on; frame f sent at first_time_s + 0.02 f.
VendorRecording FlatPress(const std::string& sn, double first_time_s) {
  std::vector<double> positions, displacements, forces, resultant, moment, time;
  std::vector<std::int64_t> index;
  for (int f = 0; f < kFrames; ++f) {
    for (int i = 0; i < kSide * kSide; ++i) {
      const double dz = (f > 0 && i == kPressed) ? -0.1 : 0.0;
      positions.insert(positions.end(), {1.0 * (i % kSide), 1.0 * (i / kSide), 5.0 + dz});
      displacements.insert(displacements.end(), {0.0, 0.0, dz});
      forces.insert(forces.end(), {0.0, 0.0, dz == 0 ? 0.0 : -0.5});
    }
    resultant.insert(resultant.end(), {0.0, 0.0, f > 0 ? -0.5 : 0.0});
    moment.insert(moment.end(), {0.25 * f, 0.0, 0.0});
    time.push_back(first_time_s + 0.02 * f);
    index.push_back(100 + f);
  }
  VendorRecording r;
  r.serial_number = sn;
  r.positions = Doubles({kFrames, kSide * kSide, 3}, positions);
  r.displacements = Doubles({kFrames, kSide * kSide, 3}, displacements);
  r.forces = Doubles({kFrames, kSide * kSide, 3}, forces);
  r.resultant_force = Doubles({kFrames, 1, 3}, resultant);
  r.resultant_moment = Doubles({kFrames, 1, 3}, moment);
  r.send_timestamp = Doubles({kFrames}, time);
  r.index.type = NpyType::kInt64;
  r.index.shape = {kFrames};
  r.index.data.assign(reinterpret_cast<const char*>(index.data()), index.size() * sizeof(std::int64_t));
  return r;
}

SensorRunSpec AsFastAsPossible() {
  SensorRunSpec spec;
  spec.speed = 0.0;
  return spec;
}

std::vector<TactileFrame> AllFrames(SensorStream& stream) {
  std::vector<TactileFrame> frames;
  const std::atomic<bool> stop{false};
  stream.Start({});
  ProducedFrame out;
  EXPECT_FALSE(stream.ZeroRetakesReference());
  while (stream.Next(stop, out) == Produced::kFrame) frames.push_back(*out.frame);
  EXPECT_TRUE(stream.End(static_cast<long>(frames.size())).failure.empty());
  return frames;
}

std::string RefusalOf(const std::string& folder, bool replace_sn = false) {
  try {
    OpenVendorStream(folder, AsFastAsPossible(), replace_sn);
  } catch (const Error& e) {
    return e.what();
  }
  return "accepted";
}

TEST(VendorReplay, SeveralSensorsComeInterleavedOnTheirOneClockAsRecorded) {
  const std::string dir = testing::MakeTempDir("vendor_replay");
  WriteVendorRecording(FlatPress("AD2-0065R", 10.01), dir);  // each frame 10 ms after AD2-0065L's
  WriteVendorRecording(FlatPress("AD2-0065L", 10.00), dir);
  const std::vector<TactileFrame> frames = AllFrames(*OpenVendorStream(dir, AsFastAsPossible(), false));
  ASSERT_EQ(frames.size(), 2u * kFrames);
  for (int k = 0; k < 2 * kFrames; ++k) {
    const TactileFrame& frame = frames[k];
    EXPECT_EQ(frame.sn, k % 2 == 0 ? "AD2-0065L" : "AD2-0065R") << k;
    EXPECT_EQ(frame.index, 100 + k / 2);
    EXPECT_EQ(frame.timestamp_s, (k % 2 == 0 ? 10.00 : 10.01) + 0.02 * (k / 2));  // bit for bit
    EXPECT_EQ(frame.rows, kSide);
    EXPECT_EQ(frame.initialize_progress, 100);
    const bool pressed = k >= 2;
    EXPECT_EQ(frame.positions_mm[kPressed], Eigen::Vector3d(1, 1, pressed ? 4.9 : 5.0));
    EXPECT_EQ(frame.forces_n[kPressed], Eigen::Vector3d(0, 0, pressed ? -0.5 : 0.0));
    EXPECT_EQ(frame.resultant_moment_nmm.x(), 0.25 * (k / 2));
    // Normals of the grid: +z on the flat border; tilted around the dent, still outwards.
    EXPECT_TRUE(frame.normals[0].isApprox(Eigen::Vector3d::UnitZ(), 1e-12)) << frame.normals[0].transpose();
    for (const Eigen::Vector3d& n : frame.normals) {
      EXPECT_NEAR(n.norm(), 1.0, 1e-12);
      EXPECT_GT(n.z(), 0.9);
    }
    // Contact: the pressed marker only (0.5 N into the gel; the others carry none).
    for (int i = 0; i < kSide * kSide; ++i) EXPECT_EQ(frame.contact[i], pressed && i == kPressed) << k << " " << i;
  }
}

TEST(VendorReplay, TheSnFolderOrTheOnlySensorTakesAnSnSeveralDoNot) {
  const std::string dir = testing::MakeTempDir("vendor_replay_sn");
  WriteVendorRecording(FlatPress("AD2-0065L", 3.0), dir);
  SensorRunSpec spec = AsFastAsPossible();
  spec.sn = "THUMB";
  for (const std::string& folder : {dir, dir + "/AD2-0065L"}) {
    const std::vector<TactileFrame> frames = AllFrames(*OpenVendorStream(folder, spec, /*replace_sn=*/true));
    ASSERT_EQ(frames.size(), static_cast<size_t>(kFrames)) << folder;
    EXPECT_EQ(frames[0].sn, "THUMB");
  }
  // The run file's way in: OpenSensorStream on vendor:DIR with the spec's SN.
  spec.source = "vendor:" + dir;
  EXPECT_EQ(AllFrames(*OpenSensorStream(spec, nullptr))[3].sn, "THUMB");
  EXPECT_TRUE(IsPacedSource(spec.source));

  WriteVendorRecording(FlatPress("AD2-0065R", 3.0), dir);
  EXPECT_THAT(RefusalOf(dir, /*replace_sn=*/true), HasSubstr("holds 2 sensors"));
  EXPECT_EQ(RefusalOf(dir, /*replace_sn=*/false), "accepted");
}

TEST(VendorReplay, ABrokenFileIsRefusedNamingItBeforeAnyFrame) {
  const std::string dir = testing::MakeTempDir("vendor_replay_broken");
  WriteVendorRecording(FlatPress("AD2-0065L", 0.0), dir);
  WriteVendorRecording(FlatPress("AD2-0065R", 0.0), dir);
  const fs::path forces = fs::path(dir) / "AD2-0065R" / "3D_Forces.npy";
  fs::resize_file(forces, fs::file_size(forces) - 8);
  EXPECT_THAT(RefusalOf(dir), HasSubstr(forces.string() + "': "));
  EXPECT_THAT(RefusalOf(dir), HasSubstr("truncated"));
  // The other sensor's folder alone still replays.
  EXPECT_EQ(RefusalOf(dir + "/AD2-0065L"), "accepted");
  fs::remove(forces);
  EXPECT_THAT(RefusalOf(dir), HasSubstr(forces.string() + "' is missing"));
  EXPECT_THAT(RefusalOf(testing::MakeTempDir("vendor_replay_empty")), HasSubstr("holds no vendor recording"));
  EXPECT_THAT(RefusalOf(dir + "/no-such-folder"), HasSubstr("is not a folder"));
  SensorRunSpec backwards = AsFastAsPossible();
  backwards.speed = -1.0;
  EXPECT_THROW(OpenVendorStream(dir + "/AD2-0065L", backwards, false), Error);
}

TEST(VendorReplay, RealRecordingsReplayEveryFrameAsRecorded) {
  TAC3D_REQUIRE_REALDATA(realdata);
  const std::string ya1 = realdata + "/tac3d/YA1-007/recording/example";
  const VendorRecording recording = ReadVendorRecording(ya1);
  const std::vector<TactileFrame> frames = AllFrames(*OpenVendorStream(ya1, AsFastAsPossible(), false));
  ASSERT_EQ(frames.size(), 168u);
  const std::vector<double> time = recording.send_timestamp.Float64Values();
  int in_contact = 0;
  for (int f = 0; f < 168; ++f) {
    EXPECT_EQ(frames[f].timestamp_s, time[f]);
    const Eigen::MatrixX3d displacements = VendorRecording::Frame(recording.displacements, f);
    for (int i = 0; i < 400; ++i) {
      ASSERT_EQ(frames[f].displacements_mm[i], displacements.row(i).transpose()) << f << " " << i;
      // The dome's normals point outwards (up) within 60 degrees of the axis.
      ASSERT_GT(frames[f].normals[i].z(), 0.5) << f << " " << i;
    }
    for (const bool c : frames[f].contact) in_contact += c;
  }
  EXPECT_GT(in_contact, 0);  // it is pressed up to 8 N
  EXPECT_NEAR(recording.MaxReferenceShiftMm(), 0.0615, 0.0005);  // the vendor's zero point moves
}

// `tac3d run --source vendor:DIR --config S.yaml --recompute-forces` on HDL1-0001's two recorded
// frames (the fixture): the forces come from the recorded displacements through the sensor's
// default inverse, the very resultants `tac3d eval vendor` checks, within 10 % of the recorded.
TEST(VendorReplay, RecomputedForcesAreTheOnesEvalVendorChecks) {
  const std::string dir = testing::MakeTempDir("vendor_recompute");
  const SensorConfig config = testing::FixtureVendorSensor();
  SaveSensorConfig(config, dir + "/hdl1.yaml");
  const VendorRecording recording = testing::FixtureForceRecording();
  WriteVendorRecording(recording, dir + "/recording");
  // A coarse gel mesh, as the evaluation's tests take it (`tac3d run`'s refinement 1 takes minutes).
  const VendorForceOptions coarse = {.gel = {.refinement = 0.5}, .cache_dir = testing::MakeTempDir("recompute_cache")};
  const ModelLoader load_model = [&coarse](const SensorConfig& c) {
    return std::make_shared<const fem::ComplianceModel>(
        fem::LoadOrBuildComplianceModel(VendorBodyModelOptions(c, coarse.gel), coarse.cache_dir, false).model);
  };
  SensorRunSpec spec = AsFastAsPossible();
  spec.config = dir + "/hdl1.yaml";
  spec.recompute_forces = true;
  const std::vector<TactileFrame> frames =
      AllFrames(*OpenVendorStream(dir + "/recording", spec, /*replace_sn=*/false, load_model));
  ASSERT_EQ(frames.size(), 2u);

  VendorEvaluationOptions options;
  options.forces = coarse;
  const VendorEvaluation e = EvaluateVendorRecording(config, recording, options);
  ASSERT_TRUE(e.forces);
  ASSERT_EQ(e.forces->frames_compared, 2);
  std::vector<double> z;
  for (size_t k = 0; k < frames.size(); ++k) {
    const Eigen::Vector3d recorded = VendorRecording::Frame(recording.resultant_force, k).row(0).transpose();
    const Eigen::Vector3d& f = frames[k].resultant_force_n;
    EXPECT_LT(std::abs(f.norm() - recorded.norm()) / recorded.norm(), 0.10) << k;
    // Not the vendor's per-marker forces replayed: those sum to 1.23 x its resultant.
    const Eigen::Vector3d vendor_sum = VendorRecording::Frame(recording.forces, k).colwise().sum().transpose();
    EXPECT_GT((f - vendor_sum).norm(), 0.1 * recorded.norm()) << k;
    z.push_back(f.z());
  }
  EXPECT_NEAR(0.5 * (z[0] + z[1]), e.forces->tac3d.median_resultant_n.z(), 1e-9);

  // The re-solve, asked for by the option of the same name, reads high, as eval vendor says.
  spec.support_resolve = true;
  const std::vector<TactileFrame> resolved =
      AllFrames(*OpenVendorStream(dir + "/recording", spec, /*replace_sn=*/false, load_model));
  ASSERT_EQ(resolved.size(), 2u);
  EXPECT_NEAR(0.5 * (resolved[0].resultant_force_n.z() + resolved[1].resultant_force_n.z()),
              e.forces->tac3d_support_resolve.median_resultant_n.z(), 1e-9);
  EXPECT_LT(resolved[0].resultant_force_n.z(), frames[0].resultant_force_n.z() - 0.3);
}

TEST(VendorReplay, RecomputingNeedsOneSensorAndItsOwnConfig) {
  const std::string dir = testing::MakeTempDir("vendor_recompute_refused");
  WriteVendorRecording(FlatPress("AD2-0065L", 10.0), dir);
  WriteVendorRecording(FlatPress("AD2-0066R", 10.0), dir);
  SensorRunSpec spec = AsFastAsPossible();
  spec.recompute_forces = true;
  const ModelLoader never = [](const SensorConfig&) -> std::shared_ptr<const fem::ComplianceModel> {
    ADD_FAILURE() << "no model is needed to refuse";
    return nullptr;
  };
  EXPECT_THAT([&] { OpenVendorStream(dir + "/AD2-0065L", spec, false, never); },
              ::testing::ThrowsMessage<Error>(HasSubstr("needs its sensor's config")));
  const std::string config_path = dir + "/hdl1.yaml";
  SaveSensorConfig(testing::FixtureVendorSensor(), config_path);
  spec.config = config_path;
  EXPECT_THAT([&] { OpenVendorStream(dir, spec, false, never); },
              ::testing::ThrowsMessage<Error>(HasSubstr("holds 2 sensors: recompute one at a time")));
  EXPECT_THAT([&] { OpenVendorStream(dir + "/AD2-0065L", spec, false, never); },
              ::testing::ThrowsMessage<Error>(HasSubstr("the recording is of sensor AD2-0065L")));
}

}  // namespace
}  // namespace tac3d::runtime
