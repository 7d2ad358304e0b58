#include "tac3d/io/npy.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "tac3d/testing/npy_reader.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using testing::LoadNpy;

using ::testing::HasSubstr;

// What numpy 1.24's np.save writes for the same arrays (it pads to 128 bytes, leaving room to
// grow the first axis): the bytes must agree exactly at that size.
std::string NumpyHeader(const std::string& dict) {
  std::string h = std::string("\x93NUMPY\x01\x00\x76\x00", 10) + dict;
  h.append(127 - h.size(), ' ');
  return h + "\n";
}

TEST(NpyHeader, MatchesNumpysBytes) {
  EXPECT_EQ(NpyHeader(NpyType::kFloat64, {7, 400, 3}, 128),
            NumpyHeader("{'descr': '<f8', 'fortran_order': False, 'shape': (7, 400, 3), }"));
  EXPECT_EQ(NpyHeader(NpyType::kUint32, {5}, 128),
            NumpyHeader("{'descr': '<u4', 'fortran_order': False, 'shape': (5,), }"));
  EXPECT_EQ(NpyHeader(NpyType::kBool, {2, 3}, 128),
            NumpyHeader("{'descr': '|b1', 'fortran_order': False, 'shape': (2, 3), }"));
  EXPECT_THAT(NpyHeader(NpyType::kInt64, {2}),
              HasSubstr("{'descr': '<i8', 'fortran_order': False, 'shape': (2,), }"));
}

TEST(NpyHeader, IsTheShortestMultipleOfSixtyFourUnlessTold) {
  // 10 bytes of preamble + the 64-byte dict + '\n' = 75 -> 128.
  const std::string h = NpyHeader(NpyType::kFloat64, {7, 400, 3});
  ASSERT_EQ(h.size(), 128u);
  EXPECT_EQ(static_cast<std::uint8_t>(h[8]) | (static_cast<std::uint8_t>(h[9]) << 8), 118);
  EXPECT_EQ(h.back(), '\n');
  // 10 + a 149-byte dict + 1 = 160 -> 192.
  const std::int64_t g = 1000000000;
  EXPECT_EQ(NpyHeader(NpyType::kFloat64, {g, g, g, g, g, g, g, g}).size(), 192u);
  EXPECT_EQ(NpyHeader(NpyType::kFloat64, {1}, 256).size(), 256u);
  EXPECT_THROW(NpyHeader(NpyType::kFloat64, {1}, 100), Error);  // not a multiple of 64
  EXPECT_THROW(NpyHeader(NpyType::kFloat64, {1}, 64), Error);   // too small
  EXPECT_THROW(NpyHeader(NpyType::kFloat64, {-1}), Error);
}

TEST(NpyWriter, RoundTripsEveryType) {
  const std::string dir = testing::MakeTempDir("npy");
  // 4 x 2 x 3 doubles, distinct, with the values a float format loses first.
  std::vector<double> f(24);
  for (std::size_t i = 0; i < f.size(); ++i)
    f[i] = 0.1 * static_cast<double>(i) - 1e-300 + 1.0 / 3.0;
  f[5] = std::numeric_limits<double>::quiet_NaN();
  f[6] = -0.0;
  WriteNpy(dir + "/f.npy", NpyType::kFloat64, {4, 2, 3}, f.data());
  const std::vector<std::int64_t> i64 = {-1, 0, std::numeric_limits<std::int64_t>::max()};
  WriteNpy(dir + "/i.npy", NpyType::kInt64, {3}, i64.data());
  const std::vector<std::uint32_t> u32 = {0, 1, 0xffffffffu, 32, 5, 6};
  WriteNpy(dir + "/u.npy", NpyType::kUint32, {2, 3}, u32.data());
  const std::vector<std::uint8_t> b = {1, 0, 0, 1, 1};
  WriteNpy(dir + "/b.npy", NpyType::kBool, {5}, b.data());

  const auto fa = LoadNpy(dir + "/f.npy");
  EXPECT_EQ(fa.descr, "<f8");
  EXPECT_FALSE(fa.fortran_order);
  EXPECT_EQ(fa.shape, (std::vector<std::int64_t>{4, 2, 3}));
  EXPECT_EQ(fa.header_bytes % 64, 0u);
  ASSERT_EQ(fa.data.size(), 24 * 8u);
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (i == 5) {
      EXPECT_TRUE(std::isnan(fa.at<double>(i)));
    } else {
      EXPECT_EQ(fa.at<double>(i), f[i]) << i;  // bit-exact
    }
  }
  EXPECT_TRUE(std::signbit(fa.at<double>(6)));

  const auto ia = LoadNpy(dir + "/i.npy");
  EXPECT_EQ(ia.descr, "<i8");
  EXPECT_EQ(ia.shape, (std::vector<std::int64_t>{3}));
  ASSERT_EQ(ia.data.size(), 24u);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(ia.at<std::int64_t>(i), i64[i]);

  const auto ua = LoadNpy(dir + "/u.npy");
  EXPECT_EQ(ua.descr, "<u4");
  EXPECT_EQ(ua.shape, (std::vector<std::int64_t>{2, 3}));
  ASSERT_EQ(ua.data.size(), 24u);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(ua.at<std::uint32_t>(i), u32[i]);

  const auto ba = LoadNpy(dir + "/b.npy");
  EXPECT_EQ(ba.descr, "|b1");
  EXPECT_EQ(ba.shape, (std::vector<std::int64_t>{5}));
  EXPECT_EQ(ba.data, std::string("\x01\x00\x00\x01\x01", 5));
}

TEST(NpyWriter, StreamedRowsGiveTheFinalShapeInTheSameHeaderSpace) {
  const std::string path = testing::MakeTempDir("npy") + "/rows.npy";
  NpyWriter writer(path, NpyType::kFloat64, {2, 3});
  std::vector<double> row(6);
  for (int t = 0; t < 1000; ++t) {
    for (int k = 0; k < 6; ++k) row[k] = t * 10 + k;
    writer.Append(row.data());
  }
  EXPECT_EQ(writer.rows(), 1000);
  writer.Close();
  EXPECT_THROW(writer.Append(row.data()), Error);  // closed
  const auto a = LoadNpy(path);
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{1000, 2, 3}));
  EXPECT_EQ(a.header_bytes % 64, 0u);
  ASSERT_EQ(a.data.size(), 1000 * 6 * 8u);
  EXPECT_EQ(a.at<double>(999 * 6 + 5), 9995.0);
  EXPECT_EQ(std::filesystem::file_size(path), a.header_bytes + a.data.size());
}

TEST(NpyWriter, EmptyArrayAndUnwritablePath) {
  const std::string dir = testing::MakeTempDir("npy");
  {
    NpyWriter writer(dir + "/empty.npy", NpyType::kBool, {400});
    writer.Close();
  }
  const auto a = LoadNpy(dir + "/empty.npy");
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{0, 400}));
  EXPECT_TRUE(a.data.empty());
  EXPECT_THROW(NpyWriter(dir + "/no/such/folder/x.npy", NpyType::kFloat64, {}), Error);
  EXPECT_THROW(NpyWriter(dir + "/neg.npy", NpyType::kFloat64, {-3}), Error);
  EXPECT_THROW(WriteNpy(dir + "/scalar.npy", NpyType::kFloat64, {}, nullptr), Error);
}

// Raw bytes of a file.
std::string NpyTestFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void WriteNpyTestFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// An .npy file of the given version around a dict, as NumPy lays it out (header padded to 64).
std::string NpyFileBytes(int major, const std::string& dict, const std::string& data) {
  const std::size_t length_bytes = major == 1 ? 2 : 4;
  std::string header = dict;
  while ((8 + length_bytes + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string bytes = std::string("\x93NUMPY", 6) + static_cast<char>(major) + '\0';
  for (std::size_t i = 0; i < length_bytes; ++i) bytes += static_cast<char>((header.size() >> (8 * i)) & 0xff);
  return bytes + header + data;
}

std::string DoubleBytes(const std::vector<double>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
}

std::string NpyRefusalOf(const std::string& path) {
  try {
    ReadNpy(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "accepted";
}

TEST(ReadNpy, RoundTripsBitForBit) {
  const std::string dir = testing::MakeTempDir("npy");
  NpyArray a;
  a.shape = {2, 3};
  a.data = DoubleBytes({-0.0, std::numeric_limits<double>::denorm_min(), 1e300, -1.5,
                        std::numeric_limits<double>::quiet_NaN(), 3.0});
  WriteNpy(dir + "/a.npy", a);
  const NpyArray back = ReadNpy(dir + "/a.npy");
  EXPECT_EQ(back, a);  // the data bytes, NaN's included
  WriteNpy(dir + "/b.npy", back);
  EXPECT_EQ(NpyTestFileBytes(dir + "/a.npy"), NpyTestFileBytes(dir + "/b.npy"));
  // The test program's own independent parser agrees.
  const auto parsed = LoadNpy(dir + "/a.npy");
  EXPECT_EQ(parsed.shape, a.shape);
  EXPECT_EQ(parsed.data, a.data);

  NpyArray ints;
  ints.type = NpyType::kInt64;
  ints.shape = {3};
  const std::vector<std::int64_t> values = {39715, -1, std::numeric_limits<std::int64_t>::max()};
  ints.data.assign(reinterpret_cast<const char*>(values.data()), 3 * sizeof(std::int64_t));
  WriteNpy(dir + "/i.npy", ints);
  EXPECT_EQ(ReadNpy(dir + "/i.npy").Int64Values(), values);
  NpyArray wrong = ints;
  wrong.shape = {4};
  EXPECT_THROW(WriteNpy(dir + "/w.npy", wrong), Error);
}

TEST(ReadNpy, ReadsVersionsTwoAndThreeAndFortranOrder) {
  const std::string dir = testing::MakeTempDir("npy");
  // A 2 x 3 array [[0, 1, 2], [3, 4, 5]] stored column by column.
  const std::string data = DoubleBytes({0, 3, 1, 4, 2, 5});
  for (const int version : {1, 2, 3}) {
    const std::string path = dir + "/v" + std::to_string(version) + ".npy";
    WriteNpyTestFile(path, NpyFileBytes(version, "{'shape': (2, 3), 'fortran_order': True, 'descr': '<f8'}", data));
    const NpyArray a = ReadNpy(path);
    EXPECT_TRUE(a.fortran_order);
    EXPECT_EQ(a.shape, (std::vector<std::int64_t>{2, 3}));
    EXPECT_EQ(a.Float64Values(), (std::vector<double>{0, 1, 2, 3, 4, 5})) << "version " << version;
  }
  // A Fortran-ordered array keeps its order and bytes through a write.
  const NpyArray a = ReadNpy(dir + "/v2.npy");
  WriteNpy(dir + "/again.npy", a);
  EXPECT_EQ(ReadNpy(dir + "/again.npy"), a);
}

TEST(ReadNpy, RefusesMalformedFilesNamingThem) {
  const std::string dir = testing::MakeTempDir("npy");
  const std::string path = dir + "/x.npy";
  const std::string good = NpyFileBytes(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }",
                                        DoubleBytes({0, 1, 2, 3, 4, 5}));
  WriteNpyTestFile(path, good);
  ASSERT_EQ(NpyRefusalOf(path), "accepted");
  const auto refusal = [&](const std::string& bytes) {
    WriteNpyTestFile(path, bytes);
    return NpyRefusalOf(path);
  };
  const auto with_dict = [&](const std::string& dict, std::size_t data_bytes = 48) {
    return refusal(NpyFileBytes(1, dict, std::string(data_bytes, '\0')));
  };
  EXPECT_THAT(refusal(good.substr(0, good.size() - 1)), HasSubstr("x.npy': 47 data bytes where shape (2, 3) of '<f8' needs 48 (truncated)"));
  EXPECT_THAT(refusal(good.substr(0, 60)), HasSubstr("x.npy': truncated: the .npy header says 118 bytes"));
  EXPECT_THAT(refusal(good.substr(0, 9)), HasSubstr("is not an .npy file"));
  EXPECT_THAT(refusal(good + "x"), HasSubstr("49 data bytes"));
  EXPECT_THAT(refusal("PK\x03\x04 a zip"), HasSubstr("x.npy' is not an .npy file"));
  std::string v4 = good;
  v4[6] = 4;
  EXPECT_THAT(refusal(v4), HasSubstr("format version 4.0"));
  EXPECT_THAT(with_dict("{'descr': '>f8', 'fortran_order': False, 'shape': (2, 3), }"),
              HasSubstr("x.npy': dtype '>f8' is not one tac3d reads"));
  EXPECT_THAT(with_dict("{'descr': '|O', 'fortran_order': False, 'shape': (2, 3), }"), HasSubstr("dtype '|O'"));
  EXPECT_THAT(with_dict("{'descr': '<f8', 'fortran_order': False, 'shape': (2, -3), }"),
              HasSubstr("a dimension must be an integer >= 0"));
  EXPECT_THAT(with_dict("{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999, 99999999999, 99999999999), }"),
              HasSubstr("needs more than"));
  EXPECT_THAT(with_dict("{'descr': '<f8', 'fortran_order': Maybe, 'shape': (2, 3), }"), HasSubstr("True or False"));
  EXPECT_THAT(with_dict("{'descr': '<f8', 'shape': (2, 3), }"), HasSubstr("lacks descr, fortran_order or shape"));
  EXPECT_THAT(with_dict("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), 'extra': 1}"),
              HasSubstr("unknown key 'extra'"));
  EXPECT_THAT(with_dict("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3"), HasSubstr("')' expected"));
  EXPECT_THAT(NpyRefusalOf(dir + "/missing.npy"), HasSubstr("missing.npy"));
  EXPECT_THAT(NpyRefusalOf(dir), HasSubstr(dir));
}

}  // namespace
}  // namespace tac3d
