#include "tac3d/util/file_io.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ReadFileCapped, ReadsASmallFile) {
  const std::string dir = testing::MakeTempDir("read");
  std::ofstream(dir + "/a.yaml") << "key: 1\n";
  EXPECT_EQ(ReadFileCapped(dir + "/a.yaml", 100, "sensor config"), "key: 1\n");
}

TEST(ReadFileCapped, RefusesAFolderADeviceAMissingFileAndAnOversizedOne) {
  const std::string dir = testing::MakeTempDir("refuse");
  EXPECT_EQ(MessageOf([&] { ReadFileCapped(dir, 100, "sensor config"); }),
            fmt::format("sensor config '{}' is a directory, not a file", dir));
  EXPECT_EQ(MessageOf([&] { ReadFileCapped(dir + "/missing.yaml", 100, "scene file"); }),
            fmt::format("scene file '{}/missing.yaml' does not exist", dir));
  // /dev/zero never ends: refused as a device, not read until memory runs out.
  EXPECT_EQ(MessageOf([] { ReadFileCapped("/dev/zero", 100, "sensor config"); }),
            "sensor config '/dev/zero' is not a regular file (a device or a pipe?)");
  std::ofstream(dir + "/big.yaml") << std::string(101, 'x');
  EXPECT_EQ(MessageOf([&] { ReadFileCapped(dir + "/big.yaml", 100, "sensor config"); }),
            fmt::format(
                "sensor config '{}/big.yaml' is 101 bytes, more than the limit of 100 bytes", dir));
}

TEST(CheckOutputFile, RefusesAMissingFolderAWrongExtensionAndAFolder) {
  const std::string dir = testing::MakeTempDir("check");
  EXPECT_NO_THROW(CheckOutputFile(dir + "/d.PNG", "--png", {".png"}));
  EXPECT_EQ(MessageOf([&] { CheckOutputFile(dir + "/x.notanext", "--png", {".png"}); }),
            fmt::format("--png '{}/x.notanext' must end in .png", dir));
  EXPECT_EQ(MessageOf([&] { CheckOutputFile(dir + "/missing/d.svg", "--svg", {".svg"}); }),
            fmt::format("--svg '{0}/missing/d.svg': the folder '{0}/missing' does not exist", dir));
  EXPECT_EQ(MessageOf([&] { CheckOutputFile(dir, "--out"); }),
            fmt::format("--out '{}' is a directory", dir));
}

// Issue 22, defect 10: Python's simulate() and cache_dir made missing parents the CLI refuses
// elsewhere; both now go through these.
TEST(CheckOutputFolder, RefusesAMissingParentAndAFile) {
  const std::string dir = testing::MakeTempDir("folder");
  EXPECT_NO_THROW(CheckOutputFolder(dir + "/new", "dataset folder"));
  EXPECT_NO_THROW(CheckOutputFolder(dir + "/", "dataset folder"));
  EXPECT_EQ(MessageOf([&] { CheckOutputFolder(dir + "/missing/dir/sim", "dataset folder"); }),
            fmt::format("dataset folder '{0}/missing/dir/sim': the folder '{0}/missing/dir' does "
                        "not exist",
                        dir));
  std::ofstream(dir + "/file") << "x";
  EXPECT_EQ(MessageOf([&] { CheckOutputFolder(dir + "/file", "dataset folder"); }),
            fmt::format("dataset folder '{}/file' is a file, not a folder", dir));
}

TEST(MakeCacheDirectory, MakesOneLevelAndRefusesAMissingParent) {
  const std::string dir = testing::MakeTempDir("cache_dir");
  MakeCacheDirectory(dir + "/cache");
  EXPECT_TRUE(fs::is_directory(dir + "/cache"));
  MakeCacheDirectory(dir + "/cache");  // already there
  EXPECT_EQ(MessageOf([&] { MakeCacheDirectory(dir + "/missing/cache"); }),
            fmt::format("cache folder '{0}/missing/cache': the folder '{0}/missing' does not exist",
                        dir));
  EXPECT_FALSE(fs::exists(dir + "/missing"));
}

TEST(WriteFileAtomically, WritesWholeFilesAndLeavesNothingWhenTheWriterFails) {
  const std::string dir = testing::MakeTempDir("atomic");
  const std::string path = dir + "/out.txt";
  WriteTextFileAtomically(path, "first");
  EXPECT_THROW(WriteFileAtomically(path,
                                   [](const std::string& temporary) {
                                     std::ofstream(temporary) << "half";
                                     throw Error("the writer failed");
                                   }),
               Error);
  std::ifstream in(path);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "first");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1)
      << "a temporary was left";
  EXPECT_THROW(WriteTextFileAtomically(dir + "/missing/out.txt", "x"), Error);
}

// A FILE* on a pipe is block-buffered: without the flush the reader would see nothing yet.
TEST(WriteLineFlushed, TheReaderOfAPipeGetsTheLineAtOnce) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  std::FILE* out = ::fdopen(fds[1], "w");
  ASSERT_NE(out, nullptr);
  WriteLineFlushed(out, R"({"index":0})");
  pollfd readable{fds[0], POLLIN, 0};
  ASSERT_EQ(::poll(&readable, 1, 0), 1) << "the line is still in the writer's buffer";
  char buffer[64] = {};
  const ssize_t n = ::read(fds[0], buffer, sizeof(buffer));
  EXPECT_EQ(std::string(buffer, n > 0 ? n : 0), "{\"index\":0}\n");
  std::fclose(out);
  ::close(fds[0]);
}

}  // namespace
}  // namespace tac3d
