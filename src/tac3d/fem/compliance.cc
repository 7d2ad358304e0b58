#include "tac3d/fem/compliance.h"

#include <chrono>

#include "tac3d/util/cache_file.h"
#include "tac3d/util/error.h"
#include "tac3d/util/seconds_since.h"
#include "tac3d/util/shared_cache.h"
#include "tac3d/util/version.h"

namespace tac3d::fem {
namespace {

// Bump whenever a change to the mesh, the element or the loads changes H: it is part of the
// cache key, so models cached by older code are rebuilt.
constexpr int kFemModelRevision = 1;
constexpr char kMagic[] = "TAC3DFEM";
constexpr std::uint32_t kFormatVersion = 1;

ComplianceProvenance ProvenanceFromJson(const nlohmann::json& json) {
  ComplianceProvenance p;
  p.num_nodes = json.at("num_nodes").get<int>();
  p.num_elements = json.at("num_elements").get<int>();
  p.num_free_dofs = json.at("num_free_dofs").get<int>();
  p.assembly_s = json.at("assembly_s").get<double>();
  p.factorization_s = json.at("factorization_s").get<double>();
  p.solves_s = json.at("solves_s").get<double>();
  p.build_s = json.at("build_s").get<double>();
  p.built_utc = json.at("built_utc").get<std::string>();
  p.code_version = json.at("code_version").get<std::string>();
  return p;
}

}  // namespace

nlohmann::json ToJson(const ComplianceProvenance& p) {
  return {{"num_nodes", p.num_nodes},
          {"num_elements", p.num_elements},
          {"num_free_dofs", p.num_free_dofs},
          {"assembly_s", p.assembly_s},
          {"factorization_s", p.factorization_s},
          {"solves_s", p.solves_s},
          {"build_s", p.build_s},
          {"built_utc", p.built_utc},
          {"code_version", p.code_version}};
}

std::string FemCodeVersion() {
  return fmt::format("tac3d {}, fem model r{}", Version(), kFemModelRevision);
}

ComplianceModel CalcComplianceModel(const BodyModel& model, bool show_progress) {
  const auto start = std::chrono::steady_clock::now();
  const Eigen::SparseMatrix<double> readout =
      model.CalcPointInterpolation(model.marker_positions());
  const Eigen::SparseMatrix<double> loads = model.CalcMarkerPatchLoads();
  ComplianceModel result;
  result.options = model.options();
  result.marker_positions = model.marker_positions();
  result.h = model.solver().CalcResponse(readout, loads, show_progress);
  const ElasticSolverSummary& summary = model.solver().summary();
  ComplianceProvenance& p = result.provenance;
  p.num_nodes = model.mesh().num_nodes();
  p.num_elements = model.mesh().num_elements();
  p.num_free_dofs = summary.num_free_dofs;
  p.assembly_s = summary.assembly_s;
  p.factorization_s = summary.factorization_s;
  p.solves_s = SecondsSince(start);
  p.build_s = p.assembly_s + p.factorization_s + p.solves_s;
  p.built_utc = UtcNow();
  p.code_version = FemCodeVersion();
  return result;
}

ComplianceModel CalcComplianceModel(const BodyModelOptions& options, bool show_progress) {
  const auto start = std::chrono::steady_clock::now();
  const BodyModel model(options, show_progress);
  ComplianceModel result = CalcComplianceModel(model, show_progress);
  // Meshing and point location count too.
  result.provenance.build_s = SecondsSince(start);
  return result;
}

std::uint64_t CalcComplianceCacheKey(const BodyModelOptions& options) {
  // nlohmann::json orders keys, so the dump is canonical; doubles print round-trip exact.
  const std::string text = ToJson(options).dump() + "|" + FemCodeVersion();
  return Fnv1a(text.data(), text.size());
}

void SaveComplianceModel(const ComplianceModel& model, const std::string& path) {
  CacheRecord record;
  record.key = CalcComplianceCacheKey(model.options);
  record.header = {{"options", ToJson(model.options)}, {"provenance", ToJson(model.provenance)}};
  record.matrices.push_back(model.h);
  WriteCacheRecord(path, kMagic, kFormatVersion, record);
}

namespace {

struct CacheFile {
  std::uint64_t key = 0;  // as stored
  ComplianceModel model;
};

// Reads and checks a file's structure and checksum; the key is returned, not judged.
CacheFile ReadCacheFile(const std::string& path) {
  CacheRecord record = ReadCacheRecord(path, kMagic, kFormatVersion);
  CacheFile file;
  file.key = record.key;
  ComplianceModel& model = file.model;
  try {
    model.options = BodyModelOptionsFromJson(record.header.at("options"));
    model.provenance = ProvenanceFromJson(record.header.at("provenance"));
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: invalid JSON header: {}", path, e.what()));
  }
  const auto n = static_cast<Eigen::Index>(3 * model.options.num_markers());
  if (record.matrices.size() != 1 || record.matrices[0].rows() != n ||
      record.matrices[0].cols() != n) {
    throw Error(fmt::format("{}: expected one {} x {} matrix H", path, n, n));
  }
  model.h = std::move(record.matrices[0]);
  model.marker_positions = CalcMarkerPositions(model.options);
  return file;
}

}  // namespace

ComplianceModel LoadComplianceModel(const std::string& path) {
  CacheFile file = ReadCacheFile(path);
  if (file.key != CalcComplianceCacheKey(file.model.options)) {
    throw Error(
        fmt::format("{}: key {:016x} does not match its options and this code ({}); it "
                    "was built by other code",
                    path,
                    file.key,
                    FemCodeVersion()));
  }
  return std::move(file.model);
}

ComplianceCacheResult LoadOrBuildComplianceModel(const BodyModelOptions& options,
                                                 const std::string& cache_dir,
                                                 bool show_progress) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  const std::uint64_t key = CalcComplianceCacheKey(options);
  ComplianceCacheResult result;
  result.path = CacheFilePath(cache_dir, "compliance", key);
  result.status = LoadOrBuildCacheFile(
      result.path, key, ReadCacheFile, [&] { return CalcComplianceModel(options, show_progress); },
      SaveComplianceModel, &result.model, &result.reason);
  result.elapsed_s = SecondsSince(start);
  return result;
}

std::shared_ptr<const ComplianceModel> LoadSharedComplianceModel(const BodyModelOptions& options,
                                                                 const std::string& cache_dir,
                                                                 bool show_progress,
                                                                 SharedModelSource* source) {
  options.Validate();
  // The key covers every option H depends on and the code that builds it (as the cache file's
  // name does): one key, one H, whichever cache_dir it comes from.
  static SharedCache<std::uint64_t, ComplianceModel> models;
  const std::uint64_t key = CalcComplianceCacheKey(options);
  return GetSharedModel(
      models, key, CacheFilePath(cache_dir, "compliance", key),
      [&] { return LoadOrBuildComplianceModel(options, cache_dir, show_progress); }, source);
}

}  // namespace tac3d::fem
