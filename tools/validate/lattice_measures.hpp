// Measures of a frame of real particles that started on one box lattice (the plate and
// the twisting column): the lattice index of each particle, its trapezoidal mass, and the
// hourglass measure (the part of a nodal field that no local quadratic explains).
#pragma once

#include "engine/output/vtu_writer.hpp"

#include "tools/validate/support.hpp"

#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph::validate {

/// The real particles' places on the initial lattice of a single box (lower, dx, node counts).
template <int Dim>
struct LatticeFrame {
  std::array<int, Dim> nodes{};
  std::vector<std::array<int, Dim>> index;  ///< per particle
  std::map<std::array<int, Dim>, std::size_t> particle_at;

  LatticeFrame(const output::VtuFrame& f, const std::array<double, Dim>& lower, const std::array<double, Dim>& upper,
               double dx) {
    for (int d = 0; d < Dim; ++d) nodes[d] = static_cast<int>(std::lround((upper[d] - lower[d]) / dx)) + 1;
    const auto& x0 = array_of(f, "initial_position");
    index.resize(f.point_count);
    for (std::size_t i = 0; i < f.point_count; ++i) {
      for (int d = 0; d < Dim; ++d) index[i][d] = static_cast<int>(std::lround((x0[3 * i + d] - lower[d]) / dx));
      particle_at[index[i]] = i;
    }
  }
  /// The trapezoidal weight of the particle's lattice volume: 1/2 per face it lies on.
  double volume_fraction(std::size_t i) const {
    double w = 1.0;
    for (int d = 0; d < Dim; ++d)
      if (index[i][d] == 0 || index[i][d] == nodes[d] - 1) w *= 0.5;
    return w;
  }
};

/// The hourglass measure of a nodal vector field: at each node whose 3^Dim lattice
/// stencil is complete, the residual r = f_c - q(x_c) of the least-squares quadratic q
/// through the stencil (6 terms in 2D, 10 in 3D). Smooth fields leave O(dx^3 f''')
/// (a linear or quadratic field exactly 0); a checkerboard (-1)^(i+j[+k]) or an odd-even
/// column of amplitude a leaves a residual of order a. Returns {RMS, max} of |r| over
/// those nodes.
template <int Dim>
std::array<double, 2> hourglass_residual(const LatticeFrame<Dim>& lattice, const std::vector<double>& field) {
  // The stencil's offsets and the residual weights w_k = delta_ck - P_ck, P the
  // projection on the quadratics.
  static const auto stencil = [] {
    std::vector<std::array<int, Dim>> offsets;
    std::array<int, Dim> o{};
    const int count = Dim == 2 ? 9 : 27;
    for (int k = 0; k < count; ++k) {
      int rest = k;
      for (int d = 0; d < Dim; ++d) {
        o[d] = rest % 3 - 1;
        rest /= 3;
      }
      offsets.push_back(o);
    }
    const int terms = Dim == 2 ? 6 : 10;
    Eigen::MatrixXd basis(count, terms);
    for (int k = 0; k < count; ++k) {
      int t = 0;
      basis(k, t++) = 1.0;
      for (int d = 0; d < Dim; ++d) basis(k, t++) = offsets[k][d];
      for (int d = 0; d < Dim; ++d)
        for (int e = d; e < Dim; ++e) basis(k, t++) = offsets[k][d] * offsets[k][e];
    }
    const Eigen::MatrixXd projection = basis * (basis.transpose() * basis).inverse() * basis.transpose();
    const int centre = count / 2;
    std::vector<double> weights(count);
    for (int k = 0; k < count; ++k) weights[k] = (k == centre ? 1.0 : 0.0) - projection(centre, k);
    return std::make_pair(offsets, weights);
  }();
  double sum = 0.0, largest = 0.0;
  std::size_t count = 0;
  std::vector<std::size_t> members(stencil.first.size());
  for (std::size_t i = 0; i < lattice.index.size(); ++i) {
    bool complete = true;
    for (std::size_t k = 0; k < stencil.first.size() && complete; ++k) {
      std::array<int, Dim> at = lattice.index[i];
      for (int d = 0; d < Dim; ++d) at[d] += stencil.first[k][d];
      const auto it = lattice.particle_at.find(at);
      if (it == lattice.particle_at.end()) complete = false;
      else members[k] = it->second;
    }
    if (!complete) continue;
    double r2 = 0.0;
    for (int d = 0; d < 3; ++d) {
      double r = 0.0;
      for (std::size_t k = 0; k < members.size(); ++k) r += stencil.second[k] * field[3 * members[k] + d];
      r2 += r * r;
    }
    sum += r2;
    largest = std::max(largest, std::sqrt(r2));
    ++count;
  }
  return {count ? std::sqrt(sum / static_cast<double>(count)) : 0.0, largest};
}

/// Times t with v(t) = 0 (sign changes, linearly interpolated).
inline std::vector<double> zero_crossings(const std::vector<double>& t, const std::vector<double>& v) {
  std::vector<double> out;
  for (std::size_t k = 1; k < t.size(); ++k)
    if ((v[k - 1] > 0.0 && v[k] <= 0.0) || (v[k - 1] < 0.0 && v[k] >= 0.0))
      out.push_back(t[k - 1] + (t[k] - t[k - 1]) * v[k - 1] / (v[k - 1] - v[k]));
  return out;
}

/// The period from successive zero crossings: 2 (t_last - t_first) / (n - 1); NaN with fewer than 3.
inline double period_from_crossings(const std::vector<double>& crossings) {
  if (crossings.size() < 3) return std::nan("");
  return 2.0 * (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
}

}  // namespace tsph::validate
