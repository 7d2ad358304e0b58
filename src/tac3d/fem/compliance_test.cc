#include "tac3d/fem/compliance.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <thread>

#include "tac3d/fem/test_domes.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

// The shared small dome with 3 x 3 markers.
BodyModelOptions SmallDome3x3() { return testing::SmallDome(3, 3); }

void ExpectSameModel(const ComplianceModel& a, const ComplianceModel& b) {
  EXPECT_TRUE(a.h == b.h);  // bit for bit
  EXPECT_EQ(ToJson(a.options), ToJson(b.options));
  EXPECT_EQ(ToJson(a.provenance), ToJson(b.provenance));
  ASSERT_EQ(a.marker_positions.size(), b.marker_positions.size());
  for (size_t k = 0; k < a.marker_positions.size(); ++k) {
    EXPECT_EQ(a.marker_positions[k], b.marker_positions[k]);
  }
}

// Overwrites one byte at offset (counted from the end when negative).
void FlipByte(const std::string& path, long offset) {
  std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
  file.seekg(offset, offset < 0 ? std::ios::end : std::ios::beg);
  const std::streampos at = file.tellg();
  char byte = 0;
  file.read(&byte, 1);
  file.seekp(at);
  byte = static_cast<char>(byte ^ 0x5a);
  file.write(&byte, 1);
}

TEST(ComplianceCache, BuildsOnceThenLoads) {
  const std::string dir = testing::MakeTempDir("cache");
  const ComplianceCacheResult built = LoadOrBuildComplianceModel(SmallDome3x3(), dir, false);
  EXPECT_EQ(built.status, ComplianceCacheStatus::kBuiltMissing);
  EXPECT_TRUE(std::filesystem::exists(built.path));
  EXPECT_EQ(built.model.h.rows(), 27);
  const ComplianceCacheResult loaded = LoadOrBuildComplianceModel(SmallDome3x3(), dir, false);
  EXPECT_EQ(loaded.status, ComplianceCacheStatus::kLoaded);
  EXPECT_EQ(loaded.path, built.path);
  ExpectSameModel(loaded.model, built.model);
  EXPECT_EQ(loaded.model.provenance.code_version, FemCodeVersion());
  EXPECT_GT(loaded.model.provenance.num_free_dofs, 0);
}

// Sensors of one gel in one process: one H, loaded (or built) once, even when two threads ask
// for it at once; another gel gets its own; freed after its last holder.
TEST(ComplianceCache, OneGelSharesOneModelInTheProcess) {
  const std::string dir = testing::MakeTempDir("shared");
  const BodyModelOptions gel = testing::SmallDome(2, 3);
  std::shared_ptr<const ComplianceModel> first;
  std::thread other([&] { first = LoadSharedComplianceModel(gel, dir, false); });
  std::shared_ptr<const ComplianceModel> second = LoadSharedComplianceModel(gel, dir, false);
  other.join();
  EXPECT_EQ(first, second);
  ExpectSameModel(*second, LoadOrBuildComplianceModel(gel, dir, false).model);
  BodyModelOptions stiffer = gel;
  stiffer.material.youngs_modulus_mpa *= 2.0;
  const std::shared_ptr<const ComplianceModel> other_gel = LoadSharedComplianceModel(stiffer, dir, false);
  EXPECT_NE(other_gel, first);
  EXPECT_FALSE(other_gel->h == first->h);
  // H taken from the model (SharedH, as a pipeline takes it) keeps the model.
  std::shared_ptr<const Eigen::MatrixXd> h = SharedH(first);
  EXPECT_EQ(h.get(), &first->h);
  const std::weak_ptr<const ComplianceModel> model = first;
  first.reset();
  second.reset();
  EXPECT_FALSE(model.expired());
  h.reset();
  EXPECT_TRUE(model.expired());
}

// The process-wide copy (GetSharedModel, tested in util) of the cached model: one for the gel,
// reported with its cache file.
TEST(ComplianceCache, SharedLoadSaysWhereItsModelCameFrom) {
  const std::string dir = testing::MakeTempDir("shared_source");
  const BodyModelOptions gel = testing::SmallDome(2, 2);
  SharedModelSource built;
  std::shared_ptr<const ComplianceModel> first = LoadSharedComplianceModel(gel, dir, false, &built);
  EXPECT_EQ(first, LoadSharedComplianceModel(gel, dir, false, nullptr));
  const ComplianceCacheResult file = LoadOrBuildComplianceModel(gel, dir, false);
  EXPECT_EQ(file.status, ComplianceCacheStatus::kLoaded);
  EXPECT_EQ(built.path, file.path);
  EXPECT_EQ(built.status, ComplianceCacheStatus::kBuiltMissing);
}

TEST(ComplianceCache, StaleKeyIsRebuiltNotUsed) {
  const std::string dir = testing::MakeTempDir("cache");
  BodyModelOptions stiffer = SmallDome3x3();
  stiffer.material.youngs_modulus_mpa = 2.0;
  const ComplianceCacheResult other = LoadOrBuildComplianceModel(stiffer, dir, false);
  // Put the stiffer body's file where the nominal body's belongs.
  const std::string path =
      (std::filesystem::path(dir) /
       fmt::format("compliance_{:016x}.bin", CalcComplianceCacheKey(SmallDome3x3())))
          .string();
  std::filesystem::copy_file(other.path, path);
  const ComplianceCacheResult result = LoadOrBuildComplianceModel(SmallDome3x3(), dir, false);
  EXPECT_EQ(result.status, ComplianceCacheStatus::kRebuiltStale) << result.reason;
  // H scales as 1 / E: the rebuilt H is twice the stiffer one, so it is not the stale file's.
  EXPECT_LT((result.model.h - 2.0 * other.model.h).norm(), 1e-9 * result.model.h.norm());
  EXPECT_EQ(LoadOrBuildComplianceModel(SmallDome3x3(), dir, false).status,
            ComplianceCacheStatus::kLoaded);
}

TEST(ComplianceCache, CorruptOrTruncatedFileIsRebuiltNotUsed) {
  const std::string dir = testing::MakeTempDir("cache");
  const ComplianceCacheResult built = LoadOrBuildComplianceModel(SmallDome3x3(), dir, false);
  // The file's size changes with each rebuild (its provenance holds timings).
  long size = 0;
  const std::vector<std::function<void()>> damages = {
      [&] { FlipByte(built.path, -100); },  // inside H
      [&] { FlipByte(built.path, 40); },    // inside the JSON header
      [&] { FlipByte(built.path, 0); },     // the magic
      [&] { FlipByte(built.path, 8); },     // the format version
      [&] { FlipByte(built.path, -1); },    // the checksum
      [&] { std::filesystem::resize_file(built.path, size - 8); },
      [&] { std::filesystem::resize_file(built.path, 20); },
      [&] { std::filesystem::resize_file(built.path, size + 3); },
      [&] { std::filesystem::resize_file(built.path, 0); },
  };
  for (size_t d = 0; d < damages.size(); ++d) {
    size = static_cast<long>(std::filesystem::file_size(built.path));
    damages[d]();
    EXPECT_THROW(LoadComplianceModel(built.path), Error) << "damage " << d;
    const ComplianceCacheResult result = LoadOrBuildComplianceModel(SmallDome3x3(), dir, false);
    EXPECT_EQ(result.status, ComplianceCacheStatus::kRebuiltCorrupt) << "damage " << d;
    EXPECT_FALSE(result.reason.empty());
    EXPECT_TRUE(result.model.h == built.model.h) << "damage " << d;
    EXPECT_NO_THROW(LoadComplianceModel(built.path)) << "damage " << d;  // replaced
  }
}

TEST(ComplianceCache, SaveLoadRoundTripAndMissingFile) {
  const std::string dir = testing::MakeTempDir("files");
  const ComplianceModel model = CalcComplianceModel(SmallDome3x3());
  const std::string path = dir + "/h.bin";
  SaveComplianceModel(model, path);
  ExpectSameModel(LoadComplianceModel(path), model);
  EXPECT_THROW(LoadComplianceModel(dir + "/missing.bin"), Error);
  EXPECT_THROW(SaveComplianceModel(model, dir + "/no/such/dir/h.bin"), Error);
}

TEST(ComplianceCache, KeyDependsOnEveryOption) {
  const BodyModelOptions base;
  const std::uint64_t key = CalcComplianceCacheKey(base);
  EXPECT_EQ(CalcComplianceCacheKey(BodyModelOptions{}), key);
  const std::vector<std::function<void(BodyModelOptions&)>> changes = {
      [](auto& o) { o.base_diameter_mm = 41; },
      [](auto& o) { o.thickness_mm = 8.5; },
      [](auto& o) { o.sphere_radius_mm = 46; },
      [](auto& o) { o.lateral_boundary = LateralBoundary::kFixed; },
      [](auto& o) { o.material.youngs_modulus_mpa = 1.1; },
      [](auto& o) { o.material.poisson_ratio = 0.47; },
      [](auto& o) { o.marker_rows = 19; },
      [](auto& o) { o.marker_cols = 19; },
      [](auto& o) { o.marker_pitch_mm = 1.2; },
      [](auto& o) { o.marker_depth_mm = 0.6; },
      [](auto& o) { o.refinement = 1.5; },
  };
  // Together with BodyModelOptions.JsonRoundTrip this covers every field the JSON holds.
  EXPECT_EQ(changes.size(), ToJson(base).size());
  for (size_t c = 0; c < changes.size(); ++c) {
    BodyModelOptions changed = base;
    changes[c](changed);
    EXPECT_NE(CalcComplianceCacheKey(changed), key) << "change " << c;
  }
}

}  // namespace
}  // namespace tac3d::fem
