#include "tac3d/scene/ply.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

enum class Format { kAscii, kBinaryLittle, kBinaryBig };

struct Property {
  std::string name;
  std::string type;        // scalar type, or the list's item type
  std::string count_type;  // non-empty for a list
};

struct Element {
  std::string name;
  long count = 0;
  std::vector<Property> properties;
};

int TypeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" ||
      type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

// Reads one value of a PLY type from the body.
class BodyReader {
 public:
  BodyReader(std::istream& in, Format format, const std::string& path)
      : in_(in), format_(format), path_(path) {}

  double Read(const std::string& type) {
    if (format_ == Format::kAscii) {
      std::string token;
      if (!(in_ >> token)) Fail("the body ends early (truncated file)");
      try {
        size_t used = 0;
        const double v = std::stod(token, &used);
        if (used != token.size()) throw std::invalid_argument(token);
        return v;
      } catch (const std::exception&) {
        Fail(fmt::format("'{}' is not a number", token));
      }
    }
    const int size = TypeSize(type);
    unsigned char raw[8] = {};
    if (!in_.read(reinterpret_cast<char*>(raw), size)) Fail("the body ends early (truncated file)");
    const bool swap = (format_ == Format::kBinaryBig) == (std::endian::native == std::endian::little);
    unsigned char bytes[8] = {};
    for (int i = 0; i < size; ++i) bytes[i] = raw[swap ? size - 1 - i : i];
    return Decode(type, bytes);
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(fmt::format("PLY file '{}': {}", path_, what));
  }

 private:
  static double Decode(const std::string& type, const unsigned char* b) {
    auto as = [b]<typename T>(T) {
      T v;
      std::memcpy(&v, b, sizeof(T));
      return static_cast<double>(v);
    };
    if (type == "char" || type == "int8") return as(std::int8_t{});
    if (type == "uchar" || type == "uint8") return as(std::uint8_t{});
    if (type == "short" || type == "int16") return as(std::int16_t{});
    if (type == "ushort" || type == "uint16") return as(std::uint16_t{});
    if (type == "int" || type == "int32") return as(std::int32_t{});
    if (type == "uint" || type == "uint32") return as(std::uint32_t{});
    if (type == "float" || type == "float32") return as(float{});
    return as(double{});
  }

  std::istream& in_;
  Format format_;
  const std::string& path_;
};

}  // namespace

TriangleMesh ReadPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("PLY file '{}' cannot be opened", path));
  auto fail = [&](const std::string& what) -> void {
    throw Error(fmt::format("PLY file '{}': {}", path, what));
  };
  std::string line;
  if (!std::getline(in, line) || line.substr(0, 3) != "ply") fail("not a PLY file (no 'ply' magic)");
  Format format = Format::kAscii;
  bool has_format = false;
  std::vector<Element> elements;
  while (true) {
    if (!std::getline(in, line)) fail("the header has no end_header");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header") break;
    if (keyword == "comment" || keyword == "obj_info" || keyword.empty()) continue;
    if (keyword == "format") {
      std::string name;
      words >> name;
      if (name == "ascii") format = Format::kAscii;
      else if (name == "binary_little_endian") format = Format::kBinaryLittle;
      else if (name == "binary_big_endian") format = Format::kBinaryBig;
      else fail(fmt::format("unsupported format '{}'", name));
      has_format = true;
    } else if (keyword == "element") {
      Element e;
      if (!(words >> e.name >> e.count) || e.count < 0) fail(fmt::format("bad element line '{}'", line));
      elements.push_back(e);
    } else if (keyword == "property") {
      if (elements.empty()) fail("a property before any element");
      Property p;
      std::string type;
      words >> type;
      if (type == "list") {
        words >> p.count_type >> p.type;
        if (TypeSize(p.count_type) == 0 || TypeSize(p.type) == 0) fail(fmt::format("bad list types in '{}'", line));
      } else {
        p.type = type;
        if (TypeSize(p.type) == 0) fail(fmt::format("unsupported property type '{}'", type));
      }
      if (!(words >> p.name)) fail(fmt::format("a property without a name: '{}'", line));
      elements.back().properties.push_back(p);
    } else {
      fail(fmt::format("unknown header line '{}'", line));
    }
  }
  if (!has_format) fail("the header has no format line");

  TriangleMesh mesh;
  BodyReader body(in, format, path);
  for (const Element& element : elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    std::array<int, 3> xyz = {-1, -1, -1};
    int face_list = -1;
    for (int i = 0; i < static_cast<int>(element.properties.size()); ++i) {
      const Property& p = element.properties[i];
      if (is_vertex && p.count_type.empty()) {
        if (p.name == "x") xyz[0] = i;
        else if (p.name == "y") xyz[1] = i;
        else if (p.name == "z") xyz[2] = i;
        else mesh.vertex_properties[p.name].reserve(element.count);
      }
      if (is_face && !p.count_type.empty() && (p.name == "vertex_indices" || p.name == "vertex_index")) {
        face_list = i;
      }
    }
    if (is_vertex && std::count(xyz.begin(), xyz.end(), -1) > 0) fail("the vertex element lacks x, y or z");
    if (is_face && face_list < 0) fail("the face element has no vertex_indices list");
    for (long k = 0; k < element.count; ++k) {
      Eigen::Vector3d v;
      for (int i = 0; i < static_cast<int>(element.properties.size()); ++i) {
        const Property& p = element.properties[i];
        if (!p.count_type.empty()) {
          const double count = body.Read(p.count_type);
          if (!(count >= 0 && count <= 1000)) fail(fmt::format("{} {}: list length {}", element.name, k, count));
          std::vector<int> items(static_cast<size_t>(count));
          for (int& item : items) item = static_cast<int>(body.Read(p.type));
          if (i == face_list) {
            if (items.size() < 3) fail(fmt::format("face {} has {} vertices", k, items.size()));
            for (size_t j = 1; j + 1 < items.size(); ++j) {
              mesh.triangles.emplace_back(items[0], items[j], items[j + 1]);
            }
          }
          continue;
        }
        const double value = body.Read(p.type);
        if (!is_vertex) continue;
        if (i == xyz[0]) v.x() = value;
        else if (i == xyz[1]) v.y() = value;
        else if (i == xyz[2]) v.z() = value;
        else mesh.vertex_properties[p.name].push_back(value);
      }
      if (is_vertex) {
        if (!v.allFinite()) fail(fmt::format("vertex {} is not finite", k));
        mesh.vertices.push_back(v);
      }
    }
  }
  const int n = static_cast<int>(mesh.vertices.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    if (tri.minCoeff() < 0 || tri.maxCoeff() >= n) {
      fail(fmt::format("a triangle of face data (triangle {}) indexes a vertex outside 0..{}", t, n - 1));
    }
  }
  return mesh;
}

void WritePly(const TriangleMesh& mesh, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error(fmt::format("cannot write PLY file '{}'", path));
  out << "ply\nformat ascii 1.0\ncomment written by tac3d\n";
  out << "element vertex " << mesh.vertices.size() << "\n";
  out << "property double x\nproperty double y\nproperty double z\n";
  for (const auto& [name, values] : mesh.vertex_properties) out << "property double " << name << "\n";
  out << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    out << fmt::format("{} {} {}", mesh.vertices[i].x(), mesh.vertices[i].y(), mesh.vertices[i].z());
    for (const auto& [name, values] : mesh.vertex_properties) out << " " << fmt::format("{}", values.at(i));
    out << "\n";
  }
  for (const Eigen::Vector3i& t : mesh.triangles) out << "3 " << t.x() << " " << t.y() << " " << t.z() << "\n";
  if (!out) throw Error(fmt::format("writing PLY file '{}' failed", path));
}

}  // namespace tac3d
