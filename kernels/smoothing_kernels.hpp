// Smoothing kernels W(r, h) with compact support 2h, for Dim = 1, 2, 3.
//
// Every kernel is a small value type with `value(r, h)` and `derivative(r, h)` (dW/dr),
// and the support radius `support_radius(h) = 2h` (docs/method.md section 2). The gradient
// with respect to the first point, grad_I W(x_I - x_J), is `kernel_gradient` below.
// Normalisation constants are constexpr per dimension; tests/test_kernels.cpp checks
// that each integrates to one.
//
// For the packed stencil loops (kernels/corrected_operators.hpp) every kernel also has
// branch-free `shape(q)` and `slope_over_q(q)` for double and Pack (kernels/simd.hpp):
//   W(r, h) = value_factor(h) shape(q),  (dW/dr) / r = slope_factor(h) slope_over_q(q),
// with q = r / h; pieces are chosen by selects, and slope_over_q is finite at q = 0 (the
// division by r of the gradient is folded into the polynomial), so no lane divides by
// zero. They agree with value() and derivative() to round-off (tests/test_kernels.cpp).
#pragma once

#include "kernels/simd.hpp"

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>

namespace tsph {

inline constexpr double kSupportFactor = 2.0;  // support radius = 2h (seed section 3)

template <int Dim>
constexpr double power_of_h(double h) {
  if constexpr (Dim == 1) return h;
  else if constexpr (Dim == 2) return h * h;
  else return h * h * h;
}

/// sigma / h^Dim and sigma / h^(Dim + 2), the factors of shape() and slope_over_q().
template <int Dim, class Kernel>
struct KernelFactors {
  static double value_factor(double h) { return Kernel::sigma / power_of_h<Dim>(h); }
  static double slope_factor(double h) { return Kernel::sigma / (power_of_h<Dim>(h) * h * h); }
};

/// Cubic B-spline (Monaghan & Lattanzio 1985), q = r/h in [0, 2].
template <int Dim>
struct CubicSpline : KernelFactors<Dim, CubicSpline<Dim>> {
  static_assert(Dim >= 1 && Dim <= 3, "CubicSpline: Dim must be 1, 2 or 3");
  static constexpr std::string_view name = "cubic_spline";
  static constexpr double sigma = Dim == 1   ? 2.0 / 3.0
                                  : Dim == 2 ? 10.0 / (7.0 * std::numbers::pi)
                                             : 1.0 / std::numbers::pi;

  double value(double r, double h) const {
    const double q = r / h;
    const double c = sigma / power_of_h<Dim>(h);
    if (q < 1.0) return c * (1.0 - 1.5 * q * q + 0.75 * q * q * q);
    if (q < 2.0) {
      const double t = 2.0 - q;
      return c * 0.25 * t * t * t;
    }
    return 0.0;
  }
  double derivative(double r, double h) const {
    const double q = r / h;
    const double c = sigma / (power_of_h<Dim>(h) * h);
    if (q < 1.0) return c * (-3.0 * q + 2.25 * q * q);
    if (q < 2.0) {
      const double t = 2.0 - q;
      return -c * 0.75 * t * t;
    }
    return 0.0;
  }
  template <class T>
  static T shape(T q) {
    const T t = max_of(2.0 - q, 0.0);
    return select(q < 1.0, 1.0 - 1.5 * q * q + 0.75 * q * q * q, 0.25 * t * t * t);
  }
  /// W'(q) / q: -3 + 2.25 q inside q < 1, -0.75 (2 - q)^2 / q outside (q >= 1 there).
  template <class T>
  static T slope_over_q(T q) {
    const T t = max_of(2.0 - q, 0.0);
    return select(q < 1.0, -3.0 + 2.25 * q, -0.75 * t * t / max_of(q, 1.0));
  }
};

/// Wendland C2 (Wendland 1995; Dehnen & Aly 2012), q = r/h in [0, 2].
/// 1D: (1 - q/2)^3 (1.5 q + 1); 2D and 3D: (1 - q/2)^4 (2 q + 1).
template <int Dim>
struct WendlandC2 : KernelFactors<Dim, WendlandC2<Dim>> {
  static_assert(Dim >= 1 && Dim <= 3, "WendlandC2: Dim must be 1, 2 or 3");
  static constexpr std::string_view name = "wendland_c2";
  static constexpr double sigma = Dim == 1   ? 5.0 / 8.0
                                  : Dim == 2 ? 7.0 / (4.0 * std::numbers::pi)
                                             : 21.0 / (16.0 * std::numbers::pi);

  double value(double r, double h) const {
    const double q = r / h;
    if (q >= 2.0) return 0.0;
    const double c = sigma / power_of_h<Dim>(h);
    const double t = 1.0 - 0.5 * q;
    if constexpr (Dim == 1) return c * t * t * t * (1.5 * q + 1.0);
    else return c * t * t * t * t * (2.0 * q + 1.0);
  }
  double derivative(double r, double h) const {
    const double q = r / h;
    if (q >= 2.0) return 0.0;
    const double c = sigma / (power_of_h<Dim>(h) * h);
    const double t = 1.0 - 0.5 * q;
    // d/dq [t^3 (1.5q + 1)] = -1.5 t^2 (1.5q + 1) + 1.5 t^3 = -3 q t^2
    // d/dq [t^4 (2q + 1)]   = -2 t^3 (2q + 1) + 2 t^4      = -5 q t^3
    if constexpr (Dim == 1) return c * (-3.0 * q * t * t);
    else return c * (-5.0 * q * t * t * t);
  }
  template <class T>
  static T shape(T q) {
    const T t = max_of(1.0 - 0.5 * q, 0.0);
    if constexpr (Dim == 1) return t * t * t * (1.5 * q + 1.0);
    else return t * t * t * t * (2.0 * q + 1.0);
  }
  template <class T>
  static T slope_over_q(T q) {
    const T t = max_of(1.0 - 0.5 * q, 0.0);
    if constexpr (Dim == 1) return -3.0 * t * t;
    else return -5.0 * t * t * t;
  }
};

/// Quintic spline (Morris 1996) rescaled from support 3h to support 2h: with s = 1.5 q,
/// W = sigma / h^d [(3 - s)^5 - 6 (2 - s)^5 + 15 (1 - s)^5] (terms taken where positive).
template <int Dim>
struct QuinticSpline : KernelFactors<Dim, QuinticSpline<Dim>> {
  static_assert(Dim >= 1 && Dim <= 3, "QuinticSpline: Dim must be 1, 2 or 3");
  static constexpr std::string_view name = "quintic_spline";
  // Morris' constants per h'^d with h' = h / 1.5, hence the factor 1.5^d.
  static constexpr double sigma = Dim == 1   ? 1.5 / 120.0
                                  : Dim == 2 ? 2.25 * 7.0 / (478.0 * std::numbers::pi)
                                             : 3.375 / (120.0 * std::numbers::pi);

  double value(double r, double h) const {
    const double s = 1.5 * (r / h);  // (2h)/h is exactly 2, so s is exactly 3 at 2h
    if (s >= 3.0) return 0.0;
    const double c = sigma / power_of_h<Dim>(h);
    double w = pow5(3.0 - s);
    if (s < 2.0) w -= 6.0 * pow5(2.0 - s);
    if (s < 1.0) w += 15.0 * pow5(1.0 - s);
    return c * w;
  }
  double derivative(double r, double h) const {
    const double s = 1.5 * (r / h);
    if (s >= 3.0) return 0.0;
    const double c = 1.5 * sigma / (power_of_h<Dim>(h) * h);
    double dw = -5.0 * pow4(3.0 - s);
    if (s < 2.0) dw += 30.0 * pow4(2.0 - s);
    if (s < 1.0) dw -= 75.0 * pow4(1.0 - s);
    return c * dw;
  }

  template <class T>
  static T shape(T q) {
    const T s = 1.5 * q;
    const T a = max_of(3.0 - s, 0.0), b = max_of(2.0 - s, 0.0), c = max_of(1.0 - s, 0.0);
    return pow5(a) - 6.0 * pow5(b) + 15.0 * pow5(c);
  }
  /// W'(q) / q = 2.25 [-5 (3 - s)^4 + 30 (2 - s)^4 - 75 (1 - s)^4] / s; the bracket is
  /// exactly 0 at s = 0 (-405 + 480 - 75), so the division by max(s, DBL_MIN) gives 0 there.
  template <class T>
  static T slope_over_q(T q) {
    const T s = 1.5 * q;
    const T a = max_of(3.0 - s, 0.0), b = max_of(2.0 - s, 0.0), c = max_of(1.0 - s, 0.0);
    return 2.25 * (-5.0 * pow4(a) + 30.0 * pow4(b) - 75.0 * pow4(c)) /
           max_of(s, std::numeric_limits<double>::min());
  }

 private:
  template <class T>
  static T pow4(T x) { return (x * x) * (x * x); }
  template <class T>
  static T pow5(T x) { return pow4(x) * x; }
};

/// grad_I W(x_I - x_J) for the separation `x_ij = x_I - x_J` (docs/method.md section 2).
template <int Dim, class Kernel>
Eigen::Matrix<double, Dim, 1> kernel_gradient(const Kernel& kernel,
                                              const Eigen::Matrix<double, Dim, 1>& x_ij,
                                              double h) {
  const double r = x_ij.norm();
  if (r <= 0.0) return Eigen::Matrix<double, Dim, 1>::Zero();
  return (kernel.derivative(r, h) / r) * x_ij;
}

/// The kernels a user can choose by name.
enum class KernelKind { cubic_spline, wendland_c2, quintic_spline };

inline constexpr std::array<KernelKind, 3> kAllKernelKinds = {
    KernelKind::cubic_spline, KernelKind::wendland_c2, KernelKind::quintic_spline};

inline std::string_view to_string(KernelKind kind) {
  switch (kind) {
    case KernelKind::cubic_spline: return "cubic_spline";
    case KernelKind::wendland_c2: return "wendland_c2";
    case KernelKind::quintic_spline: return "quintic_spline";
  }
  return "unknown";
}

inline std::optional<KernelKind> parse_kernel_kind(std::string_view name) {
  for (KernelKind kind : kAllKernelKinds)
    if (to_string(kind) == name) return kind;
  return std::nullopt;
}

/// Calls `f(Kernel{})` with the kernel type named by `kind`: the one runtime dispatch,
/// taken outside the particle loops so that the loops are compiled per kernel.
template <int Dim, class F>
decltype(auto) visit_kernel(KernelKind kind, F&& f) {
  switch (kind) {
    case KernelKind::wendland_c2: return f(WendlandC2<Dim>{});
    case KernelKind::quintic_spline: return f(QuinticSpline<Dim>{});
    case KernelKind::cubic_spline: break;
  }
  return f(CubicSpline<Dim>{});
}

}  // namespace tsph
