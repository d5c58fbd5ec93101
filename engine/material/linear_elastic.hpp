// Linear (hypo-)elastic material with the Jaumann stress rate, seed eq. (1a):
//   d sigma / dt = D : d + omega sigma - sigma omega,
// d = sym(grad v), omega = skew(grad v), grad v(i, j) = d v_i / d x_j.
// The first model of the material interface (material/material.hpp); a small evaluator
// with value semantics: the loops call it per particle.
#pragma once

#include "engine/material/stress.hpp"
#include "engine/material/stress_update.hpp"
#include "engine/particle_set.hpp"

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>

namespace tsph {

template <int Dim>
class LinearElastic {
 public:
  /// Young's modulus E > 0, Poisson's ratio nu in (-1, 0.5), reference density > 0.
  /// In 1D the bar is in uniaxial stress and only E enters.
  LinearElastic(double young_modulus, double poisson_ratio, double density,
                PlaneMode plane_mode = PlaneMode::plane_strain)
      : young_(young_modulus), poisson_(poisson_ratio), density_(density), plane_mode_(plane_mode) {
    if (!(young_ > 0.0) || !std::isfinite(young_))
      throw std::invalid_argument("material: E = " + std::to_string(young_) + " must be positive");
    if (!(density_ > 0.0) || !std::isfinite(density_))
      throw std::invalid_argument("material: rho = " + std::to_string(density_) +
                                  " must be positive");
    if (Dim > 1 && !(poisson_ > -1.0 && poisson_ < 0.5))
      throw std::invalid_argument("material: nu = " + std::to_string(poisson_) +
                                  " must lie in (-1, 0.5)");
    shear_ = young_ / (2.0 * (1.0 + poisson_));
    lame_ = young_ * poisson_ / ((1.0 + poisson_) * (1.0 - 2.0 * poisson_));
    model_lame_ = Dim == 2 && plane_mode_ == PlaneMode::plane_stress ? 2.0 * lame_ * shear_ / (lame_ + 2.0 * shear_)
                  : Dim == 1                                         ? 0.0
                                                                     : lame_;
  }

  double young_modulus() const { return young_; }
  double poisson_ratio() const { return poisson_; }
  double reference_density() const { return density_; }
  PlaneMode plane_mode() const { return plane_mode_; }

  double shear_modulus() const { return shear_; }
  /// The first Lame constant of this model: lambda, or in plane stress
  /// 2 lambda mu / (lambda + 2 mu) (sigma_zz = 0 eliminated).
  double model_lame() const { return model_lame_; }

  /// Modulus of the fastest (longitudinal) wave in this model.
  /// 1D: E; plane stress: E / (1 - nu^2); plane strain and 3D: lambda + 2 mu.
  double p_wave_modulus() const { return Dim == 1 ? young_ : model_lame() + 2.0 * shear_; }
  /// Shear wave speed sqrt(mu / rho) (no shear wave in 1D).
  double s_wave_speed(double density) const { return std::sqrt(shear_ / density); }
  /// Longitudinal wave speed c = sqrt(M / rho): sets the time step, dt = CFL dx / c.
  double p_wave_speed(double density) const { return std::sqrt(p_wave_modulus() / density); }

  /// Stress rate of seed eq. (1a): elastic part D : d plus, if `objective`, the
  /// Jaumann terms omega sigma - sigma omega (left out in geometrically linear runs).
  ///
  /// Written per component (called once per stencil row in both half steps; the 3x3
  /// tensor form with Eigen cost 160 instructions per call in 2D): with symmetric sigma,
  /// omega sigma - sigma omega = P + P^T, P = omega sigma, and omega has no out-of-plane
  /// part in 2D (sigma_zz only takes lambda tr d, or 0 in plane stress).
  /// Always inlined: the plastic models call it too, and a call costs the elastic loops
  /// 2 % of the 2D step's instructions (callgrind, 2026-11-26).
  [[gnu::always_inline]] StressVector<Dim> stress_rate(const Matrix<Dim>& grad_v, const StressVector<Dim>& stress,
                                                       bool objective = true) const {
    if constexpr (Dim == 1) {
      return {young_ * grad_v(0, 0)};
    } else {
      double trace = grad_v(0, 0);
      for (int d = 1; d < Dim; ++d) trace += grad_v(d, d);
      // Plane stress: sigma_zz = 0 eliminates d_zz, leaving model_lame() in place of lambda.
      const double volumetric = model_lame_ * trace;
      const double twice_shear = 2.0 * shear_;
      StressVector<Dim> rate{};
      for (int i = 0; i < Dim; ++i)
        for (int j = i; j < Dim; ++j) {
          const double strain = 0.5 * (grad_v(i, j) + grad_v(j, i));
          rate[stress_index<Dim>(i, j)] = (i == j ? volumetric : 0.0) + twice_shear * strain;
        }
      if constexpr (Dim == 2) rate[3] = plane_mode_ == PlaneMode::plane_stress ? 0.0 : volumetric;
      if (objective) {
        double spin[Dim][Dim], sigma[Dim][Dim], p[Dim][Dim];
        for (int i = 0; i < Dim; ++i)
          for (int j = 0; j < Dim; ++j) {
            spin[i][j] = 0.5 * (grad_v(i, j) - grad_v(j, i));
            sigma[i][j] = stress[stress_index<Dim>(i, j)];
          }
        for (int i = 0; i < Dim; ++i)
          for (int j = 0; j < Dim; ++j) {
            double sum = 0.0;
            for (int k = 0; k < Dim; ++k)
              if (k != i) sum += spin[i][k] * sigma[k][j];  // spin[i][i] = 0
            p[i][j] = sum;
          }
        for (int i = 0; i < Dim; ++i)
          for (int j = i; j < Dim; ++j) rate[stress_index<Dim>(i, j)] += p[i][j] + p[j][i];
      }
      return rate;
    }
  }

  /// The material interface (material/material.hpp): sigma^{n+1} = sigma^n + dt
  /// stress_rate(L, sigma_rate, objective), per component. No internal variables.
  [[gnu::always_inline]] StressVector<Dim> update_stress(const StressUpdate<Dim>& in) const {
    const StressVector<Dim> rate = stress_rate(in.velocity_gradient, in.rate_stress, in.objective);
    StressVector<Dim> updated;
    for (int m = 0; m < stress_component_count<Dim>; ++m) updated[m] = in.stress[m] + in.dt * rate[m];
    return updated;
  }
  /// Every model has an elastic part (wave speeds, the characteristic boundary): itself.
  const LinearElastic& elastic() const { return *this; }

  /// Strain energy per unit volume, sigma : C^-1 : sigma / 2 (isotropic compliance).
  double strain_energy_density(const StressVector<Dim>& stress) const {
    if constexpr (Dim == 1) {
      return stress[0] * stress[0] / (2.0 * young_);
    } else {
      const Eigen::Matrix3d s = to_tensor<Dim>(stress);
      const double trace = s.trace();
      return ((1.0 + poisson_) * s.squaredNorm() - poisson_ * trace * trace) / (2.0 * young_);
    }
  }

 private:
  double young_;
  double poisson_;
  double density_;
  PlaneMode plane_mode_;
  double shear_ = 0.0;
  double lame_ = 0.0;
  double model_lame_ = 0.0;  ///< model_lame(), computed once
};

}  // namespace tsph
