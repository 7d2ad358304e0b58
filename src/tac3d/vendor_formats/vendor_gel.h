#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

#include "tac3d/fem/body_model.h"
#include "tac3d/sensor/sensor_config.h"

namespace tac3d {

/// What tac3d assumes about a real Tac3D's gel where its vendor's calibration is silent
/// (docs/real-sensors.md, "The gel's compliance"). The calibration gives the markers' rest
/// positions (its reference pixels triangulated), the sphere they lie on (the import's dome
/// fit), the refraction plane, E and nu; it gives no thickness, marker depth or gel footprint.
struct VendorGelOptions {
  /// How deep the markers lie under the outer surface (mm): the outer surface is the markers'
  /// fitted sphere grown by this. The vendor states none; tac3d's default marker depth (the
  /// paper's prototype's) is used.
  double marker_depth_mm = MarkerConfig{}.depth_mm;
  /// The gel's flat base is the refraction plane (where the vendor's rays enter the gel) moved
  /// up by this (mm; negative: a thicker gel reaching under the plane).
  double base_offset_mm = 0.0;
  /// The base disc's diameter (mm); 0: where the markers' fitted sphere meets the base plane
  /// (the largest footprint under which every marker keeps gel beneath it).
  double base_diameter_mm = 0.0;
  /// The FEM mesh's refinement (fem::BodyModelOptions::refinement).
  double refinement = 1.0;

  /// @throws Error naming the field: marker_depth_mm > 0, base_diameter_mm >= 0, every value
  ///   finite, refinement in [0.25, 4].
  void Validate() const;
};

nlohmann::json ToJson(const VendorGelOptions& options);

/// The FEM body of a sensor imported by `tac3d import-vendor` (SensorConfig::vendor_camera):
/// a gel on a flat, fixed base in the horizontal plane through the refraction plane's point under
/// the dome's axis (moved by base_offset_mm); its outer surface the dome fit's sphere
/// grown by marker_depth_mm, centred on the fit's centre (the axis is the vertical through
/// it); the lateral face free, at the base diameter; the markers at their reference
/// positions triangulated from the calibration's reference pixels (VendorStereo), pitch the
/// fit's; E and nu from elastic_body (the datasheet's). Nothing comes from a recording.
/// @throws Error if the config has no vendor camera model, a reference marker cannot be
///   triangulated, the options are invalid, or the body they give is (a marker outside the
///   gel: fem::BodyModelOptions::Validate's message).
fem::BodyModelOptions VendorBodyModelOptions(const SensorConfig& config,
                                             const VendorGelOptions& options = {});

/// The FEM body a sensor's compliance model (the pipeline's H) is built from: an imported sensor's
/// gel under VendorGelOptions' defaults (VendorBodyModelOptions) when the config has a vendor camera
/// model, else the designed sensor's (fem::BodyModelOptionsFromSensor).
fem::BodyModelOptions SensorBodyModelOptions(const SensorConfig& config);

/// One line: the gel's shape and how it was chosen (thickness on the axis, outer radius, base
/// diameter and height, marker depth, E, nu, refinement).
std::string DescribeVendorGel(const fem::BodyModelOptions& body, const VendorGelOptions& options);

}  // namespace tac3d
