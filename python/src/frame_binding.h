#pragma once

#include <pybind11/pybind11.h>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d::python {

/// A tac3d.TactileFrame owning `frame` (moved, no copy of its vectors).
pybind11::object FrameToPython(TactileFrame&& frame);

}  // namespace tac3d::python
