#include <cstdio>
#include <exception>
#include <filesystem>
#include <new>
#include <string>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "tac3d/util/error.h"
#include "tac3d/util/version.h"

int main(int argc, char** argv) {
  CLI::App app{"tac3d: software for mirror-stereo vision-based tactile sensors (Tac3D class)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("tac3d ") + tac3d::Version());
  tac3d::cli::RegisterDesign(app);
  tac3d::cli::RegisterRender(app);
  tac3d::cli::RegisterCalibrate(app);
  tac3d::cli::RegisterDemo(app);
  tac3d::cli::RegisterBuildModel(app);
  tac3d::cli::RegisterRun(app);
  tac3d::cli::RegisterSimulate(app);
  tac3d::cli::RegisterCalibrateForce(app);
  tac3d::cli::RegisterFrictionMap(app);
  tac3d::cli::RegisterEval(app);
  tac3d::cli::RegisterRecording(app);
  tac3d::cli::RegisterView(app);
  tac3d::cli::RegisterImportVendor(app);
  tac3d::cli::RegisterTrack(app);
  tac3d::cli::RegisterDataset(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const tac3d::Error& e) {
    std::fprintf(stderr, "tac3d: error: %s\n", e.what());
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // A file the user named that cannot be looked at (a link loop, no permission): the path and
    // why, as any other input error.
    std::fprintf(stderr, "tac3d: error: '%s': %s\n", e.path1().c_str(), e.code().message().c_str());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "tac3d: error: out of memory (an input larger than this machine holds?)\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tac3d: unexpected error: %s\n", e.what());
    return 1;
  }
  return 0;
}
