#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

// Issue 11's friction-map acceptance (ctest label `eval`, not run by CI): `tac3d eval friction`
// on the friction scenes, simulated by the twin (minutes each; the twin body is built once,
// ~15 min, and cached), their images through the pipeline, mapped and compared with the
// truth. TAC3D_EVAL_FRICTION_DATASETS names a folder of datasets to reuse (DIR/<scene>).

namespace tac3d {
namespace {

// Runs the command on `scenes` and expects every check of every scene, and of their pooled
// figures, to pass.
void ExpectEveryCheckPasses(const std::string& name, const std::string& scenes) {
  const std::string out = ::testing::TempDir() + "/eval_friction_" + name;
  std::string command = std::string(TAC3D_CLI_PATH) + " eval friction --scenes " + scenes + " --out " + out;
  if (const char* datasets = std::getenv("TAC3D_EVAL_FRICTION_DATASETS")) {
    command += std::string(" --datasets ") + datasets;
  }
  command += " > " + out + ".log";
  std::printf("%s\n", command.c_str());
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(out + "/report.json");
  ASSERT_TRUE(in) << out << "/report.json";
  const nlohmann::json report = nlohmann::json::parse(in);
  for (const nlohmann::json& scene : report.at("scenes")) {
    SCOPED_TRACE(scene.at("scene").get<std::string>());
    for (const nlohmann::json& check : scene.at("checks")) {
      std::printf("%s %s %s\n",
                  scene.at("scene").get<std::string>().c_str(),
                  check.at("name").get<std::string>().c_str(),
                  check.at("value").dump().c_str());
      EXPECT_TRUE(check.at("pass").get<bool>()) << check.dump();
    }
  }
  EXPECT_TRUE(report.at("overall").at("all_pass").get<bool>()) << report.at("overall").dump(2);
}

// The three friction scenes of the acceptance.
TEST(EvalFriction, MeetsTheAcceptanceOnTheFrictionScenes) {
  ExpectEveryCheckPasses("issue", "friction_block friction_bottle friction_paint_can");
}

// The scene held out of the map's settings, against the same targets. Fails today on band
// agreement and slip recall (docs/friction.md says why).
TEST(EvalFriction, HeldOutToolHandleMeetsTheSameTargets) {
  ExpectEveryCheckPasses("held_out", "friction_tool_handle");
}

}  // namespace
}  // namespace tac3d
