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

// The JSON or the report of an evaluation.
template <typename Evaluation>
void Print(const Evaluation& evaluation, bool json) {
  if (json) {
    std::printf("%s\n", ToJson(evaluation).dump(2).c_str());
    return;
  }
  std::printf("%s", evaluation.Report().c_str());
}

}  // namespace

void RegisterEvalCalibration(CLI::App& eval) {
  auto calibration = std::make_shared<Args>();
  CLI::App* c = eval.add_subcommand(
      "calibration", "Calibrate from rendered board images of a perturbed sensor; compare with its truth");
  AddCommon(c, *calibration);
  c->callback([calibration] {
    Print(EvaluateCalibration(Prepare(*calibration)), calibration->json);
  });

  auto displacement = std::make_shared<Args>();
  CLI::App* d = eval.add_subcommand(
      "displacement", "Paper V.A in the twin: a dot board moved 3 mm along x, y, z, measured by stereo");
  AddCommon(d, *displacement);
  d->callback([displacement] {
    DisplacementEvaluationOptions options;
    options.calibration = Prepare(*displacement);
    Print(EvaluateDisplacement(options), displacement->json);
  });

  auto markers = std::make_shared<Args>();
  auto known_sensor = std::make_shared<bool>(false);
  CLI::App* m = eval.add_subcommand(
      "markers", "The marker layer under shear, dent and twist through the gel: tracked, triangulated, compensated");
  AddCommon(m, *markers);
  m->add_flag("--known-sensor", *known_sensor,
              "render the designed sensor and measure with it exactly (no calibration)");
  auto real_image = std::make_shared<bool>(false);
  m->add_flag("--real-image-nuisances", *real_image,
              "render with a real camera's nuisances: coloured uneven LEDs, blur, JPEG (docs/render.md)");
  m->callback([markers, known_sensor, real_image] {
    MarkerEvaluationOptions options;
    options.calibration = Prepare(*markers);
    options.calibrate = !*known_sensor;
    options.real_image_nuisances = *real_image;
    Print(EvaluateMarkers(options), markers->json);
  });
}

}  // namespace tac3d::cli
