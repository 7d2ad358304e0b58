#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/eval/calibration_evaluation.h"
#include "tac3d/eval/marker_evaluation.h"

namespace tac3d::cli {
namespace {

struct Args {
  TwinCalibrationOptions calibration;
  bool asymmetric = false;
  bool json = false;
};

void AddCommon(CLI::App* cmd, Args& a) {
  cmd->add_option("--views", a.calibration.views, "random board poses besides the reference")
      ->capture_default_str();
  cmd->add_option("--seed", a.calibration.seed, "seed of the sensor's perturbation, poses, noise")
      ->capture_default_str();
  cmd->add_flag("--asymmetric", a.asymmetric, "calibrate with a 4 x 9 asymmetric circle grid");
  cmd->add_flag("--json", a.json, "print JSON");
}

TwinCalibrationOptions Prepare(Args& a) {
  if (a.asymmetric) {
    a.calibration.board.layout = CalibrationBoard::Layout::kAsymmetric;
    a.calibration.board.rows = 9;
    a.calibration.board.cols = 4;
  }
  a.calibration.progress = !a.json;
  return a.calibration;
}

void Print(const nlohmann::json& j, bool json, const char* keys[], int count) {
  if (json) {
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  for (int i = 0; i < count; ++i) std::printf("%s: %s\n", keys[i], j.at(keys[i]).dump().c_str());
}

}  // namespace

void RegisterEvalCalibration(CLI::App& eval) {
  auto calibration = std::make_shared<Args>();
  CLI::App* c = eval.add_subcommand(
      "calibration", "Calibrate from rendered board images of a perturbed sensor; compare with its truth");
  AddCommon(c, *calibration);
  c->callback([calibration] {
    const nlohmann::json j = EvaluateCalibration(Prepare(*calibration));
    const char* keys[] = {"views_used", "reprojection_rms_px", "camera_position_error_mm",
                          "camera_rotation_error_deg", "nominal_camera_position_error_mm",
                          "nominal_camera_rotation_error_deg", "focal_length_error_px",
                          "principal_point_error_px", "acceptance", "pass"};
    Print(j, calibration->json, keys, std::size(keys));
  });

  auto displacement = std::make_shared<Args>();
  CLI::App* d = eval.add_subcommand(
      "displacement", "Paper V.A in the twin: a dot board moved 3 mm along x, y, z, measured by stereo");
  AddCommon(d, *displacement);
  d->callback([displacement] {
    DisplacementEvaluationOptions options;
    options.calibration = Prepare(*displacement);
    const nlohmann::json j = EvaluateDisplacement(options);
    const char* keys[] = {"step_mm", "dots_per_move", "rmse_mm", "rmse_mm_true_rig",
                          "calibration_reprojection_rms_px", "acceptance_mm", "pass"};
    Print(j, displacement->json, keys, std::size(keys));
  });

  auto markers = std::make_shared<Args>();
  auto known_sensor = std::make_shared<bool>(false);
  CLI::App* m = eval.add_subcommand(
      "markers", "The marker layer under shear, dent and twist through the gel: tracked, triangulated, compensated");
  AddCommon(m, *markers);
  m->add_flag("--known-sensor", *known_sensor,
              "render the designed sensor and measure with it exactly (no calibration)");
  m->callback([markers, known_sensor] {
    MarkerEvaluationOptions options;
    options.calibration = Prepare(*markers);
    options.calibrate = !*known_sensor;
    const nlohmann::json j = EvaluateMarkers(options);
    const char* keys[] = {"position_rmse_mm", "displacement_rmse_mm", "by_model",
                          "undeformed_position_rmse_mm", "min_valid_markers", "calibration",
                          "acceptance", "pass"};
    Print(j, markers->json, keys, std::size(keys));
  });
}

}  // namespace tac3d::cli
