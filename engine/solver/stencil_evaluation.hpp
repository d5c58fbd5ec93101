// Evaluation of one stencil row (docs/method.md section 2): the interpolated state of a
// query point and the corrected gradients of the flux, shared by the half step (seed
// eq. 3) and the full step (seed eq. 4), and the tally of stencil fallbacks.
#pragma once

#include "engine/elasticity.hpp"
#include "engine/particle_set.hpp"
#include "kernels/corrected_operators.hpp"
#include "kernels/simd.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

namespace tsph {

/// exp(x), as std::exp to round-off (1-2 ulp), for the density update
/// rho^{n+1} = rho^n exp(-dt tr L): there |x| is about dt |div v|, far below 2^-10, where
/// the Taylor polynomial to x^5 is exact to x^6 / 720 < 2e-21 (relative), and costs a
/// tenth of std::exp (two calls per pair of stencil rows); std::exp elsewhere.
inline double exp_of_small(double x) {
  if (!(std::abs(x) <= 0x1p-10)) return std::exp(x);
  return 1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0)))));
}

template <int Dim>
struct StencilEvaluation {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;
  using StressGradient = std::array<Vec, stress_count>;

  /// Interpolated state and flux derivatives of one query point over a stencil.
  struct LocalState {
    StressVector<Dim> stress{};
    Vec velocity = Vec::Zero();
    double density = 0.0;
    Mat velocity_gradient = Mat::Zero();  ///< grad v(i, j) = d v_i / d x_j
    Vec stress_divergence = Vec::Zero();  ///< div sigma
  };

  /// Source fields evaluate reads per neighbour: stress components, then velocity, then
  /// density; the first `gradient_field_count` (the in-plane stress components and the
  /// velocity) also enter the gradients.
  static constexpr int velocity_field = stress_count, density_field = stress_count + Dim;
  static constexpr int gathered_count = stress_count + Dim + 1;
  static constexpr int gradient_field_count = stress_count + Dim;
  /// The gradient fields of one row, as loaded by the interpolation pass (padded like
  /// StencilWeights), for the gradient pass.
  struct GatheredSource {
    std::array<PackBuffer, gradient_field_count> field;
  };
  /// Per-thread scratch of the half and full steps.
  struct StepScratch {
    StencilWeights<Dim> weights;
    GatheredSource gathered;
    std::vector<std::uint32_t> wide_row;  ///< a widened stencil (full_step.hpp, widen)
  };

  /// The body of evaluate, compiled once per instruction set (kernels/simd.hpp).
  /// Two passes over the row, kLanes neighbours at a time. The interpolation pass loads
  /// each source field straight into a pack from its array (load_indexed_pack; padding
  /// lanes read the first neighbour again and have zero weights) and keeps the gradient
  /// fields' packs for the gradient pass (before: a scalar gather of every field into
  /// buffers first, 2.5x the instructions; same sums, same order: bitwise the same
  /// results; bench/RESULTS.md, "Per-row overheads").
  [[gnu::always_inline]] static LocalState evaluate_in_packs(const ParticleView<Dim>& source,
                                                              std::span<const std::uint32_t> nb,
                                                              const StencilWeights<Dim>& w,
                                                              GatheredSource& gathered) {
    const std::size_t n = nb.size();
    const std::size_t padded = padded_size(n);
    std::array<const double*, gathered_count> source_field;
    for (int m = 0; m < stress_count; ++m) source_field[m] = source.stress[m];
    for (int d = 0; d < Dim; ++d) source_field[velocity_field + d] = source.velocity[d];
    source_field[density_field] = source.density;
    if (gathered.field[0].size() < padded)  // all grow together, never shrink
      for (auto& buffer : gathered.field) buffer.resize(padded);
    std::array<double*, gradient_field_count> kept;
    for (int m = 0; m < gradient_field_count; ++m) kept[m] = gathered.field[m].data();
    const std::uint32_t* const index = nb.data();
    const double* const value = w.value.data();

    // Interpolation: sum_J V_J Wn_IJ f_J, one partial sum per lane.
    std::array<Pack, gathered_count> sum{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<std::uint32_t, kLanes> j;
      if (k + kLanes <= n) {  // a full pack (all but the last of a row)
        for (std::size_t l = 0; l < kLanes; ++l) j[l] = index[k + l];
      } else {
        for (std::size_t l = 0; l < kLanes; ++l) j[l] = k + l < n ? index[k + l] : index[0];
      }
      const Pack c = load_pack(value + k);
      for (int m = 0; m < gathered_count; ++m) {
        const Pack f = load_indexed_pack(source_field[m], j);
        if (m < gradient_field_count) store_pack(kept[m] + k, f);
        sum[m] += c * f;
      }
    }
    const auto interpolated = lane_sums(sum);
    LocalState s;
    for (int m = 0; m < stress_count; ++m) s.stress[m] = interpolated[m];
    for (int d = 0; d < Dim; ++d) s.velocity[d] = interpolated[velocity_field + d];
    s.density = interpolated[density_field];

    // Gradients relative to the interpolated value: sum_J V_J Gn_IJ (f_J - f_I).
    std::array<const double*, Dim> gradient;
    for (int l = 0; l < Dim; ++l) gradient[l] = w.gradient[l].data();
    // Partial sums: velocity gradient (i, l) at i * Dim + l, then the divergence.
    std::array<Pack, Dim * Dim + Dim> derivative{};
    auto velocity_terms = [&](std::size_t k, const std::array<Pack, Dim>& g) {
      for (int i = 0; i < Dim; ++i) {
        const Pack dv = load_pack(kept[velocity_field + i] + k) - s.velocity[i];
        for (int l = 0; l < Dim; ++l) derivative[i * Dim + l] += dv * g[l];
      }
    };
    auto stress_terms = [&](std::size_t k, const std::array<Pack, Dim>& g) {
      for (int i = 0; i < Dim; ++i)
        for (int l = 0; l < Dim; ++l) {
          const int m = stress_index<Dim>(i, l);
          derivative[Dim * Dim + i] += (load_pack(kept[m] + k) - s.stress[m]) * g[l];
        }
    };
    auto gradient_packs = [&](std::size_t k) {
      std::array<Pack, Dim> g;
      for (int l = 0; l < Dim; ++l) g[l] = load_pack(gradient[l] + k);
      return g;
    };
    if constexpr (Dim == 3) {
      // Two sweeps: the 12 partial sums of one sweep with the 3 gradient packs exceeded
      // the 16 vector registers, and one sum lived on the stack, each pack's FMA waiting
      // on the last pack's store (perf, 2026-12-07: 7.5 % of this function's samples on
      // the quarter Taylor bar). Each sum's operations and order are the same: the same bits.
      for (std::size_t k = 0; k < padded; k += kLanes) velocity_terms(k, gradient_packs(k));
      for (std::size_t k = 0; k < padded; k += kLanes) stress_terms(k, gradient_packs(k));
    } else {
      for (std::size_t k = 0; k < padded; k += kLanes) {
        const std::array<Pack, Dim> g = gradient_packs(k);
        velocity_terms(k, g);
        stress_terms(k, g);
      }
    }
    const auto derivatives = lane_sums(derivative);
    for (int i = 0; i < Dim; ++i) {
      for (int l = 0; l < Dim; ++l) s.velocity_gradient(i, l) = derivatives[i * Dim + l];
      s.stress_divergence[i] = derivatives[Dim * Dim + i];
    }
    return s;
  }
  static LocalState evaluate_sse2(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                                  const StencilWeights<Dim>& w, GatheredSource& gathered) {
    return evaluate_in_packs(source, nb, w, gathered);
  }
  TSPH_TARGET_AVX2 static LocalState evaluate_avx2(const ParticleView<Dim>& source,
                                                    std::span<const std::uint32_t> nb,
                                                    const StencilWeights<Dim>& w,
                                                    GatheredSource& gathered) {
    return evaluate_in_packs(source, nb, w, gathered);
  }

  /// Interpolates U at the query point and takes the corrected gradients of the
  /// velocity and the divergence of the stress, both relative to the interpolated
  /// value at the query point (docs/method.md section 2). Same instruction set as
  /// compute_stencil (simd_path()).
  static LocalState evaluate(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                             const StencilWeights<Dim>& w, GatheredSource& gathered) {
    if (simd_path() == SimdPath::avx2) return evaluate_avx2(source, nb, w, gathered);
    return evaluate_sse2(source, nb, w, gathered);
  }

  /// The corrected gradients of `Fields` source fields, each relative to its value
  /// `centre[f]` at the query: result[f] = sum_J V_J Gn_IJ (f_J - centre_f). The body of
  /// field_gradients, compiled once per instruction set: kLanes neighbours at a time, one
  /// partial sum per lane (the padding lanes of the last pack have zero gradients:
  /// compute_stencil). Before (2026-12-07) a scalar loop per neighbour and field: the
  /// boundary rows' gradients at n and their stress gradients at n+1/2 were 10.8 % of
  /// the twisting column's instructions.
  template <int Fields>
  [[gnu::always_inline]] static std::array<Vec, Fields> field_gradients_in_packs(
      const std::array<const double*, Fields>& field, std::span<const std::uint32_t> nb,
      const StencilWeights<Dim>& w, const std::array<double, Fields>& centre) {
    const std::size_t n = nb.size();
    const std::size_t padded = padded_size(n);
    const std::uint32_t* const index = nb.data();
    std::array<const double*, Dim> gradient;
    for (int l = 0; l < Dim; ++l) gradient[l] = w.gradient[l].data();
    std::array<Pack, Fields * Dim> sum{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<std::uint32_t, kLanes> j;
      for (std::size_t l = 0; l < kLanes; ++l) j[l] = k + l < n ? index[k + l] : index[0];
      std::array<Pack, Dim> g;
      for (int l = 0; l < Dim; ++l) g[l] = load_pack(gradient[l] + k);
      for (int f = 0; f < Fields; ++f) {
        const Pack difference = load_indexed_pack(field[f], j) - centre[f];
        for (int l = 0; l < Dim; ++l) sum[f * Dim + l] += difference * g[l];
      }
    }
    const auto total = lane_sums(sum);
    std::array<Vec, Fields> result;
    for (int f = 0; f < Fields; ++f)
      for (int l = 0; l < Dim; ++l) result[f][l] = total[f * Dim + l];
    return result;
  }
  template <int Fields>
  static std::array<Vec, Fields> field_gradients_sse2(const std::array<const double*, Fields>& field,
                                                      std::span<const std::uint32_t> nb, const StencilWeights<Dim>& w,
                                                      const std::array<double, Fields>& centre) {
    return field_gradients_in_packs<Fields>(field, nb, w, centre);
  }
  template <int Fields>
  TSPH_TARGET_AVX2 static std::array<Vec, Fields> field_gradients_avx2(const std::array<const double*, Fields>& field,
                                                                       std::span<const std::uint32_t> nb,
                                                                       const StencilWeights<Dim>& w,
                                                                       const std::array<double, Fields>& centre) {
    return field_gradients_in_packs<Fields>(field, nb, w, centre);
  }
  /// field_gradients_in_packs on the instruction set of compute_stencil (simd_path()).
  template <int Fields>
  static std::array<Vec, Fields> field_gradients(const std::array<const double*, Fields>& field,
                                                 std::span<const std::uint32_t> nb, const StencilWeights<Dim>& w,
                                                 const std::array<double, Fields>& centre) {
    if (simd_path() == SimdPath::avx2) return field_gradients_avx2<Fields>(field, nb, w, centre);
    return field_gradients_sse2<Fields>(field, nb, w, centre);
  }

  /// Full corrected gradient of every stress component, relative to `centre`.
  static StressGradient stress_gradient(const ParticleView<Dim>& source,
                                        std::span<const std::uint32_t> nb,
                                        const StencilWeights<Dim>& w,
                                        const StressVector<Dim>& centre) {
    std::array<const double*, stress_count> field;
    std::array<double, stress_count> value;
    for (int m = 0; m < stress_count; ++m) field[m] = source.stress[m], value[m] = centre[m];
    return field_gradients<stress_count>(field, nb, w, value);
  }

  /// The corrected velocity gradient (grad v(i, j) = d v_i / d x_j) and the gradient of
  /// every stress component, relative to `velocity` and `stress` at the query, in one
  /// pass (the boundary rows at n: characteristics.hpp).
  static void velocity_and_stress_gradients(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                                            const StencilWeights<Dim>& w, const Vec& velocity,
                                            const StressVector<Dim>& stress, Mat& velocity_gradient,
                                            StressGradient& stress_gradient) {
    constexpr int fields = Dim + stress_count;
    std::array<const double*, fields> field;
    std::array<double, fields> value;
    for (int d = 0; d < Dim; ++d) field[d] = source.velocity[d], value[d] = velocity[d];
    for (int m = 0; m < stress_count; ++m) field[Dim + m] = source.stress[m], value[Dim + m] = stress[m];
    const auto gradients = field_gradients<fields>(field, nb, w, value);
    for (int d = 0; d < Dim; ++d) velocity_gradient.row(d) = gradients[d].transpose();
    for (int m = 0; m < stress_count; ++m) stress_gradient[m] = gradients[Dim + m];
  }
};

/// Per-thread tally of stencil fallbacks (SolverCounters).
struct StencilCounts {
  std::int64_t empty = 0, interpolation = 0, gradient = 0, widened = 0;
  StencilCounts& operator+=(const StencilStatus& status) {
    empty += status.no_neighbors;
    interpolation += status.interpolation_fallback;
    gradient += status.gradient_fallback;
    return *this;
  }
  StencilCounts& operator+=(const StencilCounts& other) {
    empty += other.empty;
    interpolation += other.interpolation;
    gradient += other.gradient;
    widened += other.widened;
    return *this;
  }
};

}  // namespace tsph
