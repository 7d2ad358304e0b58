#pragma once

// What a run does with each TactileFrame (the UDP stream, the recording, the viewer, JSON
// lines) and the frame loop that gives them, whatever the source: camera images through the
// Pipeline or a recording's frames replayed as they were computed.

#include <atomic>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/protocol/udp_sender.h"
#include "tac3d/record/recording.h"
#include "tac3d/ros2/ros2_publisher.h"
#include "tac3d/web/web_server.h"

namespace tac3d {
struct MarkerObservation;  // tac3d/tracking/marker_tracker.h
}

namespace tac3d::runtime {

/// The frame-level outputs of `tac3d run` (docs/pipeline.md).
struct FrameOutputArgs {
  std::string udp;             ///< stream the Tac3D protocol to HOST:PORT, or ""
  std::string udp_items;       ///< with udp: StreamOptions::items (extra items, "all")
  bool udp_progress = false;   ///< with udp: StreamOptions::send_initializing
  std::string record;          ///< record the frames to this new file, or ""
  bool record_images = false;  ///< record each frame's image too
  bool json = false;           ///< print each frame's summary as a JSON line on stdout
  std::string sn;              ///< the SN the frames carry, for the messages only ("" unknown)
  bool overwrite = false;      ///< replace an existing `record` file
  std::string web;             ///< serve the live viewer on HOST:PORT (docs/viewer.md), or ""
  std::string web_root;        ///< the viewer page's folder ("": the built or installed one)
  /// After the source ends, keep serving the last frames this many seconds (< 0: until
  /// Ctrl-C); with `web` only.
  double web_hold_s = 0.0;
  /// Publish ROS 2 topics under this namespace (docs/ros2.md), or "".
  std::string ros2;
  bool ros2_reliable = false;  ///< with ros2: Ros2PublisherOptions::reliable
  bool ros2_image = false;     ///< with ros2: Ros2PublisherOptions::image
  std::string ros2_frame_id;   ///< with ros2: Ros2PublisherOptions::frame_id
  /// Take a `$C` (or the viewer's or ROS 2's zero) under load too, with a warning, instead of refusing it
  /// (ZeroLoad).
  bool allow_zero_under_load = false;

  /// Checks what can be checked before any work: HOST:PORT's form, --udp-items' names,
  /// --udp-items and --udp-progress only with --udp, --record-images and --overwrite only
  /// with --record, --web-hold only with --web, the record file's folder, --ros2's namespace and
  /// frame_id, --ros2-* only with --ros2.
  /// @param inputs what the run reads (its source, its config): the record file must be none of
  ///   them (CheckOutputFile).
  /// @throws Error naming the flag.
  void Validate(const std::vector<std::string>& inputs = {}) const;
};

/// A frame is under load for a `$C` when a valid marker is displaced more than this from its
/// reference (mm). Zeroing takes the markers as they are for undeformed, so a load then offsets
/// every later reading; drift, what `$C` is for, is smaller: the drift monitor's rest band is
/// 0.05 mm (DriftOptions::rest_band_mm), the creeps docs/pipeline.md re-zeroes 0.02-0.05 mm.
/// Not the resultant: a uniform creep of 0.04 mm already reads 1.5 N.
inline constexpr double kMaxZeroDisplacementMm = 0.1;

/// What a frame shows of a load, for a `$C` received after it.
struct ZeroLoad {
  double force_n = 0.0;              ///< |resultant force| (N)
  double max_displacement_mm = 0.0;  ///< the largest valid marker displacement (mm)
  bool under_load = false;           ///< max_displacement_mm > kMaxZeroDisplacementMm
};
ZeroLoad MeasureZeroLoad(const TactileFrame& frame);

/// The publisher options of `args.ros2` and its flags.
Ros2PublisherOptions Ros2Options(const FrameOutputArgs& args);

/// Starts the viewer `args.web` names (docs/viewer.md), with `api` answering its /api/
/// requests, and names it on stderr.
/// @pre args.web is not empty. @throws Error as WebServer's constructor does.
std::shared_ptr<WebServer> OpenViewer(const FrameOutputArgs& args, WebApiHandler api = {});

/// Opens the outputs a run asked for and sends every frame to each of them.
class FrameOutputs {
 public:
  /// Validates the arguments, opens the UDP sender, the recording and the ROS 2 topics and names
  /// them on stderr.
  /// @param shared_viewer a viewer several sensors publish to (then args.web must be empty);
  ///   else one is opened when args.web asks for it.
  /// @throws Error on a malformed HOST:PORT, a host that does not resolve, or a recording
  /// file that exists or cannot be created, or DDS that cannot start (Ros2Publisher).
  explicit FrameOutputs(const FrameOutputArgs& args,
                        std::shared_ptr<WebServer> shared_viewer = nullptr);
  ~FrameOutputs();

  /// Records the frame (with `image` if record_images and it is not empty), streams it,
  /// publishes it on ROS 2 (with `image` if ros2_image), publishes it to the viewer (with `image` and the tracker's `markers` in it, when given,
  /// drawn on it) and prints its JSON line.
  /// @throws Error as RecordingWriter::Write and UdpSender::Send do.
  void Emit(const TactileFrame& frame, const cv::Mat& image, const MarkerObservation* markers = nullptr);
  /// The next command the UDP client sent (`$C`, `$Q`), or a zero the viewer asked for this
  /// SN or a ROS 2 node on NAMESPACE/zero (`$C`); nullopt when none.
  std::optional<SensorCommand> PollCommand();
  /// Whether a `$C` received after `last` (the frame emitted last) is to be taken: at rest it
  /// is, quietly; under load (MeasureZeroLoad) it is refused with a line on stderr naming the
  /// load, or with allow_zero_under_load taken with a warning line naming it.
  bool AcceptZero(const TactileFrame& last) const;
  /// With --web and --web-hold: keeps the viewer up after the source ended, until the hold
  /// is over or Ctrl-C / SIGTERM.
  void HoldWeb();
  /// ", N streamed (M initialising withheld)" when streaming, ", N recorded to FILE" when
  /// recording, ", N published on ROS 2 under NAMESPACE", and the viewer's counts; else "".
  std::string RecordedNote() const;

 private:
  FrameOutputArgs args_;
  std::optional<UdpSender> sender_;
  std::optional<RecordingWriter> recorder_;
  std::unique_ptr<Ros2Publisher> ros2_;
  std::shared_ptr<WebServer> web_;
};

/// With a viewer and a hold (`--web-hold`): keeps it up after the sources ended, until the
/// hold is over or Ctrl-C / SIGTERM (none when the run was stopped that way).
void HoldViewer(const WebServer* viewer, double hold_s);

/// While an instance lives, Ctrl-C and SIGTERM set flag() (and no longer end the process).
/// One instance at a time.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  /// Set by a signal; cleared by the frame loops when they start.
  static std::atomic<bool>& flag();
};

/// What a run's frame producer made of one step.
enum class Produced {
  kFrame,    ///< a frame to emit
  kSkipped,  ///< nothing to emit this time (a bad image); go on
  kEnd,      ///< no more frames
};

/// A frame a producer gives: pointers to storage it owns, valid until its next call.
struct ProducedFrame {
  const TactileFrame* frame = nullptr;
  const cv::Mat* image = nullptr;  ///< the frame's camera image (possibly empty), or null
  /// The tracker's markers in `image` (a pipeline's stream), or null (a recording's).
  const MarkerObservation* markers = nullptr;
};

/// Gives the next frame: fills `out`. `stop` is set by Ctrl-C, SIGTERM or the client's `$Q`; a
/// producer that waits checks it.
using FrameProducer = std::function<Produced(const std::atomic<bool>& stop, ProducedFrame& out)>;

/// What a client's `$C` does to a stream.
struct ZeroHandler {
  std::function<void()> zero;
  /// Whether it retakes the reference of the frames to come (a pipeline's stream), so one under
  /// load is refused (FrameOutputs::AcceptZero); a recording's frames were computed when it was
  /// recorded, and its stream only notes the `$C`.
  bool retakes_reference = true;
};

struct FrameLoopCounts {
  long emitted = 0;
  long skipped = 0;
  bool quit = false;  ///< ended by the client's `$Q`
};

/// One sensor's loop: takes frames from `produce` and emits them until it ends, `max_frames`
/// (> 0) have been emitted, `stop` is set, or the client's `$Q`; a `$C` calls `on_zero.zero`,
/// if it retakes the reference only when outputs.AcceptZero of the frame just emitted.
/// Thread-safe for distinct outputs (the sensors of a run file each run one).
FrameLoopCounts FrameLoop(FrameOutputs& outputs,
                          long max_frames,
                          const std::atomic<bool>& stop,
                          const FrameProducer& produce,
                          const ZeroHandler& on_zero);

/// The loop of `tac3d run`: FrameLoop, stopped by Ctrl-C or SIGTERM as well, whose handlers
/// are in place only during the loop; a `$Q` also skips the viewer's hold.
FrameLoopCounts RunFrameLoop(FrameOutputs& outputs,
                             long max_frames,
                             const FrameProducer& produce,
                             const ZeroHandler& on_zero);

/// The recording's path when `source` is "recording:FILE", else nullopt.
std::optional<std::string> RecordingSourcePath(const std::string& source);

/// The vendor recording's folder when `source` is "vendor:DIR", else nullopt.
std::optional<std::string> VendorSourcePath(const std::string& source);

}  // namespace tac3d::runtime
