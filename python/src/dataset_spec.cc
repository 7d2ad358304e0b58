// Dataset specs (src/tac3d/dataset_spec): parsed and drawn in C++ with the YAML reader every
// tac3d file uses, so `tac3d.datasets` (Python, on Dask) never parses a spec itself.
#include "tac3d/dataset_spec/dataset_spec.h"

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "arrays.h"
#include "bindings.h"

namespace tac3d::python {

void RegisterDatasetSpec(py::module_& m) {
  py::class_<DatasetSpec>(
      m, "DatasetSpec", "A dataset spec (docs/datasets.md): distributions of scenes, one seed.")
      .def_readonly("name", &DatasetSpec::name)
      .def_readonly("seed", &DatasetSpec::seed)
      .def_readonly("steps", &DatasetSpec::steps)
      .def_readonly("images", &DatasetSpec::images)
      .def_readonly("measured", &DatasetSpec::measured,
                    "Whether episodes store what the sensor's pipeline measures beside the truth.")
      .def_readonly("sensor", &DatasetSpec::sensor)
      .def_property_readonly(
          "twin_options",
          [](const DatasetSpec& s) {
            // tac3d.simulate's twin_options: integers where TwinBodyOptions has integers.
            py::dict d;
            for (const auto& [key, value] : s.twin_options) {
              if (key == "margin_mm") {
                d[key.c_str()] = value;
              } else {
                d[key.c_str()] = static_cast<int>(value);
              }
            }
            return d;
          },
          "TwinBodyOptions by name, as tac3d.simulate's twin_options takes them.")
      .def(
          "draw",
          [](const DatasetSpec& s, int episode) {
            const EpisodeDraw d = DrawEpisode(s, episode);
            py::dict out;
            out["episode"] = d.episode;
            out["seed"] = py::int_(d.seed);
            out["parameters"] = JsonToPython(d.parameters);
            out["scene_yaml"] = d.scene_yaml;
            return out;
          },
          py::arg("episode"),
          "Episode i: {episode, seed, parameters, scene_yaml}, drawn from a seed of (spec seed,\n"
          "i) only. scene_yaml is for tac3d.parse_scene. Raises tac3d.Error if i < 0.");
  m.def(
      "load_dataset_spec",
      [](const std::string& path) {
        py::gil_scoped_release release;
        return LoadDatasetSpec(path);
      },
      py::arg("path"),
      "Reads a dataset spec YAML. Raises tac3d.Error naming the file, the line and the key of\n"
      "a duplicated or unknown key or a value out of range.");
  m.def(
      "parse_dataset_spec",
      [](const std::string& text, const std::string& base_dir) {
        return ParseDatasetSpec(text, "<python>", base_dir);
      },
      py::arg("yaml_text"),
      py::arg("base_dir") = ".",
      "As load_dataset_spec, from text; relative paths are against base_dir.");
}

}  // namespace tac3d::python
