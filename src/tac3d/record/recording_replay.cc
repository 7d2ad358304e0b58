#include "tac3d/record/recording_replay.h"

#include <fmt/format.h>

#include <cmath>

#include "tac3d/util/error.h"

namespace tac3d {

void RecordingReplayOptions::Validate() const {
  if (!(speed == 0.0 || (speed >= kMinSpeed && speed <= kMaxSpeed))) {
    throw Error(fmt::format("replay speed {} must be 0 (as fast as possible) or in [{}, {}] (1: the "
                            "recorded pace)",
                            speed,
                            kMinSpeed,
                            kMaxSpeed));
  }
}

RecordingReplay::RecordingReplay(const std::string& path, const RecordingReplayOptions& options)
    : path_(path), options_((options.Validate(), options)), reader_(path), pacer_(options.speed) {}

std::optional<RecordedFrame> RecordingReplay::Next(const std::atomic<bool>* stop) {
  std::optional<RecordedFrame> recorded = reader_.Next();
  if (!recorded) return std::nullopt;
  if (!pacer_.Wait(recorded->frame.timestamp_s, stop)) return std::nullopt;
  return recorded;
}

std::string RecordingReplay::Describe() const {
  return options_.speed > 0.0 ? fmt::format("recording {} at {}x", path_, options_.speed)
                              : fmt::format("recording {} as fast as possible", path_);
}

}  // namespace tac3d
