// The neighbour-list lifecycle (docs/architecture.md): the searches of both half-step
// lists and of the boundary rows, the Verlet skin's check, the full step's list, the
// rebuild after the motion, and the sort of both sets into a spatial order (with every
// per-particle state of the solver permuted in one call each).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/boundary/free_edge.hpp"
#include "engine/solver/boundary/mirror_planes.hpp"
#include "engine/solver/boundary/normals.hpp"
#include "engine/solver/stabilisation/volumetric_average.hpp"
#include "engine/solver/state.hpp"
#include "neighbor/neighbor_search.hpp"
#include "neighbor/spatial_order.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <vector>

namespace tsph {

template <int Dim>
struct NeighborLists {
  /// Neighbour lists of both half-steps and of the real set, and the boundary normals
  /// n = -sum_J V_J grad_I W_IJ / |.| (they point out of the body).
  static void build(SolverState<Dim>& state) {
    search(state);
    compute_normals(state);
  }

  /// BoundaryNormals::compute, and after the first build's surface decision the static
  /// geometry of the free corners and edges (FreeEdge::classify).
  static void compute_normals(SolverState<Dim>& state) {
    const bool first_build = !state.lists.surface_decided;
    BoundaryNormals<Dim>::compute(state);
    if (first_build) FreeEdge<Dim>::classify(state);
  }

  /// The searches of build, with radius state.list_radius(): both half-step lists
  /// (without skin in updated Lagrangian the full step's is left to the full step), the
  /// boundary rows of the real set, and with a skin the path bounds reset.
  static void search(SolverState<Dim>& state) {
    const double radius = state.list_radius();
    const bool skin = state.skin_distance() > 0.0;
    MirrorPlanes<Dim>::generate(state);  // mirror planes: the ghosts, sources like the owned particles
    // With the reference kernel the pairs are those within 2h at X, for the whole run.
    const bool reference = state.reference_kernel();
    const PointsView<Dim> real_points = reference ? initial_points_of<Dim>(state.real) : points_of<Dim>(state.real);
    const PointsView<Dim> virtual_points =
        reference ? initial_points_of<Dim>(state.virtual_) : points_of<Dim>(state.virtual_);
    // Rows for the owned particles only (a ghost is never a target).
    PointsView<Dim> real_rows = real_points, virtual_rows = virtual_points;
    real_rows.count = state.real.size();
    virtual_rows.count = state.virtual_.size();
    // The old lists are released first, so that two generations never coexist (memory).
    state.lists.virtual_from_real = NeighborList{};
    state.lists.real_from_virtual = NeighborList{};
    state.lists.real_from_real = NeighborList{};
    {
      const NeighborSearcher<Dim> real_search(state.settings.neighbor_search, real_points, radius);
      state.lists.search_used = real_search.kind();
      state.lists.virtual_from_real = real_search.query(virtual_rows);
      // Same-set rows only where they are used: the boundary particles (rows of the other
      // real particles are empty, so the list is still indexed by real particle).
      state.lists.real_from_real = real_search.query_subset(real_rows, state.boundary.particle, true);
    }
    // The transpose of virtual_from_real lacks the virtual ghosts: with mirror planes the
    // full step's list is searched.
    if (!state.lists_used_once())
      state.lists.real_from_virtual =
          (state.settings.transpose_lists || skin) && !state.mirror.active()
              ? transpose(state.lists.virtual_from_real, state.real.size())
              : NeighborSearcher<Dim>(state.settings.neighbor_search, virtual_points, radius).query(real_rows);
    state.lists.real_path_bound = 0.0;  // the lists hold the pairs within state.list_radius() from here on
    state.lists.virtual_path_bound = 0.0;
    ++state.counters.neighbor_builds;
    if (VolumetricAverage<Dim>::active(state)) VolumetricAverage<Dim>::build(state);  // its material stencils
  }

  /// The full step's list (rows: real, entries: virtual). In updated-Lagrangian runs
  /// without skin (SolverState::lists_used_once) the half step's list is done with:
  /// released, and the full step's built now at the midpoint configuration (searched, or
  /// transposed with SolverSettings::transpose_lists). Otherwise the lists are kept.
  static void prepare_full_step(SolverState<Dim>& state) {
    if (!state.lists_used_once()) return;
    state.lists.real_from_virtual = NeighborList{};
    if (state.settings.transpose_lists && !state.mirror.active()) {
      state.lists.real_from_virtual = transpose(state.lists.virtual_from_real, state.real.size());
      state.lists.virtual_from_real = NeighborList{};
    } else {
      state.lists.virtual_from_real = NeighborList{};
      PointsView<Dim> real_rows = points_of<Dim>(state.real);
      real_rows.count = state.real.size();
      state.lists.real_from_virtual =
          NeighborSearcher<Dim>(state.settings.neighbor_search, points_of<Dim>(state.virtual_), state.support_radius())
              .query(real_rows);
    }
  }

  /// After the motion to x^{n+1} (updated Lagrangian): with a skin that still covers the
  /// motion the lists hold every pair within 2h and only the normals are computed again;
  /// otherwise the lists are rebuilt.
  static void update_after_move(SolverState<Dim>& state, double dt) {
    if (state.reference_kernel() || (state.skin_distance() > 0.0 && !outdated(state, dt))) {
      compute_normals(state);
    } else {
      rebuild(state);
    }
  }

  /// Verlet skin (SolverSettings::neighbor_skin): whether the lists may miss a pair
  /// within 2h, from bounds on how far the particles have moved since the last search,
  /// without storing the positions of that search. Each call first adds the move just
  /// made to the path bound of each set: both moves of a step (move_to_midpoint, move)
  /// displace every particle by dt/2 times the velocity it holds after the move, so the
  /// largest dt/2 |v| over the set bounds that move's displacements. A particle's net
  /// displacement since the search is at most its path length, at most its set's bound
  /// b (state.lists.real_path_bound, state.lists.virtual_path_bound). A pair (i, j) changes its distance by at
  /// most d_i + d_j, so by at most b_real + b_virtual for the virtual -> real rows and
  /// 2 b_real for the real -> real (boundary) rows. While both are <= s, every pair
  /// within 2h now was within 2h + s at the search (triangle inequality:
  /// |x_i - x_j| >= |x_i^0 - x_j^0| - d_i - d_j > (2h + s) - s for a pair not in the
  /// list), so the lists are complete. Called at every configuration where lists are
  /// used, right after the move that reached it: x^n (end of the previous step) and the
  /// midpoint (move_to_midpoint). One pass over the velocities of both sets, a maximum
  /// per block of threads (parallel_blocks), combined afterwards: no atomics, the same
  /// answer on any number of threads. A non-finite velocity makes the bound non-finite
  /// and counts as moved (the search then reports it).
  static bool outdated(SolverState<Dim>& state, double dt) {
    ++state.counters.skin_checks;
    const double half_dt = 0.5 * dt;
    auto largest_speed = [](const ParticleSet<Dim>& set) {
      std::vector<double> block_largest(static_cast<std::size_t>(std::max(1, thread_count())), 0.0);
      const std::size_t blocks =
          parallel_blocks(set.size(), [&](std::size_t b, std::size_t begin, std::size_t end) {
            double m = 0.0;
            for (std::size_t i = begin; i < end; ++i) {
              double v2 = 0.0;
              for (int d = 0; d < Dim; ++d) v2 += set.velocity[d][i] * set.velocity[d][i];
              m = v2 <= m ? m : v2;  // NaN propagates: a non-finite velocity counts as moved
            }
            block_largest[b] = m;
          });
      double largest = 0.0;
      for (std::size_t b = 0; b < blocks; ++b) largest = block_largest[b] <= largest ? largest : block_largest[b];
      return std::sqrt(largest);
    };
    // The move just made: dt/2 |v| after it, or the largest move Motion::move measured.
    state.lists.real_path_bound +=
        state.lists.real_move_bound >= 0.0 ? state.lists.real_move_bound : half_dt * largest_speed(state.real);
    state.lists.real_move_bound = -1.0;
    state.lists.virtual_path_bound += half_dt * largest_speed(state.virtual_);
    const double pair_bound = state.lists.real_path_bound + std::max(state.lists.real_path_bound, state.lists.virtual_path_bound);
    return !(pair_bound <= state.skin_distance() && std::isfinite(pair_bound));
  }

  /// Neighbour lists (build), and the particle sets sorted when their order has
  /// decayed (SolverSettings::spatial_order), the lists then built again.
  static void rebuild(SolverState<Dim>& state) {
    build(state);
    if (state.settings.spatial_order == SpatialOrder::none) return;
    const double spread = mean_row_spread(state.lists.virtual_from_real, nullptr, state.real.size());
    if (state.lists.sorted_spread < 0.0) {
      // First build: the spread the sorted order would have, from the ranks of the
      // sorted order applied to the current list.
      const std::vector<std::uint32_t> order = order_of(state, state.real);
      std::vector<std::uint32_t> rank(order.size());
      for (std::size_t k = 0; k < order.size(); ++k) rank[order[k]] = static_cast<std::uint32_t>(k);
      state.lists.sorted_spread = mean_row_spread(state.lists.virtual_from_real, rank.data(), state.real.size());
    }
    if (!(spread > state.settings.reorder_threshold * std::max(state.lists.sorted_spread, 1.0))) return;
    sort_particles(state);
    build(state);
    state.lists.sorted_spread = mean_row_spread(state.lists.virtual_from_real, nullptr, state.real.size());
  }

  /// Mean over the rows of `list` of the spread (last - first) of their entries, or of
  /// their ranks rank[j] if given: how far apart in memory one stencil's sources lie.
  /// Entries from `owned` on (mirror ghosts, held behind the owned particles) are left out.
  static double mean_row_spread(const NeighborList& list, const std::uint32_t* rank,
                                std::size_t owned = UINT32_MAX) {
    std::uint64_t total = 0;  // an integer sum: exact, whatever the order
    std::size_t rows = 0;
    for (std::size_t i = 0; i < list.query_count(); ++i) {
      auto row = list.neighbors(i);
      // Rows are sorted: the owned entries come first.
      row = row.first(static_cast<std::size_t>(std::lower_bound(row.begin(), row.end(), owned) - row.begin()));
      if (row.empty()) continue;
      ++rows;
      if (!rank) {
        total += row.back() - row.front();
        continue;
      }
      std::uint32_t low = UINT32_MAX, high = 0;
      for (std::uint32_t j : row) low = std::min(low, rank[j]), high = std::max(high, rank[j]);
      total += high - low;
    }
    return rows > 0 ? static_cast<double>(total) / static_cast<double>(rows) : 0.0;
  }

  static std::vector<std::uint32_t> order_of(const SolverState<Dim>& state, const ParticleSet<Dim>& set) {
    PointsView<Dim> owned = points_of<Dim>(set);
    owned.count = set.size();
    return spatial_order<Dim>(state.settings.spatial_order, owned, 0.25 * state.support_radius());
  }

  /// Sorts both sets into SolverSettings::spatial_order (permute).
  static void sort_particles(SolverState<Dim>& state) {
    permute(state, order_of(state, state.real), order_of(state, state.virtual_));
    ++state.counters.reorders;
  }

  /// Renumbers both sets (ParticleSet::permute: new real particle k is old
  /// real_order[k], likewise for the virtual set) and the boundary slots
  /// (BoundaryParticles::permute). The stages' scratch is either rewritten before it is
  /// read in every step or keyed to SolverCounters::neighbor_builds, which the build
  /// that follows a permutation advances, or to SolverCounters::renumberings (the
  /// hourglass stiffness's lists in the initial coordinates). The caller builds the
  /// lists again.
  static void permute(SolverState<Dim>& state, const std::vector<std::uint32_t>& real_order,
                      const std::vector<std::uint32_t>& virtual_order) {
    MirrorPlanes<Dim>::detach(state);  // the build that follows makes them again
    state.real.permute(real_order);
    state.virtual_.permute(virtual_order);
    std::vector<std::uint32_t> new_index(real_order.size());
    for (std::size_t k = 0; k < real_order.size(); ++k) new_index[real_order[k]] = static_cast<std::uint32_t>(k);
    state.boundary.permute(new_index);
    ++state.counters.renumberings;
  }
};

}  // namespace tsph
