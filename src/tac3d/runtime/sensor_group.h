#pragma once

// Several sensors in one `tac3d run` (a run file): one thread per sensor, one clock, one
// viewer; a sensor that fails is reported and the others go on (docs/pipeline.md).

#include <atomic>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "run_outputs.h"
#include "sensor_stream.h"

namespace tac3d::cli {

/// What the sensors of a run share.
struct SensorGroupOptions {
  long max_frames = 0;  ///< per sensor; 0 until its source ends
  bool json = false;    ///< each frame's summary as a JSON line on stdout (with its SN)
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

  /// "SN: 30 frames, 0 skipped, 0.03-1.00 s, longest gap 35 ms[, last skipped: why]
  /// [, FAILED: why]".
  std::string BriefReport() const;
};

/// Runs each sensor on its own thread until all have ended (their sources ended, max_frames,
/// `$Q` from their UDP client) or `stop` is set. The sensors are opened one after the other
/// first (so a compliance model shared by several is loaded once); one that cannot be
/// opened, or fails later, gets its failure in its report and the others go on. Frames are
/// stamped with seconds since one steady-clock epoch taken when all are open, from which a
/// dataset's pace counts too.
/// @param viewer the viewer every sensor publishes to (a panel per SN), or nullptr.
/// @throws Error before any work if an output argument is malformed (UDP address, record
///   file).
std::vector<SensorReport> RunSensorGroup(const std::vector<SensorRunSpec>& sensors,
                                         const ModelLoader& load_model,
                                         const SensorGroupOptions& options,
                                         const std::shared_ptr<WebServer>& viewer,
                                         const std::atomic<bool>& stop);

}  // namespace tac3d::cli
