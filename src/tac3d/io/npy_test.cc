#include "tac3d/io/npy.h"

#include <gtest/gtest.h>

#include <filesystem>
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

}  // namespace
}  // namespace tac3d
