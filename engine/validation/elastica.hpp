// The large-deflection cantilever under a dead tip load (docs/validation.md, the
// elastica; shared reference "large-deformation.md" section 2, Bisshopp & Drucker 1945).
//
// Inextensible Euler-Bernoulli beam, arc length s in [0, L], slope theta(s), dead tip load
// P (direction fixed in space, along +y), k = P L^2 / (E I):
//     theta'' = -k cos(theta),  theta(0) = 0,  theta'(1) = 0   (s in units of L),
//     delta / L = int_0^1 sin(theta) ds,  x_tip / L = int_0^1 cos(theta) ds.
// Solved by shooting on theta'(0) (bisection on [0, k]: theta'(1) is increasing in it)
// with RK4.
//
// Shear and extension (Reissner's geometrically exact beam): with the tip force
// F = (0, P) the section carries the axial force N = P sin(theta) and the shear force
// V = P cos(theta), so the axis stretches by eps = N / (E A) and shears by
// gamma = V / (kappa G A); its tangent is r' = (1 + eps) t + gamma n, t = (cos, sin),
// n = (-sin, cos), and the moment balance (E I theta')' = -(r' x F)_z reads
//     theta'' = -k [(1 + eps) cos(theta) - gamma sin(theta)].
// The compliances enter as the dimensionless `axial` = P / (E A) and `shear` =
// P / (kappa G A). For the seed's beam (plane stress, L = 1, D = 0.1) we take kappa so
// that the small-load limit is Timoshenko & Goodier's 2D solution (seed eq. 5), the one
// the small-strain cantilever validates: its tip deflection is
// P L^3 / (3 E I) + P L (4 + 5 nu) D^2 / (24 E I), i.e. kappa = 4 (1 + nu) / (4 + 5 nu)
// (0.945 at nu = 0.3; shear then adds 0.69 % of the linear deflection).
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

/// The deformed axis of the cantilever: tip components and the shape.
struct ElasticaSolution {
  double load_parameter = 0.0;   ///< k = P L^2 / (E I)
  double root_curvature = 0.0;   ///< theta'(0) L
  double tip_deflection = 0.0;   ///< delta / L (along the load)
  double tip_x = 0.0;            ///< x_tip / L
  double tip_angle = 0.0;        ///< theta(1) (rad)
  std::vector<double> x, y;      ///< the axis, points at s = i / steps (units of L)
};

/// The beam's dimensionless compliances: P / (E A) and P / (kappa G A), both 0 for the
/// inextensible, shear-rigid elastica.
struct ElasticaCompliance {
  double axial = 0.0;
  double shear = 0.0;
};

namespace detail {
struct ElasticaState {
  double theta, curvature, x, y;
};
inline ElasticaState elastica_rate(const ElasticaState& s, double k, const ElasticaCompliance& c) {
  const double cs = std::cos(s.theta), sn = std::sin(s.theta);
  const double stretch = 1.0 + c.axial * sn;  // 1 + eps, eps = P sin(theta) / (E A)
  const double shear = c.shear * cs;          // gamma = P cos(theta) / (kappa G A)
  return {s.curvature, -k * (stretch * cs - shear * sn), stretch * cs - shear * sn, stretch * sn + shear * cs};
}
/// RK4 from s = 0 to 1 with theta(0) = 0, theta'(0) = root_curvature.
inline ElasticaState shoot(double k, double root_curvature, const ElasticaCompliance& c, int steps,
                           std::vector<double>* xs = nullptr, std::vector<double>* ys = nullptr) {
  ElasticaState s{0.0, root_curvature, 0.0, 0.0};
  const double ds = 1.0 / steps;
  auto axpy = [](const ElasticaState& a, double f, const ElasticaState& b) {
    return ElasticaState{a.theta + f * b.theta, a.curvature + f * b.curvature, a.x + f * b.x, a.y + f * b.y};
  };
  if (xs) xs->assign(1, 0.0), ys->assign(1, 0.0);
  for (int i = 0; i < steps; ++i) {
    const ElasticaState k1 = elastica_rate(s, k, c);
    const ElasticaState k2 = elastica_rate(axpy(s, 0.5 * ds, k1), k, c);
    const ElasticaState k3 = elastica_rate(axpy(s, 0.5 * ds, k2), k, c);
    const ElasticaState k4 = elastica_rate(axpy(s, ds, k3), k, c);
    s.theta += ds / 6.0 * (k1.theta + 2.0 * k2.theta + 2.0 * k3.theta + k4.theta);
    s.curvature += ds / 6.0 * (k1.curvature + 2.0 * k2.curvature + 2.0 * k3.curvature + k4.curvature);
    s.x += ds / 6.0 * (k1.x + 2.0 * k2.x + 2.0 * k3.x + k4.x);
    s.y += ds / 6.0 * (k1.y + 2.0 * k2.y + 2.0 * k3.y + k4.y);
    if (xs) xs->push_back(s.x), ys->push_back(s.y);
  }
  return s;
}
}  // namespace detail

/// Solves the (Reissner) elastica for k = P L^2 / (E I) in [0, 6] (the slope stays
/// below 90 degrees; beyond, the bracket of the shooting is not guaranteed).
inline ElasticaSolution solve_elastica(double k, ElasticaCompliance compliance = {}, int steps = 2000) {
  if (!(k >= 0.0 && k <= 6.0))
    throw std::invalid_argument("elastica: load parameter P L^2 / (E I) = " + std::to_string(k) +
                                " must lie in [0, 6]");
  ElasticaSolution out;
  out.load_parameter = k;
  // theta'(1) as a function of theta'(0): -k int cos < 0 at 0, >= 0 at k (1 + compliances).
  double low = 0.0, high = k * (1.0 + compliance.axial + compliance.shear) + 1e-12;
  for (int it = 0; it < 200 && high - low > 1e-15 * (1.0 + high); ++it) {
    const double mid = 0.5 * (low + high);
    (detail::shoot(k, mid, compliance, steps).curvature < 0.0 ? low : high) = mid;
  }
  out.root_curvature = 0.5 * (low + high);
  const detail::ElasticaState tip = detail::shoot(k, out.root_curvature, compliance, steps, &out.x, &out.y);
  out.tip_deflection = tip.y;
  out.tip_x = tip.x;
  out.tip_angle = tip.theta;
  return out;
}

/// The compliances of a rectangular beam of depth D (unit thickness in plane stress) and
/// length L under the load parameter k, with kappa = 4 (1 + nu) / (4 + 5 nu) (the small-
/// load limit is Timoshenko & Goodier's 2D solution, see the file comment).
inline ElasticaCompliance rectangular_beam_compliance(double k, double length, double depth, double poisson_ratio) {
  // P = k E I / L^2, I = D^3 / 12, A = D: P / (E A) = k D^2 / (12 L^2); G = E / (2 (1 + nu)).
  const double axial = k * depth * depth / (12.0 * length * length);
  const double kappa = 4.0 * (1.0 + poisson_ratio) / (4.0 + 5.0 * poisson_ratio);
  return {axial, axial * 2.0 * (1.0 + poisson_ratio) / kappa};
}

}  // namespace tsph
