#include "tac3d/eval/force_evaluation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <random>

#include <fmt/format.h>

#include "tac3d/fem/compliance.h"
#include "tac3d/fem/compliance_family.h"
#include "tac3d/force/force_gains.h"
#include "tac3d/force/force_reconstructor.h"
#include "tac3d/util/cache_file.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"
#include "tac3d/util/progress.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {
namespace {

// Loads stay this far inside the sensing area (mm): presses are centred within +-kPressRange
// and at most kMaxPressRadius wide, so their contact stays on the marker grid.
constexpr double kPressRange = 6.0;
constexpr double kMinPressRadius = 1.5, kMaxPressRadius = 3.0;
// Tangential press force at most this times the normal one (a friction coefficient).
constexpr double kMaxTangentialRatio = 0.6;
// Each outer-surface element is integrated on kSubdivisions^2 sub-rectangles, each with the
// traction of its centre (0.03 mm at refinement 2: the edge of a 1 mm pin is well resolved).
constexpr int kSubdivisions = 8;
// The probe (paper Fig. 7A, B: 2 mm end diameter) and the pins (Fig. 7C, D: 2.54 mm apart).
constexpr double kProbeRadius = 1.0, kProbeForce = 3.0;
constexpr double kPinRadius = 0.5, kPinSpacing = 2.54, kPinForce = 1.0;
// Acceptance bounds of `tac3d eval force`.
constexpr double kMaxResultantErrorPctFs = 2.0;
constexpr double kMaxPinsDipRatio = 0.7;

// A traction over a disc of the outer surface, in the sensor's (x, y): Hertz-like
// sqrt(1 - r^2 / a^2) or uniform, along one direction, with the given resultant.
struct DiscTraction {
  Eigen::Vector2d center_mm = Eigen::Vector2d::Zero();
  double radius_mm = 1.0;
  bool hertz = true;
  Eigen::Vector3d force_n = Eigen::Vector3d::Zero();
};

using LoadCase = std::vector<DiscTraction>;

nlohmann::json Json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Nodal forces of a load case on the model's outer surface (central block only).
Eigen::VectorXd AssembleLoad(const fem::BodyModel& model, const LoadCase& load) {
  const fem::DomeMesh& dome = model.dome();
  const double a = dome.central_half_width_mm;
  const int nc = dome.central_elements;
  const double h = 2.0 * a / nc;
  Eigen::VectorXd forces = Eigen::VectorXd::Zero(model.mesh().num_dofs());
  for (const DiscTraction& disc : load) {
    TAC3D_DEMAND(disc.center_mm.cwiseAbs().maxCoeff() + disc.radius_mm < a);
    std::vector<std::pair<int, double>> node_weights;
    double total = 0.0;
    const auto cell_range = [&](double c) {
      return std::pair{std::max(0, static_cast<int>(std::floor((c - disc.radius_mm + a) / h))),
                       std::min(nc, static_cast<int>(std::ceil((c + disc.radius_mm + a) / h)))};
    };
    const auto [i_begin, i_end] = cell_range(disc.center_mm.x());
    const auto [j_begin, j_end] = cell_range(disc.center_mm.y());
    for (int j = j_begin; j < j_end; ++j) {
      for (int i = i_begin; i < i_end; ++i) {
        const int element = dome.CentralTopElement(i, j);
        const fem::Hex8Nodes nodes = model.mesh().ElementNodes(element);
        for (int su = 0; su < kSubdivisions; ++su) {
          for (int sv = 0; sv < kSubdivisions; ++sv) {
            const double xi0 = -1.0 + 2.0 * su / kSubdivisions, xi1 = xi0 + 2.0 / kSubdivisions;
            const double eta0 = -1.0 + 2.0 * sv / kSubdivisions, eta1 = eta0 + 2.0 / kSubdivisions;
            const Eigen::Vector3d center = nodes.transpose() *
                fem::CalcHex8Shape(Eigen::Vector3d(0.5 * (xi0 + xi1), 0.5 * (eta0 + eta1), 1.0));
            const double r2 = (center.head<2>() - disc.center_mm).squaredNorm() /
                              (disc.radius_mm * disc.radius_mm);
            if (r2 >= 1.0) continue;
            const double pressure = disc.hertz ? std::sqrt(1.0 - r2) : 1.0;
            const fem::TopFaceIntegrals integrals =
                fem::IntegrateHex8TopFace(nodes, xi0, xi1, eta0, eta1);
            for (int k = 0; k < 4; ++k) {
              node_weights.emplace_back(model.mesh().elements[element][4 + k],
                                        pressure * integrals.shape_integrals(k));
            }
            total += pressure * integrals.area_mm2;
          }
        }
      }
    }
    TAC3D_DEMAND(total > 0.0);
    // Normalised so the nodal forces sum to the resultant exactly.
    for (const auto& [node, weight] : node_weights) {
      forces.segment<3>(3 * node) += weight / total * disc.force_n;
    }
  }
  return forces;
}

// Sphere presses spanning the full scale, from `rng`.
std::vector<LoadCase> MakePresses(int count, const EvalForceOptions& options, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<LoadCase> presses;
  for (int k = 0; k < count; ++k) {
    DiscTraction press;
    press.center_mm = kPressRange * Eigen::Vector2d(2 * uniform(*rng) - 1, 2 * uniform(*rng) - 1);
    press.radius_mm = kMinPressRadius + (kMaxPressRadius - kMinPressRadius) * uniform(*rng);
    const double fz = options.full_scale_normal_n * (0.1 + 0.9 * uniform(*rng));
    const double tangential = std::min(options.full_scale_tangential_n, kMaxTangentialRatio * fz);
    press.force_n = Eigen::Vector3d(tangential * (2 * uniform(*rng) - 1),
                                    tangential * (2 * uniform(*rng) - 1), -fz);
    presses.push_back({press});
  }
  return presses;
}

// The largest and RMS resultant error over the test presses, per axis, in % of full scale.
struct PressResultantErrors {
  Eigen::Vector3d max_pct_fs = Eigen::Vector3d::Zero();
  Eigen::Vector3d rms_pct_fs = Eigen::Vector3d::Zero();
  nlohmann::json presses = nlohmann::json::array();
};

PressResultantErrors MeasureResultantErrors(ForceReconstructor& reconstructor,
                                       const std::vector<Eigen::VectorXd>& test_frames,
                                       const std::vector<LoadCase>& test,
                                       const Eigen::Vector3d& full_scale_n) {
  PressResultantErrors errors;
  Eigen::Vector3d sum_squares = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < test.size(); ++k) {
    const Eigen::Vector3d measured = reconstructor.Reconstruct(test_frames[k]).resultant_force_n;
    const Eigen::Vector3d error_pct =
        100.0 * (measured - test[k][0].force_n).cwiseAbs().cwiseQuotient(full_scale_n);
    errors.max_pct_fs = errors.max_pct_fs.cwiseMax(error_pct);
    sum_squares += error_pct.cwiseAbs2();
    errors.presses.push_back({{"reference_n", Json(test[k][0].force_n)},
                              {"measured_n", Json(measured)},
                              {"error_pct_fs", Json(error_pct)}});
  }
  errors.rms_pct_fs = (sum_squares / static_cast<double>(test.size())).cwiseSqrt();
  return errors;
}

// The test presses' frames and loads, and the axes' full scale (N).
struct TestSet {
  const std::vector<Eigen::VectorXd>& frames;
  const std::vector<LoadCase>& loads;
  Eigen::Vector3d full_scale_n;
};

// Material calibration (CalibrateMaterial) on the calibration presses: measures the gains-only
// `reconstructor` on the test set, then replaces it by the calibrated inverse (H of the fitted
// material, its w and gains).
ForceMaterialFigures CalibrateMaterialOnPresses(const EvalForceOptions& options,
                                          const std::vector<LoadCase>& calibration,
                                          const std::vector<Eigen::VectorXd>& frames,
                                          const DisplacementNoise& noise,
                                          const ForceGainFit& gains_only_fit,
                                          const TestSet& test,
                                          const fem::ComplianceFamily& family,
                                          ForceReconstructor* reconstructor,
                                          nlohmann::json* timing) {
  const auto start = std::chrono::steady_clock::now();
  const PressResultantErrors gains_only =
      MeasureResultantErrors(*reconstructor, test.frames, test.loads, test.full_scale_n);
  std::vector<CalibrationPress> presses;
  for (size_t k = 0; k < calibration.size(); ++k) {
    CalibrationPress& press = presses.emplace_back();
    press.displacement_mm = frames[k];
    press.reference_n = calibration[k][0].force_n;
    if (options.material_contact_centers) press.contact_center_mm = calibration[k][0].center_mm;
  }
  MaterialCalibrationOptions material_options = options.material;
  material_options.weight = options.weight;
  material_options.support_refinement = options.support_refinement;
  material_options.gain_fit.on_poor_fit = PoorGainFit::kFlag;  // as the gains-only fit
  const MaterialCalibration fit = CalibrateMaterial(family, presses, noise, material_options);
  *reconstructor = ForceReconstructor(family.CalcH(fit.material),
                                      family.marker_positions(),
                                      {.weight = fit.weight,
                                       .gains = fit.gains.gains,
                                       .support_refinement = options.support_refinement});
  (*timing)["material_calibration"] = SecondsSince(start);
  return {fit, options.TrueMaterial(), gains_only.max_pct_fs, gains_only.rms_pct_fs,
          gains_only_fit};
}

}  // namespace

void EvalForceOptions::Validate() const {
  body.Validate();
  weight.Validate();
  contact.Validate();
  material.Validate();
  // Checked here, not only by ComplianceFamily, so a bad node fails before the true model's
  // minutes of solving.
  if (calibrate_material && poisson_nodes.size() < 2) {
    throw Error(fmt::format("EvalForceOptions.poisson_nodes needs at least 2 values, got {}",
                            poisson_nodes.size()));
  }
  for (double nu : poisson_nodes) {
    if (!(nu > -1.0 && nu <= 0.4999)) {
      throw Error(fmt::format("EvalForceOptions.poisson_nodes: {} is not in (-1, 0.4999]", nu));
    }
  }
  if (!(truth_refinement >= 1.0 && truth_refinement <= 4.0)) {
    throw Error(fmt::format("EvalForceOptions.truth_refinement must be in [1, 4], got {}",
                            truth_refinement));
  }
  for (const auto& [value, field] :
       {std::pair{truth_shear_modulus_factor, "truth_shear_modulus_factor"},
        std::pair{truth_bulk_modulus_factor, "truth_bulk_modulus_factor"}}) {
    // No upper bound of its own: nu 0.499 against the nominal 0.48 is a bulk modulus 16x the
    // nominal one at E x 0.8; the true material's own bounds are checked below.
    if (!(value > 0.0 && std::isfinite(value))) {
      throw Error(fmt::format("EvalForceOptions.{} must be > 0 and finite, got {}", field, value));
    }
  }
  try {
    TrueMaterial().Validate();
  } catch (const Error& e) {
    throw Error(fmt::format("EvalForceOptions.truth_shear_modulus_factor / truth_bulk_modulus_factor "
                            "give an invalid true material: {}",
                            e.what()));
  }
  if (!(noise_mm >= 0.0 && std::isfinite(noise_mm))) {
    throw Error(fmt::format("EvalForceOptions.noise_mm must be >= 0, got {}", noise_mm));
  }
  // Counts bounded where a run would take hours, not by memory alone: each press is a solve.
  constexpr int kMaxCount = 10000;
  if (static_frames < 2 || static_frames > kMaxCount) {
    throw Error(fmt::format("EvalForceOptions.static_frames must be in [2, {}], got {}", kMaxCount, static_frames));
  }
  for (const auto& [value, field] : {std::pair{calibration_presses, "calibration_presses"},
                                     std::pair{test_presses, "test_presses"}}) {
    if (value < 3 || value > kMaxCount) {
      throw Error(fmt::format("EvalForceOptions.{} must be in [3, {}], got {}", field, kMaxCount, value));
    }
  }
  for (const auto& [value, field] : {std::pair{full_scale_normal_n, "full_scale_normal_n"},
                                     std::pair{full_scale_tangential_n, "full_scale_tangential_n"}}) {
    if (!(value > 0.0)) throw Error(fmt::format("EvalForceOptions.{} must be > 0, got {}", field, value));
  }
}

void EvalForceOptions::SetTrueMaterial(const ElasticMaterial& truth) {
  truth_shear_modulus_factor = truth.shear_modulus() / body.material.shear_modulus();
  truth_bulk_modulus_factor = truth.bulk_modulus() / body.material.bulk_modulus();
}

ElasticMaterial EvalForceOptions::TrueMaterial() const {
  const double e = body.material.youngs_modulus_mpa, nu = body.material.poisson_ratio;
  const double shear = truth_shear_modulus_factor * e / (2.0 * (1.0 + nu));
  const double bulk = truth_bulk_modulus_factor * e / (3.0 * (1.0 - 2.0 * nu));
  ElasticMaterial truth = body.material;
  truth.youngs_modulus_mpa = 9.0 * bulk * shear / (3.0 * bulk + shear);
  truth.poisson_ratio = (3.0 * bulk - 2.0 * shear) / (2.0 * (3.0 * bulk + shear));
  return truth;
}

namespace {

// Every load case of one evaluation. The presses come from the seeded generator, in this order,
// so a run's cases depend on the options and the seed alone, never on the true material.
struct ForceCases {
  std::vector<LoadCase> calibration, test, probes, pins;
  // Probe positions on, between and off the markers, across the sensing area.
  std::vector<Eigen::Vector2d> probe_centers = {
      {0.3, 0.2}, {-2.9, 1.7}, {4.4, -3.6}, {-6.1, -5.3}, {7.2, 6.4}};
  // The pin pairs' midpoints off a marker column, in pitches.
  std::vector<double> pin_offsets = {0.0, 0.25, 0.5};
  int pin_row = 0;

  // The cases in the order of the response matrix's columns.
  std::vector<const LoadCase*> All() const {
    std::vector<const LoadCase*> all;
    for (const std::vector<LoadCase>* group : {&calibration, &test, &probes, &pins}) {
      for (const LoadCase& load : *group) all.push_back(&load);
    }
    return all;
  }
  size_t probe_begin() const { return calibration.size() + test.size(); }
  size_t pins_begin() const { return probe_begin() + probes.size(); }
};

ForceCases MakeForceCases(const EvalForceOptions& options,
                          const std::vector<Eigen::Vector3d>& markers,
                          std::mt19937_64* rng) {
  ForceCases cases;
  cases.calibration = MakePresses(options.calibration_presses, options, rng);
  cases.test = MakePresses(options.test_presses, options, rng);
  for (const Eigen::Vector2d& center : cases.probe_centers) {
    cases.probes.push_back({{center, kProbeRadius, false, Eigen::Vector3d(0, 0, -kProbeForce)}});
  }
  // Pin pairs along x on the marker row nearest y = 0, their midpoint on a marker column, a
  // quarter and half a pitch off it. At half a pitch, 2.54 mm = 2 pitches puts each pin midway
  // between two markers: the markers between the pins lie as close to a pin as those outside
  // (sampling at the Nyquist limit in antiphase), so no reconstruction can show a dip there;
  // that placement is reported but not part of the check.
  const int cols = options.body.marker_cols;
  cases.pin_row = options.body.marker_rows / 2;
  const int mid_col = cols / 2 - 1;
  for (double offset : cases.pin_offsets) {
    const Eigen::Vector2d mid = markers[cases.pin_row * cols + mid_col].head<2>() +
                                Eigen::Vector2d(offset * options.body.marker_pitch_mm, 0.0);
    LoadCase pair;
    for (double side : {-0.5, 0.5}) {
      pair.push_back({mid + Eigen::Vector2d(side * kPinSpacing, 0.0), kPinRadius, false,
                      Eigen::Vector3d(0, 0, -kPinForce)});
    }
    cases.pins.push_back(pair);
  }
  return cases;
}

// The true sensor's noise-free marker displacements (one column a case) and the report's
// description of its model.
struct TrueResponses {
  Eigen::MatrixXd clean;
  nlohmann::json model;
};

// The true responses are solved in chunks of at most this many load cases and, with a cache
// folder, saved after each chunk: the refinement-2 truth at nu 0.499 takes hours of CPU, so a
// run that is stopped resumes from the chunks it had solved. A chunk is one PCG block
// (PcgOptions::block_columns): an iteration streams K once for the whole block and costs about
// as much for 6 cases as for 12, so smaller chunks would cost more in all.
constexpr int kTruthChunkCases = 32;
constexpr char kTruthCacheMagic[] = "TAC3DFTR";
constexpr std::uint32_t kTruthCacheFormat = 1;

// A hash of everything the true responses depend on: the code, the true body and its solver's
// tolerance, the markers and every load case.
std::uint64_t TrueResponsesKey(const fem::BodyModelOptions& truth_options,
                               const fem::BodySolverOptions& solver,
                               const std::vector<Eigen::Vector3d>& markers,
                               const std::vector<const LoadCase*>& all) {
  nlohmann::json inputs = {{"code", fem::FemCodeVersion()},
                           {"body", fem::ToJson(truth_options)},
                           {"relative_tolerance", solver.pcg.relative_tolerance},
                           {"subdivisions", kSubdivisions}};
  nlohmann::json& points = inputs["markers"] = nlohmann::json::array();
  for (const Eigen::Vector3d& p : markers) points.push_back(Json(p));
  nlohmann::json& loads = inputs["cases"] = nlohmann::json::array();
  for (const LoadCase* load : all) {
    nlohmann::json& discs = loads.emplace_back(nlohmann::json::array());
    for (const DiscTraction& disc : *load) {
      discs.push_back({disc.center_mm.x(), disc.center_mm.y(), disc.radius_mm, disc.hertz,
                       disc.force_n.x(), disc.force_n.y(), disc.force_n.z()});
    }
  }
  const std::string text = inputs.dump();
  return Fnv1a(text.data(), text.size());
}

// The cases solved so far: their columns of `clean`, and per case the solver's iterations and
// final relative residual (-1 where not solved yet).
struct TruthProgress {
  std::vector<bool> solved;
  TrueResponses responses;
  std::vector<int> iterations;
  std::vector<double> residuals;
};

void SaveTruthProgress(const std::string& path, std::uint64_t key, const TruthProgress& progress) {
  CacheRecord record;
  record.key = key;
  record.header = {{"created_utc", UtcNow()},
                   {"code", fem::FemCodeVersion()},
                   {"solved", progress.solved},
                   {"model", progress.responses.model},
                   {"iterations", progress.iterations},
                   {"relative_residuals", progress.residuals}};
  record.matrices = {progress.responses.clean};
  WriteCacheRecord(path, kTruthCacheMagic, kTruthCacheFormat, record);
}

// The saved progress if `path` holds one for `key` with this shape; else none solved. A stale or
// unreadable file is reported and solved again (then overwritten).
TruthProgress LoadTruthProgress(
    const std::string& path, std::uint64_t key, int rows, int cases, bool show_progress) {
  TruthProgress progress{std::vector<bool>(cases, false),
                         {Eigen::MatrixXd::Zero(rows, cases), {}},
                         std::vector<int>(cases, -1),
                         std::vector<double>(cases, -1.0)};
  if (path.empty() || !std::filesystem::exists(path)) return progress;
  try {
    CacheRecord record = ReadCacheRecord(path, kTruthCacheMagic, kTruthCacheFormat);
    if (record.key != key) {
      if (show_progress) fmt::print(stderr, "force truth: {} is for other inputs, solving again\n", path);
      return progress;
    }
    if (record.matrices.size() != 1 || record.matrices[0].rows() != rows ||
        record.matrices[0].cols() != cases) {
      throw Error(fmt::format("{}: the responses are not {} x {}", path, rows, cases));
    }
    TruthProgress saved{record.header.at("solved").get<std::vector<bool>>(),
                        {std::move(record.matrices[0]), record.header.at("model")},
                        record.header.at("iterations").get<std::vector<int>>(),
                        record.header.at("relative_residuals").get<std::vector<double>>()};
    if (static_cast<int>(saved.solved.size()) != cases ||
        static_cast<int>(saved.iterations.size()) != cases ||
        static_cast<int>(saved.residuals.size()) != cases) {
      throw Error(fmt::format("{}: the per-case lists do not have {} entries", path, cases));
    }
    return saved;
  } catch (const std::exception& e) {
    if (show_progress) fmt::print(stderr, "force truth: {} unusable ({}), solving again\n", path, e.what());
    return progress;
  }
}

// The true sensor: a finer mesh with the options' true material. With options.cache_dir the
// responses are cached (cache_dir/force_truth_<key>.bin), chunk by chunk.
TrueResponses CalcTrueResponses(const EvalForceOptions& options,
                                const std::vector<Eigen::Vector3d>& markers,
                                const ForceCases& cases,
                                nlohmann::json* timing) {
  auto start = std::chrono::steady_clock::now();
  fem::BodyModelOptions truth_options = options.body;
  truth_options.refinement *= options.truth_refinement;
  truth_options.material = options.TrueMaterial();
  const fem::BodySolverOptions solver_options;
  const std::vector<const LoadCase*> all = cases.All();
  const int count = static_cast<int>(all.size());
  const std::uint64_t key = TrueResponsesKey(truth_options, solver_options, markers, all);
  const std::string path =
      options.cache_dir.empty() ? std::string() : CacheFilePath(options.cache_dir, "force_truth", key);
  TruthProgress progress = LoadTruthProgress(
      path, key, static_cast<int>(markers.size()) * 3, count, options.show_progress);
  const int loaded = static_cast<int>(std::count(progress.solved.begin(), progress.solved.end(), true));
  if (options.show_progress && loaded > 0) {
    fmt::print(stderr, "force truth: {} of {} load cases loaded from {}\n", loaded, count, path);
  }
  (*timing)["truth_cases_from_cache"] = loaded;
  (*timing)["truth_model"] = 0.0;

  std::optional<fem::BodyModel> truth;  // built only if a case is left to solve
  Eigen::SparseMatrix<double> readout;
  std::vector<int> unsolved;
  for (int c = 0; c < count; ++c) {
    if (!progress.solved[c]) unsolved.push_back(c);
  }
  const int left_count = static_cast<int>(unsolved.size());
  const int chunks = (left_count + kTruthChunkCases - 1) / kTruthChunkCases;
  ProgressBar bar("force truth: load cases", count, options.show_progress && loaded < count);
  bar.Update(loaded);
  int done = loaded;
  for (int chunk = 0; chunk < chunks; ++chunk) {
    const std::vector<int> left(unsolved.begin() + left_count * chunk / chunks,
                                unsolved.begin() + left_count * (chunk + 1) / chunks);
    if (!truth) {
      truth.emplace(truth_options, options.show_progress, solver_options);
      readout = truth->CalcPointInterpolation(markers);
      const fem::ElasticSolverSummary& summary = truth->solver().summary();
      progress.responses.model = {{"options", fem::ToJson(truth_options)},
                                  {"free_dofs", summary.num_free_dofs},
                                  {"coarse_free_dofs", summary.coarse_free_dofs},
                                  {"assembly_s", summary.assembly_s},
                                  {"factorization_s", summary.factorization_s},
                                  {"iterative", summary.method != fem::ElasticSolverMethod::kDirect}};
      (*timing)["truth_model"] = SecondsSince(start);
      start = std::chrono::steady_clock::now();
    }
    std::vector<Eigen::Triplet<double>> triplets;
    for (size_t k = 0; k < left.size(); ++k) {
      const Eigen::VectorXd f = AssembleLoad(*truth, *all[left[k]]);
      for (Eigen::Index j = 0; j < f.size(); ++j) {
        if (f(j) != 0.0) triplets.emplace_back(j, static_cast<int>(k), f(j));
      }
    }
    Eigen::SparseMatrix<double> loads(truth->mesh().num_dofs(), static_cast<int>(left.size()));
    loads.setFromTriplets(triplets.begin(), triplets.end());
    fem::SolveSummary solves;
    const Eigen::MatrixXd response = truth->solver().CalcResponse(
        readout, loads, false, kTruthChunkCases, &solves);
    for (size_t k = 0; k < left.size(); ++k) {
      const int c = left[k];
      progress.responses.clean.col(c) = response.col(static_cast<Eigen::Index>(k));
      progress.solved[c] = true;
      if (k < solves.iterations.size()) {  // a direct solve reports none
        progress.iterations[c] = solves.iterations[k];
        progress.residuals[c] = solves.relative_residuals[k];
      }
    }
    if (!path.empty()) SaveTruthProgress(path, key, progress);
    done += static_cast<int>(left.size());
    bar.Update(done);
  }
  bar.Finish();
  (*timing)["truth_responses"] = SecondsSince(start);
  if (progress.responses.model.value("iterative", false)) {
    progress.responses.model["pcg_iterations"] = progress.iterations;
    progress.responses.model["pcg_relative_residuals"] = progress.residuals;
  }
  return progress.responses;
}

// The largest distance between a probe's centre and the normal-force-weighted centroid of the
// contact markers the inverse finds (mm), and a row a probe.
struct ProbeErrors {
  double max_error_mm = 0.0;
  nlohmann::json rows = nlohmann::json::array();
};

ProbeErrors MeasureProbeErrors(const EvalForceOptions& options,
                               const ForceCases& cases,
                               const std::vector<Eigen::VectorXd>& frames,
                               const MarkerSurface& surface,
                               const std::vector<Eigen::Vector3d>& markers,
                               ForceReconstructor& reconstructor) {
  ProbeErrors probes;
  for (size_t k = 0; k < cases.probes.size(); ++k) {
    const Eigen::VectorXd& d = frames[cases.probe_begin() + k];
    const ForceDecomposition split = surface.Decompose(d, {}, reconstructor.Reconstruct(d).forces_n);
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    double total = 0.0;
    for (int i = 0; i < options.body.num_markers(); ++i) {
      if (!split.contact[i]) continue;
      centroid += split.normal_force_n(i) * markers[i].head<2>();
      total += split.normal_force_n(i);
    }
    // No contact found counts as missing the probe by the sensing area's size.
    const double error = total > 0.0 ? (centroid / total - cases.probe_centers[k]).norm()
                                     : 2.0 * options.body.base_diameter_mm;
    probes.max_error_mm = std::max(probes.max_error_mm, error);
    probes.rows.push_back({{"center_mm", {cases.probe_centers[k].x(), cases.probe_centers[k].y()}},
                           {"error_mm", error},
                           {"contact_markers", split.num_contact}});
  }
  return probes;
}

// The pins: the normal force along the pins' marker row; the peak near each pin (within half a
// pitch) and the lowest value on the markers strictly between the two peaks, over the smaller
// peak. The largest ratio over the placements short of the sampling limit, and a row a pair.
struct PinDips {
  double max_dip_ratio = 0.0;
  nlohmann::json rows = nlohmann::json::array();
};

PinDips MeasurePinDips(const EvalForceOptions& options,
                       const ForceCases& cases,
                       const std::vector<Eigen::VectorXd>& frames,
                       const MarkerSurface& surface,
                       const std::vector<Eigen::Vector3d>& markers,
                       ForceReconstructor& reconstructor) {
  const int cols = options.body.marker_cols;
  const double pitch = options.body.marker_pitch_mm;
  PinDips dips;
  for (size_t k = 0; k < cases.pins.size(); ++k) {
    const LoadCase& pins = cases.pins[k];
    const Eigen::VectorXd& d = frames[cases.pins_begin() + k];
    const ForceDecomposition split = surface.Decompose(d, {}, reconstructor.Reconstruct(d).forces_n);
    const auto profile = [&](int col) { return split.normal_force_n(cases.pin_row * cols + col); };
    int peak_col[2] = {-1, -1};
    for (int p = 0; p < 2; ++p) {
      for (int col = 0; col < cols; ++col) {
        const double x = markers[cases.pin_row * cols + col].x();
        if (std::abs(x - pins[p].center_mm.x()) > 0.5 * pitch + 1e-9) continue;
        if (peak_col[p] < 0 || profile(col) > profile(peak_col[p])) peak_col[p] = col;
      }
    }
    TAC3D_DEMAND(peak_col[0] >= 0 && peak_col[1] > peak_col[0]);
    const double smaller_peak = std::min(profile(peak_col[0]), profile(peak_col[1]));
    double dip = smaller_peak;  // adjacent peaks: nothing between, not resolved
    for (int col = peak_col[0] + 1; col < peak_col[1]; ++col) dip = std::min(dip, profile(col));
    const double ratio = smaller_peak > 0.0 ? dip / smaller_peak : 1.0;
    const bool sampling_limit = cases.pin_offsets[k] >= 0.5;
    if (!sampling_limit) dips.max_dip_ratio = std::max(dips.max_dip_ratio, ratio);
    nlohmann::json row_profile = nlohmann::json::array();
    for (int col = 0; col < cols; ++col) row_profile.push_back(profile(col));
    dips.rows.push_back({{"offset_pitch", cases.pin_offsets[k]},
                         {"pins_x_mm", {pins[0].center_mm.x(), pins[1].center_mm.x()}},
                         {"peak_columns", {peak_col[0], peak_col[1]}},
                         {"dip_ratio", ratio},
                         {"sampling_limit", sampling_limit},
                         {"row_normal_force_n", row_profile}});
  }
  return dips;
}

// The median over the markers of each axis' force uncertainty (N).
Eigen::Vector3d MedianMarkerSigma(const ForceUncertainty& uncertainty) {
  Eigen::Vector3d median_sigma;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> sigma(uncertainty.marker_sigma_n.row(axis).begin(),
                              uncertainty.marker_sigma_n.row(axis).end());
    std::nth_element(sigma.begin(), sigma.begin() + sigma.size() / 2, sigma.end());
    median_sigma(axis) = sigma[sigma.size() / 2];
  }
  return median_sigma;
}

// What the pipeline makes of the true responses: noise added (drawn from `rng` after the
// cases), the noise estimated from static frames, w chosen on the calibration presses, K and the
// gains (and with calibrate_material, `family`'s material fit), then every figure and check.
ForceEvaluation EvaluateOnResponses(const EvalForceOptions& options,
                                   const fem::ComplianceModel& nominal,
                                   const fem::ComplianceFamily* family,
                                   const ForceCases& cases,
                                   const TrueResponses& truth,
                                   std::mt19937_64* rng,
                                   nlohmann::json timing) {
  std::normal_distribution<double> normal(0.0, options.noise_mm);
  const auto noisy = [&](const Eigen::VectorXd& d) {
    Eigen::VectorXd result = d;
    for (Eigen::Index j = 0; j < result.size(); ++j) result(j) += normal(*rng);
    return result;
  };
  std::vector<Eigen::VectorXd> frames;
  for (Eigen::Index c = 0; c < truth.clean.cols(); ++c) frames.push_back(noisy(truth.clean.col(c)));
  std::vector<Eigen::VectorXd> static_frames;
  for (int k = 0; k < options.static_frames; ++k) {
    static_frames.push_back(noisy(Eigen::VectorXd::Zero(truth.clean.rows())));
  }

  auto start = std::chrono::steady_clock::now();
  const DisplacementNoise noise = EstimateDisplacementNoise(static_frames);
  const ComplianceSpectrum spectrum(nominal.h);
  const std::vector<Eigen::VectorXd> calibration_frames(frames.begin(),
                                                        frames.begin() + cases.calibration.size());
  const WeightSelection selection =
      SelectRegularizationWeight(spectrum, calibration_frames, noise, options.weight);
  const std::vector<Eigen::Vector3d>& markers = nominal.marker_positions;
  ForceReconstructor reconstructor(
      nominal.h, markers,
      {.weight = selection.weight, .support_refinement = options.support_refinement});
  timing["inverse_setup"] = SecondsSince(start);
  std::vector<ForcePair> pairs;
  for (size_t k = 0; k < cases.calibration.size(); ++k) {
    pairs.push_back({reconstructor.Reconstruct(frames[k]).resultant_force_n,
                     cases.calibration[k][0].force_n});
  }
  // An evaluation flags a poor fit (the gains' usable and warning) rather than stop: its
  // resultant error check measures what such gains cost. A coarse model on 3 presses fits fz
  // with R^2 0.48 (EvaluateForceOverMaterials' test).
  const ForceGainFit gain_fit = FitForceGains(pairs, {.on_poor_fit = PoorGainFit::kFlag});
  reconstructor.set_gains(gain_fit.gains);

  // Resultants of the test presses, in percent of each axis' full scale.
  const Eigen::Vector3d full_scale(options.full_scale_tangential_n, options.full_scale_tangential_n,
                                   options.full_scale_normal_n);
  const std::vector<Eigen::VectorXd> test_frames(
      frames.begin() + cases.calibration.size(), frames.begin() + cases.probe_begin());
  ForceEvaluation result;
  result.weight = selection;
  result.gains = gain_fit;
  result.true_material = options.TrueMaterial();
  if (family != nullptr) {
    result.material = CalibrateMaterialOnPresses(options,
                                                     cases.calibration,
                                                     frames,
                                                     noise,
                                                     gain_fit,
                                                     {test_frames, cases.test, full_scale},
                                                     *family,
                                                     &reconstructor,
                                                     &timing);
    result.gains = result.material->fit.gains;
  }
  const PressResultantErrors errors =
      MeasureResultantErrors(reconstructor, test_frames, cases.test, full_scale);
  const MarkerSurface surface(options.body.marker_rows, options.body.marker_cols, markers,
                              options.contact);
  const ProbeErrors probes =
      MeasureProbeErrors(options, cases, frames, surface, markers, reconstructor);
  const PinDips pins = MeasurePinDips(options, cases, frames, surface, markers, reconstructor);
  const ForceUncertainty uncertainty = reconstructor.CalcUncertainty(noise.variance_mm2);

  result.checks = {
      EvalCheck::AtMost("resultant_error_pct_fs", errors.max_pct_fs.maxCoeff(),
                        kMaxResultantErrorPctFs, "%"),
      EvalCheck::AtMost("probe_center_error_mm", probes.max_error_mm, options.body.marker_pitch_mm,
                        "mm"),
      EvalCheck::AtMost("pins_dip_ratio", pins.max_dip_ratio, kMaxPinsDipRatio),
      EvalCheck::AtMost("truth_edge_ratio", 1.0 / options.truth_refinement, 0.5)};
  result.all_pass = AllPass(result.checks);
  result.resultant_error_max_pct_fs = errors.max_pct_fs;
  result.resultant_error_rms_pct_fs = errors.rms_pct_fs;
  result.probe_center_error_mm = probes.max_error_mm;
  result.pins_dip_ratio = pins.max_dip_ratio;
  result.details["noise"] = {{"true_sigma_mm", options.noise_mm},
                             {"estimated_sigma_mm_xyz", Json(noise.sigma_mm())},
                             {"static_frames", noise.num_frames}};
  result.details["uncertainty"] = {
      {"median_marker_sigma_n_xyz", Json(MedianMarkerSigma(uncertainty))},
      {"resultant_sigma_n_xyz", Json(uncertainty.resultant_sigma_n)}};
  result.details["presses"] = {{"calibration", cases.calibration.size()},
                               {"test", errors.presses}};
  result.details["probes"] = probes.rows;
  result.details["pins"] = pins.rows;
  result.details["truth_model"] = truth.model;
  result.details["timing_s"] = timing;
  return result;
}

// The nominal model: what the pipeline believes.
fem::ComplianceModel LoadNominalModel(const EvalForceOptions& options, nlohmann::json* timing) {
  const auto start = std::chrono::steady_clock::now();
  fem::ComplianceModel nominal =
      options.cache_dir.empty()
          ? fem::CalcComplianceModel(options.body, options.show_progress)
          : fem::LoadOrBuildComplianceModel(options.body, options.cache_dir, options.show_progress)
                .model;
  (*timing)["nominal_h"] = SecondsSince(start);
  return nominal;
}

std::optional<fem::ComplianceFamily> MakeFamily(const EvalForceOptions& options) {
  if (!options.calibrate_material) return std::nullopt;
  return std::optional<fem::ComplianceFamily>(
      std::in_place, options.body, options.poisson_nodes, options.cache_dir, options.show_progress);
}

// "x / y / z", each formatted with `spec` (a format string for one double).
std::string FormatXyz(const Eigen::Vector3d& v, const char* spec) {
  return fmt::format("{} / {} / {}", fmt::format(fmt::runtime(spec), v.x()),
                     fmt::format(fmt::runtime(spec), v.y()), fmt::format(fmt::runtime(spec), v.z()));
}

}  // namespace

std::string ForceEvaluation::GridLine() const {
  const auto xyz = [](const Eigen::Vector3d& v) { return FormatXyz(v, "{:.2f}"); };
  std::string line = fmt::format("true E {:.4g} MPa, nu {:.4f}: resultant error max {} % FS",
                                 true_material.youngs_modulus_mpa, true_material.poisson_ratio,
                                 xyz(resultant_error_max_pct_fs));
  if (material) {
    line += fmt::format("; {}; gains only {} % FS", material->fit.message,
                        xyz(material->gains_only_max_pct_fs));
  }
  if (!gains.usable()) line += "; gains UNUSABLE (an R^2 under the floor)";
  return line + fmt::format("; all checks {}", all_pass ? "pass" : "FAIL");
}

std::string ForceEvaluation::Report() const {
  std::string text = FormatChecks(checks);
  const auto xyz = [](const Eigen::Vector3d& v) { return FormatXyz(v, "{:.3g}"); };
  text += fmt::format("true material: E {:.4g} MPa, nu {:.4f}\n", true_material.youngs_modulus_mpa,
                      true_material.poisson_ratio);
  text += fmt::format("resultant error, % of full scale, x / y / z: max {}, rms {}\n",
                      xyz(resultant_error_max_pct_fs), xyz(resultant_error_rms_pct_fs));
  if (material) {
    text += fmt::format("material: {}\ngains only: resultant error max {}, rms {}\n",
                        material->fit.message, xyz(material->gains_only_max_pct_fs),
                        xyz(material->gains_only_rms_pct_fs));
  }
  text += fmt::format("gains: {}\n", xyz(gains.gains));
  if (!gains.usable()) text += fmt::format("WARNING: unusable gains: {}\n", gains.PoorFitMessage());
  text += fmt::format("weight: {:.4g} (mm/N)^2 ({})\nall pass: {}\n", weight.weight,
                      weight.summary.message, all_pass ? "yes" : "no");
  return text;
}

nlohmann::json ToJson(const ForceEvaluation& e) {
  nlohmann::json json = e.details;
  json["checks"] = ToJson(e.checks);
  json["all_pass"] = e.all_pass;
  json["resultant_error_pct_fs"] = e.resultant_error_max_pct_fs.maxCoeff();
  json["resultant_error_max_pct_fs_xyz"] = Json(e.resultant_error_max_pct_fs);
  json["resultant_error_rms_pct_fs_xyz"] = Json(e.resultant_error_rms_pct_fs);
  json["probe_center_error_mm"] = e.probe_center_error_mm;
  json["pins_dip_ratio"] = e.pins_dip_ratio;
  json["weight"] = ToJson(e.weight);
  json["gains"] = ToJson(e.gains);
  json["true_youngs_modulus_mpa"] = e.true_material.youngs_modulus_mpa;
  json["true_poisson_ratio"] = e.true_material.poisson_ratio;
  if (e.material) {
    json["material_calibration"] = {
        {"fit", ToJson(e.material->fit)},
        {"gains_only_resultant_error_max_pct_fs_xyz", Json(e.material->gains_only_max_pct_fs)},
        {"gains_only_resultant_error_rms_pct_fs_xyz", Json(e.material->gains_only_rms_pct_fs)},
        {"gains_only_gains", ToJson(e.material->gains_only)}};
  }
  return json;
}

ForceEvaluation EvaluateForce(const EvalForceOptions& options) {
  options.Validate();
  nlohmann::json timing;
  const fem::ComplianceModel nominal = LoadNominalModel(options, &timing);
  std::mt19937_64 rng(options.seed);
  const ForceCases cases = MakeForceCases(options, nominal.marker_positions, &rng);
  const TrueResponses truth = CalcTrueResponses(options, nominal.marker_positions, cases, &timing);
  const std::optional<fem::ComplianceFamily> family = MakeFamily(options);
  return EvaluateOnResponses(
      options, nominal, family ? &*family : nullptr, cases, truth, &rng, timing);
}

void MaterialGrid::Validate() const {
  for (const auto& [values, field] : {std::pair{&youngs_modulus_factors, "youngs_modulus_factors"},
                                      std::pair{&poisson_ratios, "poisson_ratios"}}) {
    if (values->empty()) throw Error(fmt::format("MaterialGrid.{} is empty", field));
  }
  for (double factor : youngs_modulus_factors) {
    if (!(factor > 0.0 && std::isfinite(factor))) {
      throw Error(fmt::format("MaterialGrid.youngs_modulus_factors: {} is not > 0", factor));
    }
  }
}

std::vector<ForceEvaluation> EvaluateForceOverMaterials(
    const EvalForceOptions& options,
    const MaterialGrid& grid,
    const std::function<void(const ForceEvaluation&)>& on_point) {
  grid.Validate();
  const double nominal_e = options.body.material.youngs_modulus_mpa;
  std::vector<EvalForceOptions> point_options;
  for (double nu : grid.poisson_ratios) {
    for (double factor : grid.youngs_modulus_factors) {
      point_options.push_back(options);
      point_options.back().SetTrueMaterial({factor * nominal_e, nu});
      point_options.back().Validate();  // every point's material before the first truth's solve
    }
  }
  nlohmann::json timing;
  const fem::ComplianceModel nominal = LoadNominalModel(options, &timing);
  const std::optional<fem::ComplianceFamily> family = MakeFamily(options);
  std::vector<ForceEvaluation> points;
  size_t point = 0;
  for (double nu : grid.poisson_ratios) {
    // One true model a Poisson's ratio, at the nominal E: at a fixed nu the stiffness is
    // proportional to E, so the true displacements at E are exactly those at the nominal E
    // times nominal_e / E.
    EvalForceOptions reference = options;
    reference.SetTrueMaterial({nominal_e, nu});
    std::mt19937_64 rng(options.seed);
    const ForceCases cases = MakeForceCases(reference, nominal.marker_positions, &rng);
    nlohmann::json truth_timing = timing;
    TrueResponses truth =
        CalcTrueResponses(reference, nominal.marker_positions, cases, &truth_timing);
    const Eigen::MatrixXd reference_clean = truth.clean;
    for (double factor : grid.youngs_modulus_factors) {
      const EvalForceOptions& point_option = point_options[point++];
      truth.clean = reference_clean / factor;
      truth.model["options"]["youngs_modulus_mpa"] = point_option.TrueMaterial().youngs_modulus_mpa;
      truth.model["responses_scaled_from_youngs_modulus_mpa"] = nominal_e;
      // The generator replays EvaluateForce's draws: the same cases, then the same noise.
      std::mt19937_64 point_rng(options.seed);
      MakeForceCases(point_option, nominal.marker_positions, &point_rng);
      points.push_back(EvaluateOnResponses(point_option, nominal, family ? &*family : nullptr,
                                           cases, truth, &point_rng, truth_timing));
      if (on_point) on_point(points.back());
    }
  }
  return points;
}

}  // namespace tac3d
