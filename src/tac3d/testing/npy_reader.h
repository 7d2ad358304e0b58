#pragma once

// A minimal .npy reader for the tests: an independent parse of what NpyWriter writes.

#include <cstdint>
#include <cstring>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace tac3d::testing {

struct NpyArray {
  std::string descr;
  bool fortran_order = true;
  std::vector<std::int64_t> shape;
  std::size_t header_bytes = 0;  ///< magic to '\n' inclusive
  std::string data;              ///< the bytes after the header

  std::int64_t elements() const {
    std::int64_t n = 1;
    for (const std::int64_t d : shape) n *= d;
    return n;
  }
  template <typename T>
  T at(std::size_t i) const {
    T value;
    std::memcpy(&value, data.data() + i * sizeof(T), sizeof(T));
    return value;
  }
};

/// Parses an .npy file version 1.0; returns false (with `error`) on anything unexpected.
inline bool ReadNpy(const std::string& path, NpyArray* array, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  const std::string bytes(std::istreambuf_iterator<char>(in), {});
  if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0) return *error = "no magic", false;
  if (bytes[6] != 1 || bytes[7] != 0) return *error = "not version 1.0", false;
  const std::size_t header_len =
      static_cast<std::uint8_t>(bytes[8]) | (static_cast<std::uint8_t>(bytes[9]) << 8);
  array->header_bytes = 10 + header_len;
  if (array->header_bytes > bytes.size()) return *error = "header past the end", false;
  const std::string header = bytes.substr(10, header_len);
  if (header.back() != '\n') return *error = "header does not end with a newline", false;
  std::smatch m;
  const std::regex dict(
      R"(^\{'descr': '([^']+)', 'fortran_order': (True|False), 'shape': \(([0-9, ]*)\), \} *\n$)");
  if (!std::regex_match(header, m, dict)) return *error = "header '" + header + "'", false;
  array->descr = m[1];
  array->fortran_order = m[2] == "True";
  array->shape.clear();
  const std::string dims = m[3];
  const std::regex number("[0-9]+");
  for (auto it = std::sregex_iterator(dims.begin(), dims.end(), number);
       it != std::sregex_iterator();
       ++it) {
    array->shape.push_back(std::stoll(it->str()));
  }
  array->data = bytes.substr(array->header_bytes);
  return true;
}

/// ReadNpy in a test: a file that does not parse fails the test (and gives an empty array).
inline NpyArray LoadNpy(const std::string& path) {
  NpyArray array;
  std::string error;
  EXPECT_TRUE(ReadNpy(path, &array, &error)) << path << ": " << error;
  return array;
}

}  // namespace tac3d::testing
