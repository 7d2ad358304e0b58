#include "tac3d/calib/virtual_stereo_calibration.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/design/light_path_design.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

// Calibrations of rendered sets are tested in eval/calibration_evaluation_test (the twin
// is a higher module); here, what needs no board image.

namespace tac3d {
namespace {

using testing::DefaultSensor;

CalibrationBoardFile Board() {
  CalibrationBoardFile file;
  file.reference_image = "reference.png";
  file.sensor_from_board = file.board.ReferenceSensorFromBoard();
  return file;
}

std::string ErrorMessage(const std::vector<CalibrationImage>& images, const SensorConfig& nominal,
                         const VirtualStereoCalibrationOptions& options = {}) {
  try {
    CalibrateVirtualStereo(images, Board(), nominal, options);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(LoadCalibrationImages, ListsImagesByNameAndKeepsCorruptOnesEmpty) {
  const std::string dir = testing::MakeTempDir("images");
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  ASSERT_TRUE(cv::imwrite(dir + "/b.png", grey));
  ASSERT_TRUE(cv::imwrite(dir + "/C.JPG", grey));
  std::ofstream(dir + "/a.png") << "not a PNG";
  std::ofstream(dir + "/board.yaml") << "board: {}";
  std::filesystem::create_directories(dir + "/sub.png");
  // Issue 14, defect 2: a PNG whose header claims 60000 x 60000 pixels stopped calibrate.
  std::vector<std::uint8_t> huge;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(8, 8, CV_8UC1, cv::Scalar(0)), huge));
  const std::uint8_t side[4] = {0x00, 0x00, 0xEA, 0x60};
  std::copy(side, side + 4, huge.begin() + 16);
  std::copy(side, side + 4, huge.begin() + 20);
  std::ofstream(dir + "/d.png", std::ios::binary).write(reinterpret_cast<const char*>(huge.data()), huge.size());
  const std::vector<CalibrationImage> images = LoadCalibrationImages(dir, 640, 480);
  ASSERT_EQ(images.size(), 4u);
  EXPECT_EQ(images[0].name, "C.JPG");  // byte order: upper case first
  EXPECT_EQ(images[1].name, "a.png");
  EXPECT_EQ(images[2].name, "b.png");
  EXPECT_EQ(images[3].name, "d.png");
  EXPECT_TRUE(images[1].image.empty());
  EXPECT_EQ(images[2].image.size(), grey.size());
  EXPECT_TRUE(images[3].image.empty());
  // Issue 22, defect 11: calibrate said only "unreadable or corrupt file" where run says why.
  EXPECT_EQ(images[1].refusal, "not a readable image (corrupt or truncated)");
  EXPECT_EQ(images[3].refusal, "its header claims 60000 x 60000 pixels, more than the 640 x 480 accepted");
  CalibrationImage reference = images[3];
  reference.name = "reference.png";
  EXPECT_THAT(ErrorMessage({reference}, DefaultSensor()),
              ::testing::HasSubstr("reference view 'reference.png' is refused: its header claims "
                                   "60000 x 60000 pixels"));
  EXPECT_THROW(LoadCalibrationImages(dir + "/missing"), Error);
}

TEST(CalibrateVirtualStereo, RefusedReferenceViewIsAnErrorWithTheReason) {
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  std::vector<CalibrationImage> images = {{"reference.png", grey}};
  EXPECT_NE(ErrorMessage(images, DefaultSensor()).find(
                "reference view 'reference.png' is refused: grid not found in the left and right halves"),
            std::string::npos);
  images[0].image = cv::Mat();
  EXPECT_NE(ErrorMessage(images, DefaultSensor()).find("unreadable or corrupt file"),
            std::string::npos);
  images[0].image = cv::Mat(240, 320, CV_8UC1, cv::Scalar(128));
  EXPECT_NE(ErrorMessage(images, DefaultSensor()).find("image is 320x240, the camera's is 640x480"),
            std::string::npos);
  images[0].image = cv::Mat(480, 640, CV_16UC1, cv::Scalar(128));
  EXPECT_NE(ErrorMessage(images, DefaultSensor()).find("not an 8-bit"), std::string::npos);
}

TEST(CalibrateVirtualStereo, MissingReferenceViewIsAnError) {
  const std::vector<CalibrationImage> images = {{"other.png", cv::Mat()}};
  EXPECT_NE(ErrorMessage(images, DefaultSensor()).find("reference view 'reference.png' is not among"),
            std::string::npos);
}

TEST(CalibrateVirtualStereo, NeedsVirtualCamerasInTheNominalConfig) {
  EXPECT_NE(ErrorMessage({}, SensorConfig{}).find("no virtual cameras"), std::string::npos);
}

TEST(VirtualStereoCalibrationOptions, Validate) {
  VirtualStereoCalibrationOptions o;
  EXPECT_NO_THROW(o.Validate());
  o.min_views = 2;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.max_edge_width_px = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.max_view_rms_px = -1;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.bias_correction_rounds = -1;
  EXPECT_THROW(o.Validate(), Error);
  EXPECT_NE(ErrorMessage({}, DefaultSensor(), o).find("bias_correction_rounds"), std::string::npos);
}

TEST(VirtualStereoCalibration, ApplyToKeepsNamesAndColumnRanges) {
  VirtualStereoCalibration c;
  c.sensor_from_vcam[1].translation() = Eigen::Vector3d(1, 2, 3);
  c.intrinsics[1].fx = 700;
  const SensorConfig out = c.ApplyTo(DefaultSensor());
  ASSERT_EQ(out.virtual_cameras.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const VirtualCameraConfig& v = out.virtual_cameras[i];
    EXPECT_EQ(v.name, DefaultSensor().virtual_cameras[i].name);
    EXPECT_EQ(v.column_begin, DefaultSensor().virtual_cameras[i].column_begin);
    EXPECT_EQ(v.column_end, DefaultSensor().virtual_cameras[i].column_end);
    EXPECT_THAT(v.sensor_from_vcam.translation(),
                EigenNear(c.sensor_from_vcam[static_cast<int>(v.half)].translation(), 0.0));
    EXPECT_EQ(v.intrinsics.fx, c.intrinsics[static_cast<int>(v.half)].fx);
  }
  EXPECT_THROW(c.ApplyTo(SensorConfig{}), Error);
}

}  // namespace
}  // namespace tac3d
