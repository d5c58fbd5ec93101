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


// Symmetric tensors in the stress arrays' layout (stress_index; 2D: xx, yy, xy, zz), for
// the plastic returns' arithmetic: 4 components in 2D, 6 in 3D, not the 9 of a 3x3 tensor.
template <int Dim>
constexpr bool is_normal_component(int m) {
  return Dim == 1 || (Dim == 2 ? m != 2 : m < 3);
}
/// a : b.
template <int Dim>
double contract(const StressVector<Dim>& a, const StressVector<Dim>& b) {
  double sum = 0.0;
  for (int m = 0; m < stress_component_count<Dim>; ++m) sum += (is_normal_component<Dim>(m) ? 1.0 : 2.0) * a[m] * b[m];
  return sum;
}
template <int Dim>
StressVector<Dim> scaled(const StressVector<Dim>& a, double factor) {
  StressVector<Dim> out;
  for (int m = 0; m < stress_component_count<Dim>; ++m) out[m] = factor * a[m];
  return out;
}
/// tr(sigma) / 3.
template <int Dim>
double mean_of(const StressVector<Dim>& sigma) {
  double trace = 0.0;
  for (int m = 0; m < stress_component_count<Dim>; ++m)
    if (is_normal_component<Dim>(m)) trace += sigma[m];
  return trace / 3.0;
}
/// dev(sigma) - back (back = 0: the deviator).
template <int Dim>
StressVector<Dim> deviator_of(const StressVector<Dim>& sigma, const StressVector<Dim>& back = {}) {
  const double mean = mean_of<Dim>(sigma);
  StressVector<Dim> out;
  for (int m = 0; m < stress_component_count<Dim>; ++m)
    out[m] = sigma[m] - (is_normal_component<Dim>(m) ? mean : 0.0) - back[m];
  return out;
}

}  // namespace tsph
