#include "tac3d/eval/replay_evaluation.h"

#include <chrono>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "tac3d/scene/scene.h"
#include "tac3d/util/error.h"
#include "tac3d/util/eval_check.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {

void ReplayOptions::Validate() const {
  pipeline.Validate();
  gain_fit.Validate();
  auto positive = [](double v, const char* field) {
    if (!(v > 0.0 && std::isfinite(v))) {
      throw Error(fmt::format("ReplayOptions.{} must be > 0 and finite, got {}", field, v));
    }
  };
  positive(full_scale_normal_n, "full_scale_normal_n");
  positive(full_scale_tangential_n, "full_scale_tangential_n");
  positive(loaded_force_n, "loaded_force_n");
  positive(reference_force_tolerance_n, "reference_force_tolerance_n");
  positive(max_force_error_pct_fs, "max_force_error_pct_fs");
  if (max_steps < 0) throw Error(fmt::format("ReplayOptions.max_steps must be >= 0, got {}", max_steps));
  if (max_steps > 0 && max_steps <= pipeline.reference_frames) {
    throw Error(fmt::format("ReplayOptions.max_steps = {} must exceed reference_frames = {}",
                            max_steps, pipeline.reference_frames));
  }
}

SensorConfig DatasetSensor(const TwinDatasetReader& dataset) {
  const nlohmann::json& header = dataset.header();
  if (!header.contains("scene") || !header.at("scene").is_string()) {
    throw Error("the dataset header names no scene; give the sensor with --config");
  }
  const std::string scene = header.at("scene").get<std::string>();
  try {
    return LoadSceneOrBuiltIn(scene).sensor;
  } catch (const Error& e) {
    throw Error(fmt::format("the dataset's scene '{}' cannot be loaded ({}); give the sensor with --config",
                            scene, e.what()));
  }
}

namespace {

Eigen::Vector3d FullScale(const ReplayOptions& o) {
  return {o.full_scale_tangential_n, o.full_scale_tangential_n, o.full_scale_normal_n};
}

// The frame's figures against the step's truth; rest_mm is the true undeformed state.
ReplayFrame Compare(const TactileFrame& out, const TwinStep& truth,
                    const std::vector<Eigen::Vector3d>& rest_mm, double loaded_force_n) {
  ReplayFrame f;
  f.step = truth.index;
  f.flags = out.flags;
  f.true_force_n = truth.total_force_n;
  f.measured_force_n = out.resultant_force_n;
  f.true_moment_nmm = truth.total_moment_nmm;
  f.measured_moment_nmm = out.resultant_moment_nmm;
  f.loaded = truth.total_force_n.norm() > loaded_force_n;
  double position_sq = 0.0, displacement_sq = 0.0;
  for (int i = 0; i < out.num_markers(); ++i) {
    const bool true_contact = truth.marker_contact[i] != 0;
    f.true_contact_markers += true_contact;
    f.measured_contact_markers += out.contact[i];
    f.contact_agreeing_markers += out.contact[i] == true_contact;
    f.contact_both_markers += out.contact[i] && true_contact;
    if (!out.valid[i]) continue;
    ++f.valid_markers;
    position_sq += (out.positions_mm[i] - truth.marker_positions_mm[i]).squaredNorm();
    const Eigen::Vector3d true_displacement = truth.marker_positions_mm[i] - rest_mm[i];
    displacement_sq += (out.displacements_mm[i] - true_displacement).squaredNorm();
  }
  if (f.valid_markers > 0) {
    f.position_rmse_mm = std::sqrt(position_sq / f.valid_markers);
    f.displacement_rmse_mm = std::sqrt(displacement_sq / f.valid_markers);
  }
  return f;
}

ReplaySummary Summarise(const std::vector<ReplayFrame>& frames, int markers, const ReplayOptions& options) {
  ReplaySummary s;
  s.frames = static_cast<int>(frames.size());
  const Eigen::Vector3d scale = FullScale(options);
  Eigen::Vector3d force_sq = Eigen::Vector3d::Zero(), moment_sq = Eigen::Vector3d::Zero();
  double worst = -1.0, position_sq = 0.0, displacement_sq = 0.0;
  long valid = 0, agreeing = 0, both = 0, either = 0;
  for (const FrameFlag flag : kAllFrameFlags) s.flag_counts.emplace_back(FrameFlagName(flag), 0);
  for (const ReplayFrame& f : frames) {
    s.flagged_frames += f.flags != 0;
    for (size_t b = 0; b < s.flag_counts.size(); ++b) {
      s.flag_counts[b].second += (f.flags & static_cast<std::uint32_t>(kAllFrameFlags[b])) != 0;
    }
    s.lost_marker_frames += markers - f.valid_markers;
    position_sq += f.position_rmse_mm * f.position_rmse_mm * f.valid_markers;
    displacement_sq += f.displacement_rmse_mm * f.displacement_rmse_mm * f.valid_markers;
    valid += f.valid_markers;
    if (!f.loaded) continue;
    ++s.loaded_frames;
    const Eigen::Vector3d e =
        100.0 * (f.measured_force_n - f.true_force_n).cwiseAbs().cwiseQuotient(scale);
    s.force_error_max_pct_fs = s.force_error_max_pct_fs.cwiseMax(e);
    force_sq += e.cwiseAbs2();
    if (e.maxCoeff() > worst) {
      worst = e.maxCoeff();
      s.worst_force_step = f.step;
    }
    const Eigen::Vector3d m = (f.measured_moment_nmm - f.true_moment_nmm).cwiseAbs();
    s.moment_error_max_nmm = s.moment_error_max_nmm.cwiseMax(m);
    moment_sq += m.cwiseAbs2();
    agreeing += f.contact_agreeing_markers;
    both += f.contact_both_markers;
    either += f.true_contact_markers + f.measured_contact_markers - f.contact_both_markers;
  }
  if (s.loaded_frames > 0) {
    s.force_error_rms_pct_fs = (force_sq / s.loaded_frames).cwiseSqrt();
    s.moment_error_rms_nmm = (moment_sq / s.loaded_frames).cwiseSqrt();
    s.contact_agreement = static_cast<double>(agreeing) / (static_cast<double>(s.loaded_frames) * markers);
    s.contact_iou = either > 0 ? static_cast<double>(both) / either : 1.0;
  }
  if (valid > 0) {
    s.position_rmse_mm = std::sqrt(position_sq / valid);
    s.displacement_rmse_mm = std::sqrt(displacement_sq / valid);
  }
  return s;
}

nlohmann::json Xyz(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

ReplayResult ReplayTwinDataset(const TwinDatasetReader& dataset, const SensorConfig& config,
                               const Eigen::MatrixXd& h,
                               const std::vector<Eigen::Vector3d>& fem_markers_mm,
                               const ReplayOptions& options,
                               const std::function<void(int, int)>& progress,
                               const std::function<void(const TwinStep&, const TactileFrame&)>& on_frame,
                               const ReplayAlterations& alter) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  const std::vector<int>& steps = dataset.steps();
  const int reference = options.pipeline.reference_frames;
  const int count = options.max_steps > 0 ? std::min<int>(options.max_steps, steps.size())
                                          : static_cast<int>(steps.size());
  if (count <= reference) {
    throw Error(fmt::format("the dataset has {} steps; the replay needs more than the {} reference frames",
                            count, reference));
  }
  Pipeline pipeline(config, h, fem_markers_mm, options.pipeline);
  const int markers = config.markers.rows * config.markers.cols;
  std::vector<Eigen::Vector3d> rest(markers, Eigen::Vector3d::Zero());
  ReplayResult result;
  TactileFrame out;
  for (int k = 0; k < count; ++k) {
    TwinStep truth = dataset.Read(steps[k]);
    if (alter.step) alter.step(truth, k < reference);
    if (truth.image.empty()) {
      throw Error(fmt::format("step {} has no image: simulate without --no-images to replay", truth.index));
    }
    if (static_cast<int>(truth.marker_positions_mm.size()) != markers) {
      throw Error(fmt::format("step {} has {} markers, the sensor {}", truth.index,
                              truth.marker_positions_mm.size(), markers));
    }
    if (k < reference) {
      if (truth.total_force_n.norm() > options.reference_force_tolerance_n) {
        throw Error(fmt::format(
            "step {} carries a force of {:.4g} N, but the pipeline takes the first {} steps as the "
            "unloaded reference: the sensor must be clear of the object for them (the built-in "
            "scenes hold their first pose for 25 steps; regenerate an older dataset)",
            truth.index, truth.total_force_n.norm(), reference));
      }
      for (int i = 0; i < markers; ++i) rest[i] += truth.marker_positions_mm[i] / reference;
    }
    pipeline.Process(Frame{truth.image, truth.t_s, truth.index}, out);
    if (k + 1 == reference && alter.after_reference) alter.after_reference(pipeline, truth);
    if (k >= reference) {
      result.frames.push_back(Compare(out, truth, rest, options.loaded_force_n));
      if (on_frame) on_frame(truth, out);
    }
    if (progress) progress(k + 1, count);
  }
  result.summary = Summarise(result.frames, markers, options);
  result.summary.steps = count;
  result.summary.seconds = SecondsSince(start);
  return result;
}

std::vector<ForcePair> ReplayForcePairs(const ReplayResult& replay, const Eigen::Vector3d& gains) {
  std::vector<ForcePair> pairs;
  for (const ReplayFrame& f : replay.frames) {
    if (f.loaded) pairs.push_back({f.measured_force_n.cwiseQuotient(gains), f.true_force_n});
  }
  return pairs;
}

ReplayGainCalibration CalibrateGainsByReplay(const TwinDatasetReader& calibration,
                                             const SensorConfig& config, const Eigen::MatrixXd& h,
                                             const std::vector<Eigen::Vector3d>& fem_markers_mm,
                                             ReplayOptions options,
                                             const std::function<void(int, int)>& progress) {
  options.pipeline.force.gains = Eigen::Vector3d::Ones();
  ReplayGainCalibration c;
  c.replay = ReplayTwinDataset(calibration, config, h, fem_markers_mm, options, progress);
  c.pairs = ReplayForcePairs(c.replay, options.pipeline.force.gains);
  c.fit = FitForceGains(c.pairs, options.gain_fit);
  return c;
}

nlohmann::json ToJson(const ReplaySummary& s, const ReplayOptions& options) {
  nlohmann::json flags = nlohmann::json::object();
  for (const auto& [name, frames] : s.flag_counts) flags[name] = frames;
  nlohmann::json checks = nlohmann::json::array();
  bool all_pass = s.loaded_frames > 0;
  for (int axis = 0; axis < 3; ++axis) {
    EvalCheck check = EvalCheck::AtMost(fmt::format("resultant_f{}_max_error", "xyz"[axis]),
                                        s.force_error_max_pct_fs[axis],
                                        options.max_force_error_pct_fs,
                                        "% FS");
    check.pass = check.pass && s.loaded_frames > 0;  // no loaded frame: nothing was measured
    all_pass = all_pass && check.pass;
    checks.push_back(ToJson(check));
  }
  return {{"steps", s.steps},
          {"frames", s.frames},
          {"loaded_frames", s.loaded_frames},
          {"flagged_frames", s.flagged_frames},
          {"frames_by_flag", flags},
          {"lost_marker_frames", s.lost_marker_frames},
          {"full_scale_n_xyz", Xyz(FullScale(options))},
          {"gains", Xyz(options.pipeline.force.gains)},
          {"resultant_error_max_pct_fs_xyz", Xyz(s.force_error_max_pct_fs)},
          {"resultant_error_rms_pct_fs_xyz", Xyz(s.force_error_rms_pct_fs)},
          {"worst_force_step", s.worst_force_step},
          {"moment_error_max_nmm_xyz", Xyz(s.moment_error_max_nmm)},
          {"moment_error_rms_nmm_xyz", Xyz(s.moment_error_rms_nmm)},
          {"position_rmse_mm", s.position_rmse_mm},
          {"displacement_rmse_mm", s.displacement_rmse_mm},
          {"contact_agreement", s.contact_agreement},
          {"contact_iou", s.contact_iou},
          {"seconds", s.seconds},
          {"checks", checks},
          {"all_pass", all_pass}};
}

std::string ReplayFramesToCsv(const std::vector<ReplayFrame>& frames) {
  std::ostringstream csv;
  csv << "step,loaded,flags,fx_true,fy_true,fz_true,fx_meas,fy_meas,fz_meas,"
         "mx_true,my_true,mz_true,mx_meas,my_meas,mz_meas,valid_markers,true_contact_markers,"
         "measured_contact_markers,position_rmse_mm,displacement_rmse_mm\n";
  for (const ReplayFrame& f : frames) {
    csv << fmt::format("{},{},\"{}\"", f.step, f.loaded ? 1 : 0, FrameFlagNames(f.flags));
    for (const Eigen::Vector3d* v : {&f.true_force_n, &f.measured_force_n, &f.true_moment_nmm,
                                     &f.measured_moment_nmm}) {
      csv << fmt::format(",{:.6g},{:.6g},{:.6g}", v->x(), v->y(), v->z());
    }
    csv << fmt::format(",{},{},{},{:.6g},{:.6g}\n", f.valid_markers, f.true_contact_markers,
                       f.measured_contact_markers, f.position_rmse_mm, f.displacement_rmse_mm);
  }
  return csv.str();
}

}  // namespace tac3d
