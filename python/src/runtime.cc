// The library's runtime (tac3d::runtime, docs/pipeline.md) from Python: several sensors, each
// on its own thread, with their outputs (UDP, recording, JSON lines) and one clock; the frames
// to a Python callback.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <exception>
#include <future>
#include <mutex>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "frame_binding.h"
#include "tac3d/runtime/run_file.h"
#include "tac3d/runtime/sensor_group.h"
#include "tac3d/runtime/sensor_stream.h"
#include "twin_common.h"

namespace tac3d::python {
namespace {

using runtime::SensorReport;
using runtime::SensorRunSpec;

SensorRunSpec MakeSpec(const std::string& sn, const std::string& source, const std::string& config,
                       int reference_frames, std::optional<double> weight,
                       std::optional<bool> support_resolve, const py::object& gains,
                       bool recompute_forces, const std::string& drift, double drift_time_constant_s,
                       std::optional<double> speed, double fps, double exposure,
                       const std::string& pixel_format,
                       const std::string& udp, const std::string& udp_items, bool udp_progress,
                       bool allow_zero_under_load, const std::string& record, bool record_images,
                       bool overwrite, const std::string& ros2, bool ros2_reliable, bool ros2_image,
                       const std::string& ros2_frame_id) {
  SensorRunSpec s;
  s.sn = sn;
  s.source = source;
  s.config = config;
  s.reference_frames = reference_frames;
  s.weight = weight;
  s.support_resolve = support_resolve;
  s.gains = ToVector3d(gains, "gains");
  s.recompute_forces = recompute_forces;
  s.drift.mode = DriftModeArg(drift);
  s.drift.time_constant_s = drift_time_constant_s;
  s.speed = speed;
  s.camera.fps = fps;
  s.exposure = exposure;
  s.camera.pixel_format = pixel_format;
  s.outputs.udp = udp;
  s.outputs.udp_items = udp_items;
  s.outputs.udp_progress = udp_progress;
  s.outputs.allow_zero_under_load = allow_zero_under_load;
  s.outputs.record = record;
  s.outputs.record_images = record_images;
  s.outputs.overwrite = overwrite;
  s.outputs.ros2 = ros2;
  s.outputs.ros2_reliable = ros2_reliable;
  s.outputs.ros2_image = ros2_image;
  s.outputs.ros2_frame_id = ros2_frame_id;
  s.outputs.sn = sn;
  s.Validate();
  return s;
}

// Calls a Python function with every frame, from the sensors' threads (taking the GIL); the
// first exception it raises is kept and stops the run.
class FrameCallback {
 public:
  FrameCallback(py::object fn, std::atomic<bool>& stop) : fn_(std::move(fn)), stop_(stop) {}

  void operator()(const TactileFrame& frame) {
    py::gil_scoped_acquire gil;
    if (error_) return;
    try {
      fn_(FrameToPython(TactileFrame(frame)));
    } catch (py::error_already_set& e) {
      error_.emplace(std::move(e));
      stop_ = true;
    }
  }

  // With the GIL held: raises the callback's exception, if it raised one.
  void RaiseIfFailed() {
    if (error_) throw std::move(*error_);
  }

 private:
  py::object fn_;
  std::atomic<bool>& stop_;
  std::optional<py::error_already_set> error_;  // guarded by the GIL
};

// Runs the sensors on their threads while this one, the GIL released, waits and wakes every
// 0.1 s for Python's signal handlers: Ctrl-C stops every sensor, then raises KeyboardInterrupt.
std::vector<SensorReport> Run(const std::vector<SensorRunSpec>& sensors, long max_frames,
                              const std::string& cache_dir, bool json, const py::object& on_frame) {
  if (max_frames < 0) throw Error(fmt::format("max_frames must be >= 0, got {}", max_frames));
  std::atomic<bool> stop{false};
  std::optional<FrameCallback> callback;
  runtime::SensorGroupOptions options{.max_frames = max_frames, .json = json, .on_frame = {}};
  if (!on_frame.is_none()) {
    callback.emplace(on_frame, stop);
    options.on_frame = [&callback](const TactileFrame& frame) { (*callback)(frame); };
  }
  const runtime::ModelLoader load_model = runtime::CachedModelLoader(ResolveCacheDir(cache_dir));
  std::future<std::vector<SensorReport>> reports;
  try {
    reports = std::async(std::launch::async, [&] {
      return runtime::RunSensorGroup(sensors, load_model, options, nullptr, stop);
    });
  } catch (const std::system_error& e) {
    throw Error(fmt::format("cannot start the run's thread: {}", e.what()));
  }
  std::optional<py::error_already_set> interrupted;
  for (;;) {
    {
      py::gil_scoped_release release;
      if (reports.wait_for(std::chrono::milliseconds(100)) == std::future_status::ready) break;
    }
    if (!interrupted && PyErr_CheckSignals() != 0) {
      interrupted.emplace();
      stop = true;
    }
  }
  if (interrupted) throw std::move(*interrupted);
  if (callback) callback->RaiseIfFailed();
  return reports.get();  // rethrows the runtime's Error (a spec refused before any work)
}

void RegisterSensorSpec(py::module_& m) {
  const SensorRunSpec d;
  py::class_<SensorRunSpec>(m, "SensorSpec", R"doc(
One sensor of tac3d.run, as one entry of a run file (docs/pipeline.md, "Several sensors"):
what it reads, how it computes its frames, where they go. Checked when made (tac3d.Error
naming the field).
)doc")
      .def(py::init(&MakeSpec), py::arg("sn"), py::arg("source"), py::kw_only(),
           // The defaults are SensorRunSpec's, as `tac3d run`'s and the run file's.
           py::arg("config") = d.config, py::arg("reference_frames") = d.reference_frames,
           py::arg("weight") = d.weight, py::arg("support_resolve") = d.support_resolve,
           py::arg("gains") = std::vector<double>(d.gains.begin(), d.gains.end()),
           py::arg("recompute_forces") = d.recompute_forces,
           py::arg("drift") = runtime::DriftModeName(d.drift.mode),
           py::arg("drift_time_constant_s") = d.drift.time_constant_s,
           py::arg("speed") = d.speed, py::arg("fps") = d.camera.fps, py::arg("exposure") = d.exposure,
           py::arg("pixel_format") = d.camera.pixel_format,
           py::arg("udp") = d.outputs.udp, py::arg("udp_items") = d.outputs.udp_items,
           py::arg("udp_progress") = d.outputs.udp_progress,
           py::arg("allow_zero_under_load") = d.outputs.allow_zero_under_load,
           py::arg("record") = d.outputs.record,
           py::arg("record_images") = d.outputs.record_images,
           py::arg("overwrite") = d.outputs.overwrite,
           py::arg("ros2") = d.outputs.ros2, py::arg("ros2_reliable") = d.outputs.ros2_reliable,
           py::arg("ros2_image") = d.outputs.ros2_image, py::arg("ros2_frame_id") = d.outputs.ros2_frame_id,
           "sn: the serial number in the stream, recording and frames; source: camera:N,\n"
           "/dev/videoN, a video file, an image folder, dataset:DIR, recording:FILE or vendor:DIR\n"
           "(a vendor recording's <SN> folder); config: a sensor YAML ('' the built-in\n"
           "prototype); weight (Tikhonov w, (mm/N)^2) and support_resolve (the contact-support\n"
           "re-solve): None for the sensor's defaults (w 0.05; the re-solve on for the built-in\n"
           "prototype, off for an imported sensor); recompute_forces: a recording's forces computed\n"
           "anew from its displacements through config's sensor; speed: pace of dataset:/recording:/vendor:\n"
           "(None: a recording at its recorded pace, a dataset as fast as possible); pixel_format:\n"
           "a camera's V4L2 pixel format, e.g. 'MJPG' ('' the driver's choice); udp:\n"
           "HOST:PORT of a Tac3D client; udp_items: tac3d's extra items after the vendor's six\n"
           "('3D_Normals,SlipState', 'all'; tac3d run's --udp-items); udp_progress: also send\n"
           "the frames taken while the reference is taken (--udp-progress);\n"
           "allow_zero_under_load: take a $C while the sensor is loaded, with a warning, instead\n"
           "of refusing it (--allow-zero-under-load); record: a new recording file; ros2: a ROS 2\n"
           "namespace to publish the frames under (tac3d run's --ros2, docs/ros2.md), with\n"
           "ros2_reliable, ros2_image, ros2_frame_id as --ros2-reliable, --ros2-image, --ros2-frame-id.")
      .def_readonly("sn", &SensorRunSpec::sn)
      .def_readonly("source", &SensorRunSpec::source)
      .def_readonly("config", &SensorRunSpec::config)
      .def_readonly("reference_frames", &SensorRunSpec::reference_frames)
      .def_readonly("weight", &SensorRunSpec::weight)
      .def_readonly("support_resolve", &SensorRunSpec::support_resolve)
      .def_readonly("recompute_forces", &SensorRunSpec::recompute_forces)
      .def_property_readonly("gains", [](const SensorRunSpec& s) { return std::vector<double>(s.gains.begin(), s.gains.end()); })
      .def_property_readonly("drift", [](const SensorRunSpec& s) { return runtime::DriftModeName(s.drift.mode); })
      .def_property_readonly("drift_time_constant_s", [](const SensorRunSpec& s) { return s.drift.time_constant_s; })
      .def_readonly("speed", &SensorRunSpec::speed)
      .def_property_readonly("fps", [](const SensorRunSpec& s) { return s.camera.fps; })
      .def_readonly("exposure", &SensorRunSpec::exposure)
      .def_property_readonly("pixel_format", [](const SensorRunSpec& s) { return s.camera.pixel_format; })
      .def_property_readonly("udp", [](const SensorRunSpec& s) { return s.outputs.udp; })
      .def_property_readonly("udp_items", [](const SensorRunSpec& s) { return s.outputs.udp_items; })
      .def_property_readonly("udp_progress", [](const SensorRunSpec& s) { return s.outputs.udp_progress; })
      .def_property_readonly("allow_zero_under_load", [](const SensorRunSpec& s) { return s.outputs.allow_zero_under_load; })
      .def_property_readonly("record", [](const SensorRunSpec& s) { return s.outputs.record; })
      .def_property_readonly("record_images", [](const SensorRunSpec& s) { return s.outputs.record_images; })
      .def_property_readonly("overwrite", [](const SensorRunSpec& s) { return s.outputs.overwrite; })
      .def_property_readonly("ros2", [](const SensorRunSpec& s) { return s.outputs.ros2; })
      .def_property_readonly("ros2_reliable", [](const SensorRunSpec& s) { return s.outputs.ros2_reliable; })
      .def_property_readonly("ros2_image", [](const SensorRunSpec& s) { return s.outputs.ros2_image; })
      .def_property_readonly("ros2_frame_id", [](const SensorRunSpec& s) { return s.outputs.ros2_frame_id; })
      .def("__repr__", [](const SensorRunSpec& s) {
        return fmt::format("tac3d.SensorSpec(sn='{}', source='{}')", s.sn, s.source);
      });
}

void RegisterSensorReport(py::module_& m) {
  py::class_<SensorReport>(m, "SensorReport", R"doc(
How one sensor of tac3d.run went: frames emitted and skipped, why it failed ('' if it did not:
it could not start, its source broke, an output or the on_frame callback failed), a warning,
the last skip's reason, and on the run's clock (s since the sensors started) its first and
last frame and the longest gap between two frames (NaN, NaN, 0 without frames).
)doc")
      .def_readonly("sn", &SensorReport::sn)
      .def_readonly("frames", &SensorReport::frames)
      .def_readonly("skipped", &SensorReport::skipped)
      .def_readonly("failure", &SensorReport::failure)
      .def_readonly("warning", &SensorReport::warning)
      .def_readonly("last_skip", &SensorReport::last_skip)
      .def_readonly("first_frame_s", &SensorReport::first_frame_s)
      .def_readonly("last_frame_s", &SensorReport::last_frame_s)
      .def_readonly("max_gap_s", &SensorReport::max_gap_s)
      .def_readonly("outputs", &SensorReport::outputs)
      .def("brief_report", &SensorReport::BriefReport,
           "'SN: 30 frames, 0 skipped, 0.03-1.00 s, longest gap 35 ms[, outputs][, FAILED: why]'.")
      .def("__repr__", [](const SensorReport& r) { return "<tac3d.SensorReport " + r.BriefReport() + ">"; });
}

}  // namespace

DriftMode DriftModeArg(const std::string& drift) {
  const std::optional<DriftMode> mode = runtime::ParseDriftMode(drift);
  if (!mode) throw Error(fmt::format("drift '{}': must be off, flag or rezero", drift));
  return *mode;
}

void RegisterRuntime(py::module_& m) {
  RegisterSensorSpec(m);
  RegisterSensorReport(m);
  m.def("load_run_file", &runtime::LoadRunFile, py::arg("path"),
        "The sensors of a run file (docs/pipeline.md, \"Several sensors\"), relative paths taken\n"
        "from its folder. Raises tac3d.Error naming the line of a mistake.");
  m.def("run", &Run, py::arg("sensors"), py::kw_only(), py::arg("max_frames") = 0,
        py::arg("cache_dir") = "", py::arg("json") = false, py::arg("on_frame") = py::none(),
        R"doc(Runs the sensors as `tac3d run --run-file` does, until every source ends: each on its
own thread (source -> pipeline -> outputs), frames stamped on one clock, a sensor that fails
reported while the others go on. Returns one SensorReport a sensor, in order.

sensors: SensorSpecs (or tac3d.load_run_file(path)); max_frames: per sensor (0: until the
source ends); cache_dir: the compliance models' cache ('' for $TAC3D_CACHE_DIR,
$XDG_CACHE_HOME/tac3d or ~/.cache/tac3d; built there the first time); json: each frame's
summary as a JSON line on stdout; on_frame(frame): called with every frame (a TactileFrame)
of every sensor, one call at a time, from the sensors' threads. The GIL is released while the
sensors run. Ctrl-C stops every sensor, then raises KeyboardInterrupt; an exception raised by
on_frame stops them too and is raised here. Raises tac3d.Error before any work for a spec it
refuses.)doc");
}

}  // namespace tac3d::python
