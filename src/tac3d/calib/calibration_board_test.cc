#include "tac3d/calib/calibration_board.h"

#include <fstream>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

TEST(CalibrationBoard, DotsFollowOpenCvsLayouts) {
  CalibrationBoard board;
  board.rows = 3;
  board.cols = 4;
  board.spacing_mm = 2.0;
  auto dots = board.DotCenters();
  ASSERT_EQ(dots.size(), 12u);
  EXPECT_THAT(dots[1 * 4 + 2], EigenNear(Eigen::Vector3d(4.0, 2.0, 0.0), 0.0));
  EXPECT_THAT(board.GridCenter(), EigenNear(Eigen::Vector3d(3.0, 2.0, 0.0), 0.0));

  board.layout = CalibrationBoard::Layout::kAsymmetric;
  dots = board.DotCenters();
  // Odd rows are shifted by one spacing; a row's dots are two spacings apart.
  EXPECT_THAT(dots[1 * 4 + 2], EigenNear(Eigen::Vector3d(10.0, 2.0, 0.0), 0.0));
  EXPECT_THAT(dots[2 * 4 + 3], EigenNear(Eigen::Vector3d(12.0, 4.0, 0.0), 0.0));
  EXPECT_THAT(board.GridCenter(), EigenNear(Eigen::Vector3d(7.0, 2.0, 0.0), 0.0));
  EXPECT_NEAR(board.NearestDotDistance(), std::sqrt(8.0), 1e-15);
}

TEST(CalibrationBoard, ReferencePlacementPutsTheGridCentreOnTheAxisAtTheGlassFace) {
  for (const auto layout : {CalibrationBoard::Layout::kSymmetric, CalibrationBoard::Layout::kAsymmetric}) {
    CalibrationBoard board;
    board.layout = layout;
    const Rigid3 pose = board.ReferenceSensorFromBoard();
    EXPECT_THAT((pose * board.GridCenter()).eval(), EigenNear(Eigen::Vector3d::Zero(), 1e-12));
    EXPECT_THAT(pose.linear(), EigenNear(Eigen::Matrix3d::Identity(), 0.0));
    for (const Eigen::Vector3d& p : board.DotCenters()) EXPECT_EQ((pose * p).z(), 0.0);
  }
}

TEST(CalibrationBoard, Validates) {
  CalibrationBoard board;
  board.rows = 2;
  EXPECT_THROW(board.Validate(), Error);
  board = {};
  board.dot_diameter_mm = board.spacing_mm;
  EXPECT_THROW(board.Validate(), Error);
  board = {};
  board.spacing_mm = 0;
  EXPECT_THROW(board.Validate(), Error);
  board = {};
  board.rows = 100000;  // once died in bad_alloc
  EXPECT_THROW(board.Validate(), Error);
  EXPECT_NO_THROW(CalibrationBoard{}.Validate());
}

TEST(CalibrationBoardFile, RoundTripsExactly) {
  CalibrationBoardFile file;
  file.board.layout = CalibrationBoard::Layout::kAsymmetric;
  file.board.rows = 9;
  file.board.cols = 4;
  file.board.spacing_mm = 2.0 / 3.0;
  file.board.dot_diameter_mm = 0.1 + 0.2;
  file.reference_image = "ref 1.png";
  file.sensor_from_board.linear() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  file.sensor_from_board.translation() = Eigen::Vector3d(-7.1, 1.0 / 7.0, 1e-3);
  const std::string path = testing::MakeTempDir("board") + "/board.yaml";
  SaveCalibrationBoardFile(file, path);
  const CalibrationBoardFile back = LoadCalibrationBoardFile(path);
  EXPECT_EQ(back.board, file.board);
  EXPECT_EQ(back.reference_image, file.reference_image);
  EXPECT_THAT(back.sensor_from_board.matrix(), EigenNear(file.sensor_from_board.matrix(), 0.0));
}

void ExpectLoadError(const std::string& text, const std::string& expected_in_message) {
  const std::string path = testing::MakeTempDir("bad") + "/board.yaml";
  std::ofstream(path) << text;
  try {
    LoadCalibrationBoardFile(path);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(expected_in_message), std::string::npos) << e.what();
  }
}

TEST(CalibrationBoardFile, RefusesBadFilesNamingTheKey) {
  const std::string board =
      "board: {layout: symmetric, rows: 7, cols: 7, spacing_mm: 2.5, dot_diameter_mm: 1.2}\n";
  const std::string reference =
      "reference:\n  image: a.png\n  sensor_from_board:\n    position_mm: [0, 0, 0]\n"
      "    rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n";
  ExpectLoadError(reference, "board: missing");
  ExpectLoadError(board + reference + "extra: 1\n", "extra: unknown key");
  ExpectLoadError("board: {layout: hexagonal, rows: 7, cols: 7, spacing_mm: 2.5, dot_diameter_mm: 1.2}\n" +
                      reference,
                  "board.layout");
  ExpectLoadError("board: {layout: symmetric, rows: seven, cols: 7, spacing_mm: 2.5, dot_diameter_mm: 1.2}\n" +
                      reference,
                  "board.rows: must be an integer");
  ExpectLoadError(board +
                      "reference:\n  image: a.png\n  sensor_from_board:\n    position_mm: [0, 0, 0]\n"
                      "    rotation: [[2, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
                  "reference.sensor_from_board.rotation: is not a rotation");
  ExpectLoadError("board: {layout: symmetric, rows: 7, cols: 7, spacing_mm: 2.5, dot_diameter_mm: 3}\n" +
                      reference,
                  "dot_diameter_mm");
  EXPECT_THROW(LoadCalibrationBoardFile("/nonexistent/board.yaml"), Error);
}

// Issue 22, defect 11: a NaN in the reference position was read, and reported later against a
// virtual camera; it is refused at its line of the board file.
TEST(CalibrationBoardFile, RefusesANonFiniteNumberAtItsLine) {
  ExpectLoadError(
      "board: {layout: symmetric, rows: 7, cols: 7, spacing_mm: 2.5, dot_diameter_mm: 1.2}\n"
      "reference:\n  image: a.png\n  sensor_from_board:\n    position_mm: [0, .nan, 0]\n"
      "    rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
      "board.yaml: line 5: reference.sensor_from_board.position_mm[1]: '.nan' is not a finite "
      "number");
  ExpectLoadError(
      "board: {layout: symmetric, rows: 7, cols: 7, spacing_mm: .inf, dot_diameter_mm: 1.2}\n",
      "board.yaml: line 1: board.spacing_mm: '.inf' is not a finite number");
}

}  // namespace
}  // namespace tac3d
