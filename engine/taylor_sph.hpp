// The Taylor-SPH stepper (seed eqs. 3-4; DESIGN.md section 3).
//
// One step n -> n+1:
//   0. boundary pre-pass: gradients of U^n at the boundary real particles, from the
//      real set itself (for the characteristic boundary conditions);
//   1. half_step (real -> virtual), seed eq. (3): interpolate U^n to every virtual
//      particle with the normalised kernel, then
//        U_v^{n+1/2} = U_v^n + dt/2 [ S_v^n - div F ],
//      the divergence from sum_r V_r (F_r^n - F_v^n) . Gn_vr;
//   2. full_step (virtual -> real), seed eq. (4):
//        U_r^{n+1} = U_r^n + dt [ S_r^{n+1/2} - div F ],
//      with F_r^{n+1/2} interpolated from the virtual neighbours (DESIGN.md 3.2);
//   3. boundary conditions at n+1 by characteristics (below);
//   4. in updated-Lagrangian mode: move both sets, update density, rebuild lists.
//
// The flux divergence is written per field: the velocity gradient grad v (which
// gives D : d and the Jaumann spin, seed eq. 1a) and the stress divergence div sigma
// (seed eq. 1b, divided by the density at the particle).
//
// Our choices, beyond the seed (documented in README.md):
//  * The source S (Jaumann terms) is evaluated at the particle being updated from its
//    own interpolated stress and corrected velocity gradient, rather than evaluated at
//    the neighbours and interpolated: the same order of accuracy, and no same-set
//    neighbour lists in the bulk.
//  * Boundary real particles take their state from the characteristic relations along
//    the outward normal n: the outgoing invariant t_n - Z u_n (t_n = n.sigma.n,
//    u_n = v.n, Z = rho c) is carried from the foot of the characteristic x - c dt n
//    at time n, interpolated with the real set's corrected gradient; the incoming one
//    follows from the prescribed velocity or traction. At CFL 1 with nearest-neighbour
//    stencils this is exact (the 1D bar to round-off). Implemented for Dim = 1 here;
//    the 2D/3D normal-frame generalisation belongs to the 2D/3D issue.
#pragma once

#include "engine/boundary_condition.hpp"
#include "engine/elasticity.hpp"
#include "engine/parallel.hpp"
#include "engine/particle_set.hpp"
#include "kernels/corrected_operators.hpp"
#include "kernels/smoothing_kernels.hpp"
#include "neighbor/cell_list.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

/// small_strain: particles stay at their initial positions and the density is fixed
/// (geometrically linear, the setting of the seed's bar and of its exact solution).
/// updated_lagrangian: particles move with the material, density follows
/// d rho/dt = -rho div v, and neighbour lists are rebuilt every step.
enum class Kinematics { small_strain, updated_lagrangian };

inline std::string_view to_string(Kinematics k) {
  return k == Kinematics::small_strain ? "small_strain" : "updated_lagrangian";
}

template <int Dim>
struct SolverSettings {
  double smoothing_length = 0.0;  ///< h; the support radius is 2h
  KernelKind kernel = KernelKind::cubic_spline;
  InterpolationKind interpolation = InterpolationKind::linear;
  Kinematics kinematics = Kinematics::small_strain;
  Vector<Dim> body_force = Vector<Dim>::Zero();  ///< b, per unit mass
};

/// What the run did; fallbacks are counted per stencil evaluation.
struct SolverCounters {
  std::int64_t steps = 0;
  std::int64_t neighbor_builds = 0;
  std::int64_t empty_stencils = 0;
  std::int64_t interpolation_fallbacks = 0;
  std::int64_t gradient_fallbacks = 0;
};

/// Index of stress component sigma_ij in the per-particle stress arrays.
template <int Dim>
constexpr int stress_index(int i, int j) {
  if constexpr (Dim == 1) return 0;
  else if constexpr (Dim == 2) return i == j ? i : 2;
  else {
    if (i == j) return i;
    const int sum = i + j;  // (0,1) -> 3, (1,2) -> 4, (0,2) -> 5
    return sum == 1 ? 3 : sum == 3 ? 4 : 5;
  }
}

template <int Dim>
class TaylorSph {
 public:
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;

  TaylorSph(ParticleSet<Dim> real, ParticleSet<Dim> virtual_particles, LinearElastic<Dim> material,
            SolverSettings<Dim> settings, std::vector<BoundaryCondition<Dim>> boundaries)
      : real_(std::move(real)),
        virtual_(std::move(virtual_particles)),
        material_(std::move(material)),
        settings_(std::move(settings)),
        boundaries_(std::move(boundaries)) {
    if (!(settings_.smoothing_length > 0.0) || !std::isfinite(settings_.smoothing_length))
      throw std::invalid_argument("solver: smoothing length h = " +
                                  std::to_string(settings_.smoothing_length) +
                                  " must be positive");
    if (real_.size() == 0 || virtual_.size() == 0)
      throw std::invalid_argument("solver: needs at least one real and one virtual particle");
    for (std::size_t i = 0; i < real_.size(); ++i) {
      const std::int32_t b = real_.boundary[i];
      if (b == ParticleSet<Dim>::kNoBoundary) continue;
      if (b < 0 || static_cast<std::size_t>(b) >= boundaries_.size())
        throw std::invalid_argument("solver: real particle " + std::to_string(i) +
                                    " refers to boundary condition " + std::to_string(b) +
                                    " of " + std::to_string(boundaries_.size()));
      boundary_particles_.push_back(static_cast<std::uint32_t>(i));
    }
    if constexpr (Dim > 1)
      if (!boundary_particles_.empty())
        throw std::logic_error(
            "solver: boundary conditions in 2D/3D are not implemented yet (issue 3)");
    if (settings_.kinematics == Kinematics::updated_lagrangian)
      for (auto& v : previous_velocity_) v.resize(real_.size());
    rebuild_neighbors();
  }

  double support_radius() const { return kSupportFactor * settings_.smoothing_length; }
  double time() const { return time_; }
  /// Sets the clock (to land exactly on an output time after round-off).
  void set_time(double t) { time_ = t; }
  const ParticleSet<Dim>& real() const { return real_; }
  ParticleSet<Dim>& real() { return real_; }
  const ParticleSet<Dim>& virtual_particles() const { return virtual_; }
  const LinearElastic<Dim>& material() const { return material_; }
  const SolverSettings<Dim>& settings() const { return settings_; }
  const SolverCounters& counters() const { return counters_; }
  const NeighborList& virtual_from_real() const { return virtual_from_real_; }
  const NeighborList& real_from_virtual() const { return real_from_virtual_; }
  /// Outward unit normals of the boundary particles, in `boundary_particles()` order.
  const std::vector<Vec>& boundary_normals() const { return boundary_normal_; }
  const std::vector<std::uint32_t>& boundary_particles() const { return boundary_particles_; }

  /// Advances the solution by dt (seed eqs. 3 and 4, then the boundary conditions).
  void step(double dt) {
    if (!(dt > 0.0) || !std::isfinite(dt))
      throw std::invalid_argument("solver: time step dt = " + std::to_string(dt) +
                                  " must be positive");
    visit_kernel<Dim>(settings_.kernel, [&](const auto& kernel) {
      boundary_gradients(kernel);
      half_step(kernel, dt);
      full_step(kernel, dt);
    });
    apply_boundary_conditions(dt, time_ + dt);
    if (settings_.kinematics == Kinematics::updated_lagrangian) {
      move(dt);
      rebuild_neighbors();
    }
    time_ += dt;
    ++counters_.steps;
  }

  /// Kinetic energy sum_I m_I |v_I|^2 / 2 of the real particles.
  double kinetic_energy() const {
    double energy = 0.0;
    for (std::size_t i = 0; i < real_.size(); ++i) {
      double v2 = 0.0;
      for (int d = 0; d < Dim; ++d) v2 += real_.velocity[d][i] * real_.velocity[d][i];
      energy += 0.5 * real_.mass[i] * v2;
    }
    return energy;
  }
  /// Strain energy sum_I V_I w(sigma_I) of the real particles.
  double strain_energy() const {
    double energy = 0.0;
    for (std::size_t i = 0; i < real_.size(); ++i)
      energy += real_.volume[i] * material_.strain_energy_density(stress_of(real_, i));
    return energy;
  }
  /// Linear momentum sum_I m_I v_I of the real particles.
  Vec linear_momentum() const {
    Vec p = Vec::Zero();
    for (std::size_t i = 0; i < real_.size(); ++i)
      for (int d = 0; d < Dim; ++d) p[d] += real_.mass[i] * real_.velocity[d][i];
    return p;
  }

 private:
  static StressVector<Dim> stress_of(const ParticleSet<Dim>& set, std::size_t i) {
    StressVector<Dim> s;
    for (int c = 0; c < stress_count; ++c) s[c] = set.stress[c][i];
    return s;
  }

  /// Interpolated state and flux derivatives of one query point over a stencil.
  struct LocalState {
    StressVector<Dim> stress{};
    Vec velocity = Vec::Zero();
    double density = 0.0;
    Mat velocity_gradient = Mat::Zero();  ///< grad v(i, j) = d v_i / d x_j
    Vec stress_divergence = Vec::Zero();  ///< div sigma
  };

  /// Interpolates U at the query point and takes the corrected gradients of the
  /// velocity and the divergence of the stress, both relative to the interpolated
  /// value at the query point (DESIGN.md section 2).
  static LocalState evaluate(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                             const StencilWeights<Dim>& w) {
    LocalState s;
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const std::uint32_t j = nb[k];
      const double c = w.value[k];
      for (int m = 0; m < stress_count; ++m) s.stress[m] += c * source.stress[m][j];
      for (int d = 0; d < Dim; ++d) s.velocity[d] += c * source.velocity[d][j];
      s.density += c * source.density[j];
    }
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const std::uint32_t j = nb[k];
      const Vec& g = w.gradient[k];
      for (int i = 0; i < Dim; ++i) {
        const double dv = source.velocity[i][j] - s.velocity[i];
        for (int l = 0; l < Dim; ++l) s.velocity_gradient(i, l) += dv * g[l];
      }
      for (int i = 0; i < Dim; ++i)
        for (int l = 0; l < Dim; ++l) {
          const int m = stress_index<Dim>(i, l);
          s.stress_divergence[i] += (source.stress[m][j] - s.stress[m]) * g[l];
        }
    }
    return s;
  }

  /// Per-thread tally of stencil fallbacks.
  struct StencilCounts {
    std::int64_t empty = 0, interpolation = 0, gradient = 0;
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
      return *this;
    }
  };
  void add(const StencilCounts& counts) {
    counters_.empty_stencils += counts.empty;
    counters_.interpolation_fallbacks += counts.interpolation;
    counters_.gradient_fallbacks += counts.gradient;
  }

  /// Seed eq. (3): real -> virtual, U_v^{n+1/2} = U_v^n + dt/2 (S - div F).
  template <class Kernel>
  void half_step(const Kernel& kernel, double dt) {
    const ParticleView<Dim> source = real_.view();
    const ParticleView<Dim> target = virtual_.view();
    const PointsView<Dim> source_points = points_of<Dim>(real_);
    const double h = settings_.smoothing_length;
    const double half_dt = 0.5 * dt;
    const bool moving = settings_.kinematics == Kinematics::updated_lagrangian;
    add(parallel_for_with_scratch<StencilWeights<Dim>, StencilCounts>(
        target.count, [&](std::size_t q, StencilWeights<Dim>& w, StencilCounts& counts) {
          const auto nb = virtual_from_real_.neighbors(q);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, h, target.position_of(q), source_points,
                                   source.volume, nb, settings_.interpolation, w);
          counts += status;
          if (status.no_neighbors) return;  // isolated: keeps its values (counted)
          const LocalState s = evaluate(source, nb, w);
          const StressVector<Dim> rate = material_.stress_rate(s.velocity_gradient, s.stress);
          for (int m = 0; m < stress_count; ++m)
            target.stress[m][q] = s.stress[m] + half_dt * rate[m];
          for (int d = 0; d < Dim; ++d)
            target.velocity[d][q] =
                s.velocity[d] +
                half_dt * (s.stress_divergence[d] / s.density + settings_.body_force[d]);
          const double density =
              moving ? s.density * std::exp(-half_dt * s.velocity_gradient.trace()) : s.density;
          target.density[q] = density;
          target.volume[q] = target.mass[q] / density;
        }));
  }

  /// Seed eq. (4): virtual -> real, U_r^{n+1} = U_r^n + dt (S^{n+1/2} - div F^{n+1/2}).
  template <class Kernel>
  void full_step(const Kernel& kernel, double dt) {
    const ParticleView<Dim> source = virtual_.view();
    const ParticleView<Dim> target = real_.view();
    const PointsView<Dim> source_points = points_of<Dim>(virtual_);
    const double h = settings_.smoothing_length;
    const bool moving = settings_.kinematics == Kinematics::updated_lagrangian;
    add(parallel_for_with_scratch<StencilWeights<Dim>, StencilCounts>(
        target.count, [&](std::size_t r, StencilWeights<Dim>& w, StencilCounts& counts) {
          if (moving)
            for (int d = 0; d < Dim; ++d) previous_velocity_[d][r] = target.velocity[d][r];
          const auto nb = real_from_virtual_.neighbors(r);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, h, target.position_of(r), source_points,
                                   source.volume, nb, settings_.interpolation, w);
          counts += status;
          if (status.no_neighbors) return;
          const LocalState s = evaluate(source, nb, w);
          const StressVector<Dim> rate = material_.stress_rate(s.velocity_gradient, s.stress);
          for (int m = 0; m < stress_count; ++m) target.stress[m][r] += dt * rate[m];
          for (int d = 0; d < Dim; ++d)
            target.velocity[d][r] +=
                dt * (s.stress_divergence[d] / s.density + settings_.body_force[d]);
          if (moving) {
            target.density[r] *= std::exp(-dt * s.velocity_gradient.trace());
            target.volume[r] = target.mass[r] / target.density[r];
          }
        }));
  }

  /// Gradients of U^n at the boundary particles from the real set (step 0).
  template <class Kernel>
  void boundary_gradients(const Kernel& kernel) {
    const ParticleView<Dim> source = real_.view();
    const PointsView<Dim> source_points = points_of<Dim>(real_);
    StencilWeights<Dim> w;
    for (std::size_t b = 0; b < boundary_particles_.size(); ++b) {
      const std::uint32_t i = boundary_particles_[b];
      const auto nb = boundary_from_real_.neighbors(b);
      const StencilStatus status =
          compute_stencil<Dim>(kernel, settings_.smoothing_length, real_.position_of(i),
                               source_points, source.volume, nb, InterpolationKind::shepard, w);
      StencilCounts counts;
      counts += status;
      add(counts);
      Mat grad_v = Mat::Zero();
      std::array<Vec, stress_count> grad_stress;
      for (auto& g : grad_stress) g.setZero();
      for (std::size_t k = 0; k < nb.size(); ++k) {
        const std::uint32_t j = nb[k];
        const Vec& g = w.gradient[k];
        for (int d = 0; d < Dim; ++d)
          grad_v.row(d) += (source.velocity[d][j] - source.velocity[d][i]) * g.transpose();
        for (int m = 0; m < stress_count; ++m)
          grad_stress[m] += (source.stress[m][j] - source.stress[m][i]) * g;
      }
      boundary_velocity_gradient_[b] = grad_v;
      boundary_stress_gradient_[b] = grad_stress;
      boundary_stress_[b] = stress_of(real_, i);
      for (int d = 0; d < Dim; ++d) boundary_velocity_[b][d] = real_.velocity[d][i];
    }
  }

  /// Step 3: characteristic boundary conditions at t_new (see the file comment).
  void apply_boundary_conditions(double dt, double t_new) {
    if constexpr (Dim == 1) {
      for (std::size_t b = 0; b < boundary_particles_.size(); ++b) {
        const std::uint32_t i = boundary_particles_[b];
        const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[i])];
        const double n = boundary_normal_[b][0];
        const double density = real_.density[i];
        const double c = material_.p_wave_speed(density);
        const double impedance = density * c;
        // Outgoing invariant w = t_n - Z u_n at the particle and its gradient, time n.
        const double stress = boundary_stress_[b][0];
        const double velocity = boundary_velocity_[b][0];
        const double outgoing = stress - impedance * n * velocity;
        const double outgoing_gradient = boundary_stress_gradient_[b][0][0] -
                                         impedance * n * boundary_velocity_gradient_[b](0, 0);
        // Carried from the foot x - c dt n; the body force changes it by -Z (b.n) dt.
        const double outgoing_new = outgoing - c * dt * n * outgoing_gradient -
                                    impedance * settings_.body_force[0] * n * dt;
        if (condition.kind == BoundaryCondition<Dim>::Kind::velocity) {
          const double prescribed = condition.value[0](t_new);
          real_.velocity[0][i] = prescribed;
          real_.stress[0][i] = outgoing_new + impedance * n * prescribed;
        } else {
          const double traction_normal = condition.value[0](t_new) * n;  // t . n
          real_.stress[0][i] = traction_normal;
          real_.velocity[0][i] = n * (traction_normal - outgoing_new) / impedance;
        }
      }
    } else {
      (void)dt;
      (void)t_new;
    }
  }

  /// Step 4 (updated Lagrangian): real particles move with the mean of v^n and
  /// v^{n+1}, virtual particles with v^{n+1/2}.
  void move(double dt) {
    parallel_for(real_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d)
        real_.position[d][i] += 0.5 * dt * (previous_velocity_[d][i] + real_.velocity[d][i]);
    });
    parallel_for(virtual_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d) virtual_.position[d][i] += dt * virtual_.velocity[d][i];
    });
  }

  /// Neighbour lists of both half-steps and of the boundary pre-pass, and the
  /// boundary normals n = -sum_J V_J grad_I W_IJ / |.| (they point out of the body).
  void rebuild_neighbors() {
    const double radius = support_radius();
    const PointsView<Dim> real_points = points_of<Dim>(real_);
    const PointsView<Dim> virtual_points = points_of<Dim>(virtual_);
    const CellList<Dim> real_cells(real_points, radius);
    virtual_from_real_ = real_cells.query(virtual_points);
    real_from_virtual_ = CellList<Dim>(virtual_points, radius).query(real_points);

    const std::size_t nb = boundary_particles_.size();
    for (auto& coordinate : boundary_points_.position) coordinate.resize(nb);
    for (std::size_t b = 0; b < nb; ++b)
      for (int d = 0; d < Dim; ++d)
        boundary_points_.position[d][b] = real_.position[d][boundary_particles_[b]];
    boundary_from_real_ = real_cells.query(points_of<Dim>(boundary_points_));
    boundary_normal_.resize(nb);
    boundary_velocity_gradient_.resize(nb);
    boundary_stress_gradient_.resize(nb);
    boundary_stress_.resize(nb);
    boundary_velocity_.resize(nb);
    visit_kernel<Dim>(settings_.kernel, [&](const auto& kernel) {
      for (std::size_t b = 0; b < nb; ++b) {
        const Vec x = real_.position_of(boundary_particles_[b]);
        Vec sum = Vec::Zero();
        for (std::uint32_t j : boundary_from_real_.neighbors(b))
          sum += real_.volume[j] *
                 kernel_gradient<Dim>(kernel, Vec(x - real_.position_of(j)),
                                      settings_.smoothing_length);
        const double norm = sum.norm();
        if (!(norm > 0.0))
          throw std::invalid_argument("solver: boundary particle " +
                                      std::to_string(boundary_particles_[b]) +
                                      " has no neighbours to define its normal");
        boundary_normal_[b] = -sum / norm;
      }
    });
    ++counters_.neighbor_builds;
  }

  ParticleSet<Dim> real_;
  ParticleSet<Dim> virtual_;
  LinearElastic<Dim> material_;
  SolverSettings<Dim> settings_;
  std::vector<BoundaryCondition<Dim>> boundaries_;
  double time_ = 0.0;
  SolverCounters counters_;

  NeighborList virtual_from_real_;   ///< rows: virtual particles; entries: real
  NeighborList real_from_virtual_;   ///< rows: real particles; entries: virtual
  NeighborList boundary_from_real_;  ///< rows: boundary particles; entries: real

  std::vector<std::uint32_t> boundary_particles_;
  struct {
    std::array<std::vector<double>, Dim> position;
  } boundary_points_;  ///< coordinates of the boundary particles, for the search
  std::vector<Vec> boundary_normal_;
  std::vector<Mat> boundary_velocity_gradient_;
  std::vector<std::array<Vec, stress_count>> boundary_stress_gradient_;
  std::vector<StressVector<Dim>> boundary_stress_;  ///< sigma^n at the boundary particles
  std::vector<Vec> boundary_velocity_;
  std::array<std::vector<double>, Dim> previous_velocity_;
};

}  // namespace tsph
