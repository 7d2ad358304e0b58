#include "tac3d/vendor_formats/vendor_gel.h"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/vendor_stereo.h"

namespace tac3d {

void VendorGelOptions::Validate() const {
  if (!(std::isfinite(marker_depth_mm) && marker_depth_mm > 0.0)) {
    throw Error(fmt::format("VendorGelOptions.marker_depth_mm must be > 0, got {}", marker_depth_mm));
  }
  if (!std::isfinite(base_offset_mm)) {
    throw Error(fmt::format("VendorGelOptions.base_offset_mm must be finite, got {}", base_offset_mm));
  }
  if (!(std::isfinite(base_diameter_mm) && base_diameter_mm >= 0.0)) {
    throw Error(fmt::format("VendorGelOptions.base_diameter_mm must be >= 0 (0: where the markers' sphere "
                            "meets the base), got {}",
                            base_diameter_mm));
  }
  if (!(refinement >= 0.25 && refinement <= 4.0)) {
    throw Error(fmt::format("VendorGelOptions.refinement must be in [0.25, 4], got {}", refinement));
  }
}

nlohmann::json ToJson(const VendorGelOptions& options) {
  return {{"marker_depth_mm", options.marker_depth_mm},
          {"base_offset_mm", options.base_offset_mm},
          {"base_diameter_mm", options.base_diameter_mm},
          {"refinement", options.refinement}};
}

fem::BodyModelOptions VendorBodyModelOptions(const SensorConfig& config, const VendorGelOptions& options) {
  options.Validate();
  const VendorStereo stereo(config);  // throws without a vendor camera model
  const VendorCameraModelConfig& model = *config.vendor_camera;
  const DomeFitConfig& dome = model.dome;

  fem::BodyModelOptions body;
  for (const Triangulation& t : stereo.TriangulateReference()) {
    if (!t.valid) {
      throw Error(fmt::format("the gel of sensor '{}': reference marker {} cannot be triangulated",
                              model.serial_number, body.marker_positions_mm.size()));
    }
    body.marker_positions_mm.push_back(t.point);
  }
  // The base is horizontal; a tilted refraction plane is met under the dome's axis.
  const Eigen::Vector3d normal = model.refraction.Normal();
  const double plane_z_at_axis =
      model.refraction.height_mm - normal.head<2>().dot(dome.center_mm.head<2>()) / normal.z();
  body.base_center_mm = Eigen::Vector3d(dome.center_mm.x(), dome.center_mm.y(), plane_z_at_axis + options.base_offset_mm);
  const double center_below_base = body.base_center_mm.z() - dome.center_mm.z();
  body.sphere_radius_mm = dome.radius_mm + options.marker_depth_mm;
  body.thickness_mm = body.sphere_radius_mm - center_below_base;
  if (options.base_diameter_mm > 0.0) {
    body.base_diameter_mm = options.base_diameter_mm;
  } else {
    if (!(center_below_base < dome.radius_mm)) {
      throw Error(fmt::format("the gel of sensor '{}': the markers' sphere (radius {} mm) does not reach the base "
                              "{} mm above its centre",
                              model.serial_number, dome.radius_mm, center_below_base));
    }
    body.base_diameter_mm = 2.0 * std::sqrt(dome.radius_mm * dome.radius_mm - center_below_base * center_below_base);
  }
  body.lateral_boundary = config.elastic_body.lateral_face == LateralFace::kFixed ? fem::LateralBoundary::kFixed
                                                                                   : fem::LateralBoundary::kFree;
  body.material.youngs_modulus_mpa = config.elastic_body.youngs_modulus_mpa;
  body.material.poisson_ratio = config.elastic_body.poisson_ratio;
  body.marker_rows = config.markers.rows;
  body.marker_cols = config.markers.cols;
  body.marker_pitch_mm = dome.pitch_mm;
  body.marker_depth_mm = options.marker_depth_mm;
  body.refinement = options.refinement;
  body.Validate();
  return body;
}

fem::BodyModelOptions SensorBodyModelOptions(const SensorConfig& config) {
  return config.vendor_camera ? VendorBodyModelOptions(config) : fem::BodyModelOptionsFromSensor(config);
}

std::string DescribeVendorGel(const fem::BodyModelOptions& body, const VendorGelOptions& options) {
  return fmt::format(
      "gel: {:.3f} mm thick on the axis (outer sphere radius {:.3f} mm = the markers' fitted sphere + {:.2f} mm "
      "marker depth), flat base {:.2f} mm across {} at z = {:.3f} mm ({}), lateral face {}; E {} MPa, nu {}; "
      "mesh refinement {}",
      body.thickness_mm, body.sphere_radius_mm, options.marker_depth_mm, body.base_diameter_mm,
      options.base_diameter_mm > 0.0 ? "(given)" : "(where the markers' sphere meets it)", body.base_center_mm.z(),
      options.base_offset_mm == 0.0 ? "the refraction plane" : fmt::format("the refraction plane {:+.2f} mm", options.base_offset_mm),
      body.lateral_boundary == fem::LateralBoundary::kFixed ? "fixed" : "free", body.material.youngs_modulus_mpa,
      body.material.poisson_ratio, body.refinement);
}

}  // namespace tac3d
