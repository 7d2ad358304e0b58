#include "tac3d/scene/ply.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

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
  // A device or a FIFO never ends (/dev/zero was read to 2 GB before its magic was checked).
  const std::uintmax_t file_bytes = RequireRegularFile(path, "PLY file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("PLY file '{}' cannot be opened", path));
  auto fail = [&](const std::string& what) -> void {
    throw Error(fmt::format("PLY file '{}': {}", path, what));
  };
  // Header lines are short: a longer one is not a PLY header.
  constexpr std::streamsize kMaxHeaderLine = 4096;
  std::string line;
  const auto header_line = [&]() -> bool {
    line.resize(kMaxHeaderLine);
    in.getline(line.data(), kMaxHeaderLine);
    if (in.fail() && in.gcount() == kMaxHeaderLine - 1) fail("a header line is over 4096 bytes: not a PLY header");
    if (in.fail() && in.gcount() == 0) return false;
    line.resize(static_cast<std::size_t>(in.gcount()) - (in.eof() ? 0 : 1));
    return true;
  };
  if (!header_line() || line.substr(0, 3) != "ply") fail("not a PLY file (no 'ply' magic)");
  Format format = Format::kAscii;
  bool has_format = false;
  std::vector<Element> elements;
  while (true) {
    if (!header_line()) fail("the header has no end_header");
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
      // Each element takes a byte at least: a larger count is a lie that would reserve memory.
      if (static_cast<std::uintmax_t>(e.count) > file_bytes) {
        fail(fmt::format("element '{}' counts {}, more than the file's {} bytes", e.name, e.count, file_bytes));
      }
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

void WritePly(const TriangleMesh& mesh, const std::string& path) { WritePly(mesh, path, PlyWriteOptions{}); }

namespace {

bool IsWritableType(const std::string& type) {
  return type == "char" || type == "uchar" || type == "short" || type == "ushort" || type == "int" ||
         type == "uint" || type == "float" || type == "double";
}

// Writes one value as a PLY type, ascii or binary little-endian.
class BodyWriter {
 public:
  BodyWriter(std::ostream& out, PlyFormat format) : out_(out), format_(format) {}

  void Write(const std::string& type, double value, bool first) {
    if (type == "float") return Put(static_cast<float>(value), first);
    if (type == "double") return Put(value, first);
    if (type == "char") return Put(Integer<std::int8_t>(value), first);
    if (type == "uchar") return Put(Integer<std::uint8_t>(value), first);
    if (type == "short") return Put(Integer<std::int16_t>(value), first);
    if (type == "ushort") return Put(Integer<std::uint16_t>(value), first);
    if (type == "int") return Put(Integer<std::int32_t>(value), first);
    TAC3D_DEMAND(type == "uint");
    Put(Integer<std::uint32_t>(value), first);
  }
  void EndLine() {
    if (format_ == PlyFormat::kAscii) out_ << "\n";
  }

 private:
  template <typename T>
  static T Integer(double value) {
    if (std::isnan(value)) return T{0};
    const double lo = static_cast<double>(std::numeric_limits<T>::min());
    const double hi = static_cast<double>(std::numeric_limits<T>::max());
    return static_cast<T>(std::clamp(std::round(value), lo, hi));
  }
  template <typename T>
  void Put(T value, bool first) {
    if (format_ == PlyFormat::kAscii) {
      if (!first) out_ << ' ';
      if constexpr (sizeof(T) == 1) {
        out_ << static_cast<int>(value);
      } else {
        out_ << fmt::format("{}", value);
      }
      return;
    }
    static_assert(std::endian::native == std::endian::little, "binary PLY writing assumes a little-endian host");
    out_.write(reinterpret_cast<const char*>(&value), sizeof(T));
  }

  std::ostream& out_;
  PlyFormat format_;
};

}  // namespace

void PlyWriteOptions::Validate() const {
  if (coordinate_type != "float" && coordinate_type != "double") {
    throw Error(fmt::format("PlyWriteOptions.coordinate_type = '{}': must be float or double", coordinate_type));
  }
  for (const auto& [name, type] : property_types) {
    if (!IsWritableType(type)) {
      throw Error(fmt::format("PlyWriteOptions.property_types[{}] = '{}': must be char, uchar, short, ushort, "
                              "int, uint, float or double",
                              name, type));
    }
  }
}

void WritePly(const TriangleMesh& mesh, const std::string& path, const PlyWriteOptions& options) {
  options.Validate();
  std::vector<std::string> names;
  for (const std::string& name : options.property_order) {
    if (mesh.vertex_properties.count(name) > 0) names.push_back(name);
  }
  for (const auto& [name, values] : mesh.vertex_properties) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    if (values.size() != mesh.vertices.size()) {
      throw Error(fmt::format("PLY file '{}': vertex property '{}' has {} values for {} vertices", path, name,
                              values.size(), mesh.vertices.size()));
    }
  }
  const auto type_of = [&](const std::string& name) {
    const auto it = options.property_types.find(name);
    return it == options.property_types.end() ? std::string("double") : it->second;
  };
  const bool binary = options.format == PlyFormat::kBinaryLittleEndian;
  WriteFileAtomically(path, [&](const std::string& temporary) {
    std::ofstream out(temporary, binary ? std::ios::binary : std::ios::out);
    if (!out) throw Error(fmt::format("cannot write PLY file '{}'", path));
    out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment written by tac3d\n";
    for (const std::string& comment : options.comments) out << "comment " << comment << "\n";
    out << "element vertex " << mesh.vertices.size() << "\n";
    for (const char* axis : {"x", "y", "z"}) out << "property " << options.coordinate_type << " " << axis << "\n";
    for (const std::string& name : names) out << "property " << type_of(name) << " " << name << "\n";
    out << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    BodyWriter writer(out, options.format);
    std::vector<std::pair<std::string, const std::vector<double>*>> columns;
    for (const std::string& name : names) columns.emplace_back(type_of(name), &mesh.vertex_properties.at(name));
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      for (int k = 0; k < 3; ++k) writer.Write(options.coordinate_type, mesh.vertices[i][k], k == 0);
      for (const auto& [type, values] : columns) writer.Write(type, (*values)[i], false);
      writer.EndLine();
    }
    for (const Eigen::Vector3i& t : mesh.triangles) {
      writer.Write("uchar", 3, true);
      for (int k = 0; k < 3; ++k) writer.Write("int", t[k], false);
      writer.EndLine();
    }
    if (!out) throw Error(fmt::format("writing PLY file '{}' failed", path));
  });
}

}  // namespace tac3d
