#include "tac3d/dataset/twin_dataset.h"

#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

TwinStep MakeStep(int index) {
  TwinStep s;
  s.index = index;
  s.t_s = 0.1 * index;
  s.world_from_sensor.linear() = Eigen::AngleAxisd(0.2 * index, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  s.world_from_sensor.translation() = Eigen::Vector3d(1.0 / 3.0, -2, index);
  s.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(10 * index));
  for (int k = 0; k < 6; ++k) {
    s.marker_positions_mm.emplace_back(k, 0.1 * k, 7.5 + 1e-13 * k);
    s.marker_forces_n.emplace_back(0.01 * k, -0.02 * k, -0.3 * k);
    s.marker_contact.push_back(k % 2);
    s.marker_slip.push_back(k % 3 == 0);
  }
  s.total_force_n = Eigen::Vector3d(0.1, 0.2, -4.5);
  s.total_moment_nmm = Eigen::Vector3d(-1, 2, 0.5);
  s.surface.positions_mm = {{0, 0, 8}, {0.4, 0, 7.99}};
  s.surface.tractions_mpa = {{0.01, 0, -0.2}, {0, 0, -0.1}};
  s.surface.states = {ContactState::kSlip, ContactState::kStick};
  s.solver = {{"iterations", 12 + index}, {"converged", true}};
  return s;
}

TEST(TwinDataset, StepsRoundTripExactly) {
  const std::string dir = testing::MakeTempDir("dataset") + "/run";
  {
    TwinDatasetWriter writer(dir, {{"name", "unit"}, {"steps", 3}});
    for (int k = 0; k < 3; ++k) writer.Write(MakeStep(k));
  }
  const TwinDatasetReader reader(dir);
  EXPECT_EQ(reader.header().at("name"), "unit");
  ASSERT_EQ(reader.steps(), (std::vector<int>{0, 1, 2}));
  const TwinStep expected = MakeStep(2);
  const TwinStep got = reader.Read(2, /*with_surface=*/true);
  EXPECT_EQ(got.t_s, expected.t_s);
  EXPECT_TRUE(got.world_from_sensor.translation() == expected.world_from_sensor.translation());
  EXPECT_THAT(got.world_from_sensor.linear(), EigenNear(expected.world_from_sensor.linear(), 1e-15));
  EXPECT_EQ(got.marker_positions_mm, expected.marker_positions_mm);  // shortest round-trip doubles
  EXPECT_EQ(got.marker_forces_n, expected.marker_forces_n);
  EXPECT_EQ(got.marker_contact, expected.marker_contact);
  EXPECT_EQ(got.marker_slip, expected.marker_slip);
  EXPECT_EQ(got.total_force_n, expected.total_force_n);
  EXPECT_EQ(got.total_moment_nmm, expected.total_moment_nmm);
  EXPECT_EQ(got.surface.positions_mm, expected.surface.positions_mm);
  EXPECT_EQ(got.surface.tractions_mpa, expected.surface.tractions_mpa);
  EXPECT_EQ(got.surface.states, expected.surface.states);
  EXPECT_EQ(got.solver, expected.solver);
  EXPECT_EQ(cv::norm(got.image, expected.image, cv::NORM_INF), 0.0);
  EXPECT_TRUE(reader.Read(1).surface.positions_mm.empty());  // not asked for
}

TEST(TwinDataset, UpdateHeaderAddsKeysAndKeepsTheRest) {
  const std::string dir = testing::MakeTempDir("dataset_header") + "/run";
  TwinDatasetWriter writer(dir, {{"name", "unit"}, {"steps", 3}});
  writer.Write(MakeStep(0));
  writer.UpdateHeader({{"steps", 1}, {"timings", {{"total_s", 0.5}}}});
  const TwinDatasetReader reader(dir);
  EXPECT_EQ(reader.header().at("name"), "unit");
  EXPECT_EQ(reader.header().at("steps"), 1);
  EXPECT_EQ(reader.header().at("timings").at("total_s"), 0.5);
  EXPECT_EQ(reader.steps(), (std::vector<int>{0}));
}

TEST(TwinDataset, AStepCutShortIsNotListedAndDamageIsNamed) {
  const std::string dir = testing::MakeTempDir("dataset") + "/cut";
  {
    TwinDatasetWriter writer(dir, {{"name", "cut"}});
    writer.Write(MakeStep(0));
    writer.Write(MakeStep(1));
  }
  // A simulation killed while writing step 2: only its temporary file exists.
  std::ofstream(dir + "/steps/000002.json.tmp") << "{\"index\": 2, \"t_";
  const TwinDatasetReader reader(dir);
  EXPECT_EQ(reader.steps(), (std::vector<int>{0, 1}));
  std::ofstream(dir + "/surface/000001.bin", std::ios::trunc) << "TAC3DSRF";
  try {
    reader.Read(1, true);
    FAIL() << "read a truncated surface file";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("000001.bin"));
  }
  std::ofstream(dir + "/steps/000000.json", std::ios::trunc) << "{\"index\": 0}";
  EXPECT_THROW(reader.Read(0), Error);
  EXPECT_THROW(TwinDatasetWriter(dir, {}), Error);  // not empty
  EXPECT_THROW(TwinDatasetReader(dir + "/nowhere"), Error);
}

TEST(TwinDataset, ImagesReplayAsAFrameSource) {
  const std::string dir = testing::MakeTempDir("dataset") + "/replay";
  {
    TwinDatasetWriter writer(dir, {{"name", "replay"}});
    for (int k = 0; k < 4; ++k) {
      TwinStep s = MakeStep(k);
      if (k == 2) s.image.release();
      writer.Write(s);
    }
  }
  const auto source = OpenTwinDataset(dir);
  Frame frame;
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  EXPECT_EQ(frame.image.at<std::uint8_t>(0, 0), 10);
  EXPECT_DOUBLE_EQ(frame.timestamp_s, 0.1);
  EXPECT_EQ(source->Read(frame), ReadStatus::kBadFrame);
  EXPECT_THAT(source->last_error(), HasSubstr("no image"));
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  EXPECT_EQ(frame.index, 3);
  EXPECT_EQ(source->Read(frame), ReadStatus::kEnd);
}

TEST(TwinDataset, MismatchedArraysAreRefused) {
  TwinDatasetWriter writer(testing::MakeTempDir("dataset") + "/bad", {});
  TwinStep s = MakeStep(0);
  s.marker_slip.pop_back();
  EXPECT_THROW(writer.Write(s), Error);
  s = MakeStep(0);
  s.surface.states.pop_back();
  EXPECT_THROW(writer.Write(s), Error);
}

}  // namespace
}  // namespace tac3d
