#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/fem/body_model.h"
#include "tac3d/util/cache_file.h"

namespace tac3d::fem {

/// Where a compliance matrix came from and what it cost.
struct ComplianceProvenance {
  int num_nodes = 0;
  int num_elements = 0;
  /// Unknowns of the FEM system (the DOFs not fixed).
  int num_free_dofs = 0;
  double assembly_s = 0.0;
  double factorization_s = 0.0;
  double solves_s = 0.0;
  /// Wall time of the whole build (s).
  double build_s = 0.0;
  /// When it was built, UTC, ISO 8601.
  std::string built_utc;
  /// The library version and the FEM model revision that built it.
  std::string code_version;
};

nlohmann::json ToJson(const ComplianceProvenance& provenance);

/// The compliance matrix H of the paper's eq. (1), D = H F, with its inputs.
/// D = (dx^1..dx^N, dy^1..dy^N, dz^1..dz^N) are the markers' displacements (mm) and
/// F = (fx^1..fx^N, fy^1..fy^N, fz^1..fz^N) the forces (N) on the markers' surface patches:
/// column c * N + k of H is the marker displacements for 1 N in direction c spread uniformly
/// over marker k's patch (BodyModel::CalcMarkerPatchLoads).
struct ComplianceModel {
  BodyModelOptions options;
  /// 3N x 3N (mm/N).
  Eigen::MatrixXd h;
  /// Marker rest positions (mm, sensor frame), index i * cols + j.
  std::vector<Eigen::Vector3d> marker_positions;
  ComplianceProvenance provenance;
};

/// The version of the library and of the FEM model ("tac3d 0.1.0, fem model r1"); the model
/// revision changes whenever a code change changes H, which invalidates cached models.
std::string FemCodeVersion();

/// Builds H on the model's (factored) mesh: H = R K^-1 F for the readout at the markers R and
/// the patch loads F, without a solve a load case (ElasticSolver::CalcResponse).
/// @param show_progress tac3d::ProgressBar lines on stderr.
ComplianceModel CalcComplianceModel(const BodyModel& model, bool show_progress = false);

/// Meshes, assembles, factors and builds H for the options.
/// @throws tac3d::Error if the options are invalid.
ComplianceModel CalcComplianceModel(const BodyModelOptions& options, bool show_progress = false);

/// The cache key: a 64-bit FNV-1a hash of every option H depends on and FemCodeVersion().
std::uint64_t CalcComplianceCacheKey(const BodyModelOptions& options);

/// Writes the model to a file (written to a temporary name, then renamed, so a crash never
/// leaves a half-written file under the final name). Format (little-endian):
/// "TAC3DFEM", u32 format version, u64 key, u64 JSON length, JSON {options, provenance},
/// u64 rows, u64 cols, rows * cols f64 (column-major H), u64 FNV-1a checksum of every byte
/// after the magic.
/// @throws tac3d::Error if the file cannot be written.
void SaveComplianceModel(const ComplianceModel& model, const std::string& path);

/// Reads a file written by SaveComplianceModel.
/// @throws tac3d::Error if the file is missing, has a wrong magic or format version, is
///   truncated or too long, its checksum does not match, its JSON is invalid, or its key is
///   not that of its options and this code (FemCodeVersion) (another version built it).
ComplianceModel LoadComplianceModel(const std::string& path);

/// What LoadOrBuildComplianceModel did (the cache policy is util/cache_file.h's).
using ComplianceCacheStatus = CacheStatus;

struct ComplianceCacheResult {
  ComplianceModel model;
  ComplianceCacheStatus status = ComplianceCacheStatus::kBuiltMissing;
  /// The cache file (cache_dir/compliance_<key as 16 hex digits>.bin).
  std::string path;
  /// Why the file was not used (empty when loaded).
  std::string reason;
  /// Wall time of the load or the build (s).
  double elapsed_s = 0.0;
};

/// Loads H for the options from cache_dir, or builds it and saves it there. A file with a
/// stale key or a corrupt or truncated file is never used: it is rebuilt and replaced.
/// @param show_progress tac3d::ProgressBar lines on stderr while building.
/// @throws tac3d::Error if the options are invalid or cache_dir cannot be created or written.
ComplianceCacheResult LoadOrBuildComplianceModel(const BodyModelOptions& options,
                                                 const std::string& cache_dir,
                                                 bool show_progress = true);

/// H for the options, one copy for the whole process: the model another holder already has
/// (another sensor of the same gel: same CalcComplianceCacheKey), else LoadOrBuildComplianceModel's,
/// kept for the next callers while anyone holds it (freed after the last). Thread-safe: callers
/// asking for one model at once wait for one load or build (SharedCache).
/// @param source if given, set to the model's cache file in cache_dir and how this call got it.
/// @throws tac3d::Error as LoadOrBuildComplianceModel.
std::shared_ptr<const ComplianceModel> LoadSharedComplianceModel(const BodyModelOptions& options,
                                                                 const std::string& cache_dir,
                                                                 bool show_progress = true,
                                                                 SharedModelSource* source = nullptr);

/// The model's H, owning the model with it (std::shared_ptr's aliasing constructor): what a
/// Pipeline or ForceReconstructor takes to share H, and their inverse, with the model's other
/// users.
inline std::shared_ptr<const Eigen::MatrixXd> SharedH(const std::shared_ptr<const ComplianceModel>& model) {
  return {model, &model->h};
}

}  // namespace tac3d::fem
