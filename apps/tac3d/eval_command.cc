#include <CLI/CLI.hpp>

#include "commands.h"

namespace tac3d::cli {

void RegisterEval(CLI::App& app) {
  CLI::App* eval = app.add_subcommand(
      "eval", "Measure a stage's accuracy against the twin's truth or an analytic oracle");
  eval->require_subcommand(1);
  RegisterEvalRender(*eval);
  RegisterEvalCalibration(*eval);
  RegisterEvalFem(*eval);
  RegisterEvalContact(*eval);
  RegisterEvalForce(*eval);
  RegisterEvalReplay(*eval);
  RegisterEvalConditions(*eval);
  RegisterEvalFriction(*eval);
  RegisterEvalIncipient(*eval);
  RegisterEvalVendor(*eval);
}

}  // namespace tac3d::cli
