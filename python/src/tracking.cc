// Single-view marker tracking (a GelSight-type sensor): tac3d.SingleViewTracker, the library's
// SingleViewSourceTracker over a frame source.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "arrays.h"
#include "bindings.h"
#include "tac3d/tracking/single_view_track.h"

namespace tac3d::python {
namespace {

struct PyTrackedFrame {
  SingleViewTrackFrame frame;
  int rows = 0, cols = 0;
};

// N x 2 float64, a copy.
py::array_t<double> Points(const std::vector<Eigen::Vector2d>& points) {
  py::array_t<double> a({static_cast<py::ssize_t>(points.size()), py::ssize_t{2}});
  auto m = a.mutable_unchecked<2>();
  for (size_t i = 0; i < points.size(); ++i) {
    m(i, 0) = points[i].x();
    m(i, 1) = points[i].y();
  }
  return a;
}

// Where the track places each marker: its estimate unless lost (NaN), as the CSV's x, y.
py::array_t<double> PlacedPoints(const GridObservation& o) {
  py::array_t<double> a = Points(o.estimate_uv);
  auto m = a.mutable_unchecked<2>();
  for (size_t i = 0; i < o.state.size(); ++i) {
    if (TrackedStateOf(o, static_cast<int>(i)) != TrackedMarkerState::kLost) continue;
    m(i, 0) = m(i, 1) = std::numeric_limits<double>::quiet_NaN();
  }
  return a;
}

py::object States(const GridObservation& o) {
  py::list names;
  for (size_t i = 0; i < o.state.size(); ++i) names.append(std::string(ToString(TrackedStateOf(o, static_cast<int>(i)))));
  return py::module_::import("numpy").attr("array")(names);
}

struct PyTracker {
  std::unique_ptr<SingleViewSourceTracker> tracker;

  std::optional<PyTrackedFrame> Next() {
    PyTrackedFrame out{{}, tracker->rows(), tracker->cols()};
    ReadStatus status;
    do {
      py::gil_scoped_release release;
      status = tracker->Next(out.frame);
    } while (status == ReadStatus::kBadFrame);
    if (status == ReadStatus::kEnd) return std::nullopt;
    return out;
  }
};

std::unique_ptr<PyTracker> MakeTracker(const std::string& source, const std::optional<std::pair<int, int>>& grid,
                                       std::int64_t reference, const std::vector<std::pair<std::int64_t, std::int64_t>>& rest_frames,
                                       int width, int height, double fps) {
  SingleViewTrackOptions options;
  if (grid) std::tie(options.rows, options.cols) = *grid;
  options.reference_frame = reference;
  for (const auto& [first, last] : rest_frames) options.rest_frames.push_back({first, last});
  options.Validate();
  CameraSourceOptions camera;
  camera.width = width;
  camera.height = height;
  camera.fps = fps;
  auto t = std::make_unique<PyTracker>();
  py::gil_scoped_release release;
  t->tracker = std::make_unique<SingleViewSourceTracker>(OpenSingleViewSource(source, camera), options);
  return t;
}

}  // namespace

void RegisterTracking(py::module_& m) {
  py::class_<PyTrackedFrame>(m, "TrackedFrame", R"doc(
One frame of a single-view track (tac3d.SingleViewTracker): the markers row-major,
index = row * cols + col.
)doc")
      .def_property_readonly("index", [](const PyTrackedFrame& f) { return f.frame.index; })
      .def_property_readonly("timestamp_s", [](const PyTrackedFrame& f) { return f.frame.timestamp_s; })
      .def_property_readonly("rows", [](const PyTrackedFrame& f) { return f.rows; })
      .def_property_readonly("cols", [](const PyTrackedFrame& f) { return f.cols; })
      .def_property_readonly("image", [](const PyTrackedFrame& f) { return ImageArray(f.frame.image); },
                             "The grey frame, uint8 H x W.")
      .def_property_readonly("xy", [](const PyTrackedFrame& f) { return PlacedPoints(f.frame.markers); },
                             "N x 2 px (pixel centres at integers): measured for 'tracked', along the border for\n"
                             "'cut', placed by the neighbours for 'estimated', NaN for 'lost'.")
      .def_property_readonly("state", [](const PyTrackedFrame& f) { return States(f.frame.markers); },
                             "N strings: 'tracked', 'cut' (its dot cut by the image's border), 'estimated' or\n"
                             "'lost', as tac3d track's CSV.")
      .def_property_readonly("acquired", [](const PyTrackedFrame& f) { return f.frame.markers.acquired; },
                             "The grid was indexed afresh in this frame (the reference, or re-acquisition).");

  py::class_<PyTracker>(m, "SingleViewTracker", R"doc(
Tracks a single-view marker sensor (GelSight-type: one camera, one grid of dark dots) through a
video file, an image folder or a camera, as `tac3d track` does. The grid is found in the
reference frame; iterating yields a TrackedFrame per frame from it on (unreadable frames are
skipped); `summary` holds the run's figures so far. Raises tac3d.Error for bad input.
)doc")
      .def(py::init(&MakeTracker), py::arg("source"), py::arg("grid") = py::none(), py::arg("reference") = 0,
           py::arg("rest_frames") = std::vector<std::pair<std::int64_t, std::int64_t>>{}, py::arg("width") = 640,
           py::arg("height") = 480, py::arg("fps") = 30.0,
           "source: a video file, an image folder (any image size), camera:N or /dev/videoN (width x\n"
           "height at fps); grid: (rows, cols), None for the lattice's extent in the reference frame;\n"
           "reference: its frame index; rest_frames: (first, last) frame ranges without contact,\n"
           "for the summary's jitter.")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__",
           [](PyTracker& t) {
             std::optional<PyTrackedFrame> f = t.Next();
             if (!f) throw py::stop_iteration();
             return std::move(*f);
           })
      .def_property_readonly("rows", [](const PyTracker& t) { return t.tracker->rows(); })
      .def_property_readonly("cols", [](const PyTracker& t) { return t.tracker->cols(); })
      .def_property_readonly("reference_xy", [](const PyTracker& t) { return Points(t.tracker->reference().estimate_uv); },
                             "N x 2 px: each marker's position in the reference frame (x0, y0).")
      .def_property_readonly("summary", [](const PyTracker& t) { return JsonToPython(ToJson(t.tracker->summary())); },
                             "The figures of `tac3d track`'s summary over the frames tracked so far, a dict.");
}

}  // namespace tac3d::python
