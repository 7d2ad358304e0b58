#include "tac3d/friction/command_options.h"

#include <algorithm>

#include "tac3d/util/error.h"

namespace tac3d::friction {

std::string FrictionMapCommandOption::Flag() const {
  std::string flag = "--" + name;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

const std::vector<FrictionMapCommandOption>& FrictionMapCommandOptions() {
  using O = FrictionMapOptions;
  static const std::vector<FrictionMapCommandOption> options = {
      {"contact_threshold",
       &O::contact_threshold_n,
       "contact_threshold_n",
       "contact marker's normal force, N"},
      {"slip_contact_threshold",
       &O::slip_contact_threshold_n,
       "slip_contact_threshold_n",
       "normal force of a marker for slip detection, N (< 0: the contact threshold)"},
      {"tangential_motion",
       &O::tangential_motion,
       "tangential_motion",
       "slip by the motion in the tangent plane (false: the paper's 3D motion)"},
      {"gross_slip_only",
       &O::gross_slip_only,
       "gross_slip_only",
       "only slip points of frames in steady gross slip vote for mu (false: the paper's, every "
       "slip point)"},
      {"friction_along_slip",
       &O::friction_along_slip,
       "friction_along_slip",
       "mu_i from the tangential force's component against the slip (false: the paper's |F_t| / "
       "F_n)"},
      {"gross_slip_margin",
       &O::gross_slip_margin,
       "gross_slip_margin",
       "frames on either side that must be in steady gross slip too"},
      {"slip_sigmas", &O::slip_sigmas, "slip_sigmas", "k of the slip threshold"},
      {"marker_noise",
       &O::marker_noise_mm,
       "marker_noise_mm",
       "per-axis marker position noise, mm"},
      {"pose_noise",
       &O::pose_noise_mm,
       "pose_noise_mm",
       "per-axis noise of the poses at the markers, frame to frame, mm (0: exact poses)"},
      {"radius", &O::radius_mm, "radius_mm", "r of equations 5 and 6, mm"},
      {"alpha", &O::alpha, "alpha", "(r - r_i) exponent of the weights (equation 6)"},
      {"beta", &O::beta, "beta", "mu_i exponent of the weights (the paper's: 2)"},
      {"gamma",
       &O::normal_force_exponent,
       "normal_force_exponent",
       "F_n exponent of the weights (the paper's: 0; 1 with beta 0: the ratio of the summed "
       "forces)"},
      {"min_slip_points",
       &O::min_slip_points,
       "min_slip_points",
       "slip points within r a vertex needs for a mu (the paper's: 1)"},
      {"max_support_offset",
       &O::max_support_offset,
       "max_support_offset",
       "a vertex keeps mu unknown when its slip points' weighted centre lies farther than this "
       "fraction of r from it (the paper's: 1, no such test)"},
      {"voxel", &O::voxel_size_mm, "voxel_size_mm", "resampling voxel, mm"},
      {"depth", &O::poisson_depth, "poisson_depth", "Poisson octree depth"},
      {"poisson_scale",
       &O::poisson_scale,
       "poisson_scale",
       "Poisson cube over the cloud's bounding box"},
      {"trim_distance",
       &O::trim_distance_mm,
       "trim_distance_mm",
       "mesh vertices farther than this from every resampled point are dropped, mm"},
      {"threads",
       &O::num_threads,
       "num_threads",
       "threads of the Poisson reconstruction (0: one a core)"},
  };
  return options;
}

const FrictionMapCommandOption* FindFrictionMapCommandOption(std::string_view name) {
  for (const FrictionMapCommandOption& option : FrictionMapCommandOptions()) {
    if (option.name == name) return &option;
  }
  return nullptr;
}

std::string FrictionMapCommandOptionNames() {
  std::string names;
  for (const FrictionMapCommandOption& option : FrictionMapCommandOptions()) {
    names += (names.empty() ? "" : ", ") + option.name;
  }
  return names;
}

void ValidateCommandOptions(const FrictionMapOptions& options, OptionNaming naming) {
  try {
    options.Validate();
  } catch (const Error& e) {
    const std::string_view message = e.what();
    for (const FrictionMapCommandOption& option : FrictionMapCommandOptions()) {
      const std::string field = "FrictionMapOptions." + option.field_name + " =";
      if (message.substr(0, field.size()) == field) {
        throw Error((naming == OptionNaming::kFlag ? option.Flag() : option.name) +
                    std::string(message.substr(field.size() - 2)));
      }
    }
    throw;
  }
}

FrictionMapOptions CommandFrictionMapDefaults() {
  FrictionMapOptions o;
  o.beta = 0.0;
  o.normal_force_exponent = 1.0;
  o.min_slip_points = 30;
  o.max_support_offset = 0.3;
  o.slip_contact_threshold_n = 0.005;
  o.tangential_motion = true;
  o.gross_slip_only = true;
  o.friction_along_slip = true;
  return o;
}

}  // namespace tac3d::friction
