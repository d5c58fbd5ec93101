// Regular particle lattices for boxes: real particles on the nodes of a lattice of
// spacing dx (the boundary nodes included), virtual particles at the cell centres
// (midpoints in 1D) of the same lattice (docs/method.md section 3).
//
// A real particle's volume is its share of the box (trapezoidal rule): dx^Dim in the
// interior, halved once per axis on which it sits on a face. So the masses add up to
// rho times the box volume, and sums over particles are the trapezoidal quadrature.
#pragma once

#include "engine/particle_set.hpp"

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace tsph {

template <int Dim>
struct LatticeBox {
  Vector<Dim> lower = Vector<Dim>::Zero();
  std::array<std::int64_t, Dim> node_count{};  ///< real particles per axis (>= 2)
  double spacing = 0.0;                        ///< dx

  std::int64_t total_nodes() const {
    std::int64_t n = 1;
    for (auto c : node_count) n *= c;
    return n;
  }
  std::int64_t total_cells() const {
    std::int64_t n = 1;
    for (auto c : node_count) n *= c - 1;
    return n;
  }
  void validate() const {
    if (!(spacing > 0.0))
      throw std::invalid_argument("lattice: dx = " + std::to_string(spacing) + " must be positive");
    for (int d = 0; d < Dim; ++d)
      if (node_count[d] < 2)
        throw std::invalid_argument("lattice: " + std::to_string(node_count[d]) +
                                    " particles along axis " + std::to_string(d) +
                                    "; at least 2 are needed");
  }
};

namespace detail {
/// Calls f(linear index, multi-index) over a Dim-dimensional index box, axis 0 fastest.
template <int Dim, class F>
void for_each_multi_index(const std::array<std::int64_t, Dim>& counts, F&& f) {
  std::array<std::int64_t, Dim> index{};
  std::int64_t total = 1;
  for (auto c : counts) total *= c;
  for (std::int64_t linear = 0; linear < total; ++linear) {
    f(linear, index);
    for (int d = 0; d < Dim; ++d) {
      if (++index[d] < counts[d]) break;
      index[d] = 0;
    }
  }
}

template <int Dim>
void fill_particle(ParticleSet<Dim>& set, std::size_t i, const Vector<Dim>& x, double volume,
                   double density) {
  for (int d = 0; d < Dim; ++d) {
    set.position[d][i] = x[d];
    set.initial_position[d][i] = x[d];
  }
  set.volume[i] = volume;
  set.density[i] = density;
  set.mass[i] = density * volume;
}
}  // namespace detail

/// Real particles on the lattice nodes, at rest, unstressed.
template <int Dim>
ParticleSet<Dim> make_real_lattice(const LatticeBox<Dim>& box, double density) {
  box.validate();
  ParticleSet<Dim> set;
  set.resize(static_cast<std::size_t>(box.total_nodes()));
  detail::for_each_multi_index<Dim>(box.node_count, [&](std::int64_t i, const auto& index) {
    Vector<Dim> x;
    double volume = 1.0;
    for (int d = 0; d < Dim; ++d) {
      x[d] = box.lower[d] + static_cast<double>(index[d]) * box.spacing;
      const bool on_face = index[d] == 0 || index[d] == box.node_count[d] - 1;
      volume *= on_face ? 0.5 * box.spacing : box.spacing;
    }
    detail::fill_particle(set, static_cast<std::size_t>(i), x, volume, density);
  });
  return set;
}

/// Virtual particles at the centres of the lattice cells, each with volume dx^Dim.
template <int Dim>
ParticleSet<Dim> make_virtual_lattice(const LatticeBox<Dim>& box, double density) {
  box.validate();
  std::array<std::int64_t, Dim> cells;
  double volume = 1.0;
  for (int d = 0; d < Dim; ++d) {
    cells[d] = box.node_count[d] - 1;
    volume *= box.spacing;
  }
  ParticleSet<Dim> set;
  set.resize(static_cast<std::size_t>(box.total_cells()));
  detail::for_each_multi_index<Dim>(cells, [&](std::int64_t i, const auto& index) {
    Vector<Dim> x;
    for (int d = 0; d < Dim; ++d)
      x[d] = box.lower[d] + (static_cast<double>(index[d]) + 0.5) * box.spacing;
    detail::fill_particle(set, static_cast<std::size_t>(i), x, volume, density);
  });
  return set;
}

}  // namespace tsph
