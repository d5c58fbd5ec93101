// Boundary conditions on real particles (seed eqs. 1c-1d; docs/method.md section 4).
// A condition prescribes either the velocity vector or the traction vector
// t = sigma . n, or (symmetry) the normal velocity and the tangential traction, both zero. Component k of the prescribed vector at particle I and time t is
//   time[k](t) * profile(x_I^0)[k],
// a time function times a spatial profile evaluated once at the particle's initial
// position (uniform by default; the cantilever's parabolic shear is a profile).
// A velocity condition may instead give a field v(x^0, t) that is not such a product
// (a rigid rotation, for example).
// Particles carry the index of their condition in ParticleSet::boundary.
#pragma once

#include "engine/particle_set.hpp"
#include "engine/time_function.hpp"

#include <algorithm>
#include <array>
#include <functional>
#include <cstdint>
#include <string>
#include <vector>

namespace tsph {

template <int Dim>
struct BoundaryCondition {
  /// symmetry: zero normal velocity and zero tangential traction on a plane (a roller,
  /// a frictionless rigid wall; issue 16), the plane's normal the particles' face normal;
  /// with a velocity, a smooth wall moving with it (its normal part imposed: a footing).
  /// mirror: a plane the solution is symmetric about (a quarter model's cut), modelled
  /// by ghost particles, the owned particles' images across it
  /// (solver/boundary/mirror_planes.hpp); no particle carries it.
  enum class Kind { velocity, traction, symmetry, mirror };
  using Profile = std::function<Vector<Dim>(const Vector<Dim>&)>;

  Kind kind = Kind::traction;
  std::array<TimeFunction, Dim> time = filled(TimeFunction::constant(0.0));
  Profile profile = [](const Vector<Dim>&) { return Vector<Dim>::Ones().eval(); };
  std::string name;
  /// Optional velocity field v(x0, t) (velocity conditions only): replaces time x profile.
  std::function<Vector<Dim>(const Vector<Dim>&, double)> field;
  /// Symmetry conditions only: the ids (ParticleSet::id) of the particles in this
  /// plane's region that carry another condition (a later one of the case: an edge
  /// where two planes meet, a free surface or a wall crossing the plane). They keep to
  /// this plane as well (solver/boundary/symmetry_planes.hpp): a quarter model's axis
  /// lies on two planes, its corner on three.
  std::vector<std::uint32_t> also_on_plane;
  /// Mirror conditions only: a point of the plane and its unit normal, pointing out of
  /// the body (the body lies on the side (x - point) . normal <= 0).
  Vector<Dim> plane_point = Vector<Dim>::Zero();
  Vector<Dim> plane_normal = Vector<Dim>::Zero();

  /// Whether the prescribed vector is zero at all times (a fixed wall or plane, a free
  /// surface): every time function zero and no field.
  bool prescribes_zero() const {
    return !field && std::all_of(time.begin(), time.end(), [](const TimeFunction& f) { return f.is_zero(); });
  }

  /// A smooth wall that moves (a symmetry condition with a velocity: a footing).
  bool moving_smooth_wall() const { return kind == Kind::symmetry && !prescribes_zero(); }

  /// The prescribed vector at a particle of initial position x0, with profile(x0) given.
  Vector<Dim> prescribed(const Vector<Dim>& x0, const Vector<Dim>& profile_at_x0, double t) const {
    if (field) return field(x0, t);
    Vector<Dim> value;
    for (int d = 0; d < Dim; ++d) value[d] = time[static_cast<std::size_t>(d)](t) * profile_at_x0[d];
    return value;
  }

  /// Prescribed velocity vector v(t) = (f_0(t), ..., f_Dim-1(t)) [x profile(x0)].
  static BoundaryCondition velocity(std::array<TimeFunction, Dim> components, std::string name,
                                    Profile profile = uniform()) {
    return {Kind::velocity, std::move(components), std::move(profile), std::move(name), {}, {}};
  }
  /// Prescribed velocity field v(x0, t) of the initial position and time.
  static BoundaryCondition velocity_field(std::function<Vector<Dim>(const Vector<Dim>&, double)> field,
                                          std::string name) {
    BoundaryCondition c = velocity(filled(TimeFunction::constant(0.0)), std::move(name));
    c.field = std::move(field);
    return c;
  }
  /// Held at rest: v = 0.
  static BoundaryCondition fixed(std::string name) {
    return velocity(filled(TimeFunction::constant(0.0)), std::move(name));
  }
  /// Prescribed traction vector t(t) = sigma . n [x profile(x0)].
  static BoundaryCondition traction(std::array<TimeFunction, Dim> components, std::string name,
                                    Profile profile = uniform()) {
    return {Kind::traction, std::move(components), std::move(profile), std::move(name), {}, {}};
  }
  /// A symmetry plane (see Kind::symmetry), or a smooth rigid wall moving with the
  /// velocity `components` (only its normal part is imposed).
  static BoundaryCondition symmetry(std::string name, std::array<TimeFunction, Dim> components =
                                                          filled(TimeFunction::constant(0.0))) {
    return {Kind::symmetry, std::move(components), uniform(), std::move(name), {}, {}};
  }
  /// A fixed plane of mirror symmetry through `point` with outward normal `normal`
  /// (normalised here).
  static BoundaryCondition mirror(std::string name, const Vector<Dim>& point, const Vector<Dim>& normal) {
    BoundaryCondition c = symmetry(std::move(name));
    c.kind = Kind::mirror;
    c.plane_point = point;
    c.plane_normal = normal.normalized();
    return c;
  }
  /// Zero traction.
  static BoundaryCondition free(std::string name) {
    return traction(filled(TimeFunction::constant(0.0)), std::move(name));
  }

  static Profile uniform() {
    return [](const Vector<Dim>&) { return Vector<Dim>::Ones().eval(); };
  }
  static std::array<TimeFunction, Dim> filled(const TimeFunction& f) {
    if constexpr (Dim == 1) return {f};
    else if constexpr (Dim == 2) return {f, f};
    else return {f, f, f};
  }
};

}  // namespace tsph
