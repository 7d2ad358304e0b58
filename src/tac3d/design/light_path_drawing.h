#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "tac3d/design/light_path_design.h"

namespace tac3d {

/// The design's cross-section (paper Fig. 4, both halves): the fingertip and glass, the
/// four mirrors, the four beams, the real camera and the two virtual cameras with their
/// sight lines to the centre mark. Drawn once as shapes in the x-z plane (mm), then
/// written as SVG or PNG.
class LightPathDrawing {
 public:
  LightPathDrawing(const LightPathRoot& root, const SensorConfig& config);

  std::string ToSvg() const;
  /// Writes an SVG file. @throws Error if the file cannot be written.
  void WriteSvg(const std::string& path) const;
  /// Writes a PNG `width_px` wide. @throws Error if the file cannot be written.
  void WritePng(const std::string& path, int width_px = 1200) const;

 private:
  struct Shape {
    std::vector<Eigen::Vector2d> points;  // x, z in mm
    std::string colour;                   // "#rrggbb"
    double width_mm = 0.3;
    bool closed = false;
    bool dashed = false;
  };
  struct Label {
    Eigen::Vector2d at;
    std::string text;
  };
  void Add(std::vector<Eigen::Vector2d> points, std::string colour, double width_mm,
           bool closed = false, bool dashed = false);

  std::vector<Shape> shapes_;
  std::vector<Label> labels_;
  Eigen::Vector2d min_, max_;
};

}  // namespace tac3d
