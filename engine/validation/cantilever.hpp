// The cantilever of seed section 4.2: a beam 0 <= x <= L, |y| <= D/2 (and |z| <= B/2
// in 3D), clamped at x = 0 and loaded at x = L by the parabolic shear traction of the
// exact solution (docs/validation.md). 2D: Timoshenko & Goodier, seed eqs. (5)-(6),
// plane stress or plane strain; 3D: Timoshenko beam theory (shear coefficient 5/6).
#pragma once

#include "engine/elasticity.hpp"
#include "engine/validation/exact_solution.hpp"

#include <cmath>
#include <memory>
#include <optional>

namespace tsph {

template <int Dim>
struct CantileverBeam {
  static_assert(Dim == 2 || Dim == 3, "the cantilever is a 2D or 3D case");
  double length = 1.0;  ///< L (m)
  double depth = 0.1;   ///< D (m), along y (the load direction)
  double width = 0.1;   ///< B (m), along z (3D only)
  double young_modulus = 8e7, poisson_ratio = 0.3, density = 2000.0;
  double load = 0.0;    ///< P (N; per unit thickness in 2D)
  PlaneMode plane_mode = PlaneMode::plane_stress;

  /// I: D^3/12 (2D), B D^3/12 (3D).
  double second_moment() const { return (Dim == 2 ? 1.0 : width) * depth * depth * depth / 12.0; }
  /// omega_1 of the Euler-Bernoulli beam (rad/s).
  double first_mode_frequency() const {
    const double area = Dim == 2 ? depth : depth * width;
    const double beta = 1.875104 / length;
    return beta * beta * std::sqrt(young_modulus * second_moment() / (density * area));
  }
  /// The parabolic shear traction at the tip per unit area at height y (seed eq. 6).
  double tip_shear(double y) const { return load / (2.0 * second_moment()) * (0.25 * depth * depth - y * y); }
  /// Vertical displacement of the point initially at (x, y) (on the axis in 3D).
  double deflection(double x, double y) const {
    const double p = load, l = length, d = depth, i = second_moment();
    if constexpr (Dim == 2) {
      double e = young_modulus, nu = poisson_ratio;
      if (plane_mode == PlaneMode::plane_strain) {
        e /= 1.0 - nu * nu;
        nu /= 1.0 - nu;
      }
      // Seed eq. (5).
      return p / (6.0 * e * i) * (3.0 * nu * y * y * (l - x) + (4.0 + 5.0 * nu) * d * d * x / 4.0 + (3.0 * l - x) * x * x);
    } else {
      (void)y;
      (void)d;
      const double shear = young_modulus / (2.0 * (1.0 + poisson_ratio));
      const double area = depth * width;
      return p / (6.0 * young_modulus * i) * (3.0 * l - x) * x * x + p * x / (5.0 / 6.0 * shear * area);
    }
  }
  double tip_deflection() const { return deflection(length, 0.0); }
};

/// The cantilever as an ExactSolution: displacement_y over every real particle, then
/// the tip particle on the axis (tip_displacement_y, its exact value, tip_error_percent)
/// and the L2 error along the axis. `centre` is the clamp's centre (x = lower x, the
/// box's centre across).
template <int Dim>
class CantileverValidation final : public ExactSolution<Dim> {
 public:
  /// `axis`: the real particles on the beam axis; `tip`: the one at x = L.
  CantileverValidation(const CantileverBeam<Dim>& beam, const Vector<Dim>& centre, std::vector<std::size_t> axis,
                       std::size_t tip)
      : axis_(std::move(axis)), tip_(tip), tip_exact_(beam.tip_deflection()) {
    const auto b = std::make_shared<CantileverBeam<Dim>>(beam);
    fields_.push_back({"displacement_y",
                       [b, centre](const Vector<Dim>& x, double) { return b->deflection(x[0] - centre[0], x[1] - centre[1]); },
                       [](const ParticleSet<Dim>& p, std::size_t i) { return p.displacement[1][i]; }});
  }
  const std::vector<ExactField<Dim>>& fields() const override { return fields_; }
  void errors(const ParticleSet<Dim>& r, double t, std::vector<ErrorRecord>& out) const override {
    ExactSolution<Dim>::errors(r, t, out);
    const double tip = r.displacement[1][tip_];
    out.push_back({t, "tip_displacement_y", tip});
    out.push_back({t, "tip_displacement_y_exact", tip_exact_});
    out.push_back({t, "tip_error_percent", 100.0 * std::abs(tip - tip_exact_) / std::abs(tip_exact_)});
    std::vector<double> numerical, exact;
    for (std::size_t i : axis_) {
      Vector<Dim> x0;
      for (int d = 0; d < Dim; ++d) x0[d] = r.initial_position[d][i];
      numerical.push_back(r.displacement[1][i]);
      exact.push_back(fields_.front().exact(x0, t));
    }
    out.push_back({t, "axis_displacement_y_l2_percent", relative_l2_percent(numerical, exact)});
  }
  std::size_t tip() const { return tip_; }
  const std::vector<std::size_t>& axis() const { return axis_; }
  double tip_exact() const { return tip_exact_; }

 private:
  std::vector<ExactField<Dim>> fields_;
  std::vector<std::size_t> axis_;
  std::size_t tip_ = 0;
  double tip_exact_ = 0.0;
};

}  // namespace tsph
