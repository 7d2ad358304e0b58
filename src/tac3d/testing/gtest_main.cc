#include <filesystem>

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

}  // namespace tac3d::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::GTEST_FLAG(random_seed) = static_cast<int>(tac3d::testing::kRandomSeed % 99999);
  return RUN_ALL_TESTS();
}
