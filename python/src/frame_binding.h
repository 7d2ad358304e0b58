#pragma once

#include <pybind11/pybind11.h>

#include <vector>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d::python {

/// A tac3d.TactileFrame owning `frame` (moved, no copy of its vectors).
pybind11::object FrameToPython(TactileFrame&& frame);

/// A tac3d.Recording of `frames` (moved; no images), complete: its whole arrays (positions,
/// ..., slip) are the frames' stacked.
pybind11::object RecordingToPython(std::vector<TactileFrame>&& frames);

}  // namespace tac3d::python
