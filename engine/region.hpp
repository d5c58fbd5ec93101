// Regions that select real particles for boundary conditions: an axis-aligned box,
// a half-space (a plane with a side), or a group number (from a particle file).
// Selection uses the initial positions, so it does not depend on the motion.
#pragma once

#include "engine/particle_set.hpp"

#include <cstdint>
#include <stdexcept>
#include <string>

namespace tsph {

template <int Dim>
struct Region {
  enum class Kind { box, half_space, group };
  Kind kind = Kind::box;
  std::string name;
  Vector<Dim> lower = Vector<Dim>::Zero(), upper = Vector<Dim>::Zero();  ///< box (inclusive)
  Vector<Dim> point = Vector<Dim>::Zero(), normal = Vector<Dim>::Zero();  ///< half-space
  std::int32_t group = 0;

  /// All x with lower <= x <= upper, widened by `tolerance` on every side.
  static Region box(std::string name, const Vector<Dim>& lower, const Vector<Dim>& upper) {
    Region r;
    r.kind = Kind::box;
    r.name = std::move(name);
    r.lower = lower;
    r.upper = upper;
    return r;
  }
  /// All x with (x - point) . normal >= -tolerance: the side the normal points to.
  static Region half_space(std::string name, const Vector<Dim>& point, const Vector<Dim>& normal) {
    if (!(normal.norm() > 0.0))
      throw std::invalid_argument("region '" + name + "': the plane normal must be non-zero");
    Region r;
    r.kind = Kind::half_space;
    r.name = std::move(name);
    r.point = point;
    r.normal = normal.normalized();
    return r;
  }
  static Region of_group(std::string name, std::int32_t group) {
    Region r;
    r.kind = Kind::group;
    r.name = std::move(name);
    r.group = group;
    return r;
  }

  bool contains(const Vector<Dim>& x, std::int32_t particle_group, double tolerance) const {
    switch (kind) {
      case Kind::box:
        return ((x - lower).array() >= -tolerance).all() && ((upper - x).array() >= -tolerance).all();
      case Kind::half_space: return (x - point).dot(normal) >= -tolerance;
      case Kind::group: return particle_group == group;
    }
    return false;
  }
};

/// Assigns boundary condition `condition` to every real particle in `region` (later
/// assignments override earlier ones). Returns the count; throws if it is zero.
template <int Dim>
std::size_t assign_boundary(ParticleSet<Dim>& set, const Region<Dim>& region,
                            std::int32_t condition, double tolerance) {
  std::size_t selected = 0;
  for (std::size_t i = 0; i < set.size(); ++i) {
    Vector<Dim> x0;
    for (int d = 0; d < Dim; ++d) x0[d] = set.initial_position[d][i];
    if (region.contains(x0, set.group[i], tolerance)) {
      set.boundary[i] = condition;
      ++selected;
    }
  }
  if (selected == 0)
    throw std::invalid_argument("region '" + region.name +
                                "' selects no particle: check its bounds against the geometry");
  return selected;
}

}  // namespace tsph
