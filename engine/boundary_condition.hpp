// Boundary conditions on real particles (seed eqs. 1c-1d; DESIGN.md section 4).
// A condition prescribes either the velocity vector or the traction vector
// t = sigma . n, each component a function of time. Particles carry the index of
// their condition in ParticleSet::boundary.
#pragma once

#include "engine/time_function.hpp"

#include <array>
#include <string>

namespace tsph {

template <int Dim>
struct BoundaryCondition {
  enum class Kind { velocity, traction };

  Kind kind = Kind::traction;
  std::array<TimeFunction, Dim> value = filled(TimeFunction::constant(0.0));
  std::string name;

  /// Prescribed velocity vector v(t) = (f_0(t), ..., f_Dim-1(t)).
  static BoundaryCondition velocity(std::array<TimeFunction, Dim> components, std::string name) {
    return {Kind::velocity, std::move(components), std::move(name)};
  }
  /// Held at rest: v = 0.
  static BoundaryCondition fixed(std::string name) {
    return velocity(filled(TimeFunction::constant(0.0)), std::move(name));
  }
  /// Prescribed traction vector t(t) = sigma . n.
  static BoundaryCondition traction(std::array<TimeFunction, Dim> components, std::string name) {
    return {Kind::traction, std::move(components), std::move(name)};
  }
  /// Zero traction.
  static BoundaryCondition free(std::string name) {
    return traction(filled(TimeFunction::constant(0.0)), std::move(name));
  }

  static std::array<TimeFunction, Dim> filled(const TimeFunction& f) {
    if constexpr (Dim == 1) return {f};
    else if constexpr (Dim == 2) return {f, f};
    else return {f, f, f};
  }
};

}  // namespace tsph
