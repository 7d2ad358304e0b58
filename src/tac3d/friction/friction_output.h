#pragma once

#include <Eigen/Core>
#include <array>
#include <nlohmann/json_fwd.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "tac3d/friction/friction_map.h"

namespace tac3d::friction {

/// The paper's colour bands (section V.B): blue mu <= 0.5, green 0.5 < mu <= 0.8,
/// red mu > 0.8, grey where mu is unknown.
enum class FrictionBand { kUnknown, kLow, kMedium, kHigh };
inline constexpr double kLowBandMaxMu = 0.5;
inline constexpr double kMediumBandMaxMu = 0.8;

/// The band of a friction coefficient (NaN: kUnknown).
FrictionBand BandOf(double mu);
/// The band's colour, RGB: blue (40, 90, 255), green (40, 200, 60), red (230, 40, 40),
/// grey (150, 150, 150).
std::array<std::uint8_t, 3> BandColorRgb(FrictionBand band);

/// Writes the map's mesh as a binary little-endian PLY that MeshLab and Blender open: float
/// x, y, z (mm, world), then per vertex float `mu` (NaN where unknown), float `confidence`
/// (the weight sum of equation 5), int `slip_count` and uchar `red`, `green`, `blue` (the
/// bands of BandColorRgb); faces as `vertex_indices`. Read back with tac3d::ReadPly.
/// @throws Error if the file cannot be written.
void WriteFrictionMapPly(const FrictionMapResult& map, const std::string& path);

/// Writes the slip points as CSV: header `x_mm,y_mm,z_mm,mu,normal_force_n,motion_mm,frame,marker`
/// (world frame; frame is TactileFrame::index, marker the row-major marker index).
/// @throws Error if the file cannot be written.
void WriteSlipPointsCsv(const std::vector<SlipPoint>& slip_points, const std::string& path);

/// An orthographic view of the mesh for WriteFrictionMapPng.
struct RenderOptions {
  /// The direction the camera looks along, world frame (non-zero; normalised).
  Eigen::Vector3d view_direction = -Eigen::Vector3d::UnitZ();
  /// World direction shown upwards (not parallel to view_direction).
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  int width = 800;   ///< pixels, in [16, 8192]
  int height = 600;  ///< pixels, in [16, 8192]
  /// Fraction of the image left blank around the mesh, each side (in [0, 0.45]).
  double margin = 0.05;
  /// Lambert shading: colour * (ambient + (1 - ambient) |n . l|), l = view_direction
  /// (in [0, 1]).
  double ambient = 0.3;
  /// A title, the bands' colour bar with its mu scale, and axes in mm along the image's right
  /// and up directions around the mesh; needs an image of at least 400 x 300.
  bool annotate = true;

  /// @throws Error naming the field and its bound.
  void Validate() const;
};

/// What WriteFrictionMapPng drew.
struct RenderSummary {
  int covered_pixels = 0;  ///< pixels the mesh covers
  /// Covered pixels by band, indexed by FrictionBand (kUnknown, kLow, kMedium, kHigh).
  std::array<int, 4> band_pixels = {0, 0, 0, 0};
};

/// Renders the mesh coloured by band (the nearest vertex's band on each pixel) with a
/// z-buffer and Lambert shading, white background, annotated (RenderOptions::annotate), and
/// writes it as PNG.
/// @throws Error if the options are invalid, the map has no triangle, or the file cannot be
///   written.
RenderSummary WriteFrictionMapPng(const FrictionMapResult& map,
                                  const std::string& path,
                                  const RenderOptions& options = {});

/// Writes slip_points.csv, and when the map has a mesh map.ply and map.png (WriteFrictionMapPng
/// along `view`), into `folder` (made if missing); returns what was written (the files, the
/// render's pixels by band) as JSON.
/// @throws Error if a file cannot be written or the view is invalid.
nlohmann::json WriteFrictionMapFiles(const FrictionMapResult& map,
                                     const std::string& folder,
                                     const RenderOptions& view);

/// The friction map's outputs as `tac3d friction-map` and the demo write them: the files
/// (WriteFrictionMapFiles) and summary.json, which holds `inputs` (what the map was built
/// from: dataset or recording, gains, strokes, frames) with "options" (as used), "map" (the
/// summary) and "files" added. Returns that summary.
/// @throws Error as WriteFrictionMapFiles, or if summary.json cannot be written.
nlohmann::json WriteFrictionMapOutputs(const FrictionMapResult& map,
                                       const FrictionMapOptions& options,
                                       const std::string& folder,
                                       const RenderOptions& view,
                                       nlohmann::json inputs);

}  // namespace tac3d::friction
