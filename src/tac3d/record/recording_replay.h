#pragma once

#include <atomic>
#include <optional>
#include <string>

#include "tac3d/record/recording.h"

namespace tac3d {

struct RecordingReplayOptions {
  /// 1: the recorded pace; 2: twice as fast; 0: as fast as possible. 0 or in [kMinSpeed,
  /// kMaxSpeed]: 1e-308 made a replay of a few seconds wait for ever.
  double speed = 1.0;
  static constexpr double kMinSpeed = 1e-3;
  static constexpr double kMaxSpeed = 1e3;

  /// @throws Error naming `speed` when it is neither 0 nor in [kMinSpeed, kMaxSpeed].
  void Validate() const;
};

/// A recording's frames at their recorded pace (RecordingReader + ReplayPacer): the source of
/// `tac3d run --source recording:FILE`. Frames come back exactly as recorded (the TactileFrame
/// and the image, if any); nothing is recomputed.
class RecordingReplay {
 public:
  /// @throws Error if the options are invalid or the file is not a recording (RecordingReader).
  explicit RecordingReplay(const std::string& path, const RecordingReplayOptions& options = {});

  /// The next good frame, returned when it is due: (t_k - t_0) / speed after the first one.
  /// nullopt at the end of the good frames (status() and message() then say why the file
  /// ended) or when `stop` is set while waiting (it is checked every 10 ms of a wait).
  std::optional<RecordedFrame> Next(const std::atomic<bool>* stop = nullptr);

  /// kReading until the end is reached, then as RecordingReader::status().
  RecordingStatus status() const { return reader_.status(); }
  const std::string& message() const { return reader_.message(); }
  std::int64_t frames_read() const { return reader_.frames_read(); }
  /// Seconds spent waiting for frames to be due (0 at speed 0).
  double waited_s() const { return pacer_.waited_s(); }
  /// ReplayPacer::TakeShortenedWait of the last Next.
  std::optional<double> TakeShortenedWait() { return pacer_.TakeShortenedWait(); }
  /// "recording FILE at 1x" or "... as fast as possible".
  std::string Describe() const;

 private:
  std::string path_;
  RecordingReplayOptions options_;
  RecordingReader reader_;
  ReplayPacer pacer_;
};

}  // namespace tac3d
