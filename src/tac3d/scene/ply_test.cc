#include "tac3d/scene/ply.h"

#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <iterator>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

std::string Write(const std::string& name, const std::string& bytes) {
  const std::string path = testing::MakeTempDir("ply") + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

std::string PlyErrorOf(const std::string& path) {
  try {
    ReadPly(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Ply, AsciiQuadWithFrictionIsFannedIntoTriangles) {
  const std::string path = Write("quad.ply",
                                 "ply\nformat ascii 1.0\ncomment a unit square\nelement vertex 4\n"
                                 "property float x\nproperty float y\nproperty float z\nproperty float mu\n"
                                 "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                 "0 0 0 0.3\n1 0 0 0.3\n1 1 0 1.2\n0 1 0 1.2\n4 0 1 2 3\n");
  const TriangleMesh mesh = ReadPly(path);
  ASSERT_EQ(mesh.vertices.size(), 4u);
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.triangles[1], Eigen::Vector3i(0, 2, 3));
  ASSERT_EQ(mesh.vertex_properties.count("mu"), 1u);
  EXPECT_DOUBLE_EQ(mesh.vertex_properties.at("mu")[2], 1.2);
}

TEST(Ply, BinaryLittleEndianRoundTripsThroughTheReader) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
      "property double z\nproperty uchar red\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  const double xyz[3][3] = {{0, 0, 0}, {2.5, 0, 0}, {0, -1.5, 7}};
  for (int i = 0; i < 3; ++i) {
    bytes.append(reinterpret_cast<const char*>(xyz[i]), sizeof(xyz[i]));
    bytes.push_back(static_cast<char>(10 * i));
  }
  bytes.push_back(3);
  const std::uint32_t indices[3] = {2, 1, 0};
  bytes.append(reinterpret_cast<const char*>(indices), sizeof(indices));
  const TriangleMesh mesh = ReadPly(Write("binary.ply", bytes));
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[2], Eigen::Vector3d(0, -1.5, 7));
  EXPECT_EQ(mesh.triangles[0], Eigen::Vector3i(2, 1, 0));
  EXPECT_DOUBLE_EQ(mesh.vertex_properties.at("red")[2], 20);
  // The same mesh written as ascii and read again.
  const std::string again = testing::MakeTempDir("ply") + "/again.ply";
  WritePly(mesh, again);
  const TriangleMesh reread = ReadPly(again);
  EXPECT_EQ(reread.vertices, mesh.vertices);
  EXPECT_EQ(reread.triangles, mesh.triangles);
  EXPECT_EQ(reread.vertex_properties, mesh.vertex_properties);
}

TEST(Ply, WrittenBinaryWithTypedPropertiesReadsBack) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1.5, 0, 0}, {0, 2.25, -1}};
  mesh.triangles = {{0, 1, 2}};
  mesh.vertex_properties["mu"] = {0.25, std::nan(""), 0.875};
  mesh.vertex_properties["red"] = {0, 254.6, 300};  // rounded and clamped to uchar
  mesh.vertex_properties["slip_count"] = {3, 0, -2};
  PlyWriteOptions options;
  options.format = PlyFormat::kBinaryLittleEndian;
  options.coordinate_type = "float";
  options.property_types = {{"mu", "float"}, {"red", "uchar"}, {"slip_count", "int"}};
  options.property_order = {"slip_count", "mu"};
  options.comments = {"a test"};
  const std::string path = testing::MakeTempDir("ply") + "/typed.ply";
  WritePly(mesh, path, options);
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(text, HasSubstr("format binary_little_endian 1.0\ncomment written by tac3d\ncomment a test\n"
                              "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                              "property int slip_count\nproperty float mu\nproperty uchar red\n"));
  // Header, then 3 x (3 floats + int + float + uchar) and one face (uchar + 3 ints).
  EXPECT_EQ(text.size() - text.find("end_header\n") - 11, 3u * (12 + 4 + 4 + 1) + 13u);
  const TriangleMesh reread = ReadPly(path);
  EXPECT_EQ(reread.vertices, mesh.vertices);  // exact in float
  EXPECT_EQ(reread.triangles, mesh.triangles);
  EXPECT_EQ(reread.vertex_properties.at("mu")[0], 0.25);
  EXPECT_TRUE(std::isnan(reread.vertex_properties.at("mu")[1]));
  EXPECT_EQ(reread.vertex_properties.at("red"), (std::vector<double>{0, 255, 255}));
  EXPECT_EQ(reread.vertex_properties.at("slip_count"), (std::vector<double>{3, 0, -2}));
}

TEST(Ply, WriteOptionsAreValidated) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}};
  const std::string path = testing::MakeTempDir("ply") + "/bad.ply";
  PlyWriteOptions options;
  options.coordinate_type = "int";
  EXPECT_THROW(
      {
        try {
          WritePly(mesh, path, options);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("PlyWriteOptions.coordinate_type = 'int'"));
          throw;
        }
      },
      Error);
  options = PlyWriteOptions{};
  options.property_types["mu"] = "long double";
  EXPECT_THROW(WritePly(mesh, path, options), Error);
  mesh.vertex_properties["mu"] = {0.1, 0.2};
  try {
    WritePly(mesh, path, PlyWriteOptions{});
    ADD_FAILURE() << "a property of the wrong size was written";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("vertex property 'mu' has 2 values for 1 vertices"));
  }
}

TEST(Ply, BinaryBigEndianFloatsAndShortIndices) {
  std::string bytes =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar short vertex_indices\nend_header\n";
  auto append_big = [&bytes](const auto value) {
    char b[sizeof(value)];
    std::memcpy(b, &value, sizeof(value));
    for (int i = sizeof(value) - 1; i >= 0; --i) bytes.push_back(b[i]);
  };
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, -2.5f}) append_big(v);
  bytes.push_back(3);
  for (std::int16_t i : {0, 1, 2}) append_big(i);
  const TriangleMesh mesh = ReadPly(Write("big.ply", bytes));
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[2], Eigen::Vector3d(0, 1, -2.5));
  EXPECT_EQ(mesh.triangles[0], Eigen::Vector3i(0, 1, 2));
}

TEST(Ply, MalformedFilesAreRefusedWithTheReason) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  EXPECT_THAT(PlyErrorOf(Write("a.ply", "solid cube\n")), HasSubstr("not a PLY file"));
  EXPECT_THAT(PlyErrorOf(Write("b.ply", header + "0 0 0\n1 0 0\n")), HasSubstr("truncated"));
  EXPECT_THAT(PlyErrorOf(Write("c.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n")), HasSubstr("outside 0..2"));
  EXPECT_THAT(PlyErrorOf(Write("d.ply", header + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n")), HasSubstr("'zero'"));
  EXPECT_THAT(PlyErrorOf(Write("e.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n")),
              HasSubstr("unsupported format"));
  EXPECT_THAT(PlyErrorOf(Write("f.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n")),
              HasSubstr("lacks x, y or z"));
  EXPECT_THAT(PlyErrorOf(Write("g.ply", "ply\nformat ascii 1.0\nelement vertex 0\n")), HasSubstr("no end_header"));
  EXPECT_THAT(PlyErrorOf("/no/such/file.ply"), HasSubstr("does not exist"));
}

// /dev/zero was read to 2 GB before its magic was checked, and a FIFO hung for ever; a header's
// counts are bounded by the file.
TEST(Ply, DevicesPipesAndHeadersThatLieAreRefusedBeforeReading) {
  EXPECT_EQ(PlyErrorOf("/dev/zero"), "PLY file '/dev/zero' is not a regular file (a device or a pipe?)");
  const std::string fifo = testing::MakeTempDir("ply_fifo") + "/mesh.ply";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THAT(PlyErrorOf(fifo), HasSubstr("is not a regular file"));
  EXPECT_THAT(PlyErrorOf(Write("h.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n"
                                        "property float y\nproperty float z\nend_header\n0 0 0\n")),
              HasSubstr("element 'vertex' counts 1000000000000, more than the file's"));
  EXPECT_THAT(PlyErrorOf(Write("i.ply", "ply\n" + std::string(10000, 'x') + "\n")),
              HasSubstr("a header line is over 4096 bytes"));
}

}  // namespace
}  // namespace tac3d
