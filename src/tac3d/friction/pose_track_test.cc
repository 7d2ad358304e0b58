#include "tac3d/friction/pose_track.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::friction {
namespace {

using ::testing::MatchesRegex;

std::string WriteCsv(const std::string& name, const std::string& text) {
  const std::string path = tac3d::testing::MakeTempDir("pose_track") + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(PoseTrack, ReadsCsvAndInterpolatesLinearlyAndBySlerp) {
  // 0 s: identity at the origin; 2 s: 90 deg about z at (10, -4, 2); 3 s: same rotation.
  const double h = std::sqrt(0.5);
  const std::string path = WriteCsv("poses.csv",
                                    "# motion capture\n"
                                    "t_s, x_mm, y_mm, z_mm, qw, qx, qy, qz\n"
                                    "0.0, 0, 0, 0, 1, 0, 0, 0\n"
                                    "\n"
                                    "2.0, 10, -4, 2, " +
                                        std::to_string(h) + ", 0, 0, " + std::to_string(h) +
                                        "\n"
                                        "3.0, 10, -4, 2, " +
                                        std::to_string(h) + ", 0, 0, " + std::to_string(h) + "\n");
  const PoseTrack track = PoseTrack::ReadCsv(path);
  ASSERT_EQ(track.poses().size(), 3u);
  EXPECT_EQ(track.poses()[1].line, 5);
  EXPECT_DOUBLE_EQ(track.begin_s(), 0.0);
  EXPECT_DOUBLE_EQ(track.end_s(), 3.0);
  // Ends are exact.
  EXPECT_THAT(track.At(0.0).matrix(), EigenNear(Eigen::Matrix4d::Identity(), 1e-12));
  EXPECT_THAT(track.At(3.0).translation().eval(), EigenNear(Eigen::Vector3d(10, -4, 2), 1e-12));
  // The midpoint of the first interval: 45 deg about z, halfway in position.
  const Rigid3 mid = track.At(1.0);
  const Eigen::Matrix3d r45 =
      Eigen::AngleAxisd(DegToRad(45), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_THAT(mid.linear().eval(), EigenNear(r45, 1e-6));
  EXPECT_THAT(mid.translation().eval(), EigenNear(Eigen::Vector3d(5, -2, 1), 1e-12));
  // A quarter: 22.5 deg (slerp's constant angular rate).
  EXPECT_NEAR(RotationAngleDeg(Eigen::Matrix3d::Identity(), track.At(0.5).linear()), 22.5, 1e-4);
}

TEST(PoseTrack, NearlyUnitQuaternionsAreNormalised) {
  const std::string path = WriteCsv("rounded.csv",
                                    "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n"
                                    "0,0,0,0,1.0004,0,0,0\n"
                                    "1,0,0,0,0.7071,0,0.7071,0\n");
  const PoseTrack track = PoseTrack::ReadCsv(path);
  for (const TimedPose& p : track.poses()) {
    const Eigen::Matrix3d r = p.world_from_sensor.linear();
    EXPECT_THAT((r.transpose() * r).eval(), EigenNear(Eigen::Matrix3d::Identity(), 1e-12));
  }
}

TEST(PoseTrack, FrameTimesOutsideThePosesAreRefused) {
  const std::string path = WriteCsv("short.csv",
                                    "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n"
                                    "1.0,0,0,0,1,0,0,0\n"
                                    "2.0,1,0,0,1,0,0,0\n");
  const PoseTrack track = PoseTrack::ReadCsv(path);
  EXPECT_THAT(
      ErrorOf([&] { track.At(2.5); }),
      MatchesRegex(
          "poses '.*short.csv' \\(lines 2-3\\) cover t = 1 \\.\\. 2 s: they do not cover the "
          "frame time 2.5 s"));
  EXPECT_THAT(ErrorOf([&] { track.At(0.999); }),
              MatchesRegex(".*do not cover the frame time 0.999 s"));
  EXPECT_NO_THROW(track.At(1.0));
  EXPECT_NO_THROW(track.At(2.0));
}

TEST(PoseTrack, NonUnitQuaternionIsRefusedWithFileLineAndTolerance) {
  const std::string path = WriteCsv("scaled.csv",
                                    "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n"
                                    "0,0,0,0,1,0,0,0\n"
                                    "1,0,0,0,2,0,0,0\n");
  EXPECT_THAT(
      ErrorOf([&] { PoseTrack::ReadCsv(path); }),
      MatchesRegex(
          ".*scaled.csv:3: quaternion \\(qw, qx, qy, qz\\) = \\(2, 0, 0, 0\\) has norm 2: not "
          "unit length within 0.001"));
  // Just outside the default tolerance, and accepted with a wider one.
  const std::string off =
      WriteCsv("off.csv", "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n0,0,0,0,1.002,0,0,0\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(off); }),
              MatchesRegex(".*off.csv:2: quaternion .*"));
  EXPECT_NO_THROW(PoseTrack::ReadCsv(off, 0.01));
}

TEST(PoseTrack, TimeGoingBackIsRefused) {
  const std::string path = WriteCsv("back.csv",
                                    "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n"
                                    "0,0,0,0,1,0,0,0\n"
                                    "1,0,0,0,1,0,0,0\n"
                                    "0.5,0,0,0,1,0,0,0\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(path); }),
              MatchesRegex(".*back.csv:4: t_s = 0.5 goes back: it must be after 1 \\(line 3\\)"));
  const std::string same =
      WriteCsv("same.csv", "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0,0,0,0,1,0,0,0\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(same); }),
              MatchesRegex(".*same.csv:3: t_s = 0 goes back.*"));
}

TEST(PoseTrack, MalformedFilesNameFileAndLine) {
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv("/nonexistent/poses.csv"); }),
              MatchesRegex("pose CSV '/nonexistent/poses.csv' does not exist"));
  const std::string rpy = WriteCsv("rpy.csv", "t_s,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(rpy); }),
              MatchesRegex(".*rpy.csv:1: the header must be t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz"));
  const std::string short_row =
      WriteCsv("row.csv", "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n0,0,0,0,1,0,0\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(short_row); }),
              MatchesRegex(".*row.csv:2: expected 8 finite numbers .*, got 7"));
  const std::string text =
      WriteCsv("text.csv", "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n0,0,zero,0,1,0,0,0\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(text); }),
              MatchesRegex(".*text.csv:2: expected 8 finite numbers.*"));
  const std::string empty = WriteCsv("empty.csv", "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(empty); }),
              MatchesRegex(".*empty.csv' has a header but no pose"));
}

TEST(PoseTrack, ConstructorChecksTimes) {
  EXPECT_THAT(ErrorOf([] { PoseTrack({}, "mem"); }), MatchesRegex("poses 'mem': no pose"));
  std::vector<TimedPose> poses(2);
  poses[0].t_s = 1.0;
  poses[1].t_s = 1.0;
  EXPECT_THAT(ErrorOf([&] { PoseTrack(poses, "mem"); }), MatchesRegex("mem: t_s = 1 goes back.*"));
}


// Issue 22, defect 8: /dev/zero grew to 2.2 GB before "is empty", a 1 GB sparse file ended in
// std::bad_alloc, and a folder was "empty". Each is refused before a byte is read.
TEST(PoseTrack, DevicesFoldersAndHugeFilesAreRefusedBeforeReading) {
  EXPECT_THAT(ErrorOf([] { PoseTrack::ReadCsv("/dev/zero"); }),
              MatchesRegex("pose CSV '/dev/zero' is not a regular file .*"));
  const std::string folder = tac3d::testing::MakeTempDir("pose_folder");
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(folder); }),
              MatchesRegex("pose CSV '.*pose_folder.*' is a directory, not a file"));
  const std::string sparse = WriteCsv("sparse.csv", "");
  std::filesystem::resize_file(sparse, std::uintmax_t{1} << 30);  // 1 GiB of holes
  EXPECT_THAT(ErrorOf([&] { PoseTrack::ReadCsv(sparse); }),
              MatchesRegex(".*sparse.csv' is 1073741824 bytes, more than the limit of .* bytes"));
}

}  // namespace
}  // namespace tac3d::friction
