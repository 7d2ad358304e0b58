#include "tac3d/io/marker_csv.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

std::string WriteText(const std::string& text) {
  const std::string path = testing::MakeTempDir("csv") + "/markers.csv";
  std::ofstream(path) << text;
  return path;
}

TEST(MarkerCsv, RoundTripIsExact) {
  const std::vector<Eigen::Vector3d> p = {{0.1, -2.0 / 3.0, 7.5}, {1e-9, 3, -0.0}};
  const std::string path = testing::MakeTempDir("csv") + "/m.csv";
  WriteMarkerPositionsCsv(p, path);
  const auto back = ReadMarkerPositionsCsv(path);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_TRUE(back[0] == p[0]);
  EXPECT_TRUE(back[1] == p[1]);
}

// Issue 14, defect 5: a 100000-row file died in bad_alloc further on.
TEST(MarkerCsv, MoreRowsThanAnySensorHasAreRefused) {
  const std::string path = testing::MakeTempDir("rows") + "/many.csv";
  {
    std::ofstream out(path);
    out << "x_mm,y_mm,z_mm\n";
    for (std::size_t i = 0; i <= kMaxMarkerCsvRows; ++i) out << "0,0,1\n";
  }
  EXPECT_THAT([&] { ReadMarkerPositionsCsv(path); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("more than 10000 marker positions")));
}

TEST(MarkerCsv, MalformedLinesAreRefusedWithTheirLineNumber) {
  auto error_of = [](const std::string& text) {
    try {
      ReadMarkerPositionsCsv(WriteText(text));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(error_of("x_mm,y_mm,z_mm\n1,2,3\n1,2\n"), HasSubstr(":3:"));
  EXPECT_THAT(error_of("x_mm,y_mm,z_mm\n1,2,x\n"), HasSubstr(":2: field 3"));
  EXPECT_THAT(error_of("x_mm,y_mm,z_mm\n1,2,3,4\n"), HasSubstr(":2:"));
  EXPECT_THAT(error_of("x_mm,y_mm,z_mm\n1,nan,3\n"), HasSubstr("finite"));
  EXPECT_THAT(error_of("1,2,3\n"), HasSubstr("header"));
  EXPECT_THAT(error_of(""), HasSubstr("empty"));
  EXPECT_THROW(ReadMarkerPositionsCsv("/nonexistent.csv"), Error);
}

// Issue 22, defect 8: /dev/zero grew to 2.2 GB before "empty", and a folder was "empty". Each
// is refused before a byte is read, as a file larger than any marker list can be.
TEST(MarkerCsv, DevicesFoldersAndHugeFilesAreRefusedBeforeReading) {
  auto refusal = [](const std::string& path, const std::string& what) {
    EXPECT_THAT([&] { ReadMarkerPositionsCsv(path); },
                ::testing::ThrowsMessage<Error>(HasSubstr(what)));
  };
  refusal("/dev/zero", "marker positions '/dev/zero' is not a regular file");
  refusal(testing::MakeTempDir("folder"), "is a directory, not a file");
  const std::string sparse = WriteText("");
  std::filesystem::resize_file(sparse, std::uintmax_t{1} << 30);  // 1 GiB of holes
  refusal(sparse, "is 1073741824 bytes, more than the limit of 4194304 bytes");
}

}  // namespace
}  // namespace tac3d
