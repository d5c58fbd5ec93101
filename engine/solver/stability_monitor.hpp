// The stability monitor: after the fields of a step are advanced and before any
// particle moves, NaN/Inf in either set, an unphysical state of a real particle
// (density, stress, speed against the p-wave speed, a particle that left the body) or a
// runaway of the total energy stops the run with a diagnosis (SolutionDiverged).
#pragma once

#include "engine/input_error.hpp"
#include "engine/parallel.hpp"
#include "engine/solver/state.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

/// The run blew up: NaN/Inf in either particle set, an unphysical state, or a runaway
/// of the energy. The message names the step, the time, the first offending particle
/// (id, position), the criterion with its value and bound, and the likely cause; the
/// command-line programs exit with status 3 on it.
class SolutionDiverged : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Runaway energy: the total energy of the real set grows by at least a factor g in each
/// of K(g) consecutive steps, g^K(g) >= kRunawayFactor, for any g of kRunawayGrowths (or
/// it overflows). A load switched on at any time whose energy input grows like
/// (t - t1)^k grows by (1 + 1/m)^k at its m-th step, which stays above g for K(g)
/// consecutive steps only if k > ln(kRunawayFactor) = 6.9, so no load of degree up to 6
/// triggers it, while a mode that grows by g or more per step (an unstable CFL: about
/// 1.45 at CFL 1.05, 12 at CFL 1.5 in the bar) is caught within K(g) steps of
/// dominating the energy, long before it overflows.
inline constexpr double kRunawayFactor = 1000.0;
inline constexpr std::array<double, 3> kRunawayGrowths = {2.0, 1.2, 1.05};
/// Runaway of an oscillating energy (the per-step rule above misses it): the largest
/// energy so far, M, grew by kRunawayWindowFactor or more over the last W steps and
/// over the W before, the later growth at least half the earlier one (an exponential,
/// whose log is straight; a power (t - t1)^k has a concave log and passes both only for
/// k > 20), for W of kRunawayWindows.
inline constexpr double kRunawayWindowFactor = 30.0;
inline constexpr std::array<int, 2> kRunawayWindows = {20, 100};
/// A sudden blow-up (the 2D updated-Lagrangian cantilever at its clamp: the energy jumps
/// x85 in 4 steps, falls back, and overflows 60 steps later): the energy exceeds
/// kRunawayJumpFactor times the largest energy of the run up to kRunawayJumpSteps steps
/// before, once the run has carried energy for kRunawayJumpAfter steps (a power
/// (t - t1)^k of the time since the load started does that only for k > 340).
inline constexpr double kRunawayJumpFactor = 30.0;
inline constexpr int kRunawayJumpSteps = 10;
inline constexpr std::int64_t kRunawayJumpAfter = 1000;
/// A slow runaway that the rates above miss (the oscillating plate of tools/cases at
/// dx = 0.002 in updated Lagrangian, 2026-11-28: a through-thickness mode growing 0.25 %
/// per step reached 150 x the initial energy by the end, exit 0): with the energy ledger
/// on (SolverSettings::energy_ledger), the energy the scheme made, E - (E0 + W) with W
/// the works booked (energy_ledger.hpp), exceeds kCreatedEnergyFactor times the largest
/// energy supplied so far, max (E0 + W), once the run has carried energy for
/// kRunawayJumpAfter steps (the first steps of a load book its work a step late: a
/// cantilever's first step "makes" 1.1 x what it was given). E is the check's kinetic
/// and elastic energy (no plastic work; a mirror plane's particles counted whole, where
/// the ledger counts their share: a quarter model's E reads a little high). The largest
/// gain of a finished validation case is +46 % (the elastic smooth footing at CFL
/// 0.1125, docs/notes/2026-11-27-energy-and-the-time-step.md).
inline constexpr double kCreatedEnergyFactor = 1.0;

/// Physical bounds (issue 14, item 4; docs/reliability.md, "Unphysical state"): each is
/// a state that no solid modelled here reaches, so that a blow-up is stopped at its
/// start, before any frame, probe or checkpoint holds it, while legitimate large
/// deformation (J down to 0.5, stretch to 1.5, shear to gamma = 5, rotations of any
/// angle) passes with a margin of 2.5 or more.
///
/// Density: rho / rho0 above kMaxDensityRatio (the Jacobian J = rho0 / rho below 0.2,
/// compression to a fifth of the volume) or below kMinDensityRatio (J above 5).
inline constexpr double kMaxDensityRatio = 5.0;
inline constexpr double kMinDensityRatio = 0.2;
/// Stress: the Frobenius norm |sigma| = sqrt(sigma : sigma) above kMaxStressOverModulus
/// times the p-wave modulus M = rho0 c_p^2 (the stiffest elastic modulus). Uniaxial strain
/// to J = 0.2 in a linear hypoelastic solid gives |sigma| = 1.8 M (nu = 0.3), simple shear
/// at most G sqrt(2) < M.
inline constexpr double kMaxStressOverModulus = 5.0;
/// Speed: a real particle moving faster than kMaxSpeedOverWaveSpeed times the p-wave
/// speed c_p (at rho0) relative to the mass-weighted mean velocity of the real set (so a
/// translation at any speed passes). A velocity difference V across a solid carries a
/// stress of order rho c_p V: V = c_p is a strain of order 1 at every wave passage.
inline constexpr double kMaxSpeedOverWaveSpeed = 1.0;

template <int Dim>
class StabilityMonitor {
 public:
  using Vec = Vector<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;

  /// NaN/Inf in the velocity, stress or density of either set (and the positions of the
  /// real one), an unphysical real particle (kMaxDensityRatio, kMinDensityRatio,
  /// kMaxStressOverModulus, kMaxSpeedOverWaveSpeed, no virtual neighbour in its support),
  /// or a runaway of the energy (kRunawayGrowths, kRunawayWindows, kRunawayJumpFactor):
  /// throws SolutionDiverged with the diagnosis.
  void check(const SolverState<Dim>& state, double dt) {
    const std::int64_t step = state.counters.steps + 1;
    auto non_finite = [](const ParticleSet<Dim>& set, std::size_t i, bool is_real) -> const char* {
      for (int d = 0; d < Dim; ++d)
        if (!std::isfinite(set.velocity[d][i])) return "velocity";
      for (int m = 0; m < stress_count; ++m)
        if (!std::isfinite(set.stress[m][i])) return "stress";
      if (!std::isfinite(set.density[i])) return "density";
      if (is_real)
        for (int d = 0; d < Dim; ++d)
          if (!std::isfinite(set.position[d][i])) return "position";
      return nullptr;
    };
    // One parallel pass over fixed blocks of particles (kStabilityBlock, not one per
    // thread: the sums' order, hence their round-off, does not depend on the thread
    // count): the first non-finite particle of each block and, for the real blocks, the
    // energies, the momentum, the extremes of density, stress and each velocity
    // component, combined in block order. Was two serial passes (3 % of a 2D step, serial).
    const std::size_t real_blocks = (state.real.size() + kStabilityBlock - 1) / kStabilityBlock;
    const std::size_t virtual_blocks = (state.virtual_.size() + kStabilityBlock - 1) / kStabilityBlock;
    stability_blocks_.resize(real_blocks + virtual_blocks);
    state.material.visit([&](const auto& model) {  // once, outside the loop
    parallel_for(real_blocks + virtual_blocks, [&](std::size_t block) {
      const bool is_real = block < real_blocks;
      const ParticleSet<Dim>& set = is_real ? state.real : state.virtual_;
      const std::size_t begin = (is_real ? block : block - real_blocks) * kStabilityBlock;
      const std::size_t end = std::min(set.size(), begin + kStabilityBlock);
      StabilityBlock result;
      for (std::size_t i = begin; i < end; ++i)
        if (non_finite(set, i, is_real) != nullptr) {
          result.first_non_finite = i;
          break;
        }
      if (result.first_non_finite != kNoParticle)
        for (std::size_t i = result.first_non_finite; i < end; ++i) {
          bool bad = !std::isfinite(set.density[i]);
          for (int m = 0; m < stress_count; ++m) bad = bad || !std::isfinite(set.stress[m][i]);
          if (bad) {
            result.first_non_finite_stress = i;
            break;
          }
        }
      if (is_real)
        for (std::size_t i = begin; i < end; ++i) {
          double v2 = 0.0;
          for (int d = 0; d < Dim; ++d) {
            const double v = set.velocity[d][i];
            v2 += v * v;
            result.momentum[d] += set.mass[i] * v;
            result.velocity_min[d] = std::min(result.velocity_min[d], v);
            result.velocity_max[d] = std::max(result.velocity_max[d], v);
          }
          result.mass += set.mass[i];
          result.kinetic += 0.5 * set.mass[i] * v2;
          const StressVector<Dim> sigma = state.stress_of(set, i);
          result.strain += set.volume[i] * model.strain_energy_density(sigma);
          result.stress_max = std::max(result.stress_max, stress_norm_squared(sigma));
          result.density_max = std::max(result.density_max, set.density[i]);
          result.density_min = std::min(result.density_min, set.density[i]);
        }
      stability_blocks_[block] = result;
    });
    });
    // The particle named: the first real one with a non-finite stress or density, else
    // the first non-finite one (real, then virtual). A non-finite stress spreads one
    // stencil a step (the full step), a velocity further (the hourglass stiffness reads
    // the step's velocities through two fits), so the stress points closer to where it
    // started.
    for (const bool stress_first : {true, false})
      for (std::size_t block = 0; block < (stress_first ? real_blocks : real_blocks + virtual_blocks); ++block) {
        const StabilityBlock& b = stability_blocks_[block];
        if (const std::size_t i = stress_first ? b.first_non_finite_stress : b.first_non_finite; i != kNoParticle) {
          const ParticleSet<Dim>& set = block < real_blocks ? state.real : state.virtual_;
          throw SolutionDiverged(diagnosis(state, step, dt, set, i,
                                           std::string("has a non-finite ") + non_finite(set, i, block < real_blocks)));
        }
      }
    check_physical_bounds(state, step, dt, real_blocks);
    double kinetic = 0.0, strain = 0.0;
    for (std::size_t block = 0; block < real_blocks; ++block) {
      kinetic += stability_blocks_[block].kinetic;
      strain += stability_blocks_[block].strain;
    }
    const double energy = kinetic + strain;
    std::string runaway = std::isfinite(energy) ? "" : "the total energy overflowed";
    for (std::size_t k = 0; k < kRunawayGrowths.size(); ++k) {
      const double g = kRunawayGrowths[k];
      auto& count = energy_growth_steps_[k];
      count = previous_energy_ > 0.0 && energy >= g * previous_energy_ ? count + 1 : 0;
      const int steps = static_cast<int>(std::ceil(std::log(kRunawayFactor) / std::log(g)));
      if (runaway.empty() && count >= steps)
        runaway = "the total energy grew by a factor " + format_number(g) + " or more in each of the last " +
                  std::to_string(steps) + " steps (to " + format_number(energy) + " J)";
    }
    const double largest = std::max(largest_energy_.empty() ? 0.0 : largest_energy_.back(), energy);
    largest_energy_.push_back(largest);  // the last 2 W + 1 values of M
    if (largest_energy_.size() > 2 * static_cast<std::size_t>(kRunawayWindows.back()) + 1)
      largest_energy_.erase(largest_energy_.begin());
    if (largest > 0.0) ++energized_steps_;
    if (const std::size_t n = largest_energy_.size() - 1, back = kRunawayJumpSteps;
        runaway.empty() && energized_steps_ > kRunawayJumpAfter && n >= back &&
        energy >= kRunawayJumpFactor * largest_energy_[n - back])
      runaway = "the total energy jumped to " + format_number(energy) + " J, x" +
                format_number(energy / largest_energy_[n - back]) +
                " the largest of the run until " + std::to_string(kRunawayJumpSteps) +
                " steps before";
    for (int w : kRunawayWindows) {
      const std::size_t n = largest_energy_.size() - 1, window = static_cast<std::size_t>(w);
      if (!runaway.empty() || n < 2 * window) continue;
      const double now = largest_energy_[n], before = largest_energy_[n - window],
                   earlier = largest_energy_[n - 2 * window];
      if (earlier > 0.0 && before >= kRunawayWindowFactor * earlier &&
          now >= kRunawayWindowFactor * before && now / before >= 0.5 * (before / earlier))
        runaway = "the largest energy so far grew steadily, x" + format_number(before / earlier) +
                  " and then x" + format_number(now / before) + " over two spans of " +
                  std::to_string(w) + " steps (to " + format_number(now) + " J)";
    }
    if (const EnergyLedger& l = state.energy; state.settings.energy_ledger && std::isfinite(l.initial_energy)) {
      const double supplied = l.initial_energy + l.external_work();
      largest_supplied_ = std::max(largest_supplied_, supplied);
      if (runaway.empty() && energized_steps_ > kRunawayJumpAfter && largest_supplied_ > 0.0 &&
          energy - supplied > kCreatedEnergyFactor * largest_supplied_)
        runaway = "the scheme made " + format_number(energy - supplied) + " J of energy, more than " +
                  format_number(kCreatedEnergyFactor) + " x the largest energy supplied (" +
                  format_number(largest_supplied_) + " J: the initial energy and the works of the loads, " +
                  "energy.csv); an instability that grows too slowly for the rate checks";
    }
    if (!runaway.empty()) {
      std::size_t worst = 0;  // the real particle holding the most energy
      double worst_energy = -1.0;
      for (std::size_t i = 0; i < state.real.size(); ++i) {
        const Vec v = state.velocity_of(i);
        const double e = 0.5 * state.real.mass[i] * v.squaredNorm() +
                         state.real.volume[i] * state.material.strain_energy_density(state.stress_of(state.real, i));
        if (e > worst_energy) worst_energy = e, worst = i;
      }
      throw SolutionDiverged(
          diagnosis(state, step, dt, state.real, worst, "holds the most energy of a runaway: " + runaway));
    }
    previous_energy_ = energy;
  }

 private:
  /// "solver: the solution diverged at step n (t = ...): <set> particle <id> at (x, y)
  /// <what>; likely cause: ..." The cause: `known_cause` if given (physical_cause), else in
  /// order: a time step above the stability
  /// limit (CFL = dt c_p / dx > 1, c_p at the material's reference density, dx from the
  /// virtual particles' initial volumes), a boundary
  /// condition (the particle is on a boundary or within the support 2h of one), else
  /// alpha = h / dx or the kinematics.
  static std::string diagnosis(const SolverState<Dim>& state, std::int64_t step, double dt, const ParticleSet<Dim>& set, std::size_t i,
                               const std::string& what, const std::string& known_cause = "") {
    const bool is_real = &set == &state.real;
    const Vec x = set.position_of(i);
    std::string where = "(";
    for (int d = 0; d < Dim; ++d) where += (d ? ", " : "") + format_number(x[d]);
    where += ")";
    const double dx = state.initial_spacing;
    const double cfl = dt * state.material.p_wave_speed(state.material.reference_density()) / dx;
    std::string cause = known_cause;
    if (!known_cause.empty()) {
      // given by the criterion (physical_cause)
    } else if (cfl > 1.0 + 1e-9) {
      cause = "the time step: CFL = dt c_p / dx = " + format_number(cfl) +
              " is above the scheme's stability limit 1; lower cfl";
    } else {
      const int near = nearest_boundary(state, x, is_real ? state.real.boundary[i] : ParticleSet<Dim>::kNoBoundary);
      if (near != ParticleSet<Dim>::kNoBoundary)
        cause = "the boundary condition '" + state.boundaries[static_cast<std::size_t>(near)].name +
                "' (the particle is within the support 2h of it): check its kind and values, "
                "and that a traction acts on a free surface";
      else
        cause = "alpha = h / dx = " + format_number(state.settings.smoothing_length / dx) + " or the " +
                std::string(to_string(state.settings.kinematics)) +
                " kinematics (stable: alpha 0.6 to 1.2, small_strain; docs/known-problems.md)";
    }
    return "solver: the solution diverged at step " + std::to_string(step) + " (t = " +
           format_number(state.time + dt) + " s): " + (is_real ? "real" : "virtual") + " particle " +
           std::to_string(set.carries(set.id) ? set.id[i] : i) + " at " + where + " " + what +
           "; likely cause: " + cause;
  }

  /// sigma : sigma, the square of the Frobenius norm of the stress tensor (the shear
  /// components twice; 2D: xx, yy, xy, zz; 3D: xx, yy, zz, xy, yz, zx).
  static double stress_norm_squared(const StressVector<Dim>& s) {
    if constexpr (Dim == 1) return s[0] * s[0];
    else if constexpr (Dim == 2) return s[0] * s[0] + s[1] * s[1] + 2.0 * s[2] * s[2] + s[3] * s[3];
    else return s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
  }

  /// The unphysical states, from the reductions of check's pass (the first `real_blocks`
  /// of stability_blocks_), in this order: density, stress, speed, a particle that left
  /// the body. Throws SolutionDiverged naming the particle, the criterion, its value and
  /// its bound.
  void check_physical_bounds(const SolverState<Dim>& state, std::int64_t step, double dt,
                             std::size_t real_blocks) {
    const double rho0 = state.material.reference_density();
    const double c_p = state.material.p_wave_speed(rho0);
    const double modulus = rho0 * c_p * c_p;  // M, the p-wave modulus
    StabilityBlock all;                       // the real set's reductions, in block order
    for (std::size_t block = 0; block < real_blocks; ++block) {
      const StabilityBlock& b = stability_blocks_[block];
      all.mass += b.mass;
      for (int d = 0; d < Dim; ++d) {
        all.momentum[d] += b.momentum[d];
        all.velocity_min[d] = std::min(all.velocity_min[d], b.velocity_min[d]);
        all.velocity_max[d] = std::max(all.velocity_max[d], b.velocity_max[d]);
      }
      all.density_max = std::max(all.density_max, b.density_max);
      all.density_min = std::min(all.density_min, b.density_min);
      all.stress_max = std::max(all.stress_max, b.stress_max);
    }
    const ParticleSet<Dim>& real = state.real;
    auto stop = [&](std::size_t i, const std::string& what) {
      throw SolutionDiverged(diagnosis(state, step, dt, real, i, what, physical_cause(step)));
    };
    // The pass keeps the extremes only (no index: its loop stays branch-free); the
    // particle that holds one is searched for when a bound is crossed.
    auto first_with = [&](auto&& value, double extreme) {
      for (std::size_t i = 0; i < real.size(); ++i)
        if (value(i) == extreme) return i;
      return std::size_t{0};
    };
    auto density_of = [&](std::size_t i) { return real.density[i]; };
    auto stress_of = [&](std::size_t i) { return stress_norm_squared(state.stress_of(real, i)); };
    if (all.density_max > kMaxDensityRatio * rho0)
      stop(first_with(density_of, all.density_max),
           "has an unphysical density: rho / rho0 = " + format_number(all.density_max / rho0) +
               " (J = rho0 / rho = " + format_number(rho0 / all.density_max) +
               ") is above the bound " + format_number(kMaxDensityRatio) +
               " (rho0 = " + format_number(rho0) + " kg/m^3): compressed to less than 1/" +
               format_number(kMaxDensityRatio) + " of its volume");
    if (all.density_min < kMinDensityRatio * rho0)
      stop(first_with(density_of, all.density_min),
           "has an unphysical density: rho / rho0 = " + format_number(all.density_min / rho0) +
               " (J = rho0 / rho = " + format_number(rho0 / all.density_min) +
               ") is below the bound " + format_number(kMinDensityRatio) +
               " (rho0 = " + format_number(rho0) + " kg/m^3): expanded to more than " +
               format_number(1.0 / kMinDensityRatio) + " times its volume");
    if (all.stress_max > kMaxStressOverModulus * kMaxStressOverModulus * modulus * modulus)
      stop(first_with(stress_of, all.stress_max),
           "has an unphysical stress: |sigma| = " + format_number(std::sqrt(all.stress_max)) +
               " Pa is above the bound " + format_number(kMaxStressOverModulus) +
               " M = " + format_number(kMaxStressOverModulus * modulus) +
               " Pa (M = rho0 c_p^2, the p-wave modulus)");
    // Speed relative to the mean velocity: the component extremes bound it (no second
    // pass unless the bound is above the limit; then the exact largest one).
    Vec mean = Vec::Zero();
    for (int d = 0; d < Dim; ++d) mean[d] = all.mass > 0.0 ? all.momentum[d] / all.mass : 0.0;
    double bound2 = 0.0;
    for (int d = 0; d < Dim; ++d) {
      const double spread = std::max(all.velocity_max[d] - mean[d], mean[d] - all.velocity_min[d]);
      bound2 += spread * spread;
    }
    const double speed_limit = kMaxSpeedOverWaveSpeed * c_p;
    if (bound2 > speed_limit * speed_limit) {
      std::size_t fastest = 0;
      double fastest2 = -1.0;
      for (std::size_t i = 0; i < real.size(); ++i)
        if (const double r2 = (state.velocity_of(i) - mean).squaredNorm(); r2 > fastest2)
          fastest2 = r2, fastest = i;
      if (fastest2 > speed_limit * speed_limit) {
        std::string v_mean = "(";
        for (int d = 0; d < Dim; ++d) v_mean += (d ? ", " : "") + format_number(mean[d]);
        stop(fastest,
             "moves at an unphysical speed: |v - v_mean| = " + format_number(std::sqrt(fastest2)) +
                 " m/s relative to the mean velocity " + v_mean + ") m/s is above the bound " +
                 format_number(kMaxSpeedOverWaveSpeed) + " c_p = " + format_number(speed_limit) +
                 " m/s (the p-wave speed at rho0)");
      }
    }
    // A real particle with no virtual particle within its support 2h has left the body
    // (its full step found an empty stencil, counted in SolverCounters::empty_stencils):
    // the rows are searched only in a step whose count rose.
    if (state.counters.empty_stencils > empty_stencils_) {
      const NeighborList& rows = state.lists.real_from_virtual;
      const PointsView<Dim> real_points = points_of<Dim>(state.real);
      const PointsView<Dim> virtual_points = points_of<Dim>(state.virtual_);
      const double radius2 = state.support_radius() * state.support_radius();
      if (rows.query_count() == real.size())
        for (std::size_t i = 0; i < real.size(); ++i) {
          bool alone = true;
          for (std::uint32_t q : rows.neighbors(i))
            if (squared_distance<Dim>(real_points, i, virtual_points, q) < radius2) {
              alone = false;
              break;
            }
          if (alone)
            stop(i, "has no virtual particle within its support 2h = " +
                        format_number(state.support_radius()) +
                        " m (particle disorder: it has left the body)");
        }
    }
    empty_stencils_ = state.counters.empty_stencils;
  }

  /// The likely cause of an unphysical state: in the first step, the case's initial
  /// state or loads; else as for any divergence (diagnosis).
  static std::string physical_cause(std::int64_t step) {
    if (step > 1) return "";
    return "the initial state or the loads (initial.velocity, initial.velocity_gradient, initial.stress, the "
           "boundary values): an elastic solid cannot take them; lower them";
  }

  /// The boundary condition a particle is on (`own`), else that of the nearest boundary
  /// particle within the support radius, else kNoBoundary.
  static int nearest_boundary(const SolverState<Dim>& state, const Vec& x, std::int32_t own) {
    if (own != ParticleSet<Dim>::kNoBoundary) return own;
    int found = ParticleSet<Dim>::kNoBoundary;
    double best = state.support_radius() * state.support_radius();
    for (std::uint32_t b : state.boundary.particle) {
      const double d2 = (state.real.position_of(b) - x).squaredNorm();
      if (d2 <= best) best = d2, found = state.real.boundary[b];
    }
    return found;
  }

  /// check's pass: per block of kStabilityBlock particles (real blocks, then
  /// virtual ones), the first non-finite particle and the real blocks' energies.
  static constexpr std::size_t kStabilityBlock = 4096;
  static constexpr std::size_t kNoParticle = static_cast<std::size_t>(-1);
  struct StabilityBlock {
    std::size_t first_non_finite = kNoParticle;
    std::size_t first_non_finite_stress = kNoParticle;  ///< non-finite stress or density
    double kinetic = 0.0, strain = 0.0;
    double mass = 0.0;
    std::array<double, Dim> momentum{};
    std::array<double, Dim> velocity_min = filled(std::numeric_limits<double>::infinity());
    std::array<double, Dim> velocity_max = filled(-std::numeric_limits<double>::infinity());
    double density_max = -std::numeric_limits<double>::infinity();
    double density_min = std::numeric_limits<double>::infinity();
    double stress_max = -1.0;  ///< the largest sigma : sigma
  };
  static std::array<double, Dim> filled(double value) {
    std::array<double, Dim> a;
    a.fill(value);
    return a;
  }
  std::vector<StabilityBlock> stability_blocks_;
  std::int64_t empty_stencils_ = 0;  ///< SolverCounters::empty_stencils at the last check
  double previous_energy_ = 0.0;   ///< total energy after the last step (check)
  std::array<int, kRunawayGrowths.size()> energy_growth_steps_{};  ///< consecutive, per growth
  std::vector<double> largest_energy_;  ///< largest energy so far, after each recent step
  std::int64_t energized_steps_ = 0;    ///< steps with a positive largest energy
  double largest_supplied_ = 0.0;       ///< largest E0 + W of the ledger so far
};

}  // namespace tsph
