// Frame sources (camera, video, image folder, twin dataset) and the in-process pipeline.
#include "tac3d/pipeline/pipeline.h"

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "frame_binding.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/fem/body_model.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/runtime/sensor_stream.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/source/frame_source.h"
#include "tac3d/vendor_formats/vendor_gel.h"
#include "twin_common.h"

namespace tac3d::python {
namespace {

const char* StatusName(ReadStatus s) {
  switch (s) {
    case ReadStatus::kOk:
      return "ok";
    case ReadStatus::kBadFrame:
      return "bad_frame";
    case ReadStatus::kEnd:
      return "end";
    case ReadStatus::kFailed:
      return "failed";
  }
  return "?";
}

struct Source {
  std::unique_ptr<FrameSource> source;
  std::string last_status = "ok";

  // The next good frame, skipping bad ones; nullopt at the end. @throws Error if it failed.
  std::optional<Frame> Next() {
    for (;;) {
      Frame frame;
      ReadStatus status;
      {
        py::gil_scoped_release release;
        status = source->Read(frame);
      }
      last_status = StatusName(status);
      if (status == ReadStatus::kOk) return frame;
      if (status == ReadStatus::kEnd) return std::nullopt;
      if (status == ReadStatus::kFailed)
        throw Error("the frame source failed: " + source->last_error());
    }
  }
};

py::tuple FrameTuple(Frame&& f) {
  return py::make_tuple(ImageArray(f.image), f.timestamp_s, f.index);
}

std::unique_ptr<Source> OpenSource(const std::string& uri, int width, int height, double fps) {
  auto s = std::make_unique<Source>();
  py::gil_scoped_release release;
  if (uri.rfind("dataset:", 0) == 0) {
    s->source = OpenTwinDataset(uri.substr(8));
  } else {
    CameraSourceOptions camera;
    camera.width = width;
    camera.height = height;
    camera.fps = fps;
    s->source = OpenFrameSource(uri, camera);
  }
  return s;
}

struct PyPipeline {
  std::unique_ptr<Pipeline> pipeline;
  TactileFrame scratch;
};

std::unique_ptr<PyPipeline> MakePipeline(const std::string& config_path,
                                         const std::string& cache_dir,
                                         const std::optional<std::string>& sn,
                                         int reference_frames,
                                         double weight,
                                         const py::object& gains,
                                         const std::string& drift,
                                         double drift_time_constant_s) {
  const SensorConfig config = LoadSensorOrDefault(config_path);
  PipelineOptions options;
  options.sn = sn ? *sn : DefaultSerialNumber(config);
  options.reference_frames = reference_frames;
  options.force.weight = weight;
  options.force.gains = ToVector3d(gains, "gains");
  options.drift.mode = DriftModeArg(drift);
  options.drift.time_constant_s = drift_time_constant_s;
  options.Validate();
  auto p = std::make_unique<PyPipeline>();
  py::gil_scoped_release release;
  const std::string cache = ResolveCacheDir(cache_dir);
  const fem::ComplianceCacheResult model = fem::LoadOrBuildComplianceModel(
      SensorBodyModelOptions(config), cache, /*show_progress=*/false);
  p->pipeline =
      std::make_unique<Pipeline>(config, model.model.h, model.model.marker_positions, options);
  return p;
}

py::object Process(PyPipeline& p, const py::array& image, double timestamp_s) {
  Frame frame;
  frame.image = ImageFromArray(image, "image");
  frame.timestamp_s = timestamp_s;
  TactileFrame out;
  {
    py::gil_scoped_release release;
    p.pipeline->Process(frame, out);
  }
  return FrameToPython(std::move(out));
}

}  // namespace

void RegisterPipeline(py::module_& m) {
  const PipelineOptions d;  // the defaults, as `tac3d run`'s
  py::class_<Source>(m, "FrameSource", R"doc(
Camera images from a V4L2 camera, a video file, an image folder or a twin dataset
(tac3d.open_source). Iterating gives (image uint8 H x W, timestamp_s, index) tuples; bad
frames (a corrupt file) are skipped; a failed camera raises tac3d.Error.
)doc")
      .def(
          "read",
          [](Source& s) -> py::object {
            std::optional<Frame> f = s.Next();
            if (!f) return py::none();
            return FrameTuple(std::move(*f));
          },
          "The next (image, timestamp_s, index), or None at the end.")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__",
           [](Source& s) {
             std::optional<Frame> f = s.Next();
             if (!f) throw py::stop_iteration();
             return FrameTuple(std::move(*f));
           })
      .def("describe", [](const Source& s) { return s.source->Describe(); });

  m.def("open_source",
        &OpenSource,
        py::arg("uri"),
        py::arg("width") = 640,
        py::arg("height") = 480,
        py::arg("fps") = 30.0,
        "Opens camera:N or /dev/videoN (width x height at fps), a video file, an image folder,\n"
        "or dataset:DIR (a twin dataset's rendered images). Raises tac3d.Error if it cannot.");

  py::class_<PyPipeline>(m, "Pipeline", R"doc(
The per-frame chain in-process (C++ tac3d::Pipeline): tracking -> 3D markers -> displacements
-> forces -> normals, contact, resultants, slip. The first reference_frames frames (and those
after zero()) build the reference: they come out with initialize_progress < 100 and the
'initializing' flag. The compliance model is loaded from the cache (built if missing: about a
minute for the default sensor), with the GIL released.
)doc")
      .def(py::init(&MakePipeline),
           py::arg("config") = "",
           py::arg("cache_dir") = "",
           py::arg("sn") = py::none(),
           py::arg("reference_frames") = d.reference_frames,
           py::arg("weight") = d.force.weight,
           py::arg("gains") = std::vector<double>(d.force.gains.begin(), d.force.gains.end()),
           py::arg("drift") = runtime::DriftModeName(d.drift.mode),
           py::arg("drift_time_constant_s") = d.drift.time_constant_s,
           "config: a sensor YAML ('' : the built-in prototype); cache_dir: '' for\n"
           "$TAC3D_CACHE_DIR, $XDG_CACHE_HOME/tac3d or ~/.cache/tac3d; sn: None for an imported\n"
           "sensor's own serial number (else 'TAC3D-TWIN'); the rest as SensorSpec's\n"
           "and `tac3d run`'s (drift: off, flag or rezero). Raises tac3d.Error.")
      .def("process",
           &Process,
           py::arg("image"),
           py::arg("timestamp") = 0.0,
           "One grey image (uint8 H x W, the camera's size) taken at `timestamp` (s) to a\n"
           "TactileFrame (its index counts the frames this pipeline processed).")
      .def(
          "zero",
          [](PyPipeline& p) { p.pipeline->RequestZero(); },
          "Takes the next reference_frames frames as the new reference (as `$C`).")
      .def_property_readonly("initializing",
                             [](const PyPipeline& p) { return p.pipeline->initializing(); });
}

}  // namespace tac3d::python
