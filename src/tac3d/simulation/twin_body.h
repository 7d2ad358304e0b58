#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "tac3d/contact/compliance.h"
#include "tac3d/fem/body_model.h"
#include "tac3d/fem/compliance.h"
#include "tac3d/scene/scene.h"
#include "tac3d/util/cache_file.h"

namespace tac3d::simulation {

/// The twin's contact grid and how its surface compliance and marker response are sampled
/// from the FEM body.
struct TwinBodyOptions {
  /// Contact cells a marker pitch (a side): each marker's pitch x pitch patch holds exactly
  /// cells_per_pitch^2 cells (3: cells of 0.423 mm for the prototype).
  int cells_per_pitch = 3;
  /// The grid covers the marker square plus at least this much on each side (mm), rounded up
  /// to whole cells. Nodes outside `active_radius_fraction` of the base radius never touch.
  double margin_mm = 2.0;
  double active_radius_fraction = 0.9;
  /// A cell's uniform traction is applied (and its displacement read) as the mean of q x q
  /// point forces at the centres of its q x q sub-cells.
  int quadrature_points_per_side = 3;
  /// Surface points are this far under the exact sphere (mm), inside the mesh's faceted
  /// surface (a face's sagitta is < 0.01 mm here).
  double surface_depth_mm = 0.01;
  /// The kernel is sampled where the offset point lies within this fraction of the base
  /// radius (and inside the mesh), and is zero beyond (it has decayed there: the provenance's
  /// kernel_truncation_ratio, docs/simulation.md).
  double kernel_radius_fraction = 0.9;
  /// Symbol eigenvalues below this fraction of the largest are raised to it
  /// (ConvolutionCompliance's clamp_floor).
  double clamp_floor = 1e-9;
  /// The body must be factored directly (its free DOFs at most this): the simulation's
  /// ~1,200 solves by two-grid PCG would take hours.
  int max_direct_free_dofs = fem::BodySolverOptions{}.max_direct_free_dofs;

  /// @throws tac3d::Error naming the field: cells_per_pitch in [1, 10], margin_mm >= 0,
  ///   active_radius_fraction, kernel_radius_fraction in (0, 1], quadrature in [1, 8],
  ///   surface_depth_mm in [0, 0.1], clamp_floor in [0, 1e-3], max_direct_free_dofs >= 1.
  void Validate() const;
};

nlohmann::json ToJson(const TwinBodyOptions& options);
nlohmann::json ToJson(const contact::SurfaceGrid& grid);

/// The twin's elastic body: the scene's sensor's (SensorBodyModelOptions: an imported sensor's
/// gel with its markers where its reference pixels triangulate, else the designed sensor's) with
/// the deviation applied (refinement x mesh_refinement, E x youngs_modulus_factor, nu x
/// poisson_ratio_factor).
fem::BodyModelOptions TwinBodyModelOptions(const SensorConfig& sensor,
                                           const TwinDeviation& deviation);

/// The contact grid in the sensor's (x, y) plane, its node positions relative to the dome's axis
/// (body.base_center_mm): cells of pitch / cells_per_pitch, centred on the axis, covering the marker square plus the margin (whole cells), so the marker patches'
/// edges fall on cell edges. @throws tac3d::Error if either options are invalid.
contact::SurfaceGrid MakeTwinContactGrid(const fem::BodyModelOptions& body,
                                         const TwinBodyOptions& options);

/// What the FEM sampling produced and cost.
struct TwinBodyProvenance {
  int num_free_dofs = 0;
  int num_nodes = 0;
  int num_elements = 0;
  double mesh_s = 0.0;           ///< meshing, point location setup
  double factorization_s = 0.0;  ///< assembly and the Cholesky factor
  double kernel_s = 0.0;         ///< the 3 kernel solves and the lattice readout
  double response_s = 0.0;       ///< the 3N marker solves
  double build_s = 0.0;          ///< wall time of the whole build
  /// Kernel points sampled (offset points inside kernel_radius_fraction of the base).
  int kernel_points = 0;
  /// Largest |kernel| on the truncation boundary relative to the largest (decay check).
  double kernel_truncation_ratio = 0.0;
  /// Largest |K_ab(d) - K_ba(-d)| before symmetrisation, relative to the largest entry.
  double kernel_asymmetry = 0.0;
  std::string built_utc;
  std::string code_version;
};

nlohmann::json ToJson(const TwinBodyProvenance& provenance);

/// A read-only matrix whose storage is shared: its own (a model just built) or the pages of a
/// mapped cache file (a model loaded: MapCacheRecord), which every process mapping the file
/// shares, so the Dask workers of one machine hold one copy of a body model between them.
class SharedMatrix {
 public:
  SharedMatrix() = default;
  explicit SharedMatrix(Eigen::MatrixXd owned);
  SharedMatrix(const MappedMatrix& mapped, std::shared_ptr<const void> mapping);

  Eigen::Map<const Eigen::MatrixXd> view() const { return {data_, rows_, cols_}; }
  Eigen::Index rows() const { return rows_; }
  Eigen::Index cols() const { return cols_; }
  /// True if the storage is a mapped file's.
  bool mapped() const { return mapped_; }

 private:
  std::shared_ptr<const void> storage_;
  const double* data_ = nullptr;
  Eigen::Index rows_ = 0;
  Eigen::Index cols_ = 0;
  bool mapped_ = false;
};

/// The twin body's precomputed model: its contact grid, surface compliance kernel and marker
/// response matrix.
/// Model assumption: the dome is shallow (R = 45 mm, markers within 18 mm of the axis), so the
/// contact normal is taken as the sensor's +z everywhere (pressure pushes along -z) and the
/// tangential directions as x, y; node i's surface point is (x_i, y_i, z_s(x_i, y_i)) on the
/// outer sphere.
struct TwinBodyModel {
  fem::BodyModelOptions body;
  TwinBodyOptions options;
  contact::SurfaceGrid grid;
  /// Translation-invariant surface compliance (mm/MPa, ComplianceOperator's components and
  /// signs), sampled at the grid's centre node (nx / 2, ny / 2) from unit cell tractions and
  /// symmetrised, K_ab(d) := (K_ab(d) + K_ba(-d)) / 2. Exact at the centre node; the dome
  /// thins from 8 mm on the axis to ~6.2 mm at the sensing area's corner, where it is softer
  /// in reality than this kernel says.
  contact::SampledKernel kernel;
  /// Marker response (3N x 3n, mm/N): row c * N + k is marker k's displacement along c, column
  /// c * n + i a unit force along c (sensor frame x, y, z) spread uniformly over cell i
  /// (component-major, as fem::ComplianceModel's H). Zero columns for inactive nodes. The
  /// model's bulk (141 MB for the prototype's 20 x 20 markers): mapped from the cache file when
  /// loaded.
  SharedMatrix marker_response;
  /// Marker rest positions (mm, sensor frame), in the body's marker order (fem::CalcMarkerPositions).
  std::vector<Eigen::Vector3d> marker_positions;
  TwinBodyProvenance provenance;

  /// Node surface points (mm, sensor frame) on the exact sphere.
  std::vector<Eigen::Vector3d> CalcNodeSurfacePoints() const;
  /// True where a node can touch (within active_radius_fraction of the base radius).
  std::vector<bool> CalcActiveNodes() const;
  /// The marker whose pitch x pitch patch holds node i, or -1 (margin); for markers given by
  /// position (body.marker_positions_mm), the nearest in (x, y) if its patch holds the node.
  std::vector<int> CalcNodeMarkers() const;
};

/// Meshes and factors the body, samples the kernel and the marker response.
/// @throws tac3d::Error if the options are invalid, or if the body has more free DOFs than
///   options.max_direct_free_dofs (with the figures and the reason).
TwinBodyModel CalcTwinBodyModel(const fem::BodyModelOptions& body,
                                const TwinBodyOptions& options,
                                bool show_progress = false);

/// The cache key: FNV-1a of the body options, the twin options and the code versions.
std::uint64_t CalcTwinBodyCacheKey(const fem::BodyModelOptions& body,
                                   const TwinBodyOptions& options);

/// Writes the model (tac3d::WriteCacheRecord, magic "TAC3DTWN"): atomic, checksummed.
void SaveTwinBodyModel(const TwinBodyModel& model, const std::string& path);
/// Maps the file (MapCacheRecord): the marker response stays in its pages.
/// @throws tac3d::Error if the file is unreadable, corrupt, or its key is not that of its
///   inputs and this code.
TwinBodyModel LoadTwinBodyModel(const std::string& path);

struct TwinBodyCacheResult {
  TwinBodyModel model;
  /// Loaded, built (missing), rebuilt (stale key or corrupt file): fem's statuses.
  fem::ComplianceCacheStatus status = fem::ComplianceCacheStatus::kBuiltMissing;
  std::string path;    ///< cache_dir/twin_body_<key>.bin
  std::string reason;  ///< why a file was not used
  double elapsed_s = 0.0;
};

/// Loads the model from cache_dir or builds and saves it (LoadOrBuildComplianceModel's
/// policy: a stale or corrupt file is never used, it is rebuilt and replaced).
/// @throws tac3d::Error as CalcTwinBodyModel, or if cache_dir cannot be created or written.
TwinBodyCacheResult LoadOrBuildTwinBodyModel(const fem::BodyModelOptions& body,
                                             const TwinBodyOptions& options,
                                             const std::string& cache_dir,
                                             bool show_progress = true);

/// The model for the options, one copy for the whole process (fem::LoadSharedComplianceModel's
/// policy): the one another holder already has (same CalcTwinBodyCacheKey), else
/// LoadOrBuildTwinBodyModel's, kept for the next callers while anyone holds it (freed after the
/// last). Thread-safe: callers asking for one model at once wait for one load or build.
/// @param source if given, set to the model's cache file in cache_dir and how this call got it.
/// @throws tac3d::Error as LoadOrBuildTwinBodyModel.
std::shared_ptr<const TwinBodyModel> LoadSharedTwinBodyModel(const fem::BodyModelOptions& body,
                                                             const TwinBodyOptions& options,
                                                             const std::string& cache_dir,
                                                             bool show_progress = true,
                                                             SharedModelSource* source = nullptr);

}  // namespace tac3d::simulation
