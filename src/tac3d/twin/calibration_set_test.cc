#include "tac3d/twin/calibration_set.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::DefaultSensor;

SensorPerturbationOptions Seeded(std::uint64_t seed) {
  SensorPerturbationOptions o;
  o.seed = seed;
  return o;
}

TEST(PerturbSensor, SameSeedSameSensorOtherSeedOtherSensor) {
  const SensorConfig a = PerturbSensor(DefaultSensor(), Seeded(7));
  const SensorConfig b = PerturbSensor(DefaultSensor(), Seeded(7));
  const SensorConfig c = PerturbSensor(DefaultSensor(), Seeded(8));
  EXPECT_EQ(SensorConfigToYaml(a), SensorConfigToYaml(b));
  EXPECT_NE(SensorConfigToYaml(a), SensorConfigToYaml(c));
}

TEST(PerturbSensor, StaysWithinItsBoundsAndItsVirtualCamerasAreTheMirrors) {
  const SensorPerturbationOptions bounds;
  const CameraIntrinsics& nominal = DefaultSensor().camera.intrinsics;
  double largest_tilt = 0, largest_shift = 0;
  for (std::uint64_t seed = 1; seed <= 50; ++seed) {
    const SensorConfig truth = PerturbSensor(DefaultSensor(), Seeded(seed));
    const CameraIntrinsics& c = truth.camera.intrinsics;
    EXPECT_LE(std::abs(c.fx / nominal.fx - 1.0), bounds.focal_error_max + 1e-15);
    EXPECT_DOUBLE_EQ(c.fx / nominal.fx, c.fy / nominal.fy);
    EXPECT_LE(std::abs(c.cx - nominal.cx), bounds.principal_point_error_max_px);
    EXPECT_LE(std::abs(c.cy - nominal.cy), bounds.principal_point_error_max_px);
    EXPECT_GE(c.distortion[0], bounds.k1_min);
    EXPECT_LE(c.distortion[0], bounds.k1_max);
    EXPECT_GE(c.distortion[1], 0.0);
    EXPECT_LE(c.distortion[1], bounds.k2_max);
    EXPECT_LE(std::abs(c.distortion[2]), bounds.tangential_max);
    EXPECT_LE(std::abs(c.distortion[3]), bounds.tangential_max);
    ASSERT_EQ(truth.mirrors.size(), 4u);
    for (size_t m = 0; m < 4; ++m) {
      const Rectangle3& a = DefaultSensor().mirrors[m].surface;
      const Rectangle3& b = truth.mirrors[m].surface;
      const double tilt = RadToDeg(std::acos(std::min(1.0, a.normal().dot(b.normal()))));
      const double shift = (a.center - b.center).norm();
      EXPECT_LE(tilt, bounds.mirror_tilt_max_deg + 1e-6);
      EXPECT_LE(shift, bounds.mirror_shift_max_mm);
      largest_tilt = std::max(largest_tilt, tilt);
      largest_shift = std::max(largest_shift, shift);
    }
    const OpticalLayout layout = truth.MakeOpticalLayout(false);
    for (const VirtualCameraConfig& v : truth.virtual_cameras) {
      EXPECT_THAT(v.sensor_from_vcam.matrix(), EigenNear(layout.SensorFromVirtualCamera(v.half).matrix(), 1e-12));
      EXPECT_EQ(v.intrinsics, c);
    }
  }
  // The draws reach near their bounds: the perturbation is not a no-op.
  EXPECT_GT(largest_tilt, 0.8 * bounds.mirror_tilt_max_deg);
  EXPECT_GT(largest_shift, 0.8 * bounds.mirror_shift_max_mm);
}

TEST(PerturbSensor, RefusesBadOptionsAndAnUndesignedSensor) {
  SensorPerturbationOptions o;
  o.k1_min = 0.1;
  o.k1_max = 0.0;
  EXPECT_THROW(PerturbSensor(DefaultSensor(), o), Error);
  o = {};
  o.mirror_tilt_max_deg = -1;
  EXPECT_THROW(PerturbSensor(DefaultSensor(), o), Error);
  EXPECT_THROW(PerturbSensor(SensorConfig{}, {}), Error);
}

TEST(DotBoard, CentredPlacementIsTheCalibrationReferencePlacement) {
  for (const auto layout : {CalibrationBoard::Layout::kSymmetric, CalibrationBoard::Layout::kAsymmetric}) {
    CalibrationBoard board;
    board.layout = layout;
    board.rows = 5;
    board.cols = 4;
    const DotBoard dot_board{board};
    EXPECT_THAT(dot_board.SensorFromBoard(Eigen::Vector3d::Zero()).matrix(),
                EigenNear(board.ReferenceSensorFromBoard().matrix(), 1e-12));
  }
}

TEST(RenderCalibrationSet, PosesStayInTheirRangesAndTheSetIsReproducible) {
  const SensorConfig truth = PerturbSensor(DefaultSensor(), {});
  CalibrationSetOptions o;
  o.views = 4;
  const CalibrationSet set = RenderCalibrationSet(truth, o);
  ASSERT_EQ(set.images.size(), 5u);
  ASSERT_EQ(set.sensor_from_board.size(), 5u);
  EXPECT_EQ(set.images[0].name, "reference.png");
  EXPECT_EQ(set.board_file.reference_image, "reference.png");
  EXPECT_THAT(set.sensor_from_board[0].matrix(), EigenNear(o.board.ReferenceSensorFromBoard().matrix(), 0.0));
  EXPECT_EQ(set.images[4].name, "view_04.png");
  for (size_t i = 1; i < set.sensor_from_board.size(); ++i) {
    const Rigid3& pose = set.sensor_from_board[i];
    const Eigen::Vector3d centre = pose * o.board.GridCenter();
    EXPECT_LE(centre.cwiseAbs().maxCoeff(), o.position_range_mm + 1e-9);
    const double tilt = RadToDeg(std::acos(pose.linear()(2, 2)));
    EXPECT_LE(tilt, o.max_tilt_deg + 1e-9);
    EXPECT_EQ(set.images[i].image.type(), CV_8UC1);
    EXPECT_EQ(set.images[i].image.cols, 640);
  }
  const CalibrationSet again = RenderCalibrationSet(truth, o);
  for (size_t i = 0; i < set.images.size(); ++i) {
    EXPECT_EQ(cv::norm(set.images[i].image, again.images[i].image, cv::NORM_INF), 0.0);
  }
}

TEST(RenderCalibrationSet, RefusesABoardTooLargeToBeSeenWhole) {
  CalibrationSetOptions o;
  o.views = 1;
  o.board.rows = o.board.cols = 15;
  EXPECT_THROW(RenderCalibrationSet(DefaultSensor(), o), Error);
  o = {};
  o.views = 0;
  EXPECT_THROW(RenderCalibrationSet(DefaultSensor(), o), Error);
}

TEST(WriteCalibrationSet, WritesTheFolderLayoutCalibrateReads) {
  const SensorConfig truth = PerturbSensor(DefaultSensor(), {});
  CalibrationSetOptions o;
  o.views = 2;
  const CalibrationSet in_memory = RenderCalibrationSet(truth, o);
  const std::string dir = testing::MakeTempDir("set") + "/nested";
  const CalibrationSet written = WriteCalibrationSet(truth, o, dir);
  EXPECT_TRUE(written.images.empty()) << "written as rendered, not kept";
  ASSERT_EQ(written.sensor_from_board.size(), 3u);
  const std::vector<CalibrationImage> images = LoadCalibrationImages(dir);
  ASSERT_EQ(images.size(), 3u);
  EXPECT_EQ(images[0].name, "reference.png");
  for (size_t i = 0; i < images.size(); ++i) {  // lossless, and the same set
    EXPECT_EQ(cv::norm(images[i].image, in_memory.images[i].image, cv::NORM_INF), 0.0);
  }
  const CalibrationBoardFile board = LoadCalibrationBoardFile(dir + "/board.yaml");
  EXPECT_EQ(board.board, in_memory.board_file.board);
  EXPECT_EQ(board.reference_image, "reference.png");
  EXPECT_EQ(SensorConfigToYaml(LoadSensorConfig(dir + "/truth.yaml")), SensorConfigToYaml(truth));
}

// Issue 22, defect 9: `calibrate render-set --count 100000` kept every image until the end
// (36 MB/s until out of memory, nothing written). WriteCalibrationSet writes each image once
// rendered (above), and the count has a bound, checked before any work.
TEST(WriteCalibrationSet, RefusesMoreViewsThanTheBoundBeforeAnyWork) {
  CalibrationSetOptions o;
  o.views = kMaxCalibrationViews + 1;
  const std::string dir = testing::MakeTempDir("set_bound") + "/out";
  EXPECT_THAT([&] { WriteCalibrationSet(PerturbSensor(DefaultSensor(), {}), o, dir); },
              ::testing::ThrowsMessage<Error>(
                  ::testing::HasSubstr("calibration set: views = 1001 must be in [1, 1000]")));
  EXPECT_FALSE(std::filesystem::exists(dir));
}

}  // namespace
}  // namespace tac3d
