#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/twin/render_evaluation.h"

namespace tac3d::cli {

void RegisterEvalRender(CLI::App& eval) {
  struct Args {
    std::string config;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = eval.add_subcommand("render", "How faithful the twin's camera image is");
  cmd->add_option("--config", args->config, "sensor YAML (default: the built-in prototype)");
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->callback([args] {
    const RenderEvaluation e = EvaluateRender(LoadSensorOrDefault(args->config));
    const nlohmann::json j = {{"blobs_per_half", {e.blobs_per_half[0], e.blobs_per_half[1]}},
                              {"dots_measured", e.dots_measured},
                              {"centroid_error_median_px", e.centroid_error_median_px},
                              {"centroid_error_max_px", e.centroid_error_max_px},
                              {"render_median_ms", e.render_median_ms}};
    if (args->json) {
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("blobs found by OpenCV: %d left, %d right (of 400 each)\n", e.blobs_per_half[0],
                e.blobs_per_half[1]);
    std::printf("dot centroid vs ray-traced projection, %d dots: median %.4f px, max %.4f px\n",
                e.dots_measured, e.centroid_error_median_px, e.centroid_error_max_px);
    std::printf("render one frame: median %.2f ms\n", e.render_median_ms);
  });
}

}  // namespace tac3d::cli
