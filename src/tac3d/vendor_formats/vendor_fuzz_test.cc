// Seeded fuzzing of the vendor's files, as of the run file and the CSV readers: a calibration
// folder with one file mutated imports or throws tac3d::Error, and a recording with one .npy
// file mutated reads, and gives every frame, or throws tac3d::Error; never a crash, a hang or
// an allocation without bound (the address space is capped at 2 GiB).
#include <sys/resource.h>

#include <chrono>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "tac3d/sensor/test_yaml_mutator.h"
#include "tac3d/testing/csv_fuzz.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"
#include "tac3d/vendor_formats/vendor_calibration.h"
#include "tac3d/vendor_formats/vendor_frames.h"
#include "tac3d/vendor_formats/vendor_recording.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

std::string FileText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

TEST(VendorFolderFuzz, AMutatedYamlFileImportsOrThrowsError) {
  const std::string folder = testing::WriteFixtureVendorFolder("vendor_fuzz_yaml");
  for (const char* file : {kVendorParametersFile, kVendorDatasheetFile, kVendorSensorFile}) {
    const fs::path path = fs::path(folder) / file;
    const std::string seed = FileText(path);
    const testing::FuzzCounts counts = testing::FuzzYamlReader(
        seed,
        [&](const std::string& text) {
          WriteText(path, text);
          ImportVendorSensor(folder);
        },
        file);
    WriteText(path, seed);
    EXPECT_GT(counts.refused, 0) << file;
    EXPECT_GT(counts.loaded, 0) << file;
  }
}

// markers.txt as the CSV readers are fuzzed, /dev/zero, a folder and a FIFO included (reached
// through a link named markers.txt).
TEST(VendorFolderFuzz, AMutatedMarkersFileImportsOrThrowsError) {
  const std::string folder = testing::WriteFixtureVendorFolder("vendor_fuzz_markers");
  const fs::path markers = fs::path(folder) / kVendorMarkersFile;
  const std::string seed = FileText(markers);
  const int iterations = testing::FuzzCsvReader(seed, [&](const std::string& path) {
    fs::remove(markers);
    fs::create_symlink(path, markers);
    ImportVendorSensor(folder);
  });
  EXPECT_GT(iterations, 100);
}

// A recording of 30 frames of 20 x 20 markers, one of its .npy files mutated a few bytes at a
// time (the header's text included), truncated or extended.
TEST(VendorRecordingFuzz, AMutatedNpyFileReadsOrThrowsError) {
  rlimit limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_AS, &limit), 0);
  const rlimit saved = limit;
  limit.rlim_cur = std::min<rlim_t>(limit.rlim_max, rlim_t{2} << 30);
  ASSERT_EQ(::setrlimit(RLIMIT_AS, &limit), 0);

  std::vector<TactileFrame> frames;
  for (int k = 0; k < 30; ++k) {
    TactileFrame frame = TactileFrame::Sized(20, 20);
    frame.sn = "FUZZ-0001";
    frame.index = k;
    frame.timestamp_s = k / 30.0;
    for (int i = 0; i < 400; ++i) {
      frame.positions_mm[i] = Eigen::Vector3d(1.27 * (i % 20 - 9.5), 1.27 * (i / 20 - 9.5), 7.5 + 0.001 * k);
      frame.displacements_mm[i] = Eigen::Vector3d(0, 0, 0.001 * k);
    }
    frames.push_back(frame);
  }
  const std::string dir = testing::MakeTempDir("vendor_npy_fuzz");
  WriteVendorRecording(VendorRecordingOfFrames(frames), dir);
  const fs::path serial = fs::path(dir) / "FUZZ-0001";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(serial)) {
    if (entry.path().extension() == ".npy") files.push_back(entry.path());
  }
  ASSERT_EQ(files.size(), 7u);

  std::mt19937 rng(testing::kRandomSeed);
  const auto uniform = [&](std::size_t lo, std::size_t hi) {
    return std::uniform_int_distribution<std::size_t>(lo, hi)(rng);
  };
  int iterations = 0, read = 0, refused = 0;
  const auto start = std::chrono::steady_clock::now();
  for (; iterations < 2000 && std::chrono::steady_clock::now() - start < std::chrono::seconds(8); ++iterations) {
    const fs::path& file = files[uniform(0, files.size() - 1)];
    const std::string seed = FileText(file);
    std::string bytes = seed;
    for (int e = static_cast<int>(uniform(1, 4)); e > 0; --e) {
      // Half the edits in the header (its first 128 bytes), where the shape and type live.
      const std::size_t at = uniform(0, uniform(0, 1) ? std::min<std::size_t>(127, bytes.size() - 1) : bytes.size() - 1);
      switch (uniform(0, 4)) {
        case 0: bytes[at] = static_cast<char>(uniform(0, 255)); break;
        case 1: bytes[at] = "0123456789(),'<>fi9"[uniform(0, 18)]; break;
        case 2: bytes.resize(at + 1); break;
        case 3: bytes.insert(at, std::string(uniform(1, 64), '9')); break;
        default: {
          // A finite value made NaN or infinite (the data's 8-byte doubles).
          const std::size_t word = at & ~std::size_t{7};
          if (word + 8 <= bytes.size()) {
            const double special = uniform(0, 1) ? std::numeric_limits<double>::quiet_NaN()
                                                 : std::numeric_limits<double>::infinity();
            std::memcpy(&bytes[word], &special, 8);
          }
        }
      }
      if (bytes.empty()) break;
    }
    WriteText(file, bytes);
    try {
      const VendorFrames vendor(ReadVendorRecording(dir));
      for (std::int64_t f = 0; f < vendor.frames(); ++f) vendor.Frame(f).Validate();
      ++read;
    } catch (const Error&) {
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a tac3d::Error: " << e.what() << " (" << file.filename() << ")";
    }
    WriteText(file, seed);
  }
  ::setrlimit(RLIMIT_AS, &saved);
  std::printf("vendor .npy fuzz: %d iterations, %d read, %d refused\n", iterations, read, refused);
  EXPECT_GT(iterations, 100);
  EXPECT_GT(refused, 0);
  EXPECT_GT(read, 0);
}

}  // namespace
}  // namespace tac3d
