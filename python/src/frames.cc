// TactileFrame with numpy fields, and recordings: read (streamed or whole), write.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <memory>
#include <optional>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "frame_binding.h"
#include "tac3d/record/recording.h"

namespace tac3d::python {
namespace {

using FramePtr = std::shared_ptr<TactileFrame>;

std::optional<FrameFlag> FlagByName(const std::string& name) {
  for (FrameFlag flag : kAllFrameFlags) {
    if (name == FrameFlagName(flag)) return flag;
  }
  return std::nullopt;
}

// A per-marker N x 3 field: a writable view into the frame's vector (the array keeps the
// Python frame, and so the C++ frame, alive); assigning copies in after a shape check.
template <std::vector<Eigen::Vector3d> TactileFrame::*kField>
void DefVector3Field(py::class_<TactileFrame, FramePtr>& c, const char* name, const char* doc) {
  c.def_property(
      name,
      [](py::object self) { return Vector3View(self.cast<TactileFrame&>().*kField, self); },
      [name](TactileFrame& f, const py::object& value) {
        f.*kField = ToVector3(value, f.num_markers(), name);
      },
      doc);
}

// A scalar of the frame's slip estimate, read and written as a float (a frame built in Python
// can carry one through a recording).
template <double FrameSlip::*kField>
auto SlipGetter() {
  return [](const TactileFrame& f) { return f.slip.*kField; };
}
template <double FrameSlip::*kField>
auto SlipSetter() {
  return [](TactileFrame& f, double value) { f.slip.*kField = value; };
}

// Whole recordings in memory: frames and their images, and T x N x 3 arrays on demand.
struct Recording {
  std::vector<FramePtr> frames;
  std::vector<cv::Mat> images;
  RecordingStatus status = RecordingStatus::kReading;
  std::string message;
  std::uint32_t version = 0;

  int markers() const {
    if (frames.empty()) return 0;
    const int n = frames.front()->num_markers();
    for (const FramePtr& f : frames) {
      if (f->num_markers() != n) {
        throw Error(fmt::format("the recording's frames have different marker counts ({} and {})",
                                n,
                                f->num_markers()));
      }
    }
    return n;
  }

  py::array_t<double> Stack(std::vector<Eigen::Vector3d> TactileFrame::*field) const {
    const int n = markers();
    py::array_t<double> out(
        {static_cast<py::ssize_t>(frames.size()), static_cast<py::ssize_t>(n), py::ssize_t{3}});
    double* p = out.mutable_data();
    for (const FramePtr& f : frames) {
      std::memcpy(p, ((*f).*field).data(), n * 3 * sizeof(double));
      p += n * 3;
    }
    return out;
  }

  // T x N bools of a per-marker flag (valid, contact).
  py::array_t<bool> StackBools(std::vector<bool> TactileFrame::*field) const {
    const int n = markers();
    py::array_t<bool> out({static_cast<py::ssize_t>(frames.size()), static_cast<py::ssize_t>(n)});
    bool* p = out.mutable_data();
    for (const FramePtr& f : frames) {
      for (int i = 0; i < n; ++i) *p++ = ((*f).*field)[i];
    }
    return out;
  }

  // One value a frame, as `get` reads it.
  template <typename T, typename Get>
  py::array_t<T> PerFrame(const Get& get) const {
    std::vector<T> values;
    values.reserve(frames.size());
    for (const FramePtr& f : frames) values.push_back(get(*f));
    return VectorOwned(std::move(values));
  }

  py::array_t<double> StackVector(Eigen::Vector3d TactileFrame::*field) const {
    py::array_t<double> out({static_cast<py::ssize_t>(frames.size()), py::ssize_t{3}});
    double* p = out.mutable_data();
    for (const FramePtr& f : frames) {
      std::memcpy(p, ((*f).*field).data(), 3 * sizeof(double));
      p += 3;
    }
    return out;
  }

  FramePtr At(py::ssize_t i) const {
    const auto size = static_cast<py::ssize_t>(frames.size());
    if (i < 0) i += size;
    if (i < 0 || i >= size) throw py::index_error(fmt::format("frame {} of {}", i, size));
    return frames[i];
  }
};

std::shared_ptr<Recording> ReadRecording(const std::string& path, bool with_images) {
  auto recording = std::make_shared<Recording>();
  py::gil_scoped_release release;
  RecordingReader reader(path);
  while (std::optional<RecordedFrame> r = reader.Next()) {
    recording->frames.push_back(std::make_shared<TactileFrame>(std::move(r->frame)));
    recording->images.push_back(with_images ? r->image : cv::Mat());
  }
  recording->status = reader.status();
  recording->message = reader.message();
  recording->version = reader.version();
  return recording;
}

// RecordingWriter with an explicit close.
struct Writer {
  std::unique_ptr<RecordingWriter> writer;
  std::int64_t written_before_close = 0;
  RecordingWriter& Get() {
    if (!writer) throw Error("RecordingWriter: closed");
    return *writer;
  }
  std::int64_t frames_written() const {
    return writer ? writer->frames_written() : written_before_close;
  }
  void Close() {
    if (writer) written_before_close = writer->frames_written();
    writer.reset();
  }
};

}  // namespace

py::object FrameToPython(TactileFrame&& frame) {
  return py::cast(std::make_shared<TactileFrame>(std::move(frame)));
}

py::object RecordingToPython(std::vector<TactileFrame>&& frames) {
  auto recording = std::make_shared<Recording>();
  for (TactileFrame& frame : frames) {
    recording->frames.push_back(std::make_shared<TactileFrame>(std::move(frame)));
    recording->images.emplace_back();
  }
  recording->status = RecordingStatus::kComplete;
  return py::cast(recording);
}

void RegisterFrames(py::module_& m) {
  py::class_<TactileFrame, FramePtr> frame(m, "TactileFrame", R"doc(
The pipeline's output for one camera frame (C++ tac3d::TactileFrame). Per-marker fields are
float64 N x 3 numpy arrays in row-major grid order (index row * cols + col), sensor frame, mm
and N; they are views into the frame (no copy, writable): keep a copy (arr.copy()) if you
change the frame. Assigning an array copies it in after a shape check.
)doc");
  frame
      .def(py::init([](int rows, int cols) {
             return std::make_shared<TactileFrame>(TactileFrame::Sized(rows, cols));
           }),
           py::arg("rows") = 20,
           py::arg("cols") = 20,
           "A frame of rows x cols markers: zero vectors, all valid, none in contact.")
      .def_readwrite("sn", &TactileFrame::sn, "Sensor serial number.")
      .def_readwrite("index", &TactileFrame::index, "Frame counter since the stream started.")
      .def_readwrite("timestamp", &TactileFrame::timestamp_s, "Seconds since the stream started.")
      .def_readonly("rows", &TactileFrame::rows)
      .def_readonly("cols", &TactileFrame::cols)
      .def_property_readonly("num_markers", &TactileFrame::num_markers)
      .def_readwrite("initialize_progress",
                     &TactileFrame::initialize_progress,
                     "0..100; below 100 the reference is still being taken.")
      .def_readwrite("flags", &TactileFrame::flags, "FrameFlag bits (see flag_names).");
  DefVector3Field<&TactileFrame::positions_mm>(
      frame, "positions", "Deformed marker positions, mm (N x 3).");
  DefVector3Field<&TactileFrame::displacements_mm>(
      frame, "displacements", "Position minus reference position, mm (N x 3).");
  DefVector3Field<&TactileFrame::forces_n>(
      frame, "forces", "Force on each marker's patch, N (N x 3).");
  DefVector3Field<&TactileFrame::normals>(
      frame, "normals", "Outward unit surface normals (N x 3).");
  frame
      .def_property(
          "valid",
          [](const TactileFrame& f) { return BoolArray(f.valid); },
          [](TactileFrame& f, const py::object& v) {
            f.valid = ToBools(v, f.num_markers(), "valid");
          },
          "bool (N,): the marker was measured this frame (a copy).")
      .def_property(
          "contact",
          [](const TactileFrame& f) { return BoolArray(f.contact); },
          [](TactileFrame& f, const py::object& v) {
            f.contact = ToBools(v, f.num_markers(), "contact");
          },
          "bool (N,): the marker's patch is in contact (a copy).")
      .def_property(
          "resultant_force",
          [](py::object self) {
            return Vector3dView(self.cast<TactileFrame&>().resultant_force_n, self);
          },
          [](TactileFrame& f, const py::object& v) {
            f.resultant_force_n = ToVector3d(v, "resultant_force");
          },
          "Sum of the forces, N (3,).")
      .def_property(
          "resultant_moment",
          [](py::object self) {
            return Vector3dView(self.cast<TactileFrame&>().resultant_moment_nmm, self);
          },
          [](TactileFrame& f, const py::object& v) {
            f.resultant_moment_nmm = ToVector3d(v, "resultant_moment");
          },
          "Sum of p x f about the sensor origin, N mm (3,).")
      .def_property_readonly(
          "flag_names",
          [](const TactileFrame& f) {
            std::vector<std::string> names;
            for (FrameFlag flag : kAllFrameFlags) {
              if (f.has(flag)) names.emplace_back(FrameFlagName(flag));
            }
            return names;
          },
          "Names of the flags set: markers_lost, grid_reacquired, displacement_out_of_range, "
          "force_out_of_range, initializing, zeroed, lighting_changed, drift_at_rest.")
      .def(
          "has",
          [](const TactileFrame& f, const std::string& name) {
            const std::optional<FrameFlag> flag = FlagByName(name);
            if (!flag)
              throw Error(
                  fmt::format("'{}' is not a frame flag ({})", name, FrameFlagNames(~0u)));
            return f.has(*flag);
          },
          py::arg("flag"),
          "Whether the flag named `flag` is set.")
      .def_property_readonly("initializing",
                             [](const TactileFrame& f) { return f.initialize_progress < 100; })
      .def_property_readonly(
          "slip_state",
          [](const TactileFrame& f) { return std::string(SlipStateName(f.slip.state)); },
          "unknown, none, stick, partial_slip or gross_slip (partial_slip: part of the contact "
          "seen slipping, read under any sideways load; not a warning of sliding).")
      .def_property_readonly("slip_fraction", [](const TactileFrame& f) { return f.slip.fraction; })
      .def_property("friction",
                    SlipGetter<&FrameSlip::friction>(),
                    SlipSetter<&FrameSlip::friction>(),
                    "Friction coefficient estimate (partial and gross slip; NaN otherwise).")
      .def_property("friction_sigma",
                    SlipGetter<&FrameSlip::friction_sigma>(),
                    SlipSetter<&FrameSlip::friction_sigma>(),
                    "Its 1-sigma uncertainty.")
      .def_property("slip_margin",
                    SlipGetter<&FrameSlip::margin>(),
                    SlipSetter<&FrameSlip::margin>(),
                    "Estimated margin to gross slip, 1 - |Q| / (mu P), median error 0.2 on the "
                    "twin (docs/incipient.md); NaN without a friction estimate.")
      .def_property("slip_margin_sigma",
                    SlipGetter<&FrameSlip::margin_sigma>(),
                    SlipSetter<&FrameSlip::margin_sigma>(),
                    "Its 1-sigma uncertainty.")
      .def_property("least_normal_force_n",
                    SlipGetter<&FrameSlip::least_normal_force_n>(),
                    SlipSetter<&FrameSlip::least_normal_force_n>(),
                    "The least normal force (N) holding the present tangential load with the "
                    "slip options' safety factor (NaN without a friction estimate).")
      .def("validate",
           &TactileFrame::Validate,
           "Raises tac3d.Error naming a field that is inconsistent.")
      .def("copy", [](const TactileFrame& f) { return std::make_shared<TactileFrame>(f); })
      .def(
          "to_dict",
          [](py::object self) {
            const TactileFrame& f = self.cast<const TactileFrame&>();
            py::dict d;
            d["SN"] = f.sn;
            d["index"] = f.index;
            d["sendTimestamp"] = f.timestamp_s;
            d["3D_Positions"] = Vector3View(f.positions_mm, self).attr("copy")();
            d["3D_Displacements"] = Vector3View(f.displacements_mm, self).attr("copy")();
            d["3D_Forces"] = Vector3View(f.forces_n, self).attr("copy")();
            d["3D_Normals"] = Vector3View(f.normals, self).attr("copy")();
            d["3D_ResultantForce"] =
                Vector3dView(f.resultant_force_n, self).attr("reshape")(1, 3).attr("copy")();
            d["3D_ResultantMoment"] =
                Vector3dView(f.resultant_moment_nmm, self).attr("reshape")(1, 3).attr("copy")();
            d["InitializeProgress"] = static_cast<double>(f.initialize_progress);
            return d;
          },
          "The frame as the vendor client's dict (copies of the arrays, 3D_Normals included;\n"
          "InitializeProgress a float, as the vendor sends it; no recvTimestamp).")
      .def("__eq__", [](const TactileFrame& a, const TactileFrame& b) { return a == b; })
      .def("__repr__", [](const TactileFrame& f) {
        return fmt::format(
            "<tac3d.TactileFrame {} #{} t={:.3f} s {}x{} F=({:.3f}, {:.3f}, {:.3f}) N{}{}>",
            f.sn,
            f.index,
            f.timestamp_s,
            f.rows,
            f.cols,
            f.resultant_force_n.x(),
            f.resultant_force_n.y(),
            f.resultant_force_n.z(),
            f.flags ? " " : "",
            FrameFlagNames(f.flags));
      });

  py::class_<RecordingReader>(m, "RecordingReader", R"doc(
Streams a recording frame by frame (C++ tac3d::RecordingReader), stopping at the first
truncated or corrupt record; then .status and .message say why it ended. Iterate it for
TactileFrames, or call read() for (frame, image-or-None).
)doc")
      .def(py::init([](const std::string& path) {
             py::gil_scoped_release release;
             return std::make_unique<RecordingReader>(path);
           }),
           py::arg("path"),
           "Raises tac3d.Error if the file is not a recording this reader knows.")
      .def(
          "read",
          [](RecordingReader& r) -> py::object {
            std::optional<RecordedFrame> next;
            {
              py::gil_scoped_release release;
              next = r.Next();
            }
            if (!next) return py::none();
            py::object image = ImageArray(next->image);
            return py::make_tuple(FrameToPython(std::move(next->frame)), image);
          },
          "(TactileFrame, image uint8 H x W or None), or None at the end.")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__",
           [](RecordingReader& r) {
             std::optional<RecordedFrame> next;
             {
               py::gil_scoped_release release;
               next = r.Next();
             }
             if (!next) throw py::stop_iteration();
             return FrameToPython(std::move(next->frame));
           })
      .def_property_readonly(
          "status",
          [](const RecordingReader& r) { return std::string(RecordingStatusName(r.status())); },
          "reading, complete, truncated or corrupt.")
      .def_property_readonly("message", &RecordingReader::message)
      .def_property_readonly("frames_read", &RecordingReader::frames_read)
      .def_property_readonly("version", &RecordingReader::version);

  py::class_<Recording, std::shared_ptr<Recording>>(m, "Recording", R"doc(
A whole recording in memory (tac3d.open_recording): len(), indexing, iteration over
TactileFrames, and whole arrays: positions, displacements, forces, normals (T x N x 3),
valid, contact (T x N bool), resultant_forces, resultant_moments (T x 3), timestamps,
indices, flags (T,), slip (a dict of T arrays), and each frame's image(i).
)doc")
      .def("__len__", [](const Recording& r) { return r.frames.size(); })
      .def("__getitem__", &Recording::At, py::arg("i"))
      .def(
          "__iter__",
          [](const Recording& r) { return py::make_iterator(r.frames.begin(), r.frames.end()); },
          py::keep_alive<0, 1>())
      .def(
          "image",
          [](const Recording& r, py::ssize_t i) {
            r.At(i);
            return ImageArray(r.images[i < 0 ? i + r.images.size() : i]);
          },
          py::arg("i"),
          "Frame i's camera image (uint8 H x W), or None if none was recorded.")
      .def_property_readonly(
          "positions", [](const Recording& r) { return r.Stack(&TactileFrame::positions_mm); })
      .def_property_readonly(
          "displacements",
          [](const Recording& r) { return r.Stack(&TactileFrame::displacements_mm); })
      .def_property_readonly("forces",
                             [](const Recording& r) { return r.Stack(&TactileFrame::forces_n); })
      .def_property_readonly("normals",
                             [](const Recording& r) { return r.Stack(&TactileFrame::normals); })
      .def_property_readonly(
          "resultant_forces",
          [](const Recording& r) { return r.StackVector(&TactileFrame::resultant_force_n); })
      .def_property_readonly(
          "resultant_moments",
          [](const Recording& r) { return r.StackVector(&TactileFrame::resultant_moment_nmm); })
      .def_property_readonly("timestamps",
                             [](const Recording& r) {
                               return r.PerFrame<double>([](const TactileFrame& f) { return f.timestamp_s; });
                             })
      .def_property_readonly("indices",
                             [](const Recording& r) {
                               return r.PerFrame<std::int64_t>([](const TactileFrame& f) { return f.index; });
                             })
      .def_property_readonly("valid", [](const Recording& r) { return r.StackBools(&TactileFrame::valid); })
      .def_property_readonly("contact", [](const Recording& r) { return r.StackBools(&TactileFrame::contact); })
      .def_property_readonly(
          "flags",
          [](const Recording& r) { return r.PerFrame<std::uint32_t>([](const TactileFrame& f) { return f.flags; }); })
      .def_property_readonly(
          "slip",
          [](const Recording& r) {
            py::dict slip;
            slip["state"] = r.PerFrame<std::uint32_t>(
                [](const TactileFrame& f) { return static_cast<std::uint32_t>(f.slip.state); });
            const std::pair<const char*, double FrameSlip::*> fields[] = {
                {"fraction", &FrameSlip::fraction},
                {"friction", &FrameSlip::friction},
                {"friction_sigma", &FrameSlip::friction_sigma},
                {"margin", &FrameSlip::margin},
                {"margin_sigma", &FrameSlip::margin_sigma},
                {"least_normal_force_n", &FrameSlip::least_normal_force_n}};
            for (const auto& [name, field] : fields) {
              slip[name] = r.PerFrame<double>([field = field](const TactileFrame& f) { return f.slip.*field; });
            }
            return slip;
          },
          "The slip estimate of every frame: {state (T uint32: 0 unknown, 1 none, 2 stick, 3 partial\n"
          "slip, 4 gross slip), fraction, friction, friction_sigma, margin, margin_sigma,\n"
          "least_normal_force_n (T float64, NaN where there is none)}.")
      .def_property_readonly(
          "status",
          [](const Recording& r) { return std::string(RecordingStatusName(r.status)); },
          "complete, truncated (a killed writer: every complete frame kept) or corrupt.")
      .def_readonly("message", &Recording::message)
      .def_readonly("version", &Recording::version);

  m.def("open_recording",
        &ReadRecording,
        py::arg("path"),
        py::arg("images") = true,
        "Reads a whole recording into memory (GIL released). A truncated file gives its\n"
        "complete frames (status 'truncated'). Raises tac3d.Error if it is not a recording.");

  py::class_<Writer>(m, "RecordingWriter", R"doc(
Writes a recording (C++ tac3d::RecordingWriter): each frame is handed to the kernel before
write() returns, so a killed process leaves every written frame readable. A context manager;
close() (or leaving the with block) closes the file.
)doc")
      .def(py::init([](const std::string& path, bool overwrite, bool sync) {
             auto w = std::make_unique<Writer>();
             w->writer = std::make_unique<RecordingWriter>(
                 path, RecordingWriterOptions{.overwrite = overwrite, .sync_every_frame = sync});
             return w;
           }),
           py::arg("path"),
           py::arg("overwrite") = false,
           py::arg("sync_every_frame") = false,
           "Raises tac3d.Error if the file exists (unless overwrite) or cannot be created.")
      .def(
          "write",
          [](Writer& w, const TactileFrame& f, const py::object& image) {
            cv::Mat mat;
            py::array keep;
            if (!image.is_none()) {
              keep = py::cast<py::array>(image);
              mat = ImageFromArray(keep, "image");
            }
            RecordingWriter& writer = w.Get();
            py::gil_scoped_release release;
            writer.Write(f, mat);
          },
          py::arg("frame"),
          py::arg("image") = py::none(),
          "Appends a frame (and an 8-bit grey image). Raises tac3d.Error if the frame is\n"
          "inconsistent (TactileFrame.validate), the writer is closed or the write fails.")
      .def_property_readonly("frames_written", [](Writer& w) { return w.frames_written(); })
      .def("close", [](Writer& w) { w.Close(); })
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](Writer& w, py::args) { w.Close(); });
}

}  // namespace tac3d::python
