#include "arrays.h"

#include <fmt/format.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"

namespace tac3d::python {

static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double), "Vector3d must be 3 packed doubles");

namespace {

constexpr py::ssize_t kRowStride = 3 * sizeof(double);

std::string ShapeOf(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += fmt::format("{}{}", i ? ", " : "", a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

py::array_t<double> Vector3View(const std::vector<Eigen::Vector3d>& v, py::handle base) {
  if (v.empty()) return py::array_t<double>(std::vector<py::ssize_t>{0, 3});
  return py::array_t<double>({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}},
                             {kRowStride, static_cast<py::ssize_t>(sizeof(double))},
                             v.front().data(),
                             base);
}

py::array_t<double> Vector3Owned(std::vector<Eigen::Vector3d>&& v) {
  std::vector<Eigen::Vector3d>* owned = nullptr;
  py::capsule base = OwnedCapsule(std::move(v), &owned);
  return Vector3View(*owned, base);
}

py::array_t<double> Vector3dView(const Eigen::Vector3d& v, py::handle base) {
  return py::array_t<double>(
      {py::ssize_t{3}}, {static_cast<py::ssize_t>(sizeof(double))}, v.data(), base);
}

py::array_t<bool> BoolArray(const std::vector<bool>& v) {
  py::array_t<bool> out(static_cast<py::ssize_t>(v.size()));
  bool* p = out.mutable_data();
  for (size_t i = 0; i < v.size(); ++i) p[i] = v[i];
  return out;
}

py::object ImageArray(const cv::Mat& image) {
  if (image.empty()) return py::none();
  if (image.depth() != CV_8U) throw Error("only 8-bit images are handed to Python");
  cv::Mat* owned = nullptr;
  cv::Mat mat = image;  // shares the buffer, reference counted
  py::capsule base = OwnedCapsule(std::move(mat), &owned);
  std::vector<py::ssize_t> shape = {owned->rows, owned->cols};
  std::vector<py::ssize_t> strides = {static_cast<py::ssize_t>(owned->step[0]),
                                      static_cast<py::ssize_t>(owned->elemSize())};
  if (owned->channels() > 1) {
    shape.push_back(owned->channels());
    strides.push_back(1);
  }
  return py::array(py::dtype::of<std::uint8_t>(), shape, strides, owned->data, base);
}

cv::Mat ImageFromArray(const py::array& a, const char* what) {
  if (!py::isinstance<py::array_t<std::uint8_t>>(a) || a.ndim() != 2) {
    throw Error(fmt::format("{}: expected a 2D uint8 array (a grey image), got {} {}",
                            what,
                            std::string(py::str(a.dtype())),
                            ShapeOf(a)));
  }
  if (!(a.flags() & py::array::c_style)) {
    throw Error(fmt::format("{}: the image must be C-contiguous (numpy.ascontiguousarray)", what));
  }
  return cv::Mat(static_cast<int>(a.shape(0)),
                 static_cast<int>(a.shape(1)),
                 CV_8UC1,
                 const_cast<void*>(a.data()));
}

std::vector<Eigen::Vector3d> ToVector3(const py::handle& h, int n, const char* what) {
  DoubleArray a;
  try {
    a = py::cast<DoubleArray>(h);
  } catch (const py::cast_error&) {
    throw Error(fmt::format("{}: expected an array of numbers", what));
  }
  if (a.ndim() != 2 || a.shape(1) != 3 || (n >= 0 && a.shape(0) != n)) {
    throw Error(fmt::format(
        "{}: expected shape ({}, 3), got {}", what, n >= 0 ? std::to_string(n) : "N", ShapeOf(a)));
  }
  std::vector<Eigen::Vector3d> out(static_cast<size_t>(a.shape(0)));
  if (!out.empty()) std::memcpy(out.front().data(), a.data(), out.size() * kRowStride);
  return out;
}

Eigen::Vector3d ToVector3d(const py::handle& h, const char* what) {
  DoubleArray a;
  try {
    a = py::cast<DoubleArray>(h);
  } catch (const py::cast_error&) {
    throw Error(fmt::format("{}: expected three numbers", what));
  }
  if (a.size() != 3)
    throw Error(fmt::format("{}: expected three numbers, got shape {}", what, ShapeOf(a)));
  return Eigen::Vector3d(a.data()[0], a.data()[1], a.data()[2]);
}

std::vector<bool> ToBools(const py::handle& h, int n, const char* what) {
  py::array_t<bool, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::cast<py::array_t<bool, py::array::c_style | py::array::forcecast>>(h);
  } catch (const py::cast_error&) {
    throw Error(fmt::format("{}: expected an array of booleans", what));
  }
  if (a.ndim() != 1 || a.shape(0) != n) {
    throw Error(fmt::format("{}: expected shape ({},), got {}", what, n, ShapeOf(a)));
  }
  return std::vector<bool>(a.data(), a.data() + n);
}

py::object JsonToPython(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

nlohmann::json PythonToJson(const py::handle& o) {
  const std::string text = py::str(py::module_::import("json").attr("dumps")(o));
  return nlohmann::json::parse(text);
}

}  // namespace tac3d::python
