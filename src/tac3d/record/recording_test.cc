#include "tac3d/record/recording.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/record/test_recordings.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

constexpr std::size_t kFileHeaderBytes = 12;

cv::Mat TestImage(int seed, int rows = 30, int cols = 40) {
  return testing::RandomImage(seed, rows, cols);
}

// Writes frames 0..n-1 (an image with every third) into `dir` and returns the path.
std::string WriteRecording(const std::string& dir, int n) {
  return testing::WriteSyntheticRecording(dir + "/rec.tac3d", n, 30, 40);
}

std::vector<RecordedFrame> ReadAll(RecordingReader* reader) {
  std::vector<RecordedFrame> frames;
  while (auto f = reader->Next()) frames.push_back(std::move(*f));
  return frames;
}

std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

TEST(Crc32, MatchesTheStandardCheckValue) {
  EXPECT_EQ(Crc32(0, "123456789", 9), 0xCBF43926u);
  EXPECT_EQ(Crc32(Crc32(0, "1234", 4), "56789", 5), 0xCBF43926u);
}

TEST(Recording, RoundTripKeepsEveryFieldAndImage) {
  const std::string path = WriteRecording(testing::MakeTempDir("rec"), 10);
  RecordingReader reader(path);
  const auto frames = ReadAll(&reader);
  ASSERT_EQ(frames.size(), 10u) << reader.message();
  EXPECT_EQ(reader.status(), RecordingStatus::kComplete);
  EXPECT_THAT(reader.message(), HasSubstr("complete after 10 frames"));
  EXPECT_EQ(reader.offset(), static_cast<std::int64_t>(fs::file_size(path)));
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(frames[i].frame, MakeSyntheticTactileFrame("AD2-0065L", i)) << i;
    if (i % 3 == 0) {
      ASSERT_EQ(frames[i].image.size(), cv::Size(40, 30));
      EXPECT_EQ(cv::norm(frames[i].image, TestImage(i), cv::NORM_INF), 0.0);
    } else {
      EXPECT_TRUE(frames[i].image.empty());
    }
  }
  EXPECT_EQ(reader.Next(), std::nullopt);  // stays at the end
}

TEST(Recording, EveryTruncationYieldsTheCompleteRecordsBeforeIt) {
  const std::string dir = testing::MakeTempDir("rec");
  const std::string bytes = FileBytes(WriteRecording(dir, 4));
  // Record boundaries, from a reader of the intact file.
  std::vector<std::size_t> ends;
  {
    RecordingReader reader(dir + "/rec.tac3d");
    while (reader.Next()) ends.push_back(reader.offset());
  }
  ASSERT_EQ(ends.size(), 4u);
  for (std::size_t cut = kFileHeaderBytes; cut <= bytes.size(); cut += 37) {
    const std::string path = WriteBytes(dir + "/cut.tac3d", bytes.substr(0, cut));
    RecordingReader reader(path);
    const auto frames = ReadAll(&reader);
    const auto complete = std::count_if(ends.begin(), ends.end(), [&](auto e) { return e <= cut; });
    ASSERT_EQ(static_cast<long>(frames.size()), complete) << "cut at " << cut;
    const bool at_boundary = cut == kFileHeaderBytes || std::count(ends.begin(), ends.end(), cut);
    EXPECT_EQ(reader.status(),
              at_boundary ? RecordingStatus::kComplete : RecordingStatus::kTruncated)
        << "cut at " << cut << ": " << reader.message();
    for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].frame.index, (int)i);
  }
}

TEST(Recording, CorruptionStopsTheReaderAtTheDamagedRecord) {
  const std::string dir = testing::MakeTempDir("rec");
  const std::string bytes = FileBytes(WriteRecording(dir, 5));
  std::vector<std::size_t> ends = {kFileHeaderBytes};
  {
    RecordingReader reader(dir + "/rec.tac3d");
    while (reader.Next()) ends.push_back(reader.offset());
  }
  std::mt19937_64 rng(testing::kRandomSeed);
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t record = rng() % 5;
    // A byte of the CRC or payload (the length is covered separately below).
    const std::size_t at = ends[record] + 4 + rng() % (ends[record + 1] - ends[record] - 4);
    std::string damaged = bytes;
    damaged[at] ^= static_cast<char>(1 + rng() % 255);
    RecordingReader reader(WriteBytes(dir + "/bad.tac3d", damaged));
    EXPECT_EQ(ReadAll(&reader).size(), record) << "byte " << at;
    EXPECT_EQ(reader.status(), RecordingStatus::kCorrupt);
    EXPECT_THAT(reader.message(), HasSubstr("checksum"));
  }
  // A length beyond the limit is corruption, not an allocation.
  std::string damaged = bytes;
  const std::uint32_t huge = kMaxRecordBytes + 1;
  std::memcpy(damaged.data() + ends[2], &huge, 4);
  RecordingReader reader(WriteBytes(dir + "/len.tac3d", damaged));
  EXPECT_EQ(ReadAll(&reader).size(), 2u);
  EXPECT_EQ(reader.status(), RecordingStatus::kCorrupt);
  EXPECT_THAT(reader.message(), HasSubstr("exceeds"));
}

TEST(Recording, RefusesWhatItCannotWriteOrRead) {
  const std::string dir = testing::MakeTempDir("rec");
  const std::string path = WriteRecording(dir, 1);
  try {
    RecordingWriter again(path);
    ADD_FAILURE() << "replaced an existing recording";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("`tac3d run --overwrite`"));
  }
  RecordingWriter writer(path, {.overwrite = true});
  TactileFrame bad = MakeSyntheticTactileFrame("S", 0);
  bad.valid.pop_back();
  EXPECT_THROW(writer.Write(bad), Error);
  EXPECT_THROW(writer.Write(MakeSyntheticTactileFrame("S", 0), cv::Mat(2, 2, CV_8UC3)), Error);
  EXPECT_EQ(writer.frames_written(), 0);

  EXPECT_THROW(RecordingReader(dir + "/missing"), Error);
  EXPECT_THROW(RecordingReader(WriteBytes(dir + "/text", "hello, world")), Error);
  // A FIFO blocked the reader's open for ever; refused, as a device is, before opening.
  ASSERT_EQ(::mkfifo((dir + "/fifo").c_str(), 0600), 0);
  EXPECT_THAT([&] { RecordingReader reader(dir + "/fifo"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("is not a regular file (a device or a pipe?)")));
  EXPECT_THAT([&] { RecordingReader reader("/dev/zero"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("recording '/dev/zero' is not a regular file")));
  std::string future = FileBytes(path);
  future[8] = 4;
  try {
    RecordingReader reader(WriteBytes(dir + "/v4", future));
    ADD_FAILURE() << "read version 4";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("version 4; this reader knows 1 to 3"));
  }
}

// The slip estimate's 25 bytes sit right after the contact flags, the 24 bytes of its margin
// and least normal force (version 3) right after them (docs/recording.md).
constexpr std::size_t kSlipBytes = 1 + 3 * 8;
constexpr std::size_t kMarginBytes = 3 * 8;
std::size_t SlipOffsetInPayload(const TactileFrame& f) {
  return 4 + 4 + 8 + 8 + 4 + 4 + 2 + f.sn.size() + 24 + 24 + 4 * 24 * f.num_markers() +
         2 * f.num_markers();
}

// An older file of the same frames: the header's version and each record without the bytes
// that version lacked (version 2: the margin's; version 1: the slip estimate's too), its length
// and CRC recomputed, as that version's writer made them.
std::string ToVersion(int version,
                      const std::string& v3,
                      const std::vector<TactileFrame>& frames) {
  std::string out = v3.substr(0, kFileHeaderBytes);
  out[8] = static_cast<char>(version);
  std::size_t at = kFileHeaderBytes;
  for (const TactileFrame& f : frames) {
    std::uint32_t length;
    std::memcpy(&length, v3.data() + at, 4);
    std::string payload = v3.substr(at + 8, length);
    payload.erase(SlipOffsetInPayload(f) + (version == 2 ? kSlipBytes : 0),
                  kMarginBytes + (version == 1 ? kSlipBytes : 0));
    const auto new_length = static_cast<std::uint32_t>(payload.size());
    const std::uint32_t crc = Crc32(Crc32(0, &new_length, 4), payload.data(), payload.size());
    out.append(reinterpret_cast<const char*>(&new_length), 4);
    out.append(reinterpret_cast<const char*>(&crc), 4);
    out += payload;
    at += 8 + length;
  }
  EXPECT_EQ(at, v3.size());
  return out;
}

TEST(Recording, SlipEstimateRoundTripsAtItsDocumentedOffset) {
  const std::string dir = testing::MakeTempDir("slip");
  const std::string path = WriteRecording(dir, 5);
  const std::string bytes = FileBytes(path);
  RecordingReader reader(path);
  EXPECT_EQ(reader.version(), 3u);
  std::size_t at = kFileHeaderBytes;
  for (int i = 0; i < 5; ++i) {
    const TactileFrame expected = MakeSyntheticTactileFrame("AD2-0065L", i);
    const auto f = reader.Next();
    ASSERT_TRUE(f) << reader.message();
    EXPECT_EQ(f->frame.slip, expected.slip) << i;
    EXPECT_EQ(f->frame.slip.state, static_cast<SlipState>(i));  // kUnknown .. kGrossSlip
    // The bytes where docs/recording.md puts them.
    const std::size_t slip = at + 8 + SlipOffsetInPayload(expected);
    EXPECT_EQ(static_cast<std::uint8_t>(bytes[slip]),
              static_cast<std::uint8_t>(expected.slip.state));
    double fraction, friction, sigma;
    std::memcpy(&fraction, bytes.data() + slip + 1, 8);
    std::memcpy(&friction, bytes.data() + slip + 9, 8);
    std::memcpy(&sigma, bytes.data() + slip + 17, 8);
    double margin, margin_sigma, least_force;
    std::memcpy(&margin, bytes.data() + slip + 25, 8);
    std::memcpy(&margin_sigma, bytes.data() + slip + 33, 8);
    std::memcpy(&least_force, bytes.data() + slip + 41, 8);
    EXPECT_EQ(
        FrameSlip(
            {expected.slip.state, fraction, friction, sigma, margin, margin_sigma, least_force}),
        expected.slip)
        << i;
    std::uint32_t length;
    std::memcpy(&length, bytes.data() + at, 4);
    at += 8 + length;
  }
  // A state byte beyond kGrossSlip is corruption, caught like any other bad value.
  TactileFrame bad = MakeSyntheticTactileFrame("AD2-0065L", 0);
  bad.slip.state = static_cast<SlipState>(9);
  RecordingWriter writer(dir + "/bad.tac3d");
  EXPECT_THROW(writer.Write(bad), Error);
}

TEST(Recording, ReadsVersion1FilesWithTheSlipUnknown) {
  const std::string dir = testing::MakeTempDir("v1");
  const std::string v3 = FileBytes(WriteRecording(dir, 7));
  std::vector<TactileFrame> frames;
  for (int i = 0; i < 7; ++i) frames.push_back(MakeSyntheticTactileFrame("AD2-0065L", i));
  RecordingReader reader(WriteBytes(dir + "/v1.tac3d", ToVersion(1, v3, frames)));
  EXPECT_EQ(reader.version(), 1u);
  const auto read = ReadAll(&reader);
  ASSERT_EQ(read.size(), 7u) << reader.message();
  EXPECT_EQ(reader.status(), RecordingStatus::kComplete);
  for (int i = 0; i < 7; ++i) {
    TactileFrame expected = frames[i];
    expected.slip = FrameSlip{};  // kUnknown, NaN
    EXPECT_EQ(read[i].frame, expected) << i;
    EXPECT_EQ(read[i].frame.slip.state, SlipState::kUnknown);
    EXPECT_TRUE(std::isnan(read[i].frame.slip.fraction));
    EXPECT_EQ(read[i].image.empty(), i % 3 != 0);
  }
}

TEST(Recording, ReadsVersion2FilesWithoutTheMargin) {
  const std::string dir = testing::MakeTempDir("v2");
  const std::string v3 = FileBytes(WriteRecording(dir, 7));
  std::vector<TactileFrame> frames;
  for (int i = 0; i < 7; ++i) frames.push_back(MakeSyntheticTactileFrame("AD2-0065L", i));
  RecordingReader reader(WriteBytes(dir + "/v2.tac3d", ToVersion(2, v3, frames)));
  EXPECT_EQ(reader.version(), 2u);
  const auto read = ReadAll(&reader);
  ASSERT_EQ(read.size(), 7u) << reader.message();
  EXPECT_EQ(reader.status(), RecordingStatus::kComplete);
  for (int i = 0; i < 7; ++i) {
    TactileFrame expected = frames[i];
    expected.slip.margin = expected.slip.margin_sigma = expected.slip.least_normal_force_n =
        FrameSlip::kNaN;
    EXPECT_EQ(read[i].frame, expected) << i;  // friction and its sigma kept
  }
}

// A child records frames as fast as it can and is killed with SIGKILL at a random moment:
// the file must hold frames 0..k-1 exactly, and lose at most the record in flight.
TEST(Recording, SurvivesKillNineAtARandomMoment) {
  const std::string dir = testing::MakeTempDir("kill");
  std::mt19937_64 rng(testing::kRandomSeed);
  // A full camera image makes each record's write() long, so kills land inside one too.
  const cv::Mat image = TestImage(0, 480, 640);
  {
    RecordingWriter writer(dir + "/one.tac3d");
    writer.Write(MakeSyntheticTactileFrame("KILL", 0), image);
  }
  // Every record has the same size (same SN, same image size).
  const auto record_bytes = static_cast<std::int64_t>(fs::file_size(dir + "/one.tac3d")) -
                            static_cast<std::int64_t>(kFileHeaderBytes);

  for (int trial = 0; trial < 10; ++trial) {
    const std::string path = dir + "/run.tac3d";
    fs::remove(path);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      try {
        RecordingWriter writer(path);
        for (std::int64_t i = 0;; ++i) writer.Write(MakeSyntheticTactileFrame("KILL", i), image);
      } catch (...) {
      }
      _exit(1);
    }
    // Let it write three whole frames (after the file header: a kill right after a smaller
    // size could leave two, which failed under load), then kill it at a random moment.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    std::error_code ec;
    const std::int64_t three_frames = static_cast<std::int64_t>(kFileHeaderBytes) + 3 * record_bytes;
    while (static_cast<std::int64_t>(fs::file_size(path, ec)) < three_frames &&
           std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    std::this_thread::sleep_for(std::chrono::microseconds(rng() % 20000));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "the child exited itself";

    RecordingReader reader(path);
    std::int64_t n = 0;
    while (auto f = reader.Next()) {
      ASSERT_EQ(f->frame, MakeSyntheticTactileFrame("KILL", n)) << "frame " << n;
      ASSERT_EQ(cv::norm(f->image, image, cv::NORM_INF), 0.0) << "frame " << n;
      ++n;
    }
    const auto size = static_cast<std::int64_t>(fs::file_size(path));
    EXPECT_GE(n, 3);
    EXPECT_NE(reader.status(), RecordingStatus::kCorrupt) << reader.message();
    // What is left after the last complete frame is a part of one record, no more.
    EXPECT_LT(size - reader.offset(), record_bytes) << reader.message();
    std::cout << "trial " << trial << ": " << reader.message() << "\n";
  }
}

TEST(Replay, DelayFollowsTheRecordedClockAtTheChosenSpeed) {
  EXPECT_DOUBLE_EQ(ReplayDelay(10.0, 11.0, 0.4, 1.0), 0.6);
  EXPECT_DOUBLE_EQ(ReplayDelay(10.0, 11.0, 0.4, 2.0), 0.1);
  EXPECT_DOUBLE_EQ(ReplayDelay(10.0, 11.0, 2.0, 1.0), 0.0);  // behind: no wait
  EXPECT_DOUBLE_EQ(ReplayDelay(10.0, 11.0, 0.0, 0.0), 0.0);  // as fast as possible
}

// A timestamp jumping by 1e9 s (or 1e300) made a replay wait for ever after a few frames: the
// wait is cut to the pacer's bound, and the pace goes on from that frame.
TEST(ReplayPacer, AJumpInTheClockIsWaitedOutForTheBoundOnly) {
  ReplayPacer pacer(1.0, 0.05);
  EXPECT_TRUE(pacer.Wait(0.0, nullptr));
  for (const double jump : {1e9, 1e300}) {
    EXPECT_TRUE(pacer.Wait(jump, nullptr));
    const std::optional<double> cut = pacer.TakeShortenedWait();  // said once
    ASSERT_TRUE(cut.has_value());
    EXPECT_GT(*cut, 0.5 * jump);
    EXPECT_FALSE(pacer.TakeShortenedWait().has_value());
    EXPECT_TRUE(pacer.Wait(jump + 0.01, nullptr));  // 10 ms after the jump, at its pace
    EXPECT_FALSE(pacer.TakeShortenedWait().has_value());
  }
  EXPECT_GE(pacer.waited_s(), 0.1);
}

}  // namespace
}  // namespace tac3d
