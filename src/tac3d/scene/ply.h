#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tac3d {

/// A triangle mesh with optional per-vertex scalar properties (a friction coefficient, say).
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;  ///< vertex indices, counter-clockwise seen from outside
  /// Per-vertex scalars by PLY property name, each the size of `vertices` (x, y, z excluded).
  std::map<std::string, std::vector<double>> vertex_properties;
};

/// Reads a PLY file (ascii, binary_little_endian or binary_big_endian): the vertex element's
/// x, y, z and every other scalar vertex property, and the face element's index list
/// (`vertex_indices` or `vertex_index`); polygons are fanned into triangles. Other elements
/// are skipped.
/// @throws Error naming the file and what is wrong: not PLY, an unsupported format or type,
///   a missing x/y/z or face list, a truncated body, an index out of range, a non-finite
///   coordinate.
TriangleMesh ReadPly(const std::string& path);

/// Writes an ascii PLY with the mesh's vertex properties (as float64 `double`).
/// @throws Error if the file cannot be written.
void WritePly(const TriangleMesh& mesh, const std::string& path);

enum class PlyFormat { kAscii, kBinaryLittleEndian };

/// How WritePly encodes a mesh.
struct PlyWriteOptions {
  PlyFormat format = PlyFormat::kAscii;
  /// PLY type of x, y, z: "float" or "double".
  std::string coordinate_type = "double";
  /// PLY scalar type of a vertex property by name: "char", "uchar", "short", "ushort", "int",
  /// "uint", "float" or "double". Unlisted properties are "double". Integer types take the
  /// value rounded and clamped to their range; NaN is kept only by "float" and "double".
  /// Colours that MeshLab and Blender show: uchar "red", "green", "blue".
  std::map<std::string, std::string> property_types;
  /// Vertex properties in this order first, then the others by name.
  std::vector<std::string> property_order;
  std::vector<std::string> comments;  ///< `comment` lines of the header

  /// @throws Error naming the field: an unknown type.
  void Validate() const;
};

/// Writes a PLY, ascii or binary little-endian, with the types the options give.
/// @throws Error if the options are invalid, a property's size is not the vertex count, or
///   the file cannot be written.
void WritePly(const TriangleMesh& mesh, const std::string& path, const PlyWriteOptions& options);

}  // namespace tac3d
