#include <pybind11/pybind11.h>

#include "bindings.h"
#include "tac3d/util/error.h"
#include "tac3d/util/version.h"

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
  m.doc() = "tac3d: the Tac3D tactile sensor stack from Python (docs/python.md).";
  m.attr("__version__") = tac3d::Version();
  // tac3d::Error (bad input: a file, an argument, the network) and its subclasses arrive as
  // tac3d.Error with the C++ message.
  py::register_exception<tac3d::Error>(m, "Error", PyExc_RuntimeError);
  m.attr("Error").attr("__doc__") =
      "Bad input (a file, an argument, a port, the network): the C++ tac3d::Error's message.";
  tac3d::python::RegisterFrames(m);
  tac3d::python::RegisterSensor(m);
  tac3d::python::RegisterPipeline(m);
  tac3d::python::RegisterTwin(m);
  tac3d::python::RegisterRuntime(m);
  tac3d::python::RegisterDatasetSpec(m);
  tac3d::python::RegisterTracking(m);
}
