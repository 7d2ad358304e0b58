#include "tac3d/record/recording_info.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// Ten frames of a 20 x 20 grid: a 24 x 32 image with frames 0, 3, 6, 9; frames 0-1
// initializing, frame 2 zeroed, frame 7 missing (an index gap); every synthetic frame has
// markers_lost.
std::string WriteFlaggedRecording(const std::string& path) {
  RecordingWriter writer(path);
  for (int i = 0; i < 11; ++i) {
    if (i == 7) continue;
    TactileFrame f = MakeSyntheticTactileFrame("AD2-0065L", i);
    if (i < 2) {
      f.initialize_progress = 50 * (i + 1);
      f.set(FrameFlag::kInitializing);
    }
    if (i == 2) f.set(FrameFlag::kZeroed);
    writer.Write(f, i % 3 == 0 ? cv::Mat(24, 32, CV_8UC1, cv::Scalar(i)) : cv::Mat());
  }
  return path;
}

std::int64_t FlagFrames(const RecordingInfo& info, FrameFlag flag) {
  for (std::size_t i = 0; i < std::size(kAllFrameFlags); ++i) {
    if (kAllFrameFlags[i] == flag) return info.flag_frames[i];
  }
  return -1;
}

TEST(RecordingInfo, SummarisesACompleteRecording) {
  const std::string path = WriteFlaggedRecording(testing::MakeTempDir("info") + "/rec.tac3d");
  const RecordingInfo info = ReadRecordingInfo(path);
  EXPECT_EQ(info.frames, 10);
  EXPECT_EQ(info.first_index, 0);
  EXPECT_EQ(info.last_index, 10);
  EXPECT_EQ(info.index_gaps, 1);
  EXPECT_EQ(info.timestamps_backwards, 0);
  EXPECT_DOUBLE_EQ(info.duration_s(), 10.0 / 90.0);
  EXPECT_NEAR(info.mean_fps(), 9.0 / (10.0 / 90.0), 1e-9);
  EXPECT_EQ(info.sns, std::vector<std::string>{"AD2-0065L"});
  ASSERT_EQ(info.grids.size(), 1u);
  EXPECT_EQ(info.grids[0], (RecordingInfo::Grid{20, 20}));
  EXPECT_EQ(info.frames_with_image, 4);  // 0, 3, 6, 9
  ASSERT_EQ(info.image_sizes.size(), 1u);
  EXPECT_EQ(info.image_sizes[0], (RecordingInfo::Grid{24, 32}));
  EXPECT_EQ(FlagFrames(info, FrameFlag::kMarkersLost), 10);
  EXPECT_EQ(FlagFrames(info, FrameFlag::kInitializing), 2);
  EXPECT_EQ(FlagFrames(info, FrameFlag::kZeroed), 1);
  EXPECT_EQ(FlagFrames(info, FrameFlag::kForceOutOfRange), 0);
  EXPECT_EQ(info.unflagged_frames, 0);
  EXPECT_EQ(info.status, RecordingStatus::kComplete);
  EXPECT_EQ(info.file_bytes, static_cast<std::int64_t>(std::filesystem::file_size(path)));
  EXPECT_EQ(info.tail_bytes(), 0);
  EXPECT_THAT(info.BriefReport(), HasSubstr("10 frames, 0.111 s, SN AD2-0065L, 20 x 20, complete"));
  EXPECT_THAT(info.FullReport(), HasSubstr("4 of 10 frames, 24 x 32"));
  EXPECT_THAT(info.FullReport(), HasSubstr("0 .. 10 (1 gaps)"));
  EXPECT_THAT(info.FullReport(), Not(HasSubstr("unread tail")));
}

TEST(RecordingInfo, ReportsATruncatedRecordingsGoodFramesAndTail) {
  const std::string path = WriteFlaggedRecording(testing::MakeTempDir("info") + "/rec.tac3d");
  const RecordingInfo whole = ReadRecordingInfo(path);
  std::int64_t end_of_sixth = 0;
  {
    RecordingReader reader(path);
    for (int i = 0; i < 6; ++i) reader.Next();
    end_of_sixth = reader.offset();
  }
  std::filesystem::resize_file(path, static_cast<std::uintmax_t>(end_of_sixth + 1000));
  const RecordingInfo info = ReadRecordingInfo(path);
  EXPECT_EQ(info.frames, 6);
  EXPECT_EQ(info.last_index, 5);
  EXPECT_EQ(info.frames_with_image, 2);  // 0, 3
  EXPECT_EQ(info.status, RecordingStatus::kTruncated);
  EXPECT_EQ(info.good_bytes, end_of_sixth);
  EXPECT_EQ(info.tail_bytes(), 1000);
  EXPECT_THAT(info.message, HasSubstr("truncated after 6 frames"));
  EXPECT_THAT(info.BriefReport(), HasSubstr("6 frames"));
  EXPECT_THAT(info.BriefReport(), HasSubstr("truncated"));
  EXPECT_THAT(info.FullReport(), HasSubstr("1000 bytes after byte"));
  EXPECT_LT(info.duration_s(), whole.duration_s());
}

TEST(RecordingInfo, EmptyRecordingHasNoFramesAndNoDuration) {
  const std::string path = testing::MakeTempDir("info") + "/empty.tac3d";
  { RecordingWriter writer(path); }
  const RecordingInfo info = ReadRecordingInfo(path);
  EXPECT_EQ(info.frames, 0);
  EXPECT_EQ(info.duration_s(), 0.0);
  EXPECT_EQ(info.mean_fps(), 0.0);
  EXPECT_EQ(info.status, RecordingStatus::kComplete);
  EXPECT_THAT(info.FullReport(), HasSubstr("none"));
}

TEST(RecordingInfo, RefusesWhatIsNotARecording) {
  const std::string dir = testing::MakeTempDir("info");
  EXPECT_THROW(ReadRecordingInfo(dir + "/missing.tac3d"), Error);
  std::ofstream(dir + "/text") << "not a recording at all";
  EXPECT_THROW(ReadRecordingInfo(dir + "/text"), Error);
}

}  // namespace
}  // namespace tac3d
