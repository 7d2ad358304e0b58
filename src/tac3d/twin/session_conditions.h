#pragma once

#include <Eigen/Core>
#include <string_view>

namespace tac3d {

/// What the twin's camera and gel look like at one moment of a session: the truth of each
/// nuisance for one frame (SessionConditions::At). The defaults are the nominal twin.
struct FrameConditions {
  double illumination_gain = 1.0;    ///< LED output relative to the session's start
  double illumination_offset = 0.0;  ///< stray light added, fraction of the 8-bit full scale
  /// LED output change from the image's left edge to its right (fraction; 0 at the centre).
  double illumination_gradient = 0.0;
  double dot_contrast = 1.0;  ///< fraction of a marker's nominal darkening it still has
  double exposure = 1.0;      ///< exposure relative to the session's start
  /// Every marker's drift at rest (creep of the gel), sensor frame, mm.
  Eigen::Vector3d creep_mm = Eigen::Vector3d::Zero();
};

/// One nuisance of a session, to measure each alone (SessionConditions::Only).
enum class Nuisance {
  kIlluminationGain,
  kIlluminationOffset,
  kIlluminationGradient,
  kContrastFade,
  kExposureDrift,
  kCreep,
};
inline constexpr Nuisance kAllNuisances[] = {Nuisance::kIlluminationGain,
                                             Nuisance::kIlluminationOffset,
                                             Nuisance::kIlluminationGradient,
                                             Nuisance::kContrastFade,
                                             Nuisance::kExposureDrift,
                                             Nuisance::kCreep};
/// snake_case, as the option's name ("illumination_gain", ..., "creep").
std::string_view ToString(Nuisance nuisance);

/// The twin's nuisances over a session: what changes on a real sensor while it
/// runs. Each ramps linearly from nothing at t = 0 to its level at `session_s` and is held
/// after it, so every frame has its own truth (At). The default is no nuisance;
/// Realistic() gives the levels docs/render.md derives ("Session conditions").
struct SessionConditions {
  double session_s = 600.0;          ///< the ramps' duration, s (> 0)
  double illumination_gain = 1.0;    ///< LED output at the end, x the start's (in (0, 2])
  double illumination_offset = 0.0;  ///< stray light at the end, fraction of full scale ([0, 0.5])
  double illumination_gradient = 0.0;  ///< left-to-right LED output change at the end ((-1, 1))
  double contrast_fade = 0.0;   ///< fraction of the markers' darkening lost at the end ([0, 1))
  double exposure_drift = 0.0;  ///< exposure x (1 + this) at the end ((-1, 1])
  double creep_mm = 0.0;        ///< markers' drift at rest at the end, mm ([0, 1])
  /// Direction of the creep (sensor frame; normalised): -z, the gel settling onto its base.
  Eigen::Vector3d creep_direction = -Eigen::Vector3d::UnitZ();

  /// The documented realistic levels over a 10-minute session.
  static SessionConditions Realistic();

  /// @throws Error naming the field and the bound.
  void Validate() const;
  /// These conditions with every nuisance but `nuisance` at nothing (same session_s).
  SessionConditions Only(Nuisance nuisance) const;
  /// The conditions at time t_s (s since the session's start; clamped to [0, session_s]).
  FrameConditions At(double t_s) const;
};

}  // namespace tac3d
