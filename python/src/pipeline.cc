// Frame sources (camera, video, image folder, twin dataset) and the in-process pipeline.
#include "tac3d/pipeline/pipeline.h"

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <limits>
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
  int rows = 0, cols = 0;
  std::vector<Eigen::Vector3d> rest_markers_mm;  // the model's, for positions not given
};

std::unique_ptr<PyPipeline> MakePipeline(const std::string& config_path,
                                         const std::string& cache_dir,
                                         const std::optional<std::string>& sn,
                                         int reference_frames,
                                         std::optional<double> weight,
                                         std::optional<bool> support_resolve,
                                         const py::object& gains,
                                         const std::string& drift,
                                         double drift_time_constant_s) {
  const SensorConfig config = LoadSensorOrDefault(config_path);
  PipelineOptions options = DefaultPipelineOptions(config);
  if (sn) options.sn = *sn;
  options.reference_frames = reference_frames;
  if (weight) options.force.weight = *weight;
  if (support_resolve) options.force.support_refinement = *support_resolve;
  options.force.gains = ToVector3d(gains, "gains");
  options.drift.mode = DriftModeArg(drift);
  options.drift.time_constant_s = drift_time_constant_s;
  options.Validate();
  auto p = std::make_unique<PyPipeline>();
  py::gil_scoped_release release;
  const std::string cache = ResolveCacheDir(cache_dir);
  // One model and inverse for every pipeline of the same gel and weight in the process.
  const std::shared_ptr<const fem::ComplianceModel> model =
      fem::LoadSharedComplianceModel(SensorBodyModelOptions(config), cache, /*show_progress=*/false);
  p->pipeline = std::make_unique<Pipeline>(config, fem::SharedH(model), model->marker_positions, options);
  p->rows = config.markers.rows;
  p->cols = config.markers.cols;
  p->rest_markers_mm = model->marker_positions;
  return p;
}

// Forces of T recorded frames through the pipeline's inverse (Pipeline::RecomputeForces).
py::list RecomputeForces(PyPipeline& p, const py::handle& displacements, const py::handle& positions,
                         const py::handle& valid, const py::handle& timestamps) {
  const std::vector<Eigen::Vector3d>& rest = p.rest_markers_mm;
  const int n = static_cast<int>(rest.size());
  const DoubleArray d = DoubleArray::ensure(displacements);
  if (!d || d.ndim() != 3 || d.shape(1) != n || d.shape(2) != 3) {
    throw Error(fmt::format("displacements must be a T x {} x 3 array (mm)", n));
  }
  const py::ssize_t frames = d.shape(0);
  const auto per_frame = [&](const py::handle& a, const char* what, py::ssize_t trailing) {
    DoubleArray array = DoubleArray::ensure(a);
    const bool ok = array && array.ndim() == (trailing ? 3 : 2) && array.shape(0) == frames && array.shape(1) == n &&
                    (!trailing || array.shape(2) == trailing);
    if (!ok) throw Error(fmt::format("{} must be a T x {}{} array, T = {} as the displacements'", what, n,
                                     trailing ? " x 3" : "", frames));
    return array;
  };
  std::optional<DoubleArray> given_positions, given_valid;
  if (!positions.is_none()) given_positions = per_frame(positions, "positions", 3);
  if (!valid.is_none()) given_valid = per_frame(valid, "valid", 0);
  std::vector<double> times(frames);
  if (!timestamps.is_none()) {
    const DoubleArray t = DoubleArray::ensure(timestamps);
    if (!t || t.ndim() != 1 || t.shape(0) != frames) throw Error(fmt::format("timestamps must hold {} values", frames));
    for (py::ssize_t k = 0; k < frames; ++k) times[k] = t.at(k);
  } else {
    for (py::ssize_t k = 0; k < frames; ++k) times[k] = static_cast<double>(k) / 30.0;
  }
  py::list out;
  for (py::ssize_t k = 0; k < frames; ++k) {
    TactileFrame frame = TactileFrame::Sized(p.rows, p.cols);
    frame.sn = p.pipeline->options().sn;
    frame.index = k;
    frame.timestamp_s = times[k];
    frame.initialize_progress = 100;
    int lost = 0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d di(d.at(k, i, 0), d.at(k, i, 1), d.at(k, i, 2));
      const Eigen::Vector3d pi = given_positions ? Eigen::Vector3d(given_positions->at(k, i, 0), given_positions->at(k, i, 1),
                                                                   given_positions->at(k, i, 2))
                                                 : Eigen::Vector3d(rest[i] + di);
      // A marker is valid where it was given as valid, or else where it is finite.
      const bool valid_i = given_valid ? given_valid->at(k, i) != 0.0 : di.allFinite() && pi.allFinite();
      frame.valid[i] = valid_i;
      lost += valid_i ? 0 : 1;
      frame.displacements_mm[i] = valid_i ? di : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
      frame.positions_mm[i] = valid_i ? pi : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
    frame.set(FrameFlag::kMarkersLost, lost > 0);
    {
      py::gil_scoped_release release;
      p.pipeline->RecomputeForces(frame);
    }
    out.append(FrameToPython(std::move(frame)));
  }
  return out;
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
           py::arg("weight") = py::none(),
           py::arg("support_resolve") = py::none(),
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
      .def("recompute_forces",
           &RecomputeForces,
           py::arg("displacements"),
           py::arg("positions") = py::none(),
           py::arg("valid") = py::none(),
           py::arg("timestamps") = py::none(),
           "Forces computed anew from recorded displacements (T x N x 3, mm; e.g. a recording's\n"
           "displacements() or a vendor recording's 3D_Displacements.npy) through this pipeline's\n"
           "inverse, as `tac3d run --recompute-forces`: a list of T TactileFrames. positions (T x N x\n"
           "3, mm; None: the rest markers displaced), valid (T x N; None: the finite markers) and\n"
           "timestamps (T, s; None: frame k at k / 30 s) are taken as given. Raises tac3d.Error for\n"
           "a shape that is not the sensor's.")
      .def(
          "zero",
          [](PyPipeline& p) { p.pipeline->RequestZero(); },
          "Takes the next reference_frames frames as the new reference (as `$C`).")
      .def_property_readonly("initializing",
                             [](const PyPipeline& p) { return p.pipeline->initializing(); });
}

}  // namespace tac3d::python
