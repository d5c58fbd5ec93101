// Stress components and tensors: the per-particle storage order of the stress
// components (engine/particle_set.hpp), conversions to the 3x3 tensor, and the
// objective rotation of a stress over a step.
#pragma once

#include "engine/particle_set.hpp"

#include <Eigen/Core>
#include <Eigen/LU>

#include <array>

namespace tsph {

/// Objective rotation of a stress over a step dt with a constant spin W, as a rate:
///   (Q sigma Q^T - sigma) / dt,   Q = (I - dt/2 W)^-1 (I + dt/2 W)
/// (the incremental rotation of Hughes & Winget 1980; Q is orthogonal for any dt). It
/// equals the Jaumann terms W sigma - sigma W to O(dt) and keeps the principal stresses
/// exactly, where the forward-Euler update sigma + dt (W sigma - sigma W) grows the
/// deviator by (2 |W| dt)^2 / 2 per step (2.5e-3 over a quarter turn in 2000 steps).
template <int N>
Eigen::Matrix<double, N, N> objective_rotation_rate(const Eigen::Matrix<double, N, N>& spin,
                                                    const Eigen::Matrix<double, N, N>& stress,
                                                    double dt) {
  using M = Eigen::Matrix<double, N, N>;
  const M half = 0.5 * dt * spin;
  const M rotation = (M::Identity() - half).inverse() * (M::Identity() + half);
  return (rotation * stress * rotation.transpose() - stress) / dt;
}

/// How a 2D model treats the out-of-plane direction.
enum class PlaneMode { plane_strain, plane_stress };

/// Index of stress component sigma_ij in the per-particle stress arrays.
template <int Dim>
constexpr int stress_index(int i, int j) {
  if constexpr (Dim == 1) return 0;
  else if constexpr (Dim == 2) return i == j ? i : 2;
  else {
    if (i == j) return i;
    const int sum = i + j;  // (0,1) -> 3, (1,2) -> 4, (0,2) -> 5
    return sum == 1 ? 3 : sum == 3 ? 4 : 5;
  }
}

template <int Dim>
using StressVector = std::array<double, stress_component_count<Dim>>;

/// Stress components <-> full 3x3 symmetric tensor (ordering in particle_set.hpp).
template <int Dim>
Eigen::Matrix3d to_tensor(const StressVector<Dim>& s) {
  Eigen::Matrix3d t = Eigen::Matrix3d::Zero();
  if constexpr (Dim == 1) {
    t(0, 0) = s[0];
  } else if constexpr (Dim == 2) {
    t(0, 0) = s[0];
    t(1, 1) = s[1];
    t(0, 1) = t(1, 0) = s[2];
    t(2, 2) = s[3];
  } else {
    t(0, 0) = s[0];
    t(1, 1) = s[1];
    t(2, 2) = s[2];
    t(0, 1) = t(1, 0) = s[3];
    t(1, 2) = t(2, 1) = s[4];
    t(2, 0) = t(0, 2) = s[5];
  }
  return t;
}

template <int Dim>
StressVector<Dim> from_tensor(const Eigen::Matrix3d& t) {
  if constexpr (Dim == 1) return {t(0, 0)};
  else if constexpr (Dim == 2) return {t(0, 0), t(1, 1), t(0, 1), t(2, 2)};
  else return {t(0, 0), t(1, 1), t(2, 2), t(0, 1), t(1, 2), t(2, 0)};
}

}  // namespace tsph
