// Mirror planes (issue 16: the Taylor bar's quarter model): a plane the solution is
// symmetric about, modelled by ghost particles. Each owned particle within reach of a
// mirror plane gets an image across it (and across both planes where two meet: the
// images of a quarter model tile the whole body); the images are held behind the owned
// particles of their set while a step runs (ParticleSet::attach_ghosts), so that the
// neighbour lists index them like any source particle and every stencil near the plane
// is the whole body's:
//   x' = R x (about the plane's point),  v' = R v,  u' = R u,  sigma' = R sigma R,
//   R = I - 2 m m^T (m the plane's unit normal), every scalar copied.
// No loop runs over the ghosts as targets: loops over ParticleSet::size() do not see
// them; a ghost's state is refreshed from its owned particle where a later stage reads
// through the lists what an earlier one wrote: after the half step and each motion
// (kinematics.hpp), and at the start of advance_positions (TaylorSph). A particle on the plane
// is its own image (no ghost across that plane): its velocity and traction keep to the
// plane by projection (v . m = 0, sigma m = (m . sigma m) m: round-off only, the stencils
// are symmetric) and its motion keeps it on the plane. Reach: the list radius (2h plus
// the skin), and the hourglass stiffness's radius, at the current or initial position.
// On a lattice symmetric about the planes the quarter model is the whole body's run to
// round-off (tests/test_mirror_planes.cpp).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/stabilisation/hourglass_stiffness.hpp"
#include "engine/solver/state.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

template <int Dim>
struct MirrorPlanes {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;

  /// How far from a plane a particle is imaged: the lists' radius, and the hourglass
  /// stiffness's lists' (stabilisation/hourglass_stiffness.hpp).
  static double reach(const SolverState<Dim>& state) {
    double r = state.list_radius();
    // The stiffness builds its lists later in the step, after the full step changed the
    // densities: 10 % more.
    if (state.settings.hourglass_stiffness > 0.0) r = std::max(r, 1.1 * HourglassStiffness<Dim>::list_radius(state));
    // Without a skin in updated Lagrangian the full step's list is searched again at the
    // midpoint: a half step's move (dt/2 |v| < dx/2 below the wave speed) is added.
    if (state.positions_move() && !state.reference_kernel() && state.skin_distance() == 0.0)
      r += 0.5 * state.initial_spacing;
    return r;
  }

  /// Decides which particles of both sets are imaged across which planes (at their
  /// current and initial positions), the owned real particles on a plane, and attaches
  /// the ghosts, filled. Called by every neighbour search (neighbor_lists.hpp). Throws
  /// std::invalid_argument for a particle beyond a plane, or closer to it than dx / 4
  /// without lying on it (its image would nearly coincide with it).
  static void generate(SolverState<Dim>& state) {
    if (!state.mirror.active()) return;
    MirrorGhosts<Dim>& mirror = state.mirror;
    state.real.detach_ghosts();
    state.virtual_.detach_ghosts();
    const double radius = reach(state), on_tolerance = 1e-6 * state.initial_spacing;
    const double too_close = 0.25 * state.initial_spacing;
    const std::size_t planes = mirror.planes.size();
    auto images_of = [&](ParticleSet<Dim>& set, typename MirrorGhosts<Dim>::Images& images, bool real, const char* what) {
      images.source.clear();
      images.planes.clear();
      if (real) mirror.on_plane.clear(), mirror.on_plane_mask.clear();
      const bool initial = set.carries(set.initial_position);
      for (std::size_t i = 0; i < set.size(); ++i) {
        std::uint8_t near = 0, on = 0;
        for (std::size_t k = 0; k < planes; ++k) {
          const auto& plane = mirror.planes[k];
          double depth = -(set.position_of(i) - plane.point).dot(plane.normal);  // >= 0 inside
          double depth0 = depth;
          if (initial) {
            Vec x0;
            for (int d = 0; d < Dim; ++d) x0[d] = set.initial_position[d][i];
            depth0 = -(x0 - plane.point).dot(plane.normal);
          }
          if (std::abs(depth0) <= on_tolerance) {
            on |= static_cast<std::uint8_t>(1u << k);
            continue;
          }
          if (depth0 < 0.0 || depth0 < too_close)
            throw std::invalid_argument(
                std::string("mirror plane '") + state.boundaries[plane.condition].name + "': " + what + " particle " +
                std::to_string(i) + " starts " + std::to_string(depth0) + " m " + (depth0 < 0.0 ? "beyond" : "inside") +
                " the plane; a mirror plane needs every particle on it or at least dx/4 = " +
                std::to_string(too_close) + " m inside: put the plane through a lattice plane of the real particles");
          if (std::min(depth, depth0) < radius) near |= static_cast<std::uint8_t>(1u << k);
        }
        if (real && on) mirror.on_plane.push_back(static_cast<std::uint32_t>(i)), mirror.on_plane_mask.push_back(on);
        // Every non-empty subset of the planes it is near: across one plane, across two
        // where two meet (a quarter model's diagonal image), ...
        for (unsigned subset = near; subset != 0; subset = (subset - 1) & near) {
          images.source.push_back(static_cast<std::uint32_t>(i));
          images.planes.push_back(static_cast<std::uint8_t>(subset));
        }
      }
    };
    images_of(state.real, mirror.real, true, "real");
    mirror.share.assign(state.real.size(), 1.0);
    for (std::size_t p = 0; p < mirror.on_plane.size(); ++p)
      for (std::size_t k = 0; k < planes; ++k)
        if (mirror.on_plane_mask[p] >> k & 1u) mirror.share[mirror.on_plane[p]] *= 0.5;
    images_of(state.virtual_, mirror.virtual_, false, "virtual");
    if (state.counters.neighbor_builds == 0) check_start(state);
    attach(state);
  }

  /// At the first search: every plane holds real particles (the lattice's mirror plane,
  /// where the case doubles their volumes), and the state on it is mirror-symmetric (no
  /// normal velocity, no shear traction on the plane), which the model keeps.
  static void check_start(const SolverState<Dim>& state) {
    const MirrorGhosts<Dim>& mirror = state.mirror;
    double speed = 0.0, stress = 0.0;
    for (std::size_t i = 0; i < state.real.size(); ++i) {
      speed = std::max(speed, state.velocity_of(i).norm());
      stress = std::max(stress, to_tensor<Dim>(SolverState<Dim>::stress_of(state.real, i)).norm());
    }
    for (std::size_t k = 0; k < mirror.planes.size(); ++k) {
      const std::string name = state.boundaries[mirror.planes[k].condition].name;
      bool held = false;
      for (std::size_t p = 0; p < mirror.on_plane.size(); ++p) {
        if (!(mirror.on_plane_mask[p] >> k & 1u)) continue;
        held = true;
        const std::uint32_t i = mirror.on_plane[p];
        const Vec& n = mirror.planes[k].normal;
        Eigen::Vector3d m = Eigen::Vector3d::Zero();
        m.template head<Dim>() = n;
        const Eigen::Vector3d traction = to_tensor<Dim>(SolverState<Dim>::stress_of(state.real, i)) * m;
        const double normal_speed = std::abs(state.velocity_of(i).dot(n));
        const double shear = (traction - traction.dot(m) * m).norm();
        if (normal_speed > 1e-12 * speed || shear > 1e-12 * stress)
          throw std::invalid_argument("mirror plane '" + name + "': real particle " + std::to_string(state.real.id[i]) +
                                      " on the plane starts with " +
                                      (normal_speed > 1e-12 * speed ? "a velocity across it (" + std::to_string(normal_speed) + " m/s)"
                                                                    : "a shear traction on it (" + std::to_string(shear) + " Pa)") +
                                      ": the initial state must be mirror-symmetric about the plane, or model the whole body");
      }
      if (!held)
        throw std::invalid_argument("mirror plane '" + name + "' holds no real particle: put it through a lattice "
                                    "plane of the real particles (the body's cut)");
    }
  }

  /// Attaches the ghosts of the last generate to both sets and fills them (the
  /// boundary slots' per-particle index grows with them: a ghost has no slot).
  /// Already attached (advance_positions after advance_fields): refreshed only, the
  /// virtual ghosts only if `virtual_changed`.
  static void attach(SolverState<Dim>& state, bool virtual_changed = true) {
    if (!state.mirror.active()) return;
    if (state.real.ghost_count() != state.mirror.real.source.size() ||
        state.virtual_.ghost_count() != state.mirror.virtual_.source.size()) {
      state.real.attach_ghosts(state.mirror.real.source.size());
      state.virtual_.attach_ghosts(state.mirror.virtual_.source.size());
      state.boundary.slot.resize(state.real.size());
      state.boundary.slot.resize(state.real.storage_size(), -1);
      refresh(state, Fields::all);
      return;
    }
    refresh(state, Fields::evolving, virtual_changed ? Fields::evolving : Fields::none);
  }

  /// Drops the ghosts (between steps the sets hold their own particles only).
  static void detach(SolverState<Dim>& state) {
    if (!state.mirror.active()) return;
    state.real.detach_ghosts();
    state.virtual_.detach_ghosts();
    state.boundary.slot.resize(state.real.size());
  }

  /// Which fields a refresh copies into the ghosts.
  enum class Fields {
    all,       ///< every carried field: ghost slots just attached (their values unset)
    evolving,  ///< all but the ones no stage changes (mass, initial position, id, boundary, group)
    motion,    ///< position and displacement: after a move (Motion), which writes nothing else
    none,      ///< nothing: no stage wrote the set since the last refresh
  };

  /// Copies each ghost's owned particle into it, reflected (see the file comment): the
  /// `fields` that changed since the ghosts were last filled. Before (2026-12-07), every
  /// refresh copied every field, four times a step: with the stress reflected as R s R
  /// per plane it was 18 % of the quarter Taylor bar's time at R0 / 4 (perf).
  /// With two arguments, the fields of each set (the real ones, the virtual ones).
  static void refresh(SolverState<Dim>& state, Fields fields) { refresh(state, fields, fields); }
  static void refresh(SolverState<Dim>& state, Fields real_fields, Fields virtual_fields) {
    if (!state.mirror.active()) return;
    const std::vector<StressMap> maps = stress_maps(state.mirror);
    refresh_set(state.mirror, maps, state.real, state.mirror.real, real_fields);
    refresh_set(state.mirror, maps, state.virtual_, state.mirror.virtual_, virtual_fields);
  }

  /// The owned real particles on a plane keep to it: v . m = 0, no shear traction on
  /// the plane (sigma <- P sigma P + (m . sigma m) m m^T, P = I - m m^T).
  static void project_on_planes(SolverState<Dim>& state) {
    if (!state.mirror.active()) return;
    const MirrorGhosts<Dim>& mirror = state.mirror;
    parallel_for(mirror.on_plane.size(), [&](std::size_t p) {
      const std::uint32_t i = mirror.on_plane[p];
      Vec v = state.velocity_of(i);
      Eigen::Matrix3d s = to_tensor<Dim>(SolverState<Dim>::stress_of(state.real, i));
      for (std::size_t k = 0; k < mirror.planes.size(); ++k) {
        if (!(mirror.on_plane_mask[p] >> k & 1u)) continue;
        const Vec& n = mirror.planes[k].normal;
        v -= v.dot(n) * n;
        Eigen::Vector3d m = Eigen::Vector3d::Zero();
        m.template head<Dim>() = n;
        const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - m * m.transpose();
        s = projector * s * projector + m.dot(s * m) * (m * m.transpose());
      }
      const StressVector<Dim> stress = from_tensor<Dim>(s);
      for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = v[d];
      for (int c = 0; c < stress_component_count<Dim>; ++c) state.real.stress[c][i] = stress[c];
    });
  }

  /// The owned real particles on a plane put back on it after a move (their normal
  /// velocity is zero; the interpolated velocity of the material motion is not, to
  /// round-off).
  static void keep_on_planes(SolverState<Dim>& state) {
    if (!state.mirror.active()) return;
    const MirrorGhosts<Dim>& mirror = state.mirror;
    parallel_for(mirror.on_plane.size(), [&](std::size_t p) {
      const std::uint32_t i = mirror.on_plane[p];
      Vec x = state.real.position_of(i);
      for (std::size_t k = 0; k < mirror.planes.size(); ++k)
        if (mirror.on_plane_mask[p] >> k & 1u) x -= (x - mirror.planes[k].point).dot(mirror.planes[k].normal) * mirror.planes[k].normal;
      for (int d = 0; d < Dim; ++d) state.real.position[d][i] = x[d];
    });
  }

 private:
  static constexpr int stress_count = stress_component_count<Dim>;
  /// The reflection of a stress vector across the planes of one mask, R s R as a linear
  /// map of the stress components (MirrorGhosts::reflect_tensor applied to each unit
  /// component); where the planes are coordinate planes it only flips signs, and the
  /// flip is all that is applied (the same bits as R s R: a product with 1, -1 or 0).
  struct StressMap {
    std::array<std::array<double, stress_count>, stress_count> matrix{};  ///< [row][column]
    std::array<double, stress_count> sign{};
    bool diagonal = true;
  };
  static std::vector<StressMap> stress_maps(const MirrorGhosts<Dim>& mirror) {
    std::vector<StressMap> maps(std::size_t{1} << std::min<std::size_t>(mirror.planes.size(), 8));
    for (std::size_t mask = 0; mask < maps.size(); ++mask) {
      StressMap& map = maps[mask];
      for (int c = 0; c < stress_count; ++c) {
        StressVector<Dim> unit{};
        unit[static_cast<std::size_t>(c)] = 1.0;
        const StressVector<Dim> column =
            from_tensor<Dim>(mirror.reflect_tensor(static_cast<std::uint8_t>(mask), to_tensor<Dim>(unit)));
        for (int r = 0; r < stress_count; ++r)
          map.matrix[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] = column[static_cast<std::size_t>(r)];
      }
      for (std::size_t r = 0; r < stress_count; ++r) {
        map.sign[r] = map.matrix[r][r];
        for (std::size_t c = 0; c < stress_count; ++c)
          if (r != c && map.matrix[r][c] != 0.0) map.diagonal = false;
        if (std::abs(map.matrix[r][r]) != 1.0) map.diagonal = false;
      }
    }
    return maps;
  }

  /// Whether `field` of `set` is one that no stage changes (Fields::evolving leaves it).
  static bool unchanging(const ParticleSet<Dim>& set, const void* field) {
    if (field == &set.mass || field == &set.id || field == &set.boundary || field == &set.group) return true;
    for (const auto& a : set.initial_position)
      if (field == &a) return true;
    return false;
  }

  // One parallel pass: the ghosts split into one contiguous block per thread, each
  // block copied and reflected field by field (every ghost is written by one thread:
  // the same bits on any thread count).
  static void refresh_set(const MirrorGhosts<Dim>& mirror, const std::vector<StressMap>& maps, ParticleSet<Dim>& set,
                          const typename MirrorGhosts<Dim>::Images& images, Fields fields) {
    const std::size_t owned = set.size(), ghosts = images.source.size();
    if (ghosts == 0 || fields == Fields::none) return;
    parallel_blocks(ghosts, [&](std::size_t, std::size_t begin, std::size_t end) {
      auto copy = [&](auto& field) {
        if (field.empty()) return;
        for (std::size_t g = begin; g < end; ++g) field[owned + g] = field[images.source[g]];
      };
      if (fields == Fields::motion) {
        for (auto& a : set.position) copy(a);
        for (auto& a : set.displacement) copy(a);
      } else {
        set.for_each_field([&](auto& field) {
          if (fields == Fields::all || !unchanging(set, &field)) copy(field);
        });
      }
      auto reflect_points = [&](std::array<std::vector<double>, Dim>& field, bool point) {
        if (field[0].empty()) return;
        for (std::size_t g = begin; g < end; ++g) {
          Vec x;
          for (int d = 0; d < Dim; ++d) x[d] = field[d][owned + g];
          x = point ? mirror.reflect_point(images.planes[g], x) : mirror.reflect_direction(images.planes[g], x);
          for (int d = 0; d < Dim; ++d) field[d][owned + g] = x[d];
        }
      };
      reflect_points(set.position, true);
      reflect_points(set.displacement, false);
      if (fields == Fields::motion) return;
      if (fields == Fields::all) reflect_points(set.initial_position, true);
      reflect_points(set.velocity, false);
      auto reflect_stress = [&](std::array<std::vector<double>, stress_count>& field) {
        if (field[0].empty()) return;
        for (std::size_t g = begin; g < end; ++g) {
          const StressMap& map = maps[images.planes[g]];
          if (map.diagonal) {
            for (std::size_t c = 0; c < stress_count; ++c) field[c][owned + g] *= map.sign[c];
            continue;
          }
          StressVector<Dim> s;
          for (std::size_t c = 0; c < stress_count; ++c) s[c] = field[c][owned + g];
          for (std::size_t r = 0; r < stress_count; ++r) {
            double reflected = 0.0;
            for (std::size_t c = 0; c < stress_count; ++c) reflected += map.matrix[r][c] * s[c];
            field[r][owned + g] = reflected;
          }
        }
      };
      reflect_stress(set.stress);
      reflect_stress(set.back_stress);
      reflect_points(set.hourglass_reference, false);
    });
  }
};

}  // namespace tsph
