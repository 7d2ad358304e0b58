#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tac3d/testing/testing.h"

namespace tac3d::testing {

std::string MakeTempDir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir = std::filesystem::temp_directory_path() / "tac3d_tests";
  if (info != nullptr) dir /= std::string(info->test_suite_name()) + "." + info->name();
  dir /= name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

namespace {

constexpr char kTestSourcesFlag[] = "--test_sources=";

// The GoogleTest filter selecting the tests defined in the files of `list` (comma-separated paths
// relative to the project's root, as tac3d_add_test registers them); empty if none is.
std::string FilterOfSources(const std::string& list) {
  std::vector<std::string> sources;
  std::stringstream stream(list);
  for (std::string source; std::getline(stream, source, ',');) sources.push_back(source);
  std::string filter;
  const ::testing::UnitTest& unit = *::testing::UnitTest::GetInstance();
  for (int i = 0; i < unit.total_test_suite_count(); ++i) {
    const ::testing::TestSuite& suite = *unit.GetTestSuite(i);
    for (int j = 0; j < suite.total_test_count(); ++j) {
      const ::testing::TestInfo& test = *suite.GetTestInfo(j);
      // test.file() is the path the compiler was given: absolute, ending in the source's.
      const std::string file = test.file();
      if (std::none_of(sources.begin(), sources.end(), [&](const std::string& source) {
            return file.ends_with("/" + source);
          })) {
        continue;
      }
      if (!filter.empty()) filter += ':';
      filter += std::string(suite.name()) + "." + test.name();
    }
  }
  return filter;
}

}  // namespace
}  // namespace tac3d::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::GTEST_FLAG(random_seed) = static_cast<int>(tac3d::testing::kRandomSeed % 99999);
  // Every test file is in this one program; CTest runs one file's tests at a time.
  for (int i = 1; i < argc; ++i) {
    const char* flag = tac3d::testing::kTestSourcesFlag;
    if (std::strncmp(argv[i], flag, std::strlen(flag)) != 0) continue;
    const std::string sources = argv[i] + std::strlen(flag);
    const std::string filter = tac3d::testing::FilterOfSources(sources);
    if (filter.empty()) {
      std::fprintf(stderr, "no test is defined in %s\n", sources.c_str());
      return 1;
    }
    ::testing::GTEST_FLAG(filter) = filter;
  }
  return RUN_ALL_TESTS();
}
