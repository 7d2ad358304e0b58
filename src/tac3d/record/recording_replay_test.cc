#include "tac3d/record/recording_replay.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/record/test_recordings.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

// Frames 0..n-1 (timestamps i / 90 s), a 24 x 32 image with every third; returns the path.
std::string WriteReplayRecording(const std::string& path, int n) {
  return testing::WriteSyntheticRecording(path, n, 24, 32);
}

std::vector<RecordedFrame> ReplayAll(RecordingReplay* replay) {
  std::vector<RecordedFrame> frames;
  while (auto f = replay->Next()) frames.push_back(std::move(*f));
  return frames;
}

TEST(RecordingReplay, GivesEveryFrameExactlyAsRecorded) {
  const std::string path = WriteReplayRecording(testing::MakeTempDir("replay") + "/rec.tac3d", 12);
  RecordingReplay replay(path, {.speed = 0.0});
  const auto frames = ReplayAll(&replay);
  ASSERT_EQ(frames.size(), 12u) << replay.message();
  for (int i = 0; i < 12; ++i) {
    EXPECT_EQ(frames[i].frame, MakeSyntheticTactileFrame("AD2-0065L", i)) << i;
    if (i % 3 == 0) {
      ASSERT_EQ(frames[i].image.size(), cv::Size(32, 24)) << i;
      EXPECT_EQ(cv::norm(frames[i].image, testing::RandomImage(i, 24, 32), cv::NORM_INF), 0.0) << i;
    } else {
      EXPECT_TRUE(frames[i].image.empty()) << i;
    }
  }
  EXPECT_EQ(replay.status(), RecordingStatus::kComplete);
  EXPECT_EQ(replay.frames_read(), 12);
  EXPECT_EQ(replay.waited_s(), 0.0);  // speed 0: as fast as possible
  EXPECT_THAT(replay.Describe(), HasSubstr("as fast as possible"));
}

TEST(RecordingReplay, KeepsTheRecordedPace) {
  // 12 frames at 90 fps: 11 / 90 = 0.122 s from the first to the last.
  const std::string path = WriteReplayRecording(testing::MakeTempDir("replay") + "/rec.tac3d", 12);
  for (const double speed : {1.0, 2.0}) {
    RecordingReplay replay(path, {.speed = speed});
    const auto start = Clock::now();
    EXPECT_EQ(ReplayAll(&replay).size(), 12u);
    const double expected_s = 11.0 / 90.0 / speed;
    // Never ahead of the recording; how much later a loaded machine makes it is not the test's
    // (the delay itself is ReplayDelay's, tested in recording_test).
    EXPECT_GE(SecondsSince(start), expected_s) << "speed " << speed;
    EXPECT_GT(replay.waited_s(), 0.0) << "speed " << speed;
    EXPECT_THAT(replay.Describe(), HasSubstr(fmt::format("at {}x", speed)));
  }
}

TEST(RecordingReplay, TruncatedFileGivesItsGoodFramesThenTheReason) {
  const std::string dir = testing::MakeTempDir("replay");
  const std::string path = WriteReplayRecording(dir + "/rec.tac3d", 5);
  // Cut in the middle of the fourth record.
  std::int64_t cut = 0;
  {
    RecordingReader reader(path);
    for (int i = 0; i < 3; ++i) reader.Next();
    cut = reader.offset() + 100;
  }
  std::filesystem::resize_file(path, static_cast<std::uintmax_t>(cut));
  RecordingReplay replay(path, {.speed = 0.0});
  const auto frames = ReplayAll(&replay);
  ASSERT_EQ(frames.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(frames[i].frame, MakeSyntheticTactileFrame("AD2-0065L", i));
  EXPECT_EQ(replay.status(), RecordingStatus::kTruncated);
  EXPECT_THAT(replay.message(), HasSubstr("truncated after 3 frames"));
  EXPECT_EQ(replay.Next(), std::nullopt);  // stays at the end
}

TEST(RecordingReplay, CorruptRecordEndsTheReplayThere) {
  const std::string path = WriteReplayRecording(testing::MakeTempDir("replay") + "/rec.tac3d", 5);
  std::int64_t at = 0;
  {
    RecordingReader reader(path);
    reader.Next();
    reader.Next();
    at = reader.offset() + 8 + 50;  // a payload byte of the third record
  }
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(at);
    f.put('\x7f');
  }
  RecordingReplay replay(path, {.speed = 0.0});
  EXPECT_EQ(ReplayAll(&replay).size(), 2u);
  EXPECT_EQ(replay.status(), RecordingStatus::kCorrupt);
  EXPECT_THAT(replay.message(), HasSubstr("checksum"));
}

TEST(RecordingReplay, RefusesBadSpeedsAndFiles) {
  const std::string dir = testing::MakeTempDir("replay");
  const std::string path = WriteReplayRecording(dir + "/rec.tac3d", 1);
  // 1e-308 made a few seconds of recording a wait for ever.
  for (const double speed : {-1.0, std::nan(""), std::numeric_limits<double>::infinity(), 1e-308, 1e9}) {
    try {
      RecordingReplay replay(path, {.speed = speed});
      ADD_FAILURE() << "accepted speed " << speed;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("speed"));
    }
  }
  EXPECT_THROW(RecordingReplay(dir + "/missing.tac3d"), Error);
  std::ofstream(dir + "/text") << "not a recording";
  EXPECT_THROW(RecordingReplay(dir + "/text"), Error);
}

TEST(ReplayPacer, AtSpeedZeroNeverSleeps) {
  ReplayPacer pacer(0.0);
  for (int i = 0; i < 1000; ++i) EXPECT_TRUE(pacer.Wait(i * 1.0, nullptr));  // 999 s recorded
  EXPECT_EQ(pacer.waited_s(), 0.0);
}

// Waits with `pacer` (made anew, speed 1) for a frame recorded at `due_s` after one at `first_s`
// while another thread sets `stop` 50 ms on; returns whether Wait said the frame was due. A
// loaded machine may run the stopper first (Wait then refuses at once, having waited nothing):
// that try is made again, so the stop comes during the wait.
bool WaitUntilStopped(double first_s, double due_s, ReplayPacer& pacer, std::atomic<bool>& stop) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    pacer = ReplayPacer(1.0);
    stop = false;
    EXPECT_TRUE(pacer.Wait(first_s, &stop));
    std::thread stopper([&stop] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      stop = true;
    });
    const bool due = pacer.Wait(due_s, &stop);
    stopper.join();
    if (due || pacer.waited_s() > 0.0) return due;
  }
  ADD_FAILURE() << "the stop came before the wait began, 100 times";
  return false;
}

TEST(ReplayPacer, StopEndsALongWait) {
  ReplayPacer pacer;
  std::atomic<bool> stop{false};
  EXPECT_FALSE(WaitUntilStopped(0.0, 100.0, pacer, stop));  // ended by the stop, not due in 100 s
  EXPECT_GT(pacer.waited_s(), 0.0);
  EXPECT_FALSE(pacer.Wait(101.0, &stop));  // stays stopped
}

// A vendor file's timestamps are whatever it holds: a gap of 1e300 s (beyond the clock's integer
// nanoseconds, where the due time once overflowed) is waited, and a stop still ends it.
TEST(ReplayPacer, AGapBeyondTheClocksRangeIsWaitedUntilStopped) {
  ReplayPacer pacer;
  std::atomic<bool> stop{false};
  EXPECT_FALSE(WaitUntilStopped(-1e300, 1e300, pacer, stop));
  EXPECT_GT(pacer.waited_s(), 0.0);
}

}  // namespace
}  // namespace tac3d
