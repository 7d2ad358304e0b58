#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "tac3d/contact/compliance.h"
#include "tac3d/geometry/geometry.h"
#include "tac3d/scene/scene.h"

namespace tac3d::simulation {

/// Where a line enters an object: the parameter t (mm along the unit direction from the
/// line's origin; negative when the origin is inside) and the entry point in the object frame.
struct LineEntry {
  double t_mm = 0.0;
  Eigen::Vector3d p_object = Eigen::Vector3d::Zero();
};

/// The entry of the line origin + t direction (object frame, direction unit length) into an
/// analytic object (every shape but kMesh), closed forms: sphere (quadratic), cylinder
/// (infinite cylinder about y within |y| <= length / 2), flat punch (cylinder about z, z >= 0;
/// a rounded edge in closed form along the axis, else marched by its signed distance),
/// pins (flat punches at ((c - (cols - 1) / 2) pitch, (r - (rows - 1) / 2) pitch, 0), the first
/// entered), box (slabs). Of the intervals where the line is inside, the first that ends ahead
/// of the origin (exit t > 0) counts; nullopt if there is none or it has no finite entry.
/// @pre object.shape != kMesh (TAC3D_DEMAND).
std::optional<LineEntry> IntersectAnalyticObject(const SceneObject& object,
                                                 const Eigen::Vector3d& origin_object,
                                                 const Eigen::Vector3d& direction_object);

/// The gap and friction each contact node sees at one pose.
struct GapField {
  /// Signed distance (mm) along the sensor's +z from the node's surface point to the nearest
  /// object's surface: negative = penetration, +infinity where nothing is ahead.
  Eigen::VectorXd gap_mm;
  /// mu of the nearest object at the entry point (its FrictionAt), 0 where nothing is ahead.
  Eigen::VectorXd friction_coefficient;
  /// The nearest object's index, -1 where nothing is ahead.
  std::vector<int> object;
};

/// Casts the line along the sensor's +z from every active node's surface point against every
/// object of a scene (TwinBodyModel's shallow-dome assumption: the contact normal is +z).
/// Analytic shapes use IntersectAnalyticObject; a mesh is rasterised into the grid (z-buffer):
/// each triangle, in the sensor frame, over the nodes inside its (x, y) footprint; triangles
/// whose outward normal (counter-clockwise winding) points along -z are entries, the others
/// exits, and the first entry whose following exit is ahead counts.
class GapCaster {
 public:
  /// @param surface_points_mm node surface points (sensor frame), one a node of `grid`.
  /// @param active nodes that can touch; the others get +infinity.
  GapCaster(const std::vector<SceneObject>& objects,
            const contact::SurfaceGrid& grid,
            std::vector<Eigen::Vector3d> surface_points_mm,
            std::vector<bool> active);

  GapField Cast(const Rigid3& world_from_sensor) const;

 private:
  void CastMesh(const SceneObject& object, const Rigid3& sensor_from_object) const;

  std::vector<SceneObject> objects_;
  contact::SurfaceGrid grid_;
  std::vector<Eigen::Vector3d> points_;
  std::vector<bool> active_;
  // Per node (t, entering) crossings of the mesh being cast (reused).
  mutable std::vector<std::vector<std::pair<double, bool>>> crossings_;
};

}  // namespace tac3d::simulation
