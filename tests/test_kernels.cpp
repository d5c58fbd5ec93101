// Smoothing kernels (kernels/smoothing_kernels.hpp): every kernel in every dimension
// integrates to one, has compact support 2h, is positive and non-increasing, and its
// derivative and gradient agree with finite differences of its value. The runtime
// selection by name (parse_kernel_kind, to_string, visit_kernel) round-trips.
#include "kernels/smoothing_kernels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

namespace tsph {
namespace {

/// The dimension a kernel type was instantiated for: CubicSpline<2> -> 2.
template <class Kernel>
struct KernelDim;
template <template <int> class Kernel, int Dim>
struct KernelDim<Kernel<Dim>> {
  static constexpr int value = Dim;
};

using AllKernels = ::testing::Types<CubicSpline<1>, CubicSpline<2>, CubicSpline<3>,
                                    WendlandC2<1>, WendlandC2<2>, WendlandC2<3>,
                                    QuinticSpline<1>, QuinticSpline<2>, QuinticSpline<3>>;

/// Test names such as "cubic_spline_2d" instead of "3".
struct KernelName {
  template <class Kernel>
  static std::string GetName(int) {
    return std::string(Kernel::name) + "_" + std::to_string(KernelDim<Kernel>::value) + "d";
  }
};


constexpr std::array<double, 2> kSmoothingLengths = {0.37, 1.0};

/// q = r / h of the knots where some kernel changes polynomial piece: cubic 1, quintic
/// 2/3 and 4/3 (s = 1.5 q = 1, 2), and the support edge 2.
constexpr std::array<double, 5> kKnots = {0.0, 2.0 / 3.0, 1.0, 4.0 / 3.0, 2.0};

/// Integral of f over [a, b] by 8-point Gauss-Legendre on `pieces` equal sub-intervals:
/// exact for piecewise polynomials of degree <= 15 whose knots are sub-interval ends.
template <class F>
double gauss_legendre(F&& f, double a, double b, int pieces) {
  static constexpr std::array<double, 4> node = {0.1834346424956498, 0.5255324099163290,
                                                 0.7966664774136267, 0.9602898564975363};
  static constexpr std::array<double, 4> weight = {0.3626837833783620, 0.3137066458778873,
                                                   0.2223810344533745, 0.1012285362903763};
  const double width = (b - a) / pieces;
  double sum = 0.0;
  for (int p = 0; p < pieces; ++p) {
    const double mid = a + (p + 0.5) * width;
    const double half = 0.5 * width;
    for (int k = 0; k < 4; ++k)
      sum += half * weight[k] * (f(mid - half * node[k]) + f(mid + half * node[k]));
  }
  return sum;
}

/// Integral of W over R^Dim, using radial symmetry in 2D and 3D; the pieces between the
/// knots are integrated separately so that the rule sees only smooth polynomials.
template <class Kernel>
double kernel_integral(const Kernel& kernel, double h) {
  constexpr int dim = KernelDim<Kernel>::value;
  auto integrand = [&](double r) {
    if constexpr (dim == 1) return kernel.value(std::abs(r), h);
    else if constexpr (dim == 2) return 2.0 * std::numbers::pi * r * kernel.value(r, h);
    else return 4.0 * std::numbers::pi * r * r * kernel.value(r, h);
  };
  double total = 0.0;
  for (std::size_t k = 0; k + 1 < kKnots.size(); ++k) {
    const double a = kKnots[k] * h, b = kKnots[k + 1] * h;
    total += gauss_legendre(integrand, a, b, 16);
    if constexpr (dim == 1) total += gauss_legendre(integrand, -b, -a, 16);  // x < 0
  }
  return total;
}

/// Central finite difference of W in r.
template <class Kernel>
double finite_difference(const Kernel& kernel, double r, double h, double step) {
  return (kernel.value(r + step, h) - kernel.value(r - step, h)) / (2.0 * step);
}

/// True if r lies within `margin` of a knot (where the FD would straddle two pieces).
bool near_knot(double r, double h, double margin) {
  return std::any_of(kKnots.begin(), kKnots.end(),
                     [&](double q) { return std::abs(r - q * h) < margin; });
}

template <class Kernel>
class KernelTest : public ::testing::Test {};
TYPED_TEST_SUITE(KernelTest, AllKernels, KernelName);

// The normalisation constant sigma is right: int W dV = 1 for any h (this also proves
// the 1/h^Dim scaling, since two different h are used).
TYPED_TEST(KernelTest, IntegratesToOne) {
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    SCOPED_TRACE("h = " + std::to_string(h));
    EXPECT_NEAR(kernel_integral(kernel, h), 1.0, 1e-12);
  }
}


// The branch-free forms of the packed stencil loop (kernels/simd.hpp) are the kernel:
// value_factor(h) shape(q) = W and slope_factor(h) slope_over_q(q) r = dW/dr to
// round-off, on either side of every knot, at q = 0 (slope finite) and beyond 2h (zero);
// the Pack versions equal the double versions lane by lane, bitwise.
TYPED_TEST(KernelTest, ShapeAndSlopeOverQMatchValueAndDerivative) {
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    std::vector<double> qs = {0.0, 1e-9, 2.0, 2.0 + 1e-12, 2.5, 7.0};
    for (double knot : kKnots)
      for (double delta : {-1e-9, 1e-9}) qs.push_back(std::max(0.0, knot + delta));
    for (int k = 1; k < 400; ++k) qs.push_back(k * 2.2 / 400.0);
    const double peak = kernel.value(0.0, h);
    const double slope_scale = std::abs(kernel.derivative(h, h));
    for (double q : qs) {
      SCOPED_TRACE("h = " + std::to_string(h) + ", q = " + std::to_string(q));
      const double r = q * h;
      const double value = TypeParam::value_factor(h) * TypeParam::shape(q);
      const double slope_over_r = TypeParam::slope_factor(h) * TypeParam::slope_over_q(q);
      EXPECT_TRUE(std::isfinite(value) && std::isfinite(slope_over_r));
      EXPECT_NEAR(value, kernel.value(r, h), 1e-14 * peak);
      EXPECT_NEAR(slope_over_r * r, kernel.derivative(r, h), 1e-13 * slope_scale);
      if (q >= 2.0) {
        EXPECT_EQ(value, 0.0);
        EXPECT_EQ(slope_over_r, 0.0);
      }
      const Pack packed_q = {q, 0.5 * q, q + 0.25, 0.0};
      const Pack shape = TypeParam::shape(packed_q), slope = TypeParam::slope_over_q(packed_q);
      for (std::size_t l = 0; l < kLanes; ++l) {
        EXPECT_EQ(shape[l], TypeParam::shape(packed_q[l]));
        EXPECT_EQ(slope[l], TypeParam::slope_over_q(packed_q[l]));
      }
    }
  }
}

// Support radius is 2h: W and dW/dr vanish beyond it, and W reaches zero continuously
// (no jump at the edge).
TYPED_TEST(KernelTest, HasCompactSupportOfTwoH) {
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    SCOPED_TRACE("h = " + std::to_string(h));
    const double edge = kSupportFactor * h;
    for (double r : {edge * (1.0 + 1e-12), 3.0 * h, 100.0 * h}) {
      EXPECT_EQ(kernel.value(r, h), 0.0) << "r = " << r;
      EXPECT_EQ(kernel.derivative(r, h), 0.0) << "r = " << r;
    }
    const double peak = kernel.value(0.0, h);
    EXPECT_GT(peak, 0.0);
    EXPECT_LT(kernel.value(edge * (1.0 - 1e-6), h), 1e-12 * peak);
    EXPECT_LT(std::abs(kernel.derivative(edge * (1.0 - 1e-6), h)), 1e-8 * peak / h);
  }
}

// A point exactly on the support radius (r = 2h, as a neighbour search includes it)
// gets exactly zero weight and zero derivative.
TYPED_TEST(KernelTest, VanishesExactlyAtTwoH) {
  const TypeParam kernel;
  for (double h : {0.37, 1.0, 0.1, 0.3, 0.7, 1.1, 2.9}) {
    const double edge = kSupportFactor * h;
    EXPECT_EQ(kernel.value(edge, h), 0.0) << "h = " << h;
    EXPECT_EQ(kernel.derivative(edge, h), 0.0) << "h = " << h;
  }
}

// W > 0 inside the support and W is non-increasing in r (dW/dr <= 0, and = 0 at r = 0).
TYPED_TEST(KernelTest, IsPositiveAndNonIncreasing) {
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    SCOPED_TRACE("h = " + std::to_string(h));
    EXPECT_EQ(kernel.derivative(0.0, h), 0.0);
    const int samples = 2000;
    double previous = kernel.value(0.0, h);
    for (int k = 1; k < samples; ++k) {
      const double r = kSupportFactor * h * k / samples;
      const double w = kernel.value(r, h);
      EXPECT_GT(w, 0.0) << "r = " << r;
      EXPECT_LE(w, previous) << "r = " << r;
      EXPECT_LE(kernel.derivative(r, h), 0.0) << "r = " << r;
      previous = w;
    }
  }
}

// derivative(r, h) is dW/dr: it matches a central difference of value() across the
// support (away from the knots), which catches a wrong constant, sign or power of h.
TYPED_TEST(KernelTest, DerivativeMatchesFiniteDifference) {
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    SCOPED_TRACE("h = " + std::to_string(h));
    const double step = 1e-5 * h;
    const double scale = kernel.value(0.0, h) / h;  // typical |dW/dr|
    const int samples = 397;
    for (int k = 0; k < samples; ++k) {
      const double r = kSupportFactor * h * (k + 0.37) / samples;
      if (r <= step || near_knot(r, h, 10.0 * step)) continue;
      const double exact = kernel.derivative(r, h);
      EXPECT_NEAR(finite_difference(kernel, r, h, step), exact,
                  1e-6 * std::abs(exact) + 1e-8 * scale)
          << "r = " << r;
    }
  }
}

// Value and first derivative are continuous at the knots (the splines are at least C2):
// catches a wrong coefficient in one piece only. The one-sided values are extrapolated
// to the knot with their own slopes, so only a jump remains.
TYPED_TEST(KernelTest, ValueAndDerivativeAreContinuousAtKnots) {
  const TypeParam kernel;
  const double h = 0.37;
  const double scale = kernel.value(0.0, h);
  for (double q : {2.0 / 3.0, 1.0, 4.0 / 3.0}) {
    const double r = q * h, eps = 1e-7 * h;
    const double left = kernel.value(r - eps, h) + eps * kernel.derivative(r - eps, h);
    const double right = kernel.value(r + eps, h) - eps * kernel.derivative(r + eps, h);
    EXPECT_NEAR(left, right, 1e-12 * scale) << "q = " << q;
    EXPECT_NEAR(kernel.derivative(r - eps, h), kernel.derivative(r + eps, h), 1e-5 * scale / h)
        << "q = " << q;
  }
}

/// Random separations inside the support ball, a fixed seed.
template <int Dim>
std::vector<Eigen::Matrix<double, Dim, 1>> random_separations(double h, int count) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Eigen::Matrix<double, Dim, 1>> points;
  while (static_cast<int>(points.size()) < count) {
    Eigen::Matrix<double, Dim, 1> x;
    for (int d = 0; d < Dim; ++d) x[d] = uniform(rng);
    if (x.norm() >= 1.0 || x.norm() < 1e-3) continue;
    points.push_back(kSupportFactor * h * x);
  }
  return points;
}

// kernel_gradient(x) = W'(|x|) x / |x|: odd in x, zero at x = 0, radial.
TYPED_TEST(KernelTest, GradientIsRadialAndAntisymmetric) {
  constexpr int dim = KernelDim<TypeParam>::value;
  using Vec = Eigen::Matrix<double, dim, 1>;
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    SCOPED_TRACE("h = " + std::to_string(h));
    EXPECT_EQ(kernel_gradient<dim>(kernel, Vec::Zero().eval(), h), Vec::Zero());
    for (const Vec& x : random_separations<dim>(h, 200)) {
      const Vec grad = kernel_gradient<dim>(kernel, x, h);
      const Vec mirrored = kernel_gradient<dim>(kernel, Vec(-x), h);
      for (int d = 0; d < dim; ++d) EXPECT_EQ(mirrored[d], -grad[d]);
      const Vec radial = kernel.derivative(x.norm(), h) * x / x.norm();
      EXPECT_LE((grad - radial).norm(), 1e-14 * radial.norm() + 1e-300);
      // It points towards the origin (W decreases outwards).
      EXPECT_LE(grad.dot(x), 0.0);
    }
    // Outside the support the gradient vanishes.
    Vec far = Vec::Zero();
    far[0] = 2.5 * h;
    EXPECT_EQ(kernel_gradient<dim>(kernel, far, h), Vec::Zero());
  }
}

// Each component of kernel_gradient is the partial derivative of W(|x|): central
// differences per component at random points.
TYPED_TEST(KernelTest, GradientMatchesFiniteDifferencePerComponent) {
  constexpr int dim = KernelDim<TypeParam>::value;
  using Vec = Eigen::Matrix<double, dim, 1>;
  const TypeParam kernel;
  for (double h : kSmoothingLengths) {
    SCOPED_TRACE("h = " + std::to_string(h));
    const double step = 1e-5 * h;
    const double scale = kernel.value(0.0, h) / h;
    for (const Vec& x : random_separations<dim>(h, 200)) {
      if (near_knot(x.norm(), h, 10.0 * step) || x.norm() < 10.0 * step) continue;
      const Vec grad = kernel_gradient<dim>(kernel, x, h);
      for (int d = 0; d < dim; ++d) {
        Vec plus = x, minus = x;
        plus[d] += step;
        minus[d] -= step;
        const double fd = (kernel.value(plus.norm(), h) - kernel.value(minus.norm(), h)) /
                          (2.0 * step);
        EXPECT_NEAR(fd, grad[d], 1e-6 * std::abs(grad[d]) + 1e-8 * scale)
            << "component " << d << " at |x| = " << x.norm();
      }
    }
  }
}

// Regression test for a bug found in WendlandC2<1>::derivative. For W = sigma/h t^3 (1.5q+1),
// t = 1 - q/2: dW/dq = -1.5 t^2 (1.5 q + 1) + 1.5 t^3 = 1.5 t^2 (t - 1.5 q - 1) = -3 q t^2,
// not -3.75 q t^2 as coded (the comment in the header has the same slip). Fixed; kept as
// a regression test.
TEST(WendlandC2Bug, OneDimensionalDerivativeIsMinusThreeQTSquared) {
  const WendlandC2<1> kernel;
  const double h = 0.37;
  for (double q : {0.1, 0.5, 1.0, 1.5, 1.9}) {
    const double t = 1.0 - 0.5 * q;
    const double expected = WendlandC2<1>::sigma / (h * h) * (-3.0 * q * t * t);
    EXPECT_NEAR(kernel.derivative(q * h, h), expected, 1e-12 * std::abs(expected)) << q;
    EXPECT_NEAR(finite_difference(kernel, q * h, h, 1e-6 * h), expected,
                1e-7 * std::abs(expected))
        << "the finite difference agrees with the hand derivation, q = " << q;
  }
}

// Regression test for a round-off bug at the quintic's support edge: with h = 0.37,
// 1.5 * (2h) / h evaluates to 2.9999999999999996, so W(2h) = sigma/h^d (3 - s)^5 ~ 1e-78
// and dW/dr ~ -3e-62 instead of exactly zero. Harmless in magnitude, but a stencil whose
// only neighbour lies exactly on the radius is then not reported as no_neighbors (unlike
// the cubic and Wendland kernels). Computing s = 1.5 * (r / h) fixes it, since
// (2h) / h == 2 exactly. Fixed that way.
TEST(QuinticSpline, VanishesExactlyAtTwoH) {
  const double h = 0.37;
  EXPECT_EQ(QuinticSpline<1>{}.value(2.0 * h, h), 0.0);
  EXPECT_EQ(QuinticSpline<2>{}.value(2.0 * h, h), 0.0);
  EXPECT_EQ(QuinticSpline<3>{}.derivative(2.0 * h, h), 0.0);
}

// Names round-trip for every kind; anything else is rejected.
TEST(KernelKindTest, ParseAndToStringRoundTrip) {
  for (KernelKind kind : kAllKernelKinds) {
    const std::optional<KernelKind> parsed = parse_kernel_kind(to_string(kind));
    ASSERT_TRUE(parsed.has_value()) << to_string(kind);
    EXPECT_EQ(*parsed, kind);
  }
  EXPECT_EQ(to_string(KernelKind::cubic_spline), "cubic_spline");
  EXPECT_EQ(to_string(KernelKind::wendland_c2), "wendland_c2");
  EXPECT_EQ(to_string(KernelKind::quintic_spline), "quintic_spline");
  for (const char* name : {"", "cubic", "Cubic_Spline", "wendland", "quintic_spline ",
                           "gaussian", "unknown"})
    EXPECT_FALSE(parse_kernel_kind(name).has_value()) << "'" << name << "'";
}

/// Checks that visit_kernel<Dim> hands each kind its own kernel type, of dimension Dim.
template <int Dim>
void expect_visit_dispatches() {
  for (KernelKind kind : kAllKernelKinds) {
    const std::string name = visit_kernel<Dim>(kind, [](const auto& kernel) {
      using Kernel = std::decay_t<decltype(kernel)>;
      EXPECT_EQ(KernelDim<Kernel>::value, Dim);
      return std::string(Kernel::name);
    });
    EXPECT_EQ(name, to_string(kind)) << "Dim = " << Dim;
  }
  const bool cubic = visit_kernel<Dim>(KernelKind::cubic_spline, [](const auto& kernel) {
    return std::is_same_v<std::decay_t<decltype(kernel)>, CubicSpline<Dim>>;
  });
  const bool wendland = visit_kernel<Dim>(KernelKind::wendland_c2, [](const auto& kernel) {
    return std::is_same_v<std::decay_t<decltype(kernel)>, WendlandC2<Dim>>;
  });
  const bool quintic = visit_kernel<Dim>(KernelKind::quintic_spline, [](const auto& kernel) {
    return std::is_same_v<std::decay_t<decltype(kernel)>, QuinticSpline<Dim>>;
  });
  EXPECT_TRUE(cubic && wendland && quintic) << "Dim = " << Dim;
}

TEST(KernelKindTest, VisitKernelDispatchesToTheNamedType) {
  expect_visit_dispatches<1>();
  expect_visit_dispatches<2>();
  expect_visit_dispatches<3>();
}

}  // namespace
}  // namespace tsph
