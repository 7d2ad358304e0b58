#pragma once

// Running sensors: one on the calling thread (`tac3d run --source`), or several (a run file,
// Python's tac3d.run): one thread per sensor, one clock, one viewer; a sensor that fails is
// reported and the others go on (docs/pipeline.md).

#include <atomic>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "tac3d/runtime/run_outputs.h"
#include "tac3d/runtime/sensor_stream.h"

namespace tac3d::runtime {

/// The most sensors a run holds (a run file, RunSensorGroup), for the worst case: sensors of
/// as many different gels, each with its own model and inverse (~55 MB for the prototype's 400
/// markers) and a thread, fit a 4 GB address space (`prlimit --as=4000000000`). Sensors of one
/// gel share those (CachedModelLoader), ~2.5 MB each beyond the first (docs/performance.md).
inline constexpr int kMaxSensors = 32;

/// What the sensors of a run share.
struct SensorGroupOptions {
  long max_frames = 0;  ///< per sensor; 0 until its source ends
  bool json = false;    ///< each frame's summary as a JSON line on stdout (with its SN)
  /// Called with every frame a sensor emits, on that sensor's thread, before its outputs (so
  /// it must be thread-safe); an exception it throws fails that sensor. Empty: none.
  std::function<void(const TactileFrame&)> on_frame = {};
};

/// How one sensor's run went.
struct SensorReport {
  std::string sn;
  long frames = 0;   ///< frames emitted
  long skipped = 0;  ///< bad frames skipped
  /// Why the sensor stopped before its source ended: it could not start (a camera missing),
  /// its source broke (unplugged, stalled, a corrupt recording), or an output failed. "" none.
  std::string failure;
  std::string warning;  ///< e.g. a truncated recording
  std::string last_skip;  ///< why the last bad frame was skipped (a file gone, say); "" none
  /// On the run's common clock (s since the sensors started): the first and last frame
  /// emitted, and the longest time between two of them. NaN, NaN, 0 without frames.
  double first_frame_s = std::numeric_limits<double>::quiet_NaN();
  double last_frame_s = std::numeric_limits<double>::quiet_NaN();
  double max_gap_s = 0.0;
  /// What the outputs did with the frames, as a single sensor's run says it ("" without
  /// outputs): ", 30 streamed to 127.0.0.1:9988, 30 recorded to x.tac3drec, 30 published on ROS 2
  /// under /hand/thumb".
  std::string outputs;

  /// "SN: 30 frames, 0 skipped, 0.03-1.00 s, longest gap 35 ms[, outputs][, last skipped: why]
  /// [, FAILED: why]".
  std::string BriefReport() const;
};

/// Runs each sensor on its own thread until all have ended (their sources ended, max_frames,
/// `$Q` from their UDP client) or `stop` is set. The sensors are opened one after the other
/// first (a compliance model several share is loaded once: CachedModelLoader's is one copy a
/// process, its matrices shared by their pipelines); one that cannot be
/// opened, or fails later, gets its failure in its report and the others go on. Frames are
/// stamped with seconds since one steady-clock epoch taken when all are open, from which a
/// dataset's pace counts too.
/// @param viewer the viewer every sensor publishes to (a panel per SN), or nullptr.
/// A sensor that cannot be opened or whose thread cannot start (memory or threads run out) gets
/// its failure in its report, as does one whose loop throws anything; none ends the process.
/// While the sensors run, OpenCV uses no worker pool of its own (cv::setNumThreads(1), restored
/// after): each sensor's OpenCV calls run on its own thread.
/// @throws Error before any work for more than kMaxSensors sensors or a sensor whose spec is
///   invalid (SensorRunSpec::Validate: a malformed UDP address or record file, say).
/// One sensor on the calling thread, as `tac3d run --source` runs it: the stream's frames, on
/// its source's own timestamps, to the outputs `outputs` names (FrameOutputs), until the source
/// ends, `max_frames` (> 0) were emitted, Ctrl-C / SIGTERM (StopSignals, during the loop) or the
/// client's `$Q`. Then prints "N frames <done>, M skipped[, K recorded to FILE...]" on stderr and
/// keeps the viewer up for outputs.web_hold_s, unless the run was stopped.
/// @param done what became of the frames, for that line ("processed", "replayed from FILE").
/// @throws Error if an output cannot be opened or fails, or, after the frames emitted were
///   recorded, if the source failed; a warning (a truncated recording) is printed on stderr.
void RunSingleSensor(SensorStream& stream, const FrameOutputArgs& outputs, long max_frames,
                     const std::string& done);

std::vector<SensorReport> RunSensorGroup(const std::vector<SensorRunSpec>& sensors,
                                         const ModelLoader& load_model,
                                         const SensorGroupOptions& options,
                                         const std::shared_ptr<WebServer>& viewer,
                                         const std::atomic<bool>& stop);

}  // namespace tac3d::runtime
