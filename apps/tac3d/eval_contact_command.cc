#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/contact/evaluation.h"

namespace tac3d::cli {

void RegisterEvalContact(CLI::App& eval) {
  struct Args {
    contact::EvalContactOptions options;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand(
      "contact", "The contact solver against Hertz, Cattaneo-Mindlin, Mindlin-Deresiewicz and a two-material slide");
  cmd->add_option("--cells-per-radius", args->options.cells_per_radius,
                  "grid cells per Hertz contact radius (finer: slower, closer)")
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    const contact::EvalContactResult result = contact::EvaluateContact(args->options);
    if (args->json) {
      nlohmann::json j = ToJson(result);
      // Each check's figure also at the top level, under its name, for scripts.
      for (const nlohmann::json& check : j.at("checks")) j[check.at("name").get<std::string>()] = check.at("value");
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%s", result.Report().c_str());
  });
}

}  // namespace tac3d::cli
