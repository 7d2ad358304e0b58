// The twin (scenes, simulation into datasets, datasets' truth), the light-path design solver
// and the friction map, as functions returning plain data (dicts of numpy arrays).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cstring>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include "arrays.h"
#include "bindings.h"
#include "frame_binding.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/design/light_path_design.h"
#include "tac3d/friction/command_options.h"
#include "tac3d/friction/friction_map.h"
#include "tac3d/scene/scene.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/simulation/simulation.h"
#include "tac3d/simulation/twin_body.h"
#include "tac3d/simulation/twin_measurement.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/cache_file.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/seconds_since.h"
#include "tac3d/vendor_formats/vendor_gel.h"
#include "twin_common.h"

namespace tac3d::python {

std::string ResolveCacheDir(const std::string& dir) {
  const std::string out = dir.empty() ? DefaultCacheDir() : dir;
  MakeCacheDirectory(out);
  return out;
}

namespace {

// {cache_file, cache_status, load_or_build_s}: what the reports say of each model they used.
nlohmann::json CacheReport(const SharedModelSource& source) {
  return {{"cache_file", source.path},
          {"cache_status", source.status ? Describe(*source.status) : "in memory"},
          {"load_or_build_s", source.elapsed_s}};
}

// Keeps `held` (a model, an inverse) for the process's life. The shared caches (fem's, the twin
// body's, SharedTikhonovInverse) keep an object only while someone holds it, and an episode's
// simulation and pipeline end with the episode: a Dask worker runs episode after episode, and
// without this would load its models and compute the inverse anew for each.
void KeepForTheProcess(std::shared_ptr<const void> held) {
  static std::mutex mutex;
  static std::set<std::shared_ptr<const void>> kept;
  const std::lock_guard<std::mutex> lock(mutex);
  kept.insert(std::move(held));
}

py::array_t<double> Matrix4(const Rigid3& pose) {
  py::array_t<double> out({4, 4});
  auto r = out.mutable_unchecked<2>();
  const Eigen::Matrix4d m = pose.matrix();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r(i, j) = m(i, j);
  return out;
}

Rigid3 PoseFromArray(const py::handle& h, const char* what) {
  DoubleArray a = py::cast<DoubleArray>(h);
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4) {
    throw Error(fmt::format("{}: expected a 4 x 4 matrix", what));
  }
  Eigen::Matrix4d m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m(i, j) = a.at(i, j);
  Rigid3 pose;
  pose.matrix() = m;
  return pose;
}

py::array_t<double> Vec2(const Eigen::Vector2d& v) {
  py::array_t<double> out(2);
  out.mutable_at(0) = v.x();
  out.mutable_at(1) = v.y();
  return out;
}

py::dict SceneInfo(const Scene& s) {
  py::dict d;
  d["name"] = s.name;
  d["steps"] = s.trajectory.steps;
  d["duration_s"] = s.trajectory.keyframes.empty() ? 0.0 : s.trajectory.duration_s();
  d["marker_rows"] = s.sensor.markers.rows;
  d["marker_cols"] = s.sensor.markers.cols;
  py::list objects;
  for (const SceneObject& o : s.objects) {
    py::dict od;
    od["name"] = o.name;
    od["shape"] = std::string(ToString(o.shape));
    od["default_mu"] = o.friction.default_mu;
    od["world_from_object"] = Matrix4(o.world_from_object);
    objects.append(od);
  }
  d["objects"] = objects;
  d["deviation"] = py::dict(py::arg("mesh_refinement") = s.deviation.mesh_refinement,
                            py::arg("youngs_modulus_factor") = s.deviation.youngs_modulus_factor,
                            py::arg("poisson_ratio_factor") = s.deviation.poisson_ratio_factor);
  return d;
}

// A scene argument: a Scene, or a built-in name or YAML path.
Scene SceneArg(const py::object& scene) {
  if (py::isinstance<Scene>(scene)) return scene.cast<Scene>();
  const std::string name = py::str(scene);
  py::gil_scoped_release release;
  return LoadSceneOrBuiltIn(name);
}

simulation::TwinBodyOptions TwinOptions(const py::dict& d) {
  simulation::TwinBodyOptions o;
  for (auto [key, value] : d) {
    const std::string k = py::str(key);
    if (k == "cells_per_pitch")
      o.cells_per_pitch = value.cast<int>();
    else if (k == "margin_mm")
      o.margin_mm = value.cast<double>();
    else if (k == "quadrature_points_per_side")
      o.quadrature_points_per_side = value.cast<int>();
    else
      throw Error(
          fmt::format("twin_options: unknown key '{}' (cells_per_pitch, margin_mm, "
                      "quadrature_points_per_side)",
                      k));
  }
  o.Validate();
  return o;
}

struct PythonAbort {};  // the progress callback raised: its Python error is set

py::object Simulate(const py::object& scene_arg,
                    const std::string& out,
                    const std::string& cache_dir,
                    int steps,
                    bool images,
                    const py::object& progress,
                    const py::dict& twin_options,
                    bool window) {
  if (steps < 0) throw Error(fmt::format("steps must be >= 0, got {}", steps));
  const Scene scene = SceneArg(scene_arg);
  const std::string scene_ref =
      py::isinstance<Scene>(scene_arg) ? scene.name : std::string(py::str(scene_arg));
  const simulation::TwinBodyOptions twin = TwinOptions(twin_options);
  std::optional<py::error_already_set> error;
  simulation::SimulationSummary summary;
  nlohmann::json model_json;
  {
    py::gil_scoped_release release;
    const fem::BodyModelOptions body =
        simulation::TwinBodyModelOptions(scene.sensor, scene.deviation);
    TwinDatasetWriter writer(out, {{"name", scene.name}, {"scene", scene_ref}});
    simulation::TwinBodyCacheResult cached = simulation::LoadOrBuildTwinBodyModel(
        body, twin, ResolveCacheDir(cache_dir), /*show_progress=*/false);
    model_json = CacheReport({cached.path, cached.status, cached.elapsed_s});
    const auto model = std::make_shared<const simulation::TwinBodyModel>(std::move(cached.model));
    simulation::SimulationOptions options;
    options.render_images = images;
    options.max_steps = steps;
    options.contact.windowed = window;
    simulation::TwinSimulation sim(scene, model, options);
    writer.UpdateHeader({{"steps", sim.num_steps()}, {"twin_body", model_json}});
    const int total = sim.num_steps();
    int done = 0;
    try {
      summary = sim.Run([&](const TwinStep& step) {
        writer.Write(step);
        ++done;
        if (progress.is_none()) return;
        py::gil_scoped_acquire gil;
        try {
          progress(done, total);
        } catch (py::error_already_set& e) {
          error.emplace(std::move(e));
          throw PythonAbort{};
        }
      });
    } catch (const PythonAbort&) {
    }
    if (!error) writer.UpdateHeader({{"summary", simulation::ToJson(summary)}});
  }
  if (error) throw std::move(*error);
  nlohmann::json result = simulation::ToJson(summary);
  result["dataset"] = out;
  result["twin_body"] = model_json;
  return JsonToPython(result);
}

struct Dataset {
  std::unique_ptr<TwinDatasetReader> reader;
};

py::dict StepDict(TwinStep&& s, bool with_image) {
  py::dict d;
  d["index"] = s.index;
  d["t"] = s.t_s;
  d["world_from_sensor"] = Matrix4(s.world_from_sensor);
  d["marker_positions"] = Vector3Owned(std::move(s.marker_positions_mm));
  d["marker_forces"] = Vector3Owned(std::move(s.marker_forces_n));
  py::array_t<bool> contact(static_cast<py::ssize_t>(s.marker_contact.size()));
  py::array_t<bool> slip(static_cast<py::ssize_t>(s.marker_slip.size()));
  for (size_t i = 0; i < s.marker_contact.size(); ++i)
    contact.mutable_at(i) = s.marker_contact[i] != 0;
  for (size_t i = 0; i < s.marker_slip.size(); ++i) slip.mutable_at(i) = s.marker_slip[i] != 0;
  d["marker_contact"] = contact;
  d["marker_slip"] = slip;
  py::array_t<double> f(3), mo(3);
  for (int c = 0; c < 3; ++c) {
    f.mutable_at(c) = s.total_force_n[c];
    mo.mutable_at(c) = s.total_moment_nmm[c];
  }
  d["total_force"] = f;
  d["total_moment"] = mo;
  if (!s.surface.positions_mm.empty()) {
    d["surface_positions"] = Vector3Owned(std::move(s.surface.positions_mm));
    d["surface_tractions"] = Vector3Owned(std::move(s.surface.tractions_mpa));
    std::vector<std::uint8_t> states(s.surface.states.size());
    for (size_t i = 0; i < states.size(); ++i)
      states[i] = static_cast<std::uint8_t>(s.surface.states[i]);
    d["surface_states"] = VectorOwned(std::move(states));
  }
  if (with_image) d["image"] = ImageArray(s.image);
  return d;
}

// Every step's truth as arrays (Dataset.truth's keys).
py::dict TruthArrays(const std::vector<TwinStep>& read) {
  const auto t = static_cast<py::ssize_t>(read.size());
  const py::ssize_t n =
      read.empty() ? 0 : static_cast<py::ssize_t>(read.front().marker_positions_mm.size());
  py::array_t<double> time(t), poses({t, py::ssize_t{4}, py::ssize_t{4}}),
      positions({t, n, py::ssize_t{3}}), forces({t, n, py::ssize_t{3}}),
      total_force({t, py::ssize_t{3}}), total_moment({t, py::ssize_t{3}});
  py::array_t<bool> contact({t, n}), slip({t, n});
  py::array_t<std::int32_t> index(t);
  auto P = poses.mutable_unchecked<3>();
  auto X = positions.mutable_unchecked<3>();
  auto F = forces.mutable_unchecked<3>();
  auto C = contact.mutable_unchecked<2>();
  auto S = slip.mutable_unchecked<2>();
  for (py::ssize_t k = 0; k < t; ++k) {
    const TwinStep& s = read[k];
    if (static_cast<py::ssize_t>(s.marker_positions_mm.size()) != n) {
      throw Error(fmt::format("step {} has {} markers, step {} has {}",
                              s.index,
                              s.marker_positions_mm.size(),
                              read.front().index,
                              n));
    }
    time.mutable_at(k) = s.t_s;
    index.mutable_at(k) = s.index;
    const Eigen::Matrix4d m = s.world_from_sensor.matrix();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) P(k, i, j) = m(i, j);
    for (py::ssize_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        X(k, i, c) = s.marker_positions_mm[i][c];
        F(k, i, c) = s.marker_forces_n[i][c];
      }
      C(k, i) = s.marker_contact[i] != 0;
      S(k, i) = s.marker_slip[i] != 0;
    }
    for (int c = 0; c < 3; ++c) {
      total_force.mutable_at(k, c) = s.total_force_n[c];
      total_moment.mutable_at(k, c) = s.total_moment_nmm[c];
    }
  }
  py::dict d;
  d["index"] = index;
  d["t"] = time;
  d["world_from_sensor"] = poses;
  d["marker_positions"] = positions;
  d["marker_forces"] = forces;
  d["marker_contact"] = contact;
  d["marker_slip"] = slip;
  d["total_force"] = total_force;
  d["total_moment"] = total_moment;
  return d;
}

py::dict Truth(const Dataset& ds) {
  const std::vector<int>& steps = ds.reader->steps();
  std::vector<TwinStep> read(steps.size());
  {
    py::gil_scoped_release release;
    for (size_t k = 0; k < steps.size(); ++k) read[k] = ds.reader->Read(steps[k]);
  }
  return TruthArrays(read);
}

// The renderer for `scene`'s images, kept for the next call while the sensor is the same: a
// worker simulating episode after episode of one spec builds it (~1 s) once.
std::shared_ptr<const MarkerImageRenderer> SharedRenderer(const Scene& scene) {
  static std::mutex mutex;
  static std::string last_sensor;
  static std::shared_ptr<const MarkerImageRenderer> last;
  const SensorConfig sensor = simulation::RenderedSensor(scene);
  const std::string key = SensorConfigToYaml(sensor);
  const std::lock_guard<std::mutex> lock(mutex);
  if (!last || key != last_sensor) {
    last = std::make_shared<const MarkerImageRenderer>(sensor);
    last_sensor = key;
  }
  return last;
}

// The body a simulation of `scene` needs, and the E scale it runs at: with scaling, the model
// at the scene's nu and E x 1 (one model for every E), scaled to the scene's E.
fem::BodyModelOptions SimulatedBody(const Scene& scene, bool scale_youngs_modulus, double* scale) {
  TwinDeviation deviation = scene.deviation;
  *scale = 1.0;
  if (scale_youngs_modulus) {
    *scale = deviation.youngs_modulus_factor;
    deviation.youngs_modulus_factor = 1.0;
  }
  return simulation::TwinBodyModelOptions(scene.sensor, deviation);
}

py::dict PrepareTwinBody(const py::object& scene_arg,
                         const std::string& cache_dir,
                         const py::dict& twin_options,
                         bool scale_youngs_modulus) {
  const Scene scene = SceneArg(scene_arg);
  const simulation::TwinBodyOptions twin = TwinOptions(twin_options);
  nlohmann::json model_json;
  {
    py::gil_scoped_release release;
    double scale = 1.0;
    const simulation::TwinBodyCacheResult cached = simulation::LoadOrBuildTwinBodyModel(
        SimulatedBody(scene, scale_youngs_modulus, &scale), twin, ResolveCacheDir(cache_dir),
        /*show_progress=*/false);
    model_json = CacheReport({cached.path, cached.status, cached.elapsed_s});
  }
  return JsonToPython(model_json);
}

py::dict PrepareSensorModel(const py::object& scene_arg, const std::string& cache_dir) {
  const Scene scene = SceneArg(scene_arg);
  nlohmann::json model_json;
  {
    py::gil_scoped_release release;
    const fem::ComplianceCacheResult cached = fem::LoadOrBuildComplianceModel(
        SensorBodyModelOptions(scene.sensor), ResolveCacheDir(cache_dir), /*show_progress=*/false);
    model_json = CacheReport({cached.path, cached.status, cached.elapsed_s});
  }
  return JsonToPython(model_json);
}

// N x H x W uint8 of grey images of one size, `image_of(item)` each item's.
template <typename Items, typename ImageOf>
py::array_t<std::uint8_t> StackImages(const Items& items, const ImageOf& image_of) {
  const cv::Mat& first = image_of(items.front());
  py::array_t<std::uint8_t> stack({static_cast<py::ssize_t>(items.size()),
                                   static_cast<py::ssize_t>(first.rows),
                                   static_cast<py::ssize_t>(first.cols)});
  std::uint8_t* data = stack.mutable_data();
  for (const auto& item : items) {
    const cv::Mat& image = image_of(item);
    TAC3D_DEMAND(image.type() == CV_8UC1 && image.size == first.size);
    for (int r = 0; r < image.rows; ++r, data += image.cols) {
      std::memcpy(data, image.ptr<std::uint8_t>(r), image.cols);
    }
  }
  return stack;
}

// T x rest, stacked from each step's vector (T x S x 3 for Vector3d, T x S otherwise).
template <typename T, typename Get>
py::array StackSteps(const std::vector<TwinStep>& steps, Get get) {
  using Element = std::decay_t<decltype(get(steps.front()).front())>;
  const auto t = static_cast<py::ssize_t>(steps.size());
  const auto s = static_cast<py::ssize_t>(get(steps.front()).size());
  constexpr bool kVector3 = std::is_same_v<Element, Eigen::Vector3d>;
  std::vector<py::ssize_t> shape = {t, s};
  if constexpr (kVector3) shape.push_back(3);
  py::array_t<T> out(shape);
  T* data = out.mutable_data();
  for (const TwinStep& step : steps) {
    const auto& v = get(step);
    if (static_cast<py::ssize_t>(v.size()) != s) {
      throw Error(fmt::format("step {} has {} surface nodes, step 0 has {}", step.index, v.size(), s));
    }
    for (const Element& e : v) {
      if constexpr (kVector3) {
        for (int c = 0; c < 3; ++c) *data++ = e[c];
      } else {
        *data++ = static_cast<T>(e);
      }
    }
  }
  return out;
}

// The twin simulation of simulate_arrays and TwinSimulation: the scene's body model shared
// within the process and kept for its life (its report in `model_json`), the renderer too.
// `options` says images, steps and the contact's; the rest is filled in here.
std::unique_ptr<simulation::TwinSimulation> MakeTwinSimulation(const Scene& scene,
                                                               const simulation::TwinBodyOptions& twin,
                                                               const std::string& cache_dir,
                                                               simulation::SimulationOptions options,
                                                               bool scale_youngs_modulus,
                                                               nlohmann::json* model_json) {
  if (options.render_images) options.renderer = SharedRenderer(scene);
  const fem::BodyModelOptions body =
      SimulatedBody(scene, scale_youngs_modulus, &options.youngs_modulus_scale);
  SharedModelSource source;
  const std::shared_ptr<const simulation::TwinBodyModel> model = simulation::LoadSharedTwinBodyModel(
      body, twin, ResolveCacheDir(cache_dir), /*show_progress=*/false, &source);
  KeepForTheProcess(model);
  *model_json = CacheReport(source);
  return std::make_unique<simulation::TwinSimulation>(scene, model, options);
}

// simulate_arrays(measure=True): the scene's sensor as its user has it (scene.sensor: neither the
// twin's deviation nor its spread) through the pipeline `tac3d run` runs (DefaultPipelineOptions,
// the compliance model loaded once a process), fed the simulation's images as they are rendered.
class ArraysMeasurement {
 public:
  ArraysMeasurement(const Scene& scene, const simulation::TwinSimulation& sim, const std::string& cache_dir) {
    const auto start = std::chrono::steady_clock::now();
    SharedModelSource source;
    const std::shared_ptr<const fem::ComplianceModel> model = fem::LoadSharedComplianceModel(
        SensorBodyModelOptions(scene.sensor), ResolveCacheDir(cache_dir), /*show_progress=*/false, &source);
    report_["compliance_model"] = CacheReport(source);
    measurement_ = std::make_unique<simulation::TwinMeasurement>(
        scene.sensor, model, DefaultPipelineOptions(scene.sensor));
    // The inverse, and with it the model (it holds H), for the worker's next episodes.
    KeepForTheProcess(
        SharedTikhonovInverse(fem::SharedH(model), measurement_->pipeline().options().force.weight));
    reference_ = measurement_->TakeReference(sim);
    frames_.reserve(sim.num_steps());
    seconds_ += SecondsSince(start);
  }

  void Measure(const TwinStep& step) {
    const auto start = std::chrono::steady_clock::now();
    frames_.push_back(measurement_->Measure(step));
    seconds_ += SecondsSince(start);
  }

  const std::vector<Frame>& reference() const { return reference_; }
  std::vector<TactileFrame>& frames() { return frames_; }

  // The pipeline's options, its model, and the seconds taken rendering the reference and
  // running the pipeline (the latter also in the simulation's timings.write_s).
  nlohmann::json Report() const {
    const PipelineOptions& used = measurement_->pipeline().options();
    nlohmann::json report = report_;
    report["reference_frames"] = used.reference_frames;
    report["sn"] = used.sn;
    report["force_weight"] = used.force.weight;
    report["support_refinement"] = used.force.support_refinement;
    report["seconds"] = seconds_;
    return report;
  }

 private:
  std::unique_ptr<simulation::TwinMeasurement> measurement_;
  std::vector<Frame> reference_;
  std::vector<TactileFrame> frames_;
  nlohmann::json report_;
  double seconds_ = 0.0;
};

py::dict SimulateArrays(const py::object& scene_arg,
                        const std::string& cache_dir,
                        int steps,
                        bool images,
                        const py::dict& twin_options,
                        bool scale_youngs_modulus,
                        bool window,
                        bool measure) {
  if (steps < 0) throw Error(fmt::format("steps must be >= 0, got {}", steps));
  const Scene scene = SceneArg(scene_arg);
  const simulation::TwinBodyOptions twin = TwinOptions(twin_options);
  nlohmann::json model_json;
  simulation::SimulationSummary summary;
  std::vector<TwinStep> run;
  std::unique_ptr<ArraysMeasurement> measurement;
  {
    py::gil_scoped_release release;
    simulation::SimulationOptions options;
    options.render_images = images || measure;
    options.max_steps = steps;
    options.contact.windowed = window;
    const std::unique_ptr<simulation::TwinSimulation> sim =
        MakeTwinSimulation(scene, twin, cache_dir, options, scale_youngs_modulus, &model_json);
    run.reserve(sim->num_steps());
    if (measure) measurement = std::make_unique<ArraysMeasurement>(scene, *sim, cache_dir);
    summary = sim->Run([&](const TwinStep& step) {
      run.push_back(step);
      if (measurement) {
        measurement->Measure(step);
        if (!images) run.back().image.release();  // rendered for the pipeline only
      }
    });
  }
  if (run.empty()) throw Error(fmt::format("scene '{}' has no steps to simulate", scene.name));
  py::dict d = TruthArrays(run);
  d.attr("pop")("index");
  if (images) {
    d["images"] = StackImages(run, [](const TwinStep& step) -> const cv::Mat& { return step.image; });
  }
  if (measurement) {
    if (images) {
      d["reference_images"] =
          StackImages(measurement->reference(), [](const Frame& f) -> const cv::Mat& { return f.image; });
    }
    d["measured"] = RecordingToPython(std::move(measurement->frames()));
  }
  const SurfaceTractions& surface = run.front().surface;
  d["surface_positions"] = Vector3Owned(std::vector<Eigen::Vector3d>(surface.positions_mm));
  d["surface_tractions"] =
      StackSteps<double>(run, [](const TwinStep& s) -> const auto& { return s.surface.tractions_mpa; });
  d["surface_states"] =
      StackSteps<std::uint8_t>(run, [](const TwinStep& s) -> const auto& { return s.surface.states; });
  d["surface_friction"] =
      StackSteps<double>(run, [](const TwinStep& s) -> const auto& { return s.surface.friction; });
  nlohmann::json result = simulation::ToJson(summary);
  result["twin_body"] = model_json;
  result["youngs_modulus_scale"] = scale_youngs_modulus ? scene.deviation.youngs_modulus_factor : 1.0;
  if (measurement) result["measurement"] = measurement->Report();
  d["summary"] = JsonToPython(result);
  return d;
}

// A simulation stepped from Python, one step a call: along the scene's trajectory, or under
// the loads a controller chose from what it measured (TwinSimulation::Step(const StepLoads&)).
struct SteppedSimulation {
  std::unique_ptr<simulation::TwinSimulation> sim;
  bool images = true;
  nlohmann::json model_json;
};

SteppedSimulation MakeSteppedSimulation(const py::object& scene_arg,
                                        const std::string& cache_dir,
                                        bool images,
                                        const py::dict& twin_options,
                                        bool scale_youngs_modulus,
                                        bool window) {
  const Scene scene = SceneArg(scene_arg);
  const simulation::TwinBodyOptions twin = TwinOptions(twin_options);
  SteppedSimulation out;
  out.images = images;
  py::gil_scoped_release release;
  simulation::SimulationOptions options;
  options.render_images = images;
  options.contact.windowed = window;
  out.sim = MakeTwinSimulation(scene, twin, cache_dir, options, scale_youngs_modulus,
                               &out.model_json);
  return out;
}

py::dict StepStepped(SteppedSimulation& s,
                     const std::optional<double>& normal_force_n,
                     const std::optional<std::pair<double, double>>& tangential_force_n) {
  if (tangential_force_n && !normal_force_n) {
    throw Error("TwinSimulation.step: a tangential_force_n needs a normal_force_n");
  }
  TwinStep step;
  {
    py::gil_scoped_release release;
    if (normal_force_n) {
      simulation::StepLoads loads;
      loads.normal_force_n = *normal_force_n;
      if (tangential_force_n) {
        loads.tangential_force_n = {tangential_force_n->first, tangential_force_n->second};
      }
      step = s.sim->Step(loads);
    } else {
      step = s.sim->Step();
    }
  }
  nlohmann::json solver = std::move(step.solver);
  py::dict d = StepDict(std::move(step), s.images);
  d["solver"] = JsonToPython(solver);
  return d;
}

py::dict DesignDict(const LightPathDesign& design) {
  py::list roots;
  for (const LightPathRoot& r : design.roots) {
    py::dict d;
    d["unknowns"] = py::make_tuple(r.unknowns[0], r.unknowns[1], r.unknowns[2], r.unknowns[3]);
    d["camera"] = Vec2(r.camera);
    d["center"] = Vec2(r.center);
    d["a0"] = Vec2(r.a0);
    d["b0"] = Vec2(r.b0);
    d["a1"] = Vec2(r.a1);
    d["b1"] = Vec2(r.b1);
    d["a2"] = Vec2(r.a2);
    d["b2"] = Vec2(r.b2);
    d["virtual_camera"] = Vec2(r.virtual_camera);
    d["max_residual"] = r.max_residual();
    d["parallax_deg"] = r.parallax_deg;
    d["valid"] = r.valid();
    d["rejections"] = r.rejections;
    roots.append(d);
  }
  py::dict out;
  out["roots"] = roots;
  out["chosen"] = design.chosen ? py::object(py::int_(*design.chosen)) : py::object(py::none());
  out["sensor_yaml"] = design.config ? py::object(py::str(SensorConfigToYaml(*design.config)))
                                     : py::object(py::none());
  out["summary"] = py::dict(py::arg("starts") = design.summary.starts,
                            py::arg("converged") = design.summary.converged,
                            py::arg("distinct_roots") = design.summary.distinct_roots,
                            py::arg("valid_roots") = design.summary.valid_roots,
                            py::arg("seconds") = design.summary.seconds);
  return out;
}

py::dict DesignLight(double h, double l, double d, double fov, int starts) {
  LightPathDesignOptions o;
  o.h_mm = h;
  o.l_mm = l;
  o.d_mm = d;
  o.fov_deg = fov;
  o.starts_per_axis = starts;
  LightPathDesign design;
  {
    py::gil_scoped_release release;
    design = DesignLightPath(o);
  }
  return DesignDict(design);
}

// `tac3d friction-map`'s options (friction::FrictionMapCommandOptions) with its defaults and
// the sensor's cover thickness, as the CLI builds them.
friction::FrictionMapOptions FrictionOptions(const py::dict& d, const SensorConfig& sensor) {
  friction::FrictionMapOptions o = friction::CommandFrictionMapDefaults().WithSensor(sensor);
  for (auto [key, value] : d) {
    const std::string k = py::str(key);
    const friction::FrictionMapCommandOption* option = friction::FindFrictionMapCommandOption(k);
    if (option == nullptr) {
      throw Error(fmt::format("friction_map: unknown option '{}' (accepted: {})",
                              k,
                              friction::FrictionMapCommandOptionNames()));
    }
    std::visit(
        [&](auto field) {
          using T = std::decay_t<decltype(o.*field)>;
          try {
            o.*field = value.cast<T>();
          } catch (const py::cast_error&) {
            const char* type = std::is_same_v<T, bool>  ? "bool"
                               : std::is_same_v<T, int> ? "int"
                                                        : "float";
            throw Error(fmt::format("friction_map: option '{}' takes a {}, not {}",
                                    k,
                                    type,
                                    std::string(py::repr(value))));
          }
        },
        option->field);
  }
  friction::ValidateCommandOptions(o, friction::OptionNaming::kName);
  return o;
}

// The options and their defaults, as `tac3d friction-map --help` lists them.
py::dict FrictionMapDefaults() {
  const friction::FrictionMapOptions defaults = friction::CommandFrictionMapDefaults();
  py::dict d;
  for (const friction::FrictionMapCommandOption& o : friction::FrictionMapCommandOptions()) {
    std::visit([&](auto field) { d[o.name.c_str()] = defaults.*field; }, o.field);
  }
  return d;
}

// friction_map's docstring: every option with its default and help, from the one list.
std::string FrictionMapDoc() {
  const py::dict defaults = FrictionMapDefaults();
  std::string doc =
      "The friction map (paper section IV.B) of a fixed object from TactileFrames and the\n"
      "sensor's poses (T x 4 x 4 world_from_sensor, one per frame), as `tac3d friction-map\n"
      "--recording FILE --poses CSV --config YAML` builds it: the same options, defaults and\n"
      "strokes (a frame with no marker over the contact threshold ends one). config: the\n"
      "sensor YAML ('': the built-in prototype), for the cover thickness. options (dict), the\n"
      "CLI's flags in snake_case (friction_map_defaults() gives them):\n";
  for (const friction::FrictionMapCommandOption& o : friction::FrictionMapCommandOptions()) {
    doc += fmt::format(
        "  {} = {}: {}\n", o.name, std::string(py::repr(defaults[o.name.c_str()])), o.help);
  }
  doc +=
      "Returns vertices (V x 3, mm, world), triangles (F x 3), vertex_normals, mu (NaN:\n"
      "unknown), confidence, slip_count, slip_points, slip_mu, slip_normal_force and summary\n"
      "(status: ok, no_contact...; the figures of `tac3d friction-map`'s summary.json \"map\").\n"
      "Raises tac3d.Error naming an unknown option (with the accepted ones) or a bad value.";
  return doc;
}

py::dict FrictionMap(const py::iterable& frames,
                     const py::object& poses,
                     const py::dict& options,
                     const std::string& config) {
  SensorConfig sensor;
  {
    py::gil_scoped_release release;
    sensor = LoadSensorOrDefault(config);
  }
  friction::FrictionMapBuilder builder(FrictionOptions(options, sensor));
  DoubleArray pose_array = py::cast<DoubleArray>(poses);
  if (pose_array.ndim() != 3 || pose_array.shape(1) != 4 || pose_array.shape(2) != 4) {
    throw Error("friction_map: poses must be T x 4 x 4 (world_from_sensor per frame)");
  }
  py::ssize_t k = 0;
  for (py::handle h : frames) {
    if (k >= pose_array.shape(0))
      throw Error(fmt::format("friction_map: more frames than the {} poses", pose_array.shape(0)));
    const TactileFrame& frame = h.cast<const TactileFrame&>();
    builder.AddFrameOfStrokes(
        frame, PoseFromArray(pose_array[py::make_tuple(k, py::ellipsis())], "poses[k]"));
    ++k;
  }
  if (k != pose_array.shape(0))
    throw Error(fmt::format("friction_map: {} frames but {} poses", k, pose_array.shape(0)));
  friction::FrictionMapResult map;
  {
    py::gil_scoped_release release;
    map = builder.Build();
  }
  py::dict d;
  std::vector<std::int32_t> triangles;
  for (const Eigen::Vector3i& t : map.triangles)
    triangles.insert(triangles.end(), {t[0], t[1], t[2]});
  py::array_t<std::int32_t> tri = VectorOwned(std::move(triangles));
  d["vertices"] = Vector3Owned(std::move(map.vertices_mm));
  d["triangles"] = tri.attr("reshape")(-1, 3);
  d["vertex_normals"] = Vector3Owned(std::move(map.vertex_normals));
  d["mu"] = VectorOwned(std::move(map.mu));
  d["confidence"] = VectorOwned(std::move(map.confidence));
  d["slip_count"] = VectorOwned(std::move(map.slip_count));
  std::vector<Eigen::Vector3d> sp;
  std::vector<double> smu, sfn;
  for (const friction::SlipPoint& p : map.slip_points) {
    sp.push_back(p.p_in_world_mm);
    smu.push_back(p.mu);
    sfn.push_back(p.normal_force_n);
  }
  d["slip_points"] = Vector3Owned(std::move(sp));
  d["slip_mu"] = VectorOwned(std::move(smu));
  d["slip_normal_force"] = VectorOwned(std::move(sfn));
  d["summary"] = JsonToPython(friction::ToJson(map.summary));
  return d;
}

}  // namespace

void RegisterTwin(py::module_& m) {
  py::class_<Scene>(
      m, "Scene", "A twin scene (tac3d.load_scene): the fingertip, objects and trajectory.")
      .def_readonly("name", &Scene::name)
      .def_property_readonly("steps", [](const Scene& s) { return s.trajectory.steps; })
      .def("info",
           &SceneInfo,
           "Plain data: name, steps, duration_s, marker grid, objects, deviation.")
      .def("__repr__", [](const Scene& s) {
        return fmt::format("<tac3d.Scene '{}' {} steps, {} objects>",
                           s.name,
                           s.trajectory.steps,
                           s.objects.size());
      });
  m.def("builtin_scenes", &BuiltInSceneNames, "Names of the built-in scenes.");
  m.def(
      "load_scene",
      [](const std::string& s) {
        py::gil_scoped_release release;
        return LoadSceneOrBuiltIn(s);
      },
      py::arg("name_or_path"),
      "A built-in scene by name or a scene YAML file (docs/scenes.md). Raises tac3d.Error\n"
      "naming the file, the key and what is wrong.");
  m.def(
      "parse_scene",
      [](const std::string& text, const std::string& base_dir) {
        return ParseScene(text, "<python>", base_dir);
      },
      py::arg("yaml_text"),
      py::arg("base_dir") = ".",
      "A scene from YAML text; relative paths in it are resolved against base_dir.");
  m.def("simulate",
        &Simulate,
        py::arg("scene"),
        py::arg("out"),
        py::kw_only(),
        py::arg("cache_dir") = "",
        py::arg("steps") = 0,
        py::arg("images") = true,
        py::arg("progress") = py::none(),
        py::arg("twin_options") = py::dict(),
        py::arg("window") = true,
        "Simulates a scene (a Scene, a built-in name or a YAML path) into the new dataset folder\n"
        "`out` (GIL released). The twin body model is loaded from cache_dir or built (the\n"
        "default sensor's: ~15 min, 7 GB, once). progress(done, total) is called after each\n"
        "step; an exception it raises stops the simulation and is re-raised. steps > 0:\n"
        "only the first steps. twin_options: cells_per_pitch, margin_mm,\n"
        "quadrature_points_per_side. window=False solves each contact on the whole grid, not\n"
        "on a window around it (the same solution, slower: tac3d simulate --no-window).\n"
        "Returns the summary (dict). Raises tac3d.Error.");

  m.def("simulate_arrays",
        &SimulateArrays,
        py::arg("scene"),
        py::kw_only(),
        py::arg("cache_dir") = "",
        py::arg("steps") = 0,
        py::arg("images") = true,
        py::arg("twin_options") = py::dict(),
        py::arg("scale_youngs_modulus") = true,
        py::arg("window") = true,
        py::arg("measure") = false,
        "Simulates a scene (a Scene, a built-in name or a YAML path) in memory (GIL released)\n"
        "and returns every step's truth as arrays, time first: t, world_from_sensor (T x 4 x 4),\n"
        "marker_positions, marker_forces (T x N x 3), marker_contact, marker_slip (T x N),\n"
        "total_force, total_moment (T x 3), images (T x H x W uint8, with images),\n"
        "surface_positions (S x 3), surface_tractions (T x S x 3, MPa), surface_states (T x S:\n"
        "0 separated, 1 stick, 2 slip), surface_friction (T x S: the object's mu where a node\n"
        "touches, NaN elsewhere) and summary (dict). The body model is loaded (or built) once a\n"
        "process and kept. scale_youngs_modulus: the model at the scene's nu and E x 1, its\n"
        "compliance scaled to the scene's youngs_modulus_factor (one model for every E); else\n"
        "the model at the scene's E, as tac3d.simulate. window: as tac3d.simulate's.\n"
        "measure: also run each rendered image through the pipeline of the scene's sensor as\n"
        "`tac3d run` does (its defaults, its compliance model loaded or built in cache_dir and\n"
        "its inverse computed once a process, and kept), its reference taken from images of\n"
        "the sensor at rest before step 0: measured (a tac3d.Recording of T frames, one a step)\n"
        "and, with images, reference_images (R x H x W uint8, what the pipeline took as its\n"
        "reference); summary['measurement'] says how. Raises tac3d.Error.");
  m.def("prepare_twin_body",
        &PrepareTwinBody,
        py::arg("scene"),
        py::kw_only(),
        py::arg("cache_dir") = "",
        py::arg("twin_options") = py::dict(),
        py::arg("scale_youngs_modulus") = true,
        "Loads, or builds and saves in cache_dir, the body model simulate_arrays would use for\n"
        "the scene (not kept: a client makes sure the model is cached before its workers load\n"
        "it). Returns {cache_file, cache_status, load_or_build_s}.");

  m.def("prepare_sensor_model",
        &PrepareSensorModel,
        py::arg("scene"),
        py::kw_only(),
        py::arg("cache_dir") = "",
        "Loads, or builds and saves in cache_dir, the compliance model the pipeline of the\n"
        "scene's sensor runs with (simulate_arrays(measure=True)'s, `tac3d run`'s; not kept).\n"
        "Returns {cache_file, cache_status, load_or_build_s}.");

  py::class_<SteppedSimulation>(m, "TwinSimulation", R"doc(
The twin stepped one step a call (docs/simulation.md, "One step": under a caller's loads):
along the scene's trajectory, or under the normal and tangential forces a controller chooses
each step from what it measured (closed-loop control; docs/grasping.md,
examples/python/hold_without_slip.py).
)doc")
      .def(py::init(&MakeSteppedSimulation),
           py::arg("scene"),
           py::kw_only(),
           py::arg("cache_dir") = "",
           py::arg("images") = true,
           py::arg("twin_options") = py::dict(),
           py::arg("scale_youngs_modulus") = true,
           py::arg("window") = true,
           "scene: a Scene, a built-in name or a YAML path; the body model is loaded (or built)\n"
           "once a process and kept, as by simulate_arrays, whose options these are.")
      .def_property_readonly("num_steps",
                             [](const SteppedSimulation& s) { return s.sim->num_steps(); })
      .def_property_readonly("steps_done",
                             [](const SteppedSimulation& s) { return s.sim->summary().steps; })
      .def_property_readonly(
          "summary",
          [](const SteppedSimulation& s) {
            nlohmann::json j = simulation::ToJson(s.sim->summary());
            j["twin_body"] = s.model_json;
            return JsonToPython(j);
          })
      .def("step",
           &StepStepped,
           py::arg("normal_force_n") = py::none(),
           py::arg("tangential_force_n") = py::none(),
           "Simulates the next step (GIL released) and returns its truth as Dataset.step does\n"
           "(t, world_from_sensor, marker_positions, marker_forces, marker_contact, marker_slip,\n"
           "total_force, total_moment, surface_positions, surface_tractions, surface_states,\n"
           "image with images=True) and solver (the contact solver's report; status\n"
           "'separated', 'converged', 'gross sliding' or 'iteration limit'). Without loads the\n"
           "step follows the scene's trajectory; with normal_force_n (N, >= 0; 0: nothing\n"
           "touches) and tangential_force_n ((x, y) N on the fingertip, default (0, 0)) both\n"
           "are force-controlled, the pose only placing the object, which the tangential load\n"
           "moves by the solved shift; above the friction capacity the contact slides as a\n"
           "whole (status 'gross sliding'). Raises tac3d.Error on bad loads, a scene with a\n"
           "trajectory.tangential_load, or no step left (num_steps: the trajectory's).");

  py::class_<Dataset>(m, "Dataset", R"doc(
A twin dataset folder (written by tac3d.simulate or `tac3d simulate`): its header, its steps'
truth one at a time (step) or all at once as arrays (truth), and the rendered images.
)doc")
      .def(py::init([](const std::string& folder) {
             py::gil_scoped_release release;
             return Dataset{std::make_unique<TwinDatasetReader>(folder)};
           }),
           py::arg("folder"),
           "Raises tac3d.Error if the folder holds no readable dataset.json.")
      .def_property_readonly("header",
                             [](const Dataset& d) { return JsonToPython(d.reader->header()); })
      .def_property_readonly("steps", [](const Dataset& d) { return d.reader->steps(); })
      .def("__len__", [](const Dataset& d) { return d.reader->steps().size(); })
      .def(
          "step",
          [](const Dataset& d, int step, bool surface, bool image) {
            TwinStep s;
            {
              py::gil_scoped_release release;
              s = d.reader->Read(step, surface);
            }
            return StepDict(std::move(s), image);
          },
          py::arg("step"),
          py::arg("surface") = false,
          py::arg("image") = true,
          "One step's truth: t, world_from_sensor (4 x 4), marker_positions, marker_forces (N x "
          "3),\n"
          "marker_contact, marker_slip (N,), total_force (N), total_moment (N mm), image; with\n"
          "surface=True the surface nodes' positions, tractions (MPa) and states.")
      .def("truth",
           &Truth,
           "Every step's truth as arrays: index, t (T,), world_from_sensor (T x 4 x 4),\n"
           "marker_positions, marker_forces (T x N x 3), marker_contact, marker_slip (T x N),\n"
           "total_force, total_moment (T x 3).");

  m.def("design_light_path",
        &DesignLight,
        py::arg("h_mm") = 40.0,
        py::arg("l_mm") = 40.0,
        py::arg("d_mm") = 8.0,
        py::arg("fov_deg") = 48.0,
        py::arg("starts_per_axis") = 8,
        "Solves the mirror layout (paper section III.B) for camera distance h, fingertip length\n"
        "l, thickness d and field of view. Returns {roots: [...], chosen: index or None,\n"
        "sensor_yaml: the designed sensor or None, summary}. Raises tac3d.Error on bad options.");
  m.def(
      "default_sensor_yaml",
      [] { return SensorConfigToYaml(DefaultSensorConfig()); },
      "The built-in prototype sensor as YAML.");
  m.def("friction_map",
        &FrictionMap,
        py::arg("frames"),
        py::arg("poses"),
        py::arg("options") = py::dict(),
        py::kw_only(),
        py::arg("config") = "",
        FrictionMapDoc().c_str());
  m.def("friction_map_defaults",
        &FrictionMapDefaults,
        "friction_map's options and their defaults (dict), those of `tac3d friction-map`.");
}

}  // namespace tac3d::python
