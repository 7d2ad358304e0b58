// Seeded fuzzing of the image sources: mutated PNG, JPEG, BMP and TIFF files in an
// image folder must each be a good frame or a bad one, never an exception, a crash, a hang or
// an allocation without bound (the address space is capped, so a decoder allocating what a
// forged header claims fails as a thrown exception, which fails the test).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "tac3d/source/frame_source.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

std::vector<std::uint8_t> Mutate(std::vector<std::uint8_t> bytes, std::mt19937& rng) {
  const auto uniform = [&](int lo, int hi) {
    return std::uniform_int_distribution<int>(lo, hi)(rng);
  };
  const int edits = uniform(1, 6);
  for (int e = 0; e < edits && !bytes.empty(); ++e) {
    // Headers hold the sizes and offsets: most edits go to the first 64 bytes.
    const int span =
        uniform(0, 3) == 0 ? static_cast<int>(bytes.size()) : std::min<int>(64, bytes.size());
    const size_t at = uniform(0, span - 1);
    switch (uniform(0, 3)) {
      case 0:
        bytes[at] = static_cast<std::uint8_t>(uniform(0, 255));
        break;
      case 1:
        bytes[at] = 0xFF;
        break;
      case 2:
        bytes.resize(uniform(0, static_cast<int>(bytes.size())));  // truncate
        break;
      default:
        bytes.insert(bytes.begin() + at, static_cast<std::uint8_t>(uniform(0, 255)));
    }
  }
  return bytes;
}

TEST(FrameSourceFuzz, MutatedImageFilesAreGoodOrBadFramesWithinBoundedMemory) {
  rlimit limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_AS, &limit), 0);
  const rlimit saved = limit;
  limit.rlim_cur = std::min<rlim_t>(limit.rlim_max, rlim_t{3} << 30);  // 3 GiB
  ASSERT_EQ(::setrlimit(RLIMIT_AS, &limit), 0);

  cv::Mat image(48, 64, CV_8UC1);
  cv::randu(image, 0, 255);
  std::vector<std::vector<std::uint8_t>> seeds;
  const std::vector<std::string> extensions = {".png", ".jpg", ".bmp", ".tiff"};
  for (const std::string& ext : extensions) {
    std::vector<std::uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(ext, image, bytes));
    seeds.push_back(bytes);
  }
  std::mt19937 rng(testing::kRandomSeed);
  const std::string dir = testing::MakeTempDir("images");
  const auto start = std::chrono::steady_clock::now();
  int good = 0, bad = 0, files = 0;
  // Rounds of 50 files a folder, read through the folder source as `tac3d run` reads them.
  for (int round = 0;
       round < 40 && std::chrono::steady_clock::now() - start < std::chrono::seconds(20);
       ++round) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    for (int k = 0; k < 50; ++k, ++files) {
      const size_t kind = k % seeds.size();
      const std::vector<std::uint8_t> bytes = Mutate(seeds[kind], rng);
      std::ofstream(fmt::format("{}/{:04d}{}", dir, k, extensions[kind]), std::ios::binary)
          .write(reinterpret_cast<const char*>(bytes.data()),
                 static_cast<std::streamsize>(bytes.size()));
    }
    CameraSourceOptions camera;
    camera.width = 64;
    camera.height = 48;
    const auto source = OpenFrameSource(dir, camera);
    Frame frame;
    for (;;) {
      ReadStatus status = ReadStatus::kFailed;
      try {
        status = source->Read(frame);
      } catch (const std::exception& e) {
        ADD_FAILURE() << "Read threw: " << e.what();
        break;
      }
      if (status == ReadStatus::kEnd) break;
      ASSERT_NE(status, ReadStatus::kFailed) << source->last_error();
      if (status == ReadStatus::kOk) {
        ++good;
        EXPECT_LE(frame.image.cols, 64);
        EXPECT_LE(frame.image.rows, 48);
      } else {
        ++bad;
      }
    }
  }
  ::setrlimit(RLIMIT_AS, &saved);
  std::printf("%d mutated image files: %d good frames, %d bad frames\n", files, good, bad);
  EXPECT_EQ(good + bad, files);
  EXPECT_GT(bad, 0);
}

}  // namespace
}  // namespace tac3d
