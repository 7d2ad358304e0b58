#pragma once

#include <pybind11/pybind11.h>

#include <string>

#include "tac3d/pipeline/drift_monitor.h"

namespace tac3d::python {

// Each file adds its part of the module `tac3d._core`.
void RegisterSensor(pybind11::module_& m);
void RegisterFrames(pybind11::module_& m);    // TactileFrame, recordings
void RegisterPipeline(pybind11::module_& m);  // frame sources, the in-process pipeline
void RegisterTwin(pybind11::module_& m);      // scenes, simulation, datasets, design, friction
void RegisterRuntime(pybind11::module_& m);   // several sensors with their outputs: tac3d.run
void RegisterDatasetSpec(pybind11::module_& m);  // dataset specs: tac3d.datasets
void RegisterTracking(pybind11::module_& m);     // single-view marker tracking: tac3d.track

/// The drift mode named by a `drift` argument (off, flag, rezero: --drift's and the run file's
/// names), for SensorSpec and Pipeline. @throws tac3d::Error naming it otherwise.
DriftMode DriftModeArg(const std::string& drift);

}  // namespace tac3d::python
