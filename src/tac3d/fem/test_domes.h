#pragma once

// Test-only helpers shared by the fem module's tests (not part of the library, not installed).

#include "tac3d/fem/body_model.h"

namespace tac3d::testing {

/// A dome small enough to factor in a fraction of a second (12 mm base, 3 mm thick, 20 mm
/// sphere). The default 3 x 4 markers (rows != cols) make a mix-up of rows and columns show.
inline fem::BodyModelOptions SmallDome(int marker_rows = 3, int marker_cols = 4) {
  fem::BodyModelOptions options;
  options.base_diameter_mm = 12.0;
  options.thickness_mm = 3.0;
  options.sphere_radius_mm = 20.0;
  options.marker_rows = marker_rows;
  options.marker_cols = marker_cols;
  return options;
}

}  // namespace tac3d::testing
