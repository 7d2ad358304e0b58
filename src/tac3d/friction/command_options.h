#pragma once

// The friction map's options as the commands take them: `tac3d friction-map`, `tac3d eval
// friction` and Python's tac3d.friction_map register the same names with the same defaults
// from this one list, so the CLI and Python cannot drift apart.
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "tac3d/friction/friction_map.h"

namespace tac3d::friction {

/// One option of the commands: its name and the FrictionMapOptions field it sets.
struct FrictionMapCommandOption {
  /// snake_case: Python's key; the CLI's flag is "--" and the name with '-' for '_'.
  std::string name;
  std::variant<double FrictionMapOptions::*, int FrictionMapOptions::*, bool FrictionMapOptions::*>
      field;
  /// The field's name, as FrictionMapOptions::Validate() names it.
  std::string field_name;
  /// What it does, with its unit and the paper's value where the default differs.
  std::string help;

  /// "--" + name with '-' for '_': --gross-slip-margin for gross_slip_margin.
  std::string Flag() const;
};

/// Every option the commands take, in the CLI's order. cover_thickness_mm is not one: it is
/// the sensor's markers.depth_mm (WithSensor).
const std::vector<FrictionMapCommandOption>& FrictionMapCommandOptions();

/// The option named `name`, or nullptr.
const FrictionMapCommandOption* FindFrictionMapCommandOption(std::string_view name);

/// The options' names, comma-separated, for a message refusing an unknown one.
std::string FrictionMapCommandOptionNames();

/// How ValidateCommandOptions names an option: "--radius" (the CLI) or "radius" (Python).
enum class OptionNaming { kFlag, kName };

/// options.Validate(), its message naming the option as the user gave it rather than the
/// field: "--radius = -1 is out of range: must be > 0 and finite".
/// @throws Error if an option is out of range.
void ValidateCommandOptions(const FrictionMapOptions& options, OptionNaming naming);

/// The commands' defaults: FrictionMapOptions' (the paper's equation 6) except where the twin
/// evaluation found the paper's weighting biased by the force inverse's per-marker noise
/// (docs/friction.md): beta 0 and gamma 1 (the ratio of the summed forces), 30 slip points a
/// vertex and none whose slip points lie to one side (0.3 r), slips detected down to 0.005 N,
/// motion in the tangent plane, only steady gross slip votes, mu_i from the force against the
/// slip. Before WithSensor.
FrictionMapOptions CommandFrictionMapDefaults();

}  // namespace tac3d::friction
