// `tac3d dataset ...`: randomized twin datasets on Dask (docs/datasets.md). Dask is Python, so
// the command is the Python module `tac3d.datasets`; the CLI execs the interpreter the module
// was built for (no libpython in the CLI, and signals and the exit code pass straight through).
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

namespace fs = std::filesystem;

// In the build tree the package is build/python/tac3d beside build/bin/tac3d; installed, it is in
// the interpreter's own dist-packages and needs no path.
void AddBuildTreePackageToPythonPath() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return;
  const fs::path package_root = exe.parent_path().parent_path() / "python";
  if (!fs::exists(package_root / "tac3d" / "datasets" / "__main__.py")) return;
  const char* old = std::getenv("PYTHONPATH");
  const std::string path =
      old && *old ? fmt::format("{}:{}", package_root.string(), old) : package_root.string();
  setenv("PYTHONPATH", path.c_str(), 1);
}

[[noreturn]] void ExecPythonModule(const std::vector<std::string>& args) {
  AddBuildTreePackageToPythonPath();
  std::vector<std::string> argv_strings = {TAC3D_PYTHON_EXECUTABLE, "-m", "tac3d.datasets"};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  execv(TAC3D_PYTHON_EXECUTABLE, argv.data());
  throw Error(fmt::format(
      "tac3d dataset: cannot run {}: {}", TAC3D_PYTHON_EXECUTABLE, std::strerror(errno)));
}

}  // namespace

void RegisterDataset(CLI::App& app) {
  CLI::App* cmd = app.add_subcommand(
      "dataset",
      "Randomized twin datasets on Dask, stored as zarr: `tac3d dataset generate --spec SPEC --out "
      "DIR --episodes N [--workers K | --scheduler tcp://HOST:PORT]`, `tac3d dataset verify DIR` "
      "(docs/datasets.md; `tac3d dataset generate --help` lists the options)");
  // Everything after `dataset` is the Python command's, --help included.
  cmd->prefix_command();
  cmd->set_help_flag();
  cmd->callback([cmd] { ExecPythonModule(cmd->remaining()); });
}

}  // namespace tac3d::cli
