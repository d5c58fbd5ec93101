// Corrected SPH operators (kernels/corrected_operators.hpp), for every kernel in 1, 2
// and 3 dimensions, on regular and randomly perturbed lattices, between the real and
// virtual sets and within the real set:
//  * the corrected gradient is exact for linear fields at every query point, the
//    boundary included (Bonet & Lok 1999), and where the stencil does not span the
//    space it falls back to the pseudo-inverse, exact along the spanned directions;
//  * `linear` interpolation reproduces linear fields, `shepard` only constants;
//  * the fallbacks are flagged exactly where the stencil geometry is degenerate, and
//    never produce NaN;
//  * checked_inverse and symmetric_pseudo_inverse behave as documented.
#include "engine/lattice.hpp"
#include "kernels/corrected_operators.hpp"
#include "kernels/smoothing_kernels.hpp"
#include "neighbor/brute_force.hpp"

#include <gtest/gtest.h>

#include "tests/typed_dimensions.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace tsph {
namespace {

template <int Dim>
using Vec = Eigen::Matrix<double, Dim, 1>;
template <int Dim>
using Mat = Eigen::Matrix<double, Dim, Dim>;

/// The linear field f(x) = a + b . x used throughout.
template <int Dim>
struct LinearField {
  double a = 1.7;
  Vec<Dim> b;

  LinearField() {
    const double components[3] = {0.8, -1.3, 0.45};
    for (int d = 0; d < Dim; ++d) b[d] = components[d];
  }
  double operator()(const Vec<Dim>& x) const { return a + b.dot(x); }
};

/// Smoothing lengths h / dx tried per dimension: 0.6 gives too few neighbours in 2D/3D.
template <int Dim>
std::vector<double> alphas() {
  if constexpr (Dim == 1)
    return {0.6, 1.0, 1.2, 1.6};
  else
    return {1.0, 1.2, 1.6};
}

/// A box of real nodes with spacing dx = 0.1 and a lower corner off the origin.
template <int Dim>
LatticeBox<Dim> test_box() {
  LatticeBox<Dim> box;
  box.spacing = 0.1;
  const double lower[3] = {0.3, -0.2, 0.1};
  const std::int64_t nodes[3][3] = {{21, 0, 0}, {9, 8, 0}, {6, 5, 5}};
  for (int d = 0; d < Dim; ++d) {
    box.lower[d] = lower[d];
    box.node_count[d] = nodes[Dim - 1][d];
  }
  return box;
}

/// Copy of `set` with every coordinate moved by up to 0.2 dx (fixed seed).
template <int Dim>
ParticleSet<Dim> perturbed(ParticleSet<Dim> set, double dx, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-0.2 * dx, 0.2 * dx);
  for (auto& coordinate : set.position)
    for (double& x : coordinate) x += uniform(rng);
  return set;
}

/// Rank of a set of vectors and the orthogonal projector onto their span, from the
/// eigen-decomposition of their Gram matrix (singular values below 1e-6 of the largest
/// count as zero).
template <int Dim>
struct Span {
  int rank = 0;
  Mat<Dim> projector = Mat<Dim>::Zero();
};

template <int Dim>
Span<Dim> span_of(const std::vector<Vec<Dim>>& vectors) {
  Mat<Dim> gram = Mat<Dim>::Zero();
  for (const auto& v : vectors) gram += v * v.transpose();
  Span<Dim> span;
  Eigen::SelfAdjointEigenSolver<Mat<Dim>> solver(gram);
  const double largest = solver.eigenvalues().cwiseAbs().maxCoeff();
  for (int k = 0; k < Dim; ++k)
    if (largest > 0.0 && solver.eigenvalues()[k] > 1e-12 * largest) {
      ++span.rank;
      span.projector += solver.eigenvectors().col(k) * solver.eigenvectors().col(k).transpose();
    }
  return span;
}

/// The geometry of one stencil, computed independently of compute_stencil: offsets
/// x_J - x_I of the neighbours where W > 0 (all), and where W is not negligible
/// (strong, W > 1e-6 W(0)), which decide what the operators can reproduce.
template <int Dim>
struct StencilGeometry {
  std::vector<Vec<Dim>> offsets_all, offsets_strong;  // r > 0
  std::vector<Vec<Dim>> affine_all, affine_strong;    // differences of points
  bool any_weight = false;
};

template <int Dim, class Kernel>
StencilGeometry<Dim> geometry_of(const Kernel& kernel, double h, const Vec<Dim>& x,
                                 const PointsView<Dim>& source,
                                 std::span<const std::uint32_t> row) {
  StencilGeometry<Dim> g;
  std::vector<Vec<Dim>> points_all, points_strong;
  const double peak = kernel.value(0.0, h);
  for (std::uint32_t j : row) {
    const Vec<Dim> offset = source.point(j) - x;
    const double w = kernel.value(offset.norm(), h);
    if (w > 0.0) {
      points_all.push_back(offset);
      if (offset.norm() > 0.0) g.offsets_all.push_back(offset);
    }
    if (w > 1e-6 * peak) {
      points_strong.push_back(offset);
      if (offset.norm() > 0.0) g.offsets_strong.push_back(offset);
    }
  }
  g.any_weight = !points_all.empty();
  for (const auto& p : points_all) g.affine_all.push_back(p - points_all.front());
  for (const auto& p : points_strong) g.affine_strong.push_back(p - points_strong.front());
  return g;
}

/// Fallbacks seen over a batch of stencils.
struct Counts {
  int stencils = 0;
  int gradient_fallbacks = 0;
  int interpolation_fallbacks = 0;
  int no_neighbors = 0;
};

/// Computes the stencil of every `query` particle over `source` with both interpolation
/// kinds and checks, at every query point:
///  * no NaN; the gradient weights do not depend on the interpolation kind;
///  * the fallback flags are set exactly when the geometry is degenerate (where it is
///    only nearly so, through negligible weights, either answer is accepted);
///  * without fallback the corrected gradient of a linear field is exact; with it, the
///    gradient is the exact one projected on the directions the stencil spans;
///  * `linear` reproduces 1 and the linear field; `shepard` reproduces 1, with
///    non-negative weights.
template <int Dim, class Kernel>
Counts check_stencils(const Kernel& kernel, double h, const ParticleSet<Dim>& query,
                      const ParticleSet<Dim>& source) {
  const LinearField<Dim> f;
  const PointsView<Dim> source_points = points_of<Dim>(source);
  const NeighborList list =
      brute_force_neighbors<Dim>(points_of<Dim>(query), source_points, kSupportFactor * h);
  const double field_scale = std::abs(f.a) + f.b.norm() * 3.0;
  Counts counts;
  StencilWeights<Dim> linear, shepard;
  for (std::size_t i = 0; i < query.size(); ++i) {
    SCOPED_TRACE("query point " + std::to_string(i));
    const Vec<Dim> x = query.position_of(i);
    const auto row = list.neighbors(i);
    const StencilStatus status = compute_stencil<Dim>(
        kernel, h, x, source_points, source.volume.data(), row, InterpolationKind::linear, linear);
    const StencilStatus shepard_status =
        compute_stencil<Dim>(kernel, h, x, source_points, source.volume.data(), row,
                             InterpolationKind::shepard, shepard);
    ++counts.stencils;
    counts.gradient_fallbacks += status.gradient_fallback;
    counts.interpolation_fallbacks += status.interpolation_fallback;
    counts.no_neighbors += status.no_neighbors;

    EXPECT_FALSE(shepard_status.interpolation_fallback);
    EXPECT_EQ(shepard_status.gradient_fallback, status.gradient_fallback);
    EXPECT_EQ(shepard_status.no_neighbors, status.no_neighbors);
    if (linear.size() != row.size() || linear.value.size() < row.size() ||
        linear.gradient[0].size() < row.size()) {
      ADD_FAILURE() << "weights not sized to the row";
      return counts;
    }
    for (std::size_t k = 0; k < row.size(); ++k) {
      EXPECT_TRUE(std::isfinite(linear.value[k]) && std::isfinite(shepard.value[k]));
      EXPECT_TRUE(linear.gradient_of(k).allFinite());
      EXPECT_EQ(linear.gradient_of(k), shepard.gradient_of(k));
    }

    // What the geometry allows.
    const StencilGeometry<Dim> g = geometry_of<Dim>(kernel, h, x, source_points, row);
    const Span<Dim> gradient_all = span_of<Dim>(g.offsets_all);
    const Span<Dim> gradient_strong = span_of<Dim>(g.offsets_strong);
    const int affine_all = span_of<Dim>(g.affine_all).rank;
    const int affine_strong = span_of<Dim>(g.affine_strong).rank;
    EXPECT_EQ(status.no_neighbors, !g.any_weight);
    if (gradient_strong.rank == Dim) {
      EXPECT_FALSE(status.gradient_fallback);
    }
    if (gradient_all.rank < Dim && !row.empty()) {
      EXPECT_TRUE(status.gradient_fallback);
    }
    if (affine_strong == Dim) {
      EXPECT_FALSE(status.interpolation_fallback);
    }
    if (g.any_weight && affine_all < Dim) {
      EXPECT_TRUE(status.interpolation_fallback);
    }

    // Gradient of the linear field: exact, or exact on the spanned directions.
    Vec<Dim> gradient = Vec<Dim>::Zero();
    for (std::size_t k = 0; k < row.size(); ++k)
      gradient += linear.gradient_of(k) * (f(source_points.point(row[k])) - f(x));
    const Vec<Dim> expected =
        status.gradient_fallback ? Vec<Dim>(gradient_all.projector * f.b) : f.b;
    EXPECT_LE((gradient - expected).norm(), 1e-10 * f.b.norm())
        << "gradient " << gradient.transpose() << " expected " << expected.transpose()
        << (status.gradient_fallback ? " (pseudo-inverse)" : "");

    // Interpolation.
    if (status.no_neighbors) {
      for (std::size_t k = 0; k < row.size(); ++k) EXPECT_EQ(linear.value[k], 0.0);
      continue;
    }
    double linear_sum = 0.0, linear_value = 0.0, shepard_sum = 0.0;
    for (std::size_t k = 0; k < row.size(); ++k) {
      linear_sum += linear.value[k];
      linear_value += linear.value[k] * f(source_points.point(row[k]));
      shepard_sum += shepard.value[k];
      EXPECT_GE(shepard.value[k], 0.0);
    }
    // The tolerances allow for round-off amplified by the moment matrix (condition up to
    // ~2e4 on perturbed 3D quintic stencils, inverted by explicit cofactors): observed
    // errors reach 2.3e-10, while any modelling error would be O(dx) ~ 0.1.
    EXPECT_NEAR(linear_sum, 1.0, 1e-9);
    EXPECT_NEAR(shepard_sum, 1.0, 1e-12);
    if (!status.interpolation_fallback) {
      EXPECT_NEAR(linear_value, f(x), 1e-9 * field_scale);
    } else {
      for (std::size_t k = 0; k < row.size(); ++k) EXPECT_EQ(linear.value[k], shepard.value[k]);
    }
  }
  return counts;
}

template <class DimConstant>
class CorrectedOperatorTest : public ::testing::Test {};

using tsph::testing::Dimensions;
using tsph::testing::DimName;
TYPED_TEST_SUITE(CorrectedOperatorTest, Dimensions, DimName);

// Regular lattices: real -> virtual, virtual -> real and real -> real, for every kernel
// and h. Exact everywhere; no fallback at all except, in 1D with h = 0.6 dx (support
// 1.2 dx), the two end nodes, which see a single virtual particle (linear falls back to
// Shepard there, the gradient stays exact).
TYPED_TEST(CorrectedOperatorTest, LinearFieldsAreExactOnRegularLattices) {
  constexpr int dim = TypeParam::value;
  const LatticeBox<dim> box = test_box<dim>();
  const auto real = make_real_lattice(box, 2.0);
  const auto virtual_set = make_virtual_lattice(box, 2.0);
  for (KernelKind kind : kAllKernelKinds)
    for (double alpha : alphas<dim>()) {
      SCOPED_TRACE(std::string(to_string(kind)) + ", h / dx = " + std::to_string(alpha));
      const double h = alpha * box.spacing;
      visit_kernel<dim>(kind, [&](const auto& kernel) {
        const Counts to_virtual = check_stencils<dim>(kernel, h, real, virtual_set);
        const Counts to_real = check_stencils<dim>(kernel, h, virtual_set, real);
        const Counts within = check_stencils<dim>(kernel, h, real, real);
        EXPECT_EQ(static_cast<std::size_t>(to_virtual.stencils), real.size());
        EXPECT_EQ(
            to_virtual.gradient_fallbacks + to_real.gradient_fallbacks + within.gradient_fallbacks,
            0);
        EXPECT_EQ(to_real.interpolation_fallbacks + within.interpolation_fallbacks, 0);
        EXPECT_EQ(to_virtual.interpolation_fallbacks, dim == 1 && alpha < 1.0 ? 2 : 0);
        EXPECT_EQ(to_virtual.no_neighbors + to_real.no_neighbors + within.no_neighbors, 0);
      });
    }
}

// Real positions perturbed by up to 0.2 dx (an asymmetric stencil everywhere): still
// exact at every query point; in 2D/3D no stencil degenerates.
TYPED_TEST(CorrectedOperatorTest, LinearFieldsAreExactOnPerturbedLattices) {
  constexpr int dim = TypeParam::value;
  const LatticeBox<dim> box = test_box<dim>();
  const auto real = perturbed(make_real_lattice(box, 2.0), box.spacing, 42 + dim);
  const auto virtual_set = make_virtual_lattice(box, 2.0);
  for (KernelKind kind : kAllKernelKinds)
    for (double alpha : alphas<dim>()) {
      SCOPED_TRACE(std::string(to_string(kind)) + ", h / dx = " + std::to_string(alpha));
      const double h = alpha * box.spacing;
      visit_kernel<dim>(kind, [&](const auto& kernel) {
        Counts total;
        for (const Counts& c : {check_stencils<dim>(kernel, h, real, virtual_set),
                                check_stencils<dim>(kernel, h, virtual_set, real),
                                check_stencils<dim>(kernel, h, real, real)}) {
          total.gradient_fallbacks += c.gradient_fallbacks;
          total.interpolation_fallbacks += c.interpolation_fallbacks;
        }
        if (dim > 1 || alpha >= 1.0) {  // 1D at 0.6 dx may isolate a perturbed particle
          EXPECT_EQ(total.gradient_fallbacks, 0);
          EXPECT_EQ(total.interpolation_fallbacks, 0);
        }
      });
    }
}

/// The affine map x = F X + c of the reference-stencil test: 1D a stretch by 2.5; 2D and
/// 3D a stretch (1.5 along x, 0.7 along z), a simple shear gamma = 3 and a rotation by
/// 90 degrees about z, so that no entry of F is near the identity's.
template <int Dim>
Mat<Dim> large_deformation() {
  if constexpr (Dim == 1) {
    return Mat<Dim>::Constant(2.5);
  } else {
    Mat<Dim> stretch = Mat<Dim>::Identity(), shear = Mat<Dim>::Identity(), rotation = Mat<Dim>::Identity();
    stretch(0, 0) = 1.5;
    if constexpr (Dim == 3) stretch(2, 2) = 0.7;
    shear(0, 1) = 3.0;
    rotation(0, 0) = 0.0, rotation(0, 1) = -1.0, rotation(1, 0) = 1.0, rotation(1, 1) = 0.0;
    return rotation * shear * stretch;
  }
}

// The reference configuration of a stencil (SolverSettings::kernel_configuration =
// reference; kernels/corrected_operators.hpp, ReferenceStencil): on the perturbed lattice
// deformed by x = F X + c (a 90 degree rotation, a shear gamma = 3 and stretches), rows
// searched at X, every virtual particle's stencil over the real set
//  * has the kernel values of the undeformed stencil (Shepard weights to 1e-14),
//  * has gradient weights F^-T times the undeformed ones (1e-10 of their size), so it is
//    exact for linear fields of the deformed body (1e-10), and
//  * with `linear` interpolation reproduces linear fields of the deformed body (1e-10),
// with no fallback. The current-configuration stencil of the same rows would also be
// exact for linear fields, but its values differ by O(1) (the kernel sees the deformed
// distances): checked too, so that a reference argument that is silently ignored fails.
TYPED_TEST(CorrectedOperatorTest, ReferenceStencilKeepsTheUndeformedKernelAndIsExactWhenDeformed) {
  constexpr int dim = TypeParam::value;
  const LatticeBox<dim> box = test_box<dim>();
  const auto real = perturbed(make_real_lattice(box, 2.0), box.spacing, 11 + dim);
  const auto virtual_set = make_virtual_lattice(box, 2.0);
  const Mat<dim> F = large_deformation<dim>();
  const Mat<dim> inverse_transpose = F.inverse().transpose();
  Vec<dim> c;
  for (int d = 0; d < dim; ++d) c[d] = 0.3 - 0.1 * d;
  auto deformed = [&](const ParticleSet<dim>& set) {
    ParticleSet<dim> out = set;
    for (std::size_t i = 0; i < set.size(); ++i) {
      const Vec<dim> x = F * set.position_of(i) + c;
      for (int d = 0; d < dim; ++d) out.position[d][i] = x[d];
    }
    return out;
  };
  const auto real_now = deformed(real), virtual_now = deformed(virtual_set);
  const LinearField<dim> f;
  for (KernelKind kind : kAllKernelKinds)
    visit_kernel<dim>(kind, [&](const auto& kernel) {
      SCOPED_TRACE(std::string(to_string(kind)));
      const double h = 1.2 * box.spacing;
      const NeighborList list =
          brute_force_neighbors<dim>(points_of<dim>(virtual_set), points_of<dim>(real), kSupportFactor * h);
      StencilWeights<dim> undeformed, shepard, linear, current;
      double largest_value_change = 0.0;
      for (std::size_t q = 0; q < virtual_set.size(); ++q) {
        const auto row = list.neighbors(q);
        const ReferenceStencil<dim> reference{virtual_set.position_of(q), points_of<dim>(real)};
        const StencilStatus s0 = compute_stencil<dim>(kernel, h, virtual_set.position_of(q), points_of<dim>(real),
                                                      real.volume.data(), row, InterpolationKind::shepard, undeformed);
        const StencilStatus s1 = compute_stencil<dim>(kernel, h, virtual_now.position_of(q), points_of<dim>(real_now),
                                                      real.volume.data(), row, InterpolationKind::shepard, shepard,
                                                      simd_path(), &reference);
        const StencilStatus s2 = compute_stencil<dim>(kernel, h, virtual_now.position_of(q), points_of<dim>(real_now),
                                                      real.volume.data(), row, InterpolationKind::linear, linear,
                                                      simd_path(), &reference);
        compute_stencil<dim>(kernel, h, virtual_now.position_of(q), points_of<dim>(real_now), real.volume.data(), row,
                             InterpolationKind::shepard, current);
        ASSERT_FALSE(s0.gradient_fallback || s1.gradient_fallback || s2.gradient_fallback) << "query " << q;
        ASSERT_FALSE(s2.interpolation_fallback) << "query " << q;
        double value_scale = 0.0, gradient_scale = 0.0;
        for (std::size_t k = 0; k < row.size(); ++k) {
          value_scale = std::max(value_scale, std::abs(undeformed.value[k]));
          gradient_scale = std::max(gradient_scale, (inverse_transpose * undeformed.gradient_of(k)).cwiseAbs().maxCoeff());
        }
        Vec<dim> gradient = Vec<dim>::Zero();
        double interpolated = 0.0;
        const Vec<dim> x_q = virtual_now.position_of(q);
        for (std::size_t k = 0; k < row.size(); ++k) {
          const Vec<dim> x_j = real_now.position_of(row[k]);
          ASSERT_NEAR(shepard.value[k], undeformed.value[k], 1e-14 * value_scale) << "query " << q << ", neighbour " << k;
          ASSERT_LE((shepard.gradient_of(k) - inverse_transpose * undeformed.gradient_of(k)).cwiseAbs().maxCoeff(),
                    1e-10 * gradient_scale)
              << "query " << q << ", neighbour " << k;
          gradient += (f(x_j) - f(x_q)) * shepard.gradient_of(k);
          interpolated += linear.value[k] * f(x_j);
          largest_value_change = std::max(largest_value_change, std::abs(current.value[k] - undeformed.value[k]) / value_scale);
        }
        ASSERT_LE((gradient - f.b).cwiseAbs().maxCoeff(), 1e-10 * f.b.cwiseAbs().maxCoeff()) << "query " << q;
        ASSERT_NEAR(interpolated, f(x_q), 1e-10 * std::abs(f(x_q))) << "query " << q;
      }
      EXPECT_GT(largest_value_change, 0.1);  // the current-configuration kernel does see the deformation
    });
}

// The SSE2 and AVX2 builds of the packed stencil (kernels/simd.hpp) give the same weights
// to round-off (the AVX2 build fuses multiply-adds; lanes are summed in one order): within
// 1e-13 of the row's largest weight (and gradient weight), for every kernel and both
// interpolation kinds on the perturbed lattice, and the same fallbacks; skipped where the
// CPU has no AVX2 and FMA. A lost or swapped term would differ by O(1) of a weight.
TYPED_TEST(CorrectedOperatorTest, SimdPathsGiveTheSameWeightsToRoundOff) {
  constexpr int dim = TypeParam::value;
  if (simd_path() != SimdPath::avx2) GTEST_SKIP() << "no AVX2 and FMA on this CPU (or TSPH_SIMD=sse2)";
  const LatticeBox<dim> box = test_box<dim>();
  const auto real = perturbed(make_real_lattice(box, 2.0), box.spacing, 7 + dim);
  const auto virtual_set = make_virtual_lattice(box, 2.0);
  const PointsView<dim> source = points_of<dim>(real);
  for (KernelKind kind : kAllKernelKinds)
    visit_kernel<dim>(kind, [&](const auto& kernel) {
      SCOPED_TRACE(std::string(to_string(kind)));
      const double h = 1.2 * box.spacing;
      const NeighborList list =
          brute_force_neighbors<dim>(points_of<dim>(virtual_set), source, kSupportFactor * h);
      StencilWeights<dim> sse2, avx2;
      for (InterpolationKind mode : {InterpolationKind::shepard, InterpolationKind::linear})
        for (std::size_t q = 0; q < virtual_set.size(); ++q) {
          const auto row = list.neighbors(q);
          const StencilStatus a = compute_stencil<dim>(kernel, h, virtual_set.position_of(q), source,
                                                       real.volume.data(), row, mode, sse2, SimdPath::sse2);
          const StencilStatus b = compute_stencil<dim>(kernel, h, virtual_set.position_of(q), source,
                                                       real.volume.data(), row, mode, avx2, SimdPath::avx2);
          ASSERT_EQ(a.no_neighbors, b.no_neighbors);
          ASSERT_EQ(a.interpolation_fallback, b.interpolation_fallback);
          ASSERT_EQ(a.gradient_fallback, b.gradient_fallback);
          ASSERT_GT(row.size(), 0u);
          double value_scale = 0.0, gradient_scale = 0.0;
          for (std::size_t k = 0; k < row.size(); ++k) {
            value_scale = std::max(value_scale, std::abs(sse2.value[k]));
            gradient_scale = std::max(gradient_scale, sse2.gradient_of(k).cwiseAbs().maxCoeff());
          }
          for (std::size_t k = 0; k < row.size(); ++k) {
            ASSERT_NEAR(sse2.value[k], avx2.value[k], 1e-13 * value_scale) << "query " << q << ", neighbour " << k;
            ASSERT_LE((sse2.gradient_of(k) - avx2.gradient_of(k)).cwiseAbs().maxCoeff(), 1e-13 * gradient_scale)
                << "query " << q << ", neighbour " << k;
          }
        }
    });
}

// Shepard is exact for constants only: at the lower corner node, whose virtual
// neighbours all lie on one side, it misses a linear field by at least half a spacing
// times the slope, while `linear` is exact there. Would catch the two modes swapped.
TYPED_TEST(CorrectedOperatorTest, ShepardIsNotExactForLinearFieldsAtTheBoundary) {
  constexpr int dim = TypeParam::value;
  const LatticeBox<dim> box = test_box<dim>();
  const auto real = make_real_lattice(box, 2.0);
  const auto virtual_set = make_virtual_lattice(box, 2.0);
  const PointsView<dim> source = points_of<dim>(virtual_set);
  Vec<dim> b = Vec<dim>::Ones();  // all slopes positive: the errors add up
  const Vec<dim> corner = real.position_of(0);
  ASSERT_EQ(corner, box.lower);
  for (KernelKind kind : kAllKernelKinds)
    for (double alpha : alphas<dim>()) {
      SCOPED_TRACE(std::string(to_string(kind)) + ", h / dx = " + std::to_string(alpha));
      const double h = alpha * box.spacing;
      const NeighborList list = brute_force_neighbors<dim>(points_of<dim>(real), source, 2 * h);
      const auto row = list.neighbors(0);
      visit_kernel<dim>(kind, [&](const auto& kernel) {
        StencilWeights<dim> weights;
        for (InterpolationKind mode : {InterpolationKind::shepard, InterpolationKind::linear}) {
          const StencilStatus status = compute_stencil<dim>(
              kernel, h, corner, source, virtual_set.volume.data(), row, mode, weights);
          double interpolated = 0.0;
          for (std::size_t k = 0; k < row.size(); ++k)
            interpolated += weights.value[k] * b.dot(source.point(row[k]));
          const double error = interpolated - b.dot(corner);
          if (mode == InterpolationKind::shepard) {
            EXPECT_GT(error, 0.5 * box.spacing * b.sum() * (1.0 - 1e-9));
          } else if (!status.interpolation_fallback) {
            EXPECT_NEAR(error, 0.0, 1e-10);
          }
        }
      });
    }
}

// A query point with an empty row, or whose only neighbour sits exactly on the support
// radius (W = W' = 0): no_neighbors, zero weights, no NaN.
TYPED_TEST(CorrectedOperatorTest, NoNeighborsGivesZeroWeights) {
  constexpr int dim = TypeParam::value;
  const double h = 0.5;  // dyadic: the neighbour below is exactly 2h away
  std::array<std::vector<double>, dim> coordinates;
  for (int d = 0; d < dim; ++d) coordinates[d] = {d == 0 ? 1.25 : 0.25};
  PointsView<dim> source;
  source.count = 1;
  for (int d = 0; d < dim; ++d) source.coordinate[d] = coordinates[d].data();
  const std::vector<double> volume = {0.3};
  Vec<dim> x = Vec<dim>::Constant(0.25);
  x[0] = 0.25;  // 1.0 = 2h from the source point along axis 0
  const std::vector<std::uint32_t> one = {0};
  for (KernelKind kind : kAllKernelKinds)
    visit_kernel<dim>(kind, [&](const auto& kernel) {
      SCOPED_TRACE(std::string(to_string(kind)));
      for (InterpolationKind mode : {InterpolationKind::shepard, InterpolationKind::linear}) {
        StencilWeights<dim> weights;
        const StencilStatus empty =
            compute_stencil<dim>(kernel, h, x, source, volume.data(), {}, mode, weights);
        EXPECT_TRUE(empty.no_neighbors);
        EXPECT_FALSE(empty.interpolation_fallback);
        EXPECT_FALSE(empty.gradient_fallback);
        EXPECT_EQ(weights.size(), 0u);

        const StencilStatus edge =
            compute_stencil<dim>(kernel, h, x, source, volume.data(), one, mode, weights);
        EXPECT_TRUE(edge.no_neighbors);
        ASSERT_EQ(weights.size(), 1u);
        EXPECT_EQ(weights.value[0], 0.0);
        EXPECT_EQ(weights.gradient_of(0), Vec<dim>::Zero());
      }
    });
}

// 1D, a single neighbour: the moment matrix of `linear` is singular, so it falls back to
// Shepard (weight 1), but one neighbour is enough for an exact 1D gradient. A single
// neighbour at the query point itself gives a zero gradient, flagged, without NaN.
TEST(CorrectedOperator1D, SingleNeighborFallsBackToShepardWithExactGradient) {
  const LinearField<1> f;
  const std::vector<double> position = {0.4, 0.4 + 0.7 * 0.3};
  const std::vector<double> volume = {0.05, 0.07};
  PointsView<1> source;
  source.count = 2;
  source.coordinate[0] = position.data();
  const double h = 0.3;
  const Vec<1> x = Vec<1>::Constant(0.4);
  for (KernelKind kind : kAllKernelKinds)
    visit_kernel<1>(kind, [&](const auto& kernel) {
      SCOPED_TRACE(std::string(to_string(kind)));
      StencilWeights<1> weights;
      const std::vector<std::uint32_t> other = {1};
      const StencilStatus status = compute_stencil<1>(kernel, h, x, source, volume.data(), other,
                                                      InterpolationKind::linear, weights);
      EXPECT_TRUE(status.interpolation_fallback);
      EXPECT_FALSE(status.gradient_fallback);
      EXPECT_FALSE(status.no_neighbors);
      EXPECT_NEAR(weights.value[0], 1.0, 1e-15);
      const double gradient = weights.gradient_of(0)[0] * (f(source.point(1)) - f(x));
      EXPECT_NEAR(gradient, f.b[0], 1e-12 * std::abs(f.b[0]));

      const std::vector<std::uint32_t> itself = {0};
      const StencilStatus self = compute_stencil<1>(kernel, h, x, source, volume.data(), itself,
                                                    InterpolationKind::linear, weights);
      EXPECT_TRUE(self.interpolation_fallback);
      EXPECT_TRUE(self.gradient_fallback);
      EXPECT_EQ(weights.value[0], 1.0);
      EXPECT_EQ(weights.gradient_of(0)[0], 0.0);
    });
}

/// Orthonormal basis (columns) of a `rank`-dimensional subspace in general position.
template <int Dim>
Eigen::Matrix<double, Dim, Eigen::Dynamic> subspace_basis(int rank) {
  Eigen::Matrix<double, Dim, Dim> m;
  if constexpr (Dim == 2)
    m << 1.0, 0.3, 2.0, -0.7;
  else
    m << 1.0, 0.3, -0.2, 2.0, -0.7, 0.5, 0.4, 1.1, 0.9;
  Eigen::HouseholderQR<Eigen::Matrix<double, Dim, Dim>> qr(m);
  const Eigen::Matrix<double, Dim, Dim> q = qr.householderQ();
  return q.leftCols(rank);
}

template <class DimConstant>
class DegenerateStencilTest : public ::testing::Test {};
using MultiDimensions =
    ::testing::Types<std::integral_constant<int, 2>, std::integral_constant<int, 3>>;
TYPED_TEST_SUITE(DegenerateStencilTest, MultiDimensions, DimName);

/// Neighbours and query point all in one `rank`-dimensional subspace (a line or a plane)
/// in general position: the correction matrix is singular, so the gradient must use the
/// pseudo-inverse (gradient_fallback) and be exact within the subspace: for b in it, it
/// returns b; for any b, its projection. `linear` falls back to Shepard. Stencils on both
/// sides and on one side (as at a boundary) are tried. No NaN anywhere.
template <int dim>
void check_subspace_stencils(int rank) {
  const double h = 0.2;
  const Vec<dim> centre = Vec<dim>::Constant(0.35);
  const LinearField<dim> general;
  {
    SCOPED_TRACE("subspace of dimension " + std::to_string(rank));
    const auto basis = subspace_basis<dim>(rank);
    const Mat<dim> projector = basis * basis.transpose();
    // Neighbour coordinates in the subspace, in units of h.
    const std::vector<std::vector<double>> two_sided = {{-1.3, 0.2}, {-0.6, -0.5}, {0.4, 0.9},
                                                        {0.9, -0.3}, {1.5, 0.1},   {0.0, 0.0}};
    const std::vector<std::vector<double>> one_sided = {
        {0.3, 0.2}, {0.8, -0.5}, {1.2, 0.4}, {1.7, 0.6}};
    for (const auto& layout : {two_sided, one_sided}) {
      std::array<std::vector<double>, dim> coordinates;
      for (const auto& t : layout) {
        Vec<dim> p = centre;
        for (int r = 0; r < rank; ++r) p += t[r] * h * basis.col(r);
        for (int d = 0; d < dim; ++d) coordinates[d].push_back(p[d]);
      }
      PointsView<dim> source;
      source.count = layout.size();
      for (int d = 0; d < dim; ++d) source.coordinate[d] = coordinates[d].data();
      const std::vector<double> volume(layout.size(), 0.01);
      std::vector<std::uint32_t> row(layout.size());
      for (std::size_t k = 0; k < row.size(); ++k) row[k] = static_cast<std::uint32_t>(k);

      for (KernelKind kind : kAllKernelKinds)
        visit_kernel<dim>(kind, [&](const auto& kernel) {
          SCOPED_TRACE(std::string(to_string(kind)));
          StencilWeights<dim> weights;
          const StencilStatus status = compute_stencil<dim>(
              kernel, h, centre, source, volume.data(), row, InterpolationKind::linear, weights);
          EXPECT_TRUE(status.gradient_fallback);
          EXPECT_TRUE(status.interpolation_fallback);
          EXPECT_FALSE(status.no_neighbors);
          double sum = 0.0;
          for (std::size_t k = 0; k < row.size(); ++k) {
            ASSERT_TRUE(std::isfinite(weights.value[k]));
            ASSERT_TRUE(weights.gradient_of(k).allFinite());
            sum += weights.value[k];
          }
          EXPECT_NEAR(sum, 1.0, 1e-12);
          // b in the subspace, and a general b.
          LinearField<dim> inside = general;
          inside.b = projector * general.b;
          for (const LinearField<dim>& f : {inside, general}) {
            Vec<dim> gradient = Vec<dim>::Zero();
            for (std::size_t k = 0; k < row.size(); ++k)
              gradient += weights.gradient_of(k) * (f(source.point(k)) - f(centre));
            EXPECT_LE((gradient - projector * f.b).norm(), 1e-10 * f.b.norm())
                << gradient.transpose() << " vs " << (projector * f.b).transpose();
          }
        });
    }
  }
}

// 2D and 3D: all neighbours on one line through the query point. In 3D the correction
// matrix is then rank one up to round-off, the case that once slipped through
// checked_inverse (see CheckedInverse.RejectsRoundOffRankOneMatrix).
TYPED_TEST(DegenerateStencilTest, CollinearStencilUsesPseudoInverse) {
  check_subspace_stencils<TypeParam::value>(1);
}

// 3D: all neighbours in one plane through the query point.
TEST(DegenerateStencil3D, CoplanarStencilUsesPseudoInverse) { check_subspace_stencils<3>(2); }

// checked_inverse (documented for symmetric positive semi-definite matrices): inverts
// well-conditioned ones, 1x1 to 4x4, and reports ok = false for singular,
// ill-conditioned (condition > 1e10), zero and non-finite ones, returning zero for those
// it cannot invert at all.
TEST(CheckedInverse, InvertsWellConditionedAndRejectsSingular) {
  bool ok = false;
  Eigen::Matrix<double, 1, 1> scalar;
  scalar << 4.0;
  EXPECT_DOUBLE_EQ(checked_inverse<1>(scalar, ok)(0, 0), 0.25);
  EXPECT_TRUE(ok);

  Eigen::Matrix3d spd;
  spd << 4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 2.0;
  const Eigen::Matrix3d spd_inverse = checked_inverse<3>(spd, ok);
  EXPECT_TRUE(ok);
  EXPECT_LE((spd * spd_inverse - Eigen::Matrix3d::Identity()).norm(), 1e-14);

  Eigen::Matrix4d factor;
  factor << 2.0, -1.0, 0.0, 3.0, 1.0, 4.0, 1.0, 0.0, 0.0, 2.0, 5.0, -1.0, 1.0, 0.0, 1.0, 3.0;
  const Eigen::Matrix4d moments = factor.transpose() * factor;  // a 4x4 moment-like SPD matrix
  const Eigen::Matrix4d moments_inverse = checked_inverse<4>(moments, ok);
  EXPECT_TRUE(ok);
  EXPECT_LE((moments_inverse * moments - Eigen::Matrix4d::Identity()).norm(), 1e-12);

  Eigen::Matrix2d singular;
  singular << 1.0, 2.0, 2.0, 4.0;
  checked_inverse<2>(singular, ok);
  EXPECT_FALSE(ok);

  Eigen::Matrix2d moderately = Eigen::Vector2d(1.0, 1e-8).asDiagonal();
  checked_inverse<2>(moderately, ok);
  EXPECT_TRUE(ok);  // condition 1e8
  Eigen::Matrix2d badly = Eigen::Vector2d(1.0, 1e-12).asDiagonal();
  checked_inverse<2>(badly, ok);
  EXPECT_FALSE(ok);  // condition 1e12

  EXPECT_EQ(checked_inverse<3>(Eigen::Matrix3d::Zero().eval(), ok), Eigen::Matrix3d::Zero());
  EXPECT_FALSE(ok);
  Eigen::Matrix2d not_finite = Eigen::Matrix2d::Identity();
  not_finite(0, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(checked_inverse<2>(not_finite, ok), Eigen::Matrix2d::Zero());
  EXPECT_FALSE(ok);
}

// infinity_norm: Eigen's largest absolute row sum to the last bit or so, and NaN when
// any entry is not finite, also in a row after the first (where Eigen's maxCoeff may
// skip a NaN row sum).
TEST(InfinityNorm, MatchesEigenAndFlagsEntriesThatAreNotFinite) {
  Eigen::Matrix4d m;
  m << 1.5, -2.0, 0.25, 3.0,  //
      -7.0, 0.5, 1.0, -0.125,  //
      0.0, 4.0, -4.0, 0.5,  //
      2.0, 2.0, -2.0, 2.0;
  EXPECT_NEAR(infinity_norm<4>(m), m.cwiseAbs().rowwise().sum().maxCoeff(), 1e-15);
  EXPECT_DOUBLE_EQ(infinity_norm<4>(m), 8.625);
  EXPECT_EQ(infinity_norm<3>(Eigen::Matrix3d::Zero().eval()), 0.0);
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                           -std::numeric_limits<double>::infinity()}) {
    Eigen::Matrix3d later_row = Eigen::Matrix3d::Identity();
    later_row(2, 1) = bad;
    EXPECT_TRUE(std::isnan(infinity_norm<3>(later_row))) << bad;
    bool ok = true;
    EXPECT_EQ(checked_inverse<3>(later_row, ok), Eigen::Matrix3d::Zero()) << bad;
    EXPECT_FALSE(ok) << bad;
  }
}

// Regression: the correction matrix of a 3D stencil whose neighbours lie on one line
// (cubic spline, h = 0.2, the line of CollinearStencilUsesPseudoInverse) is rank one up
// to round-off (eigenvalues 0, 0, 0.986). Its determinant (6.6e-19) and the cofactors of
// its explicit inverse are both pure round-off, so the "inverse" looks well scaled
// (condition estimate ~26) while |M * inverse - I| = 2.8; checked_inverse used to accept
// it. It must report ok = false, or return a true inverse.
TEST(CheckedInverse, RejectsRoundOffRankOneMatrix) {
  Eigen::Matrix3d m;
  m << 0.1911362961187188, 0.38227259223743754, 0.076454518447487491,  //
      0.38227259223743748, 0.76454518447487485, 0.15290903689497495,   //
      0.076454518447487477, 0.15290903689497493, 0.030581807378994984;
  bool ok = true;
  const Eigen::Matrix3d inverse = checked_inverse<3>(m, ok);
  // Either it is rejected, or what is returned is an inverse.
  if (ok) {
    EXPECT_LE((m * inverse - Eigen::Matrix3d::Identity()).norm(), 1e-6);
  }
  EXPECT_FALSE(ok);
}

// symmetric_pseudo_inverse of a positive semi-definite matrix satisfies the
// Moore-Penrose conditions A P A = A, P A P = P, P symmetric; it is the inverse for a
// full-rank matrix and zero for the zero matrix.
TEST(SymmetricPseudoInverse, SatisfiesPenroseConditions) {
  const Eigen::Vector3d u(1.0, 2.0, -0.5), v(0.3, -1.0, 0.7);
  const Eigen::Matrix3d rank_one = 2.5 * u * u.transpose();
  const Eigen::Matrix3d rank_two = rank_one + 0.8 * v * v.transpose();
  for (const Eigen::Matrix3d& a : {rank_one, rank_two}) {
    const Eigen::Matrix3d p = symmetric_pseudo_inverse<3>(a);
    EXPECT_LE((a * p * a - a).norm(), 1e-12 * a.norm());
    EXPECT_LE((p * a * p - p).norm(), 1e-12 * p.norm());
    EXPECT_LE((p - p.transpose()).norm(), 1e-14 * p.norm());
    EXPECT_LE((a * p - (a * p).transpose()).norm(), 1e-12);
  }
  // Rank one: P = u u^T / (2.5 |u|^4).
  EXPECT_LE((symmetric_pseudo_inverse<3>(rank_one) -
             u * u.transpose() / (2.5 * u.squaredNorm() * u.squaredNorm()))
                .norm(),
            1e-14);
  Eigen::Matrix2d spd;
  spd << 3.0, 1.0, 1.0, 2.0;
  EXPECT_LE((symmetric_pseudo_inverse<2>(spd) - spd.inverse()).norm(), 1e-14);
  EXPECT_EQ(symmetric_pseudo_inverse<2>(Eigen::Matrix2d::Zero().eval()), Eigen::Matrix2d::Zero());
}

}  // namespace
}  // namespace tsph
