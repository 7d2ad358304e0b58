#include "tac3d/runtime/sensor_group.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <system_error>
#include <thread>

#include <fmt/format.h>

#include <opencv2/core/utility.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::runtime {
namespace {

using Clock = std::chrono::steady_clock;

// A sensor ready to run (both null when it could not be opened).
struct OpenSensor {
  std::unique_ptr<FrameOutputs> outputs;
  std::unique_ptr<SensorStream> stream;
};

// While it lives, OpenCV's functions run on their caller's thread, without OpenCV's own worker
// pool: each sensor has its thread already, and a pool whose workers cannot be created (memory
// or threads run out) waits for them for ever (seen: a sensor spinning in
// connectedComponentsWithStats under `prlimit --as`).
class OpenCvOnCallersThread {
 public:
  OpenCvOnCallersThread() : saved_(cv::getNumThreads()) { cv::setNumThreads(1); }
  ~OpenCvOnCallersThread() { cv::setNumThreads(saved_); }
  OpenCvOnCallersThread(const OpenCvOnCallersThread&) = delete;
  OpenCvOnCallersThread& operator=(const OpenCvOnCallersThread&) = delete;

 private:
  int saved_;
};

// Why a sensor's work threw: a tac3d::Error's message, or what else ran out.
std::string Why(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e) != nullptr) return "out of memory (std::bad_alloc)";
  return e.what();
}

// One sensor's thread: its frame loop, timed on the common clock. Nothing escapes it: an
// exception that left a thread would end the process (std::terminate).
void RunSensor(OpenSensor& sensor, const StreamClock& clock, const SensorGroupOptions& options,
               const std::atomic<bool>& stop, SensorReport& report) {
  try {
    sensor.stream->Start(clock);
    double last = std::numeric_limits<double>::quiet_NaN();
    bool given = false;  // a frame was given and not yet known to be emitted
    const FrameLoopCounts counts = FrameLoop(
        *sensor.outputs, options.max_frames, stop,
        [&](const std::atomic<bool>& s, ProducedFrame& out) {
          // Asked again: the last frame given was emitted. Counted as they go, so a loop ended
          // by an exception reports the frames emitted before it.
          report.frames += given;
          given = false;
          const Produced produced = sensor.stream->Next(s, out);
          if (produced != Produced::kFrame) return produced;
          const double now = SecondsSince(clock.epoch);
          if (std::isnan(report.first_frame_s)) report.first_frame_s = now;
          if (!std::isnan(last)) report.max_gap_s = std::max(report.max_gap_s, now - last);
          last = report.last_frame_s = now;
          if (options.on_frame) options.on_frame(*out.frame);
          given = true;
          return produced;
        },
        {[&] { sensor.stream->Zero(); }, sensor.stream->ZeroRetakesReference()});
    report.frames = counts.emitted;
    report.skipped = counts.skipped;
    report.outputs = sensor.outputs->RecordedNote();
    const StreamEnd end = sensor.stream->End(counts.emitted);
    report.failure = end.failure;
    report.warning = end.warning;
    report.last_skip = end.last_skip;
  } catch (const std::exception& e) {
    report.failure = Why(e);  // an output failed (a full disk, say), or memory ran out
  } catch (...) {
    report.failure = "an unknown exception";
  }
  std::fprintf(stderr, "%s\n", report.BriefReport().c_str());
}

}  // namespace

std::string SensorReport::BriefReport() const {
  std::string s = fmt::format("{}: {} frames, {} skipped", sn, frames, skipped);
  if (frames > 0) {
    s += fmt::format(", {:.2f}-{:.2f} s, longest gap {:.0f} ms", first_frame_s, last_frame_s, 1e3 * max_gap_s);
  }
  s += outputs;
  if (!last_skip.empty()) s += ", last skipped: " + last_skip;
  if (!warning.empty()) s += ", warning: " + warning;
  if (!failure.empty()) s += ", FAILED: " + failure;
  return s;
}

void RunSingleSensor(SensorStream& stream, const FrameOutputArgs& output_args, long max_frames,
                     const std::string& done) {
  FrameOutputs outputs(output_args);
  stream.Start({.epoch = Clock::now(), .common = false});
  const FrameLoopCounts counts = RunFrameLoop(
      outputs, max_frames,
      [&](const std::atomic<bool>& stop, ProducedFrame& out) { return stream.Next(stop, out); },
      {[&] { stream.Zero(); }, stream.ZeroRetakesReference()});
  std::fprintf(stderr, "%ld frames %s, %ld skipped%s\n", counts.emitted, done.c_str(), counts.skipped,
               outputs.RecordedNote().c_str());
  outputs.HoldWeb();
  // The recording is complete up to the last frame; now say why the source ended.
  const StreamEnd end = stream.End(counts.emitted);
  if (!end.warning.empty()) std::fprintf(stderr, "tac3d: warning: %s\n", end.warning.c_str());
  if (!end.failure.empty()) throw Error(end.failure);
}

std::vector<SensorReport> RunSensorGroup(const std::vector<SensorRunSpec>& sensors,
                                         const ModelLoader& load_model,
                                         const SensorGroupOptions& options,
                                         const std::shared_ptr<WebServer>& viewer,
                                         const std::atomic<bool>& stop) {
  // Checked before any sensor starts: a run file's mistake stops the run.
  if (sensors.size() > static_cast<size_t>(kMaxSensors)) {
    throw Error(fmt::format("{} sensors: a run holds at most {}", sensors.size(), kMaxSensors));
  }
  for (const SensorRunSpec& spec : sensors) spec.Validate();

  std::vector<SensorReport> reports(sensors.size());
  std::vector<OpenSensor> open(sensors.size());
  for (size_t i = 0; i < sensors.size(); ++i) {
    reports[i].sn = sensors[i].sn;
    FrameOutputArgs outputs = sensors[i].outputs;
    outputs.sn = sensors[i].sn;
    outputs.json = options.json;
    try {
      SensorRunSpec spec = sensors[i];
      spec.shared_viewer = viewer != nullptr;
      open[i].stream = OpenSensorStream(spec, load_model, sensors[i].sn + ": ");
      open[i].outputs = std::make_unique<FrameOutputs>(outputs, viewer);
    } catch (const std::exception& e) {
      reports[i].failure = fmt::format("could not start: {}", Why(e));
      std::fprintf(stderr, "%s\n", reports[i].BriefReport().c_str());
      open[i] = {};
    }
  }

  const OpenCvOnCallersThread opencv_serial;
  const Clock::time_point epoch = Clock::now();
  // Joined when they go out of scope, however this ends; reserved, so adding one cannot throw
  // but for the thread that could not start.
  std::vector<std::jthread> threads;
  threads.reserve(sensors.size());
  for (size_t i = 0; i < sensors.size(); ++i) {
    if (!open[i].stream) continue;
    try {
      threads.emplace_back([&, i] {
        RunSensor(open[i], {.epoch = epoch, .common = true}, options, stop, reports[i]);
      });
    } catch (const std::system_error& e) {  // no thread to be had (address space, a limit)
      reports[i].failure = fmt::format("could not start its thread: {}", e.what());
      std::fprintf(stderr, "%s\n", reports[i].BriefReport().c_str());
      open[i] = {};  // its pipeline's memory back for the others
    }
  }
  threads.clear();  // joins them
  return reports;
}

}  // namespace tac3d::runtime
