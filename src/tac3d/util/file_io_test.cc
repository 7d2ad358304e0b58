#include "tac3d/util/file_io.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/stat.h>
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

std::string Contents(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The one output rule: a write never replaces a device or a pipe, never goes through a link,
// and never destroys what the command reads.
TEST(CheckOutputFile, RefusesADeviceAPipeALinkAndAnInput) {
  const std::string dir = testing::MakeTempDir("check_rule");
  EXPECT_EQ(MessageOf([] { CheckOutputFile("/dev/null", "--out"); }),
            "--out '/dev/null' is not a regular file (a device or a pipe?): tac3d writes only "
            "regular files");
  ASSERT_EQ(::mkfifo((dir + "/fifo").c_str(), 0600), 0);
  EXPECT_EQ(MessageOf([&] { CheckOutputFile(dir + "/fifo", "--record"); }),
            fmt::format("--record '{}/fifo' is not a regular file (a device or a pipe?): tac3d "
                        "writes only regular files",
                        dir));
  std::ofstream(dir + "/target.csv") << "keep";
  fs::create_symlink(dir + "/target.csv", dir + "/link.csv");
  EXPECT_EQ(MessageOf([&] { CheckOutputFile(dir + "/link.csv", "--out", {".csv"}); }),
            fmt::format("--out '{}/link.csv' is a symbolic link: name the file itself (tac3d "
                        "replaces only regular files)",
                        dir));
  // The input itself, by another name, and a file inside an input folder.
  EXPECT_EQ(MessageOf([&] {
              CheckOutputFile(dir + "/./target.csv", "--out", {}, {"", dir + "/target.csv"});
            }),
            fmt::format("--out '{0}/./target.csv' is the input '{0}/target.csv': write the "
                        "output elsewhere",
                        dir));
  fs::create_directory(dir + "/vendor");
  std::ofstream(dir + "/vendor/sensor.yaml") << "sn: A";
  EXPECT_EQ(MessageOf([&] {
              CheckOutputFile(dir + "/vendor/sensor.yaml", "--out", {".yaml"}, {dir + "/vendor"});
            }),
            fmt::format("--out '{0}/vendor/sensor.yaml' would replace a file inside the input "
                        "folder '{0}/vendor': write the output elsewhere",
                        dir));
  // A new file beside the inputs replaces nothing; a missing input is none.
  EXPECT_NO_THROW(CheckOutputFile(dir + "/vendor/new.yaml", "--out", {}, {dir + "/vendor"}));
  EXPECT_NO_THROW(CheckOutputFile(dir + "/out.yaml", "--out", {}, {dir + "/missing", dir + "/vendor"}));
  EXPECT_EQ(Contents(dir + "/target.csv"), "keep");
}

TEST(WriteFileAtomically, NeverWritesThroughALinkPlantedAtItsTemporaryOrItsName) {
  const std::string dir = testing::MakeTempDir("atomic_links");
  const std::string victim = dir + "/victim.txt";
  std::ofstream(victim) << "keep";
  const std::string path = dir + "/out.txt";
  // The temporaries' names are path.tmpPID-N: plant links at the next few.
  const std::string first = CreateTemporaryFile(path);
  fs::remove(first);
  const std::string stem = first.substr(0, first.rfind('-') + 1);
  const int next = std::stoi(first.substr(first.rfind('-') + 1)) + 1;
  for (int k = next; k < next + 3; ++k) fs::create_symlink(victim, stem + std::to_string(k));
  WriteTextFileAtomically(path, "written");
  EXPECT_EQ(Contents(path), "written");
  EXPECT_EQ(Contents(victim), "keep");
  // A link or a device at the final name is refused, not replaced.
  fs::create_symlink(victim, dir + "/link.txt");
  EXPECT_EQ(MessageOf([&] { WriteTextFileAtomically(dir + "/link.txt", "x"); }),
            fmt::format("'{}/link.txt' exists and is not a regular file (a device, a pipe, a "
                        "folder or a symbolic link): tac3d does not replace it",
                        dir));
  EXPECT_TRUE(fs::is_symlink(dir + "/link.txt"));
  EXPECT_EQ(Contents(victim), "keep");
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
