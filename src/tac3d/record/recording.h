#pragma once

#include <atomic>
#include <chrono>
#include <utility>
#include <cstdint>
#include <fstream>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

// A recording (docs/recording.md): the 12-byte file header "TAC3DREC" + u32 version, then one
// record per frame, [u32 payload length][u32 CRC-32 of the length and payload][payload],
// little-endian. Each record goes to the kernel in one write() as the frame is recorded, so a
// process killed at any instant leaves every complete record readable and at most a partial
// last one, which the reader detects and reports.

inline constexpr char kRecordingMagic[8] = {'T', 'A', 'C', '3', 'D', 'R', 'E', 'C'};
/// The version the writer writes. 2 adds the slip estimate (TactileFrame::slip) after the
/// contact flags, 3 its margin to gross slip and least normal force after it; the reader also
/// reads versions 1 (frames carry SlipState::kUnknown) and 2 (margin and least force NaN).
inline constexpr std::uint32_t kRecordingVersion = 3;
inline constexpr std::uint32_t kOldestRecordingVersion = 1;
/// Records longer than this are refused by the writer and taken as corruption by the reader,
/// so a damaged length field cannot make the reader allocate without bound.
inline constexpr std::uint32_t kMaxRecordBytes = 256u << 20;

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, as zlib's crc32), continued from `crc`
/// (0 to start).
std::uint32_t Crc32(std::uint32_t crc, const void* data, std::size_t size);

struct RecordingWriterOptions {
  bool overwrite = false;  ///< false: refuse to replace an existing file
  /// fdatasync after each frame: survives power loss as well as a killed process, at the cost
  /// of a disk flush per frame. Off by default (a killed process needs no sync).
  bool sync_every_frame = false;
};

/// Appends TactileFrames, and optionally the raw camera images, to a new recording file.
class RecordingWriter {
 public:
  /// Creates `path` and writes the file header.
  /// @throws Error if the path is a folder or its folder does not exist (CheckOutputFile), the
  ///   file exists (unless options.overwrite), or it cannot be written.
  explicit RecordingWriter(const std::string& path, const RecordingWriterOptions& options = {});
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  /// Appends one frame as one record and hands it to the kernel before returning.
  /// @param image an 8-bit single-channel image (the raw camera frame) or empty for none.
  /// @throws Error if the frame does not Validate(), its SN is longer than 65535 bytes, the
  /// image is not 8-bit mono, the record exceeds kMaxRecordBytes, or the write fails.
  void Write(const TactileFrame& frame, const cv::Mat& image = cv::Mat());

  std::int64_t frames_written() const { return frames_written_; }

 private:
  std::string path_;
  int fd_ = -1;
  bool sync_every_frame_;
  std::vector<std::uint8_t> record_;  // reused between frames
  std::int64_t frames_written_ = 0;
};

struct RecordedFrame {
  TactileFrame frame;
  cv::Mat image;  ///< CV_8UC1, or empty when none was recorded
};

enum class RecordingStatus {
  kReading,    ///< not at the end yet
  kComplete,   ///< the file ends exactly after a complete record
  kTruncated,  ///< the file ends inside a record (e.g. the writer was killed)
  kCorrupt,    ///< a record's length, checksum or contents are wrong
};
const char* RecordingStatusName(RecordingStatus status);

/// Reads a recording frame by frame, stopping at the first truncated or corrupt record.
class RecordingReader {
 public:
  /// @throws Error if the file cannot be opened or does not start with a recording header of
  /// a version this reader knows.
  explicit RecordingReader(const std::string& path);

  /// The next frame, or nullopt at the end; then status() says why it ended and message()
  /// where.
  std::optional<RecordedFrame> Next();

  RecordingStatus status() const { return status_; }
  /// At the end: what ended the file, with the byte offset and frame number.
  const std::string& message() const { return message_; }
  std::int64_t frames_read() const { return frames_read_; }
  /// The file's format version (1 or 2).
  std::uint32_t version() const { return version_; }
  /// Bytes of the file up to the end of the last complete record read.
  std::int64_t offset() const { return offset_; }

 private:
  std::nullopt_t End(RecordingStatus status, const std::string& message);

  std::string path_;
  std::ifstream in_;
  RecordingStatus status_ = RecordingStatus::kReading;
  std::string message_;
  std::int64_t frames_read_ = 0;
  std::int64_t offset_ = 0;
  std::uint32_t version_ = kRecordingVersion;
  std::vector<std::uint8_t> record_;
};

/// Seconds to wait before showing the frame stamped `timestamp_s`, to replay at `speed` times
/// the recorded rate: the recording started at `first_timestamp_s`, and `elapsed_s` seconds
/// have passed since its first frame was shown. speed <= 0 means as fast as possible (0 s).
double ReplayDelay(double first_timestamp_s, double timestamp_s, double elapsed_s, double speed);

/// Replays frames at a recorded pace: call Wait(frame.timestamp_s) before each frame. A frame
/// due more than max_wait_s after the call (a pause in the recording, or a timestamp jumping
/// by 1e9 s in a damaged one) is shown after max_wait_s, and the frames after it keep their
/// pace from it: a replay never stalls for ever.
class ReplayPacer {
 public:
  static constexpr double kMaxWaitS = 10.0;

  /// @param speed 1: recorded speed; 2: twice as fast; <= 0: as fast as possible.
  /// @param max_wait_s the longest wait for one frame (s, > 0).
  explicit ReplayPacer(double speed = 1.0, double max_wait_s = kMaxWaitS)
      : speed_(speed), max_wait_s_(max_wait_s) {}
  void Wait(double timestamp_s) { Wait(timestamp_s, nullptr); }
  /// As Wait, but gives up (returns false) as soon as `stop` is set, checked every 10 ms of
  /// the wait; true when the frame is due. `stop` may be null.
  bool Wait(double timestamp_s, const std::atomic<bool>* stop);
  /// Seconds spent waiting so far (0 at speed <= 0).
  double waited_s() const { return waited_s_; }
  /// The wait the last Wait cut to max_wait_s (s, at the replay's speed), once: then nullopt
  /// until another is cut. For a note to the user that the replay skipped a pause.
  std::optional<double> TakeShortenedWait() { return std::exchange(shortened_wait_s_, std::nullopt); }

 private:
  double speed_;
  double max_wait_s_;
  double waited_s_ = 0.0;
  std::optional<double> shortened_wait_s_;
  std::optional<double> first_timestamp_s_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace tac3d
