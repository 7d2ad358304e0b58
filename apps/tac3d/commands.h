#pragma once

#include <functional>
#include <initializer_list>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>
#include <utility>

#include "tac3d/pipeline/drift_monitor.h"  // DriftMode, for AddDriftOption
#include "tac3d/sensor/default_sensor.h"  // LoadSensorOrDefault, for the commands
#include "tac3d/sensor/sensor_config.h"
#include "tac3d/util/file_io.h"  // MakeDirectory, DefaultCacheDir, MakeCacheDirectory
#include "tac3d/util/seconds_since.h"  // the commands' timings

namespace CLI {
class App;
}  // namespace CLI

namespace tac3d::cli {

/// Each subcommand adds itself to the app; its callback does the work and may throw
/// tac3d::Error, which main() reports as a one-line error and exit code 1.
void RegisterDesign(CLI::App& app);
void RegisterRender(CLI::App& app);
void RegisterCalibrate(CLI::App& app);
void RegisterDemo(CLI::App& app);
void RegisterBuildModel(CLI::App& app);
void RegisterRun(CLI::App& app);
void RegisterSimulate(CLI::App& app);
void RegisterCalibrateForce(CLI::App& app);
void RegisterRecording(CLI::App& app);  // recording_command.cc: `tac3d recording info|export`
void RegisterFrictionMap(CLI::App& app);
void RegisterView(CLI::App& app);  // view_command.cc: `tac3d view`
void RegisterImportVendor(CLI::App& app);  // vendor_command.cc: `tac3d import-vendor`
void RegisterTrack(CLI::App& app);  // track_command.cc: `tac3d track`
void RegisterDataset(CLI::App& app);  // dataset_command.cc: `tac3d dataset` (Python, Dask)

/// `tac3d eval <what>`: accuracy evaluations against the twin's truth or analytic oracles,
/// each printing its figures (JSON with --json). Each adds itself to the `eval` group.
void RegisterEval(CLI::App& app);
void RegisterEvalRender(CLI::App& eval);
void RegisterEvalCalibration(CLI::App& eval);
void RegisterEvalFem(CLI::App& eval);
void RegisterEvalContact(CLI::App& eval);
void RegisterEvalForce(CLI::App& eval);
void RegisterEvalReplay(CLI::App& eval);
void RegisterEvalConditions(CLI::App& eval);
void RegisterEvalFriction(CLI::App& eval);
void RegisterEvalIncipient(CLI::App& eval);  // eval_incipient_command.cc
void RegisterEvalVendor(CLI::App& eval);  // vendor_command.cc

/// @throws Error naming the first of `names` given on `cmd`'s command line, with `why`.
void RefuseOptions(const CLI::App& cmd,
                   std::initializer_list<const char*> names,
                   const std::string& why);

/// Runs an options' Validate() and, if it throws, throws the same message with the options
/// field that starts it replaced by the flag that sets it, so the user reads the flag they
/// typed: {"ReferenceJoinOptions: max_offset_s", "--max-offset"} makes
/// "--max-offset = 1e+09 must be in [0, 600] s" of the library's message.
void ValidateNamingFlags(const std::function<void()>& validate,
                         std::initializer_list<std::pair<std::string_view, std::string_view>> flags);

/// `--drift off|flag|rezero` into `mode` (any case), with `help`.
void AddDriftOption(CLI::App* cmd, DriftMode* mode, const std::string& help);

/// Whether a command shows progress on stderr: always without --json; with --json only when
/// stderr is a terminal, so an hours-long `--json` run still shows it is alive while scripts'
/// and CI logs get the JSON alone.
bool ShowProgress(bool json);

/// Prints an evaluation's checks ([{name, value, unit, tolerance, pass}]), one line each.
void PrintChecks(const nlohmann::json& checks);

}  // namespace tac3d::cli
