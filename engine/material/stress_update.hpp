// The input of a material model's stress update (material/material.hpp).
#pragma once

#include "engine/material/stress.hpp"
#include "engine/particle_set.hpp"

namespace tsph {

/// One particle's stress update over dt: the particle's state sigma^n in, the velocity
/// gradient L = grad v (its symmetric part the rate of deformation d, its skew part the
/// spin W) in, sigma^{n+1} out. `rate_stress` is the stress that the objective
/// (Jaumann) terms W sigma - sigma W rotate: in the half step the interpolated stress
/// itself, in the full step the particle's own midpoint stress sigma_r^n + dt/2 rate
/// (full_step.hpp: the rotation of sigma_r^n to second order, which does no work; a
/// particle that yielded in the last step: the interpolated stress). `objective`: the
/// Jaumann terms are on (updated Lagrangian). `predictor`: the half step's update of a
/// virtual particle (seed eq. 3), whose stress enters the full step only through dt
/// (div sigma, W sigma - sigma W), so that O(dt^2) per step suffices: the plastic models
/// return radially there and keep the midpoint flow direction (second order) for the
/// full step (j2_plasticity.hpp).
template <int Dim>
struct StressUpdate {
  const StressVector<Dim>& stress;
  const StressVector<Dim>& rate_stress;
  const Matrix<Dim>& velocity_gradient;
  double dt;
  bool objective;
  bool predictor = false;
};

}  // namespace tsph
