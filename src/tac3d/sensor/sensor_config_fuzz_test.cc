// Seeded fuzzing of the sensor YAML reader (issues 14 and 22): mutated configs, some with
// nested aliases, must load or throw tac3d::Error, never crash, hang or allocate without bound.
// The address space is capped so an allocation driven by a value in the file shows up as
// std::bad_alloc, which fails the test.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Values that have broken readers: huge, tiny, negative, non-finite, non-numeric, YAML syntax.
const std::vector<std::string> kNastyValues = {
    "1e300",  "-1e300",     "2e9", "2000000000", "-1",     "0", ".nan", ".inf", "-.inf",
    "1e-320", "10000",      "'x'", "[1, 2]",     "{a: 1}", "~", "&a 1", "*a",   "!!binary aGVsbG8=",
    "[[[[[[", "\"\\u0000\""};

class YamlMutator {
 public:
  explicit YamlMutator(std::string seed_text)
      : seed_(std::move(seed_text)), rng_(testing::kRandomSeed) {}

  std::string Next() {
    std::string text = seed_;
    const int edits = Uniform(1, 4);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const size_t at = Uniform(0, static_cast<int>(text.size()) - 1);
      switch (Uniform(0, 6)) {
        case 0: {  // replace the value after a colon on this line
          const size_t colon = text.find(": ", at);
          const size_t end = colon == std::string::npos ? colon : text.find('\n', colon);
          if (end != std::string::npos)
            text.replace(colon + 2, end - colon - 2, Pick(kNastyValues));
          break;
        }
        case 1:  // flip a byte
          text[at] = static_cast<char>(Uniform(0, 255));
          break;
        case 2:  // delete a run
          text.erase(at, Uniform(1, 40));
          break;
        case 3: {  // duplicate a line
          const size_t begin = text.rfind('\n', at);
          const size_t end = text.find('\n', at);
          if (begin != std::string::npos && end != std::string::npos) {
            text.insert(end, text.substr(begin, end - begin));
          }
          break;
        }
        case 4:  // a second document
          text += "---\n" + text.substr(0, at);
          break;
        case 5:  // nested aliases (issue 22, defect 7): up to 10^8 values expanded
          text = NestedAliases(Uniform(1, 8), Uniform(1, 10)) + text;
          break;
        default:  // insert YAML punctuation
          text.insert(at,
                      Pick({"- ", ": ", "[", "]", "{", "}", "\n  ", "#", "&x ", "*x", "---\n"}));
      }
    }
    return text;
  }

 private:
  int Uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  // `levels` keys, each a list of `width` aliases of the one before: width^levels values.
  static std::string NestedAliases(int levels, int width) {
    std::string text = "l0: &l0 [x]\n";
    for (int level = 1; level < levels; ++level) {
      text += fmt::format("l{0}: &l{0} [", level);
      for (int k = 0; k < width; ++k) text += fmt::format("{}*l{}", k ? ", " : "", level - 1);
      text += "]\n";
    }
    return text;
  }
  std::string Pick(const std::vector<std::string>& v) {
    return v[Uniform(0, static_cast<int>(v.size()) - 1)];
  }

  std::string seed_;
  std::mt19937 rng_;
};

// A config with mirrors and virtual cameras, so every reader path is reached.
std::string SeedConfigYaml() {
  SensorConfig c;
  for (int i = 0; i < 4; ++i)
    c.mirrors.push_back({"mirror_" + std::to_string(i + 1), Rectangle3{}});
  for (ImageHalf half : kImageHalves) {
    VirtualCameraConfig v;
    v.half = half;
    v.intrinsics = c.camera.intrinsics;
    v.column_begin = half == ImageHalf::kLeft ? 0 : 320;
    v.column_end = v.column_begin + 320;
    c.virtual_cameras.push_back(v);
  }
  return SensorConfigToYaml(c);
}

TEST(SensorConfigFuzz, MutatedFilesLoadOrThrowErrorWithinBoundedMemoryAndTime) {
  rlimit limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_AS, &limit), 0);
  const rlimit saved = limit;
  limit.rlim_cur = std::min<rlim_t>(limit.rlim_max, rlim_t{2} << 30);  // 2 GiB
  ASSERT_EQ(::setrlimit(RLIMIT_AS, &limit), 0);

  const std::string seed = SeedConfigYaml();
  ASSERT_NO_THROW(ParseSensorConfig(seed, "seed.yaml"));
  YamlMutator mutator(seed);
  const auto start = std::chrono::steady_clock::now();
  int loaded = 0, refused = 0, iterations = 0;
  for (; iterations < 20000 && std::chrono::steady_clock::now() - start < std::chrono::seconds(10);
       ++iterations) {
    const std::string text = mutator.Next();
    try {
      ParseSensorConfig(text, "fuzz.yaml");
      ++loaded;
    } catch (const Error&) {
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a tac3d::Error: " << e.what() << "\non:\n" << text;
    }
  }
  ::setrlimit(RLIMIT_AS, &saved);
  std::printf("%d mutated configs: %d loaded, %d refused\n", iterations, loaded, refused);
  EXPECT_GT(iterations, 1000) << "too few iterations in the time bound: a slow path?";
  EXPECT_GT(refused, iterations / 2);
}

}  // namespace
}  // namespace tac3d
