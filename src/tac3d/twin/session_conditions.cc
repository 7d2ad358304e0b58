#include "tac3d/twin/session_conditions.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

constexpr OptionCheck Require("session conditions");

}  // namespace

SessionConditions SessionConditions::Realistic() {
  // Where each level comes from: docs/render.md, "Session conditions".
  SessionConditions c;
  c.session_s = 600.0;
  c.illumination_gain = 0.92;
  c.illumination_offset = 0.02;
  c.illumination_gradient = 0.10;
  c.contrast_fade = 0.10;
  c.exposure_drift = -0.05;
  c.creep_mm = 0.02;
  return c;
}

void SessionConditions::Validate() const {
  Require(session_s > 0 && std::isfinite(session_s), "session_s", "> 0 and finite", session_s);
  Require(illumination_gain > 0 && illumination_gain <= 2,
          "illumination_gain",
          "in (0, 2]",
          illumination_gain);
  Require(illumination_offset >= 0 && illumination_offset <= 0.5,
          "illumination_offset",
          "in [0, 0.5]",
          illumination_offset);
  Require(std::abs(illumination_gradient) < 1,
          "illumination_gradient",
          "in (-1, 1)",
          illumination_gradient);
  Require(contrast_fade >= 0 && contrast_fade < 1, "contrast_fade", "in [0, 1)", contrast_fade);
  Require(
      exposure_drift > -1 && exposure_drift <= 1, "exposure_drift", "in (-1, 1]", exposure_drift);
  Require(creep_mm >= 0 && creep_mm <= 1, "creep_mm", "in [0, 1]", creep_mm);
  Require(creep_direction.allFinite() && creep_direction.norm() > 1e-9,
          "|creep_direction|",
          "> 0 and finite",
          creep_direction.norm());
}

std::string_view ToString(Nuisance nuisance) {
  switch (nuisance) {
    case Nuisance::kIlluminationGain:
      return "illumination_gain";
    case Nuisance::kIlluminationOffset:
      return "illumination_offset";
    case Nuisance::kIlluminationGradient:
      return "illumination_gradient";
    case Nuisance::kContrastFade:
      return "contrast_fade";
    case Nuisance::kExposureDrift:
      return "exposure_drift";
    case Nuisance::kCreep:
      return "creep";
  }
  TAC3D_DEMAND(false);
}

SessionConditions SessionConditions::Only(Nuisance nuisance) const {
  SessionConditions one;
  one.session_s = session_s;
  switch (nuisance) {
    case Nuisance::kIlluminationGain:
      one.illumination_gain = illumination_gain;
      break;
    case Nuisance::kIlluminationOffset:
      one.illumination_offset = illumination_offset;
      break;
    case Nuisance::kIlluminationGradient:
      one.illumination_gradient = illumination_gradient;
      break;
    case Nuisance::kContrastFade:
      one.contrast_fade = contrast_fade;
      break;
    case Nuisance::kExposureDrift:
      one.exposure_drift = exposure_drift;
      break;
    case Nuisance::kCreep:
      one.creep_mm = creep_mm;
      one.creep_direction = creep_direction;
      break;
  }
  return one;
}

FrameConditions SessionConditions::At(double t_s) const {
  const double s = std::clamp(t_s / session_s, 0.0, 1.0);
  FrameConditions c;
  c.illumination_gain = 1.0 + s * (illumination_gain - 1.0);
  c.illumination_offset = s * illumination_offset;
  c.illumination_gradient = s * illumination_gradient;
  c.dot_contrast = 1.0 - s * contrast_fade;
  c.exposure = 1.0 + s * exposure_drift;
  c.creep_mm = s * creep_mm * creep_direction.normalized();
  return c;
}

}  // namespace tac3d
