#pragma once

// numpy <-> C++ conversions shared by the bindings. Arrays handed to Python own or borrow
// their data without a copy wherever the C++ layout is already an array's: a moved object
// lives on in a capsule that is the array's base, or a view keeps its owner alive.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "tac3d/util/error.h"  // tac3d::Error, fmt

namespace tac3d::python {

namespace py = pybind11;

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// A capsule that owns `value` (moved to the heap) and deletes it when the last array using it
/// as base goes away; `*data` points at the moved object.
template <typename T>
py::capsule OwnedCapsule(T&& value, T** data) {
  auto* owned = new T(std::forward<T>(value));
  *data = owned;
  return py::capsule(owned, [](void* p) { delete static_cast<T*>(p); });
}

/// N x 3 float64 over a vector of Vector3d (24 bytes each, no padding), no copy: a view kept
/// alive by `base` (an object that owns the vector).
py::array_t<double> Vector3View(const std::vector<Eigen::Vector3d>& v, py::handle base);
/// The same, taking the vector over (no copy of its data).
py::array_t<double> Vector3Owned(std::vector<Eigen::Vector3d>&& v);
/// (3,) float64 viewing one Vector3d owned by `base`.
py::array_t<double> Vector3dView(const Eigen::Vector3d& v, py::handle base);
/// A copy as a bool array.
py::array_t<bool> BoolArray(const std::vector<bool>& v);
template <typename T>
py::array_t<T> VectorOwned(std::vector<T>&& v) {
  std::vector<T>* owned = nullptr;
  py::capsule base = OwnedCapsule(std::move(v), &owned);
  return py::array_t<T>({static_cast<py::ssize_t>(owned->size())}, owned->data(), base);
}

/// An image as uint8 (H x W or H x W x C) sharing the cv::Mat's buffer (reference counted).
py::object ImageArray(const cv::Mat& image);
/// A cv::Mat header over a C-contiguous uint8 2D array (no copy; valid while `a` lives).
/// @throws tac3d::Error naming `what` if it is not 2D uint8 or not contiguous.
cv::Mat ImageFromArray(const py::array& a, const char* what);

/// n x 3 float64 (any numeric array, converted) to Vector3d; `n` < 0: any number of rows.
/// @throws tac3d::Error naming `what` and the shape it has and should have.
std::vector<Eigen::Vector3d> ToVector3(const py::handle& a, int n, const char* what);
Eigen::Vector3d ToVector3d(const py::handle& a, const char* what);
std::vector<bool> ToBools(const py::handle& a, int n, const char* what);

/// JSON as Python objects (dicts, lists, numbers, strings) through the json module, and back.
py::object JsonToPython(const nlohmann::json& j);
nlohmann::json PythonToJson(const py::handle& o);

}  // namespace tac3d::python
