// Structure-of-arrays particle storage (docs/architecture.md, docs/conventions.md "Structure of
// arrays"). One contiguous array per scalar component; loops receive a
// `ParticleView` of raw pointers, never the container. Every field is reached through
// `for_each_field`, so `resize` and `permute` cannot forget one.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace tsph {

/// Number of independent Cauchy stress components stored per particle.
/// 1D: xx. 2D: xx, yy, xy, zz (zz is carried for plane strain, zero in plane stress).
/// 3D: xx, yy, zz, xy, yz, zx.
template <int Dim>
inline constexpr int stress_component_count = Dim == 1 ? 1 : Dim == 2 ? 4 : 6;

template <int Dim>
using Vector = Eigen::Matrix<double, Dim, 1>;
template <int Dim>
using Matrix = Eigen::Matrix<double, Dim, Dim>;

/// Raw-pointer view of the fields a loop reads or writes. Trivially copyable.
template <int Dim>
struct ParticleView {
  static constexpr int stress_count = stress_component_count<Dim>;
  std::size_t count = 0;
  std::array<double*, Dim> position{};
  std::array<double*, Dim> velocity{};
  std::array<double*, stress_count> stress{};
  double* mass = nullptr;
  double* density = nullptr;
  double* volume = nullptr;

  Vector<Dim> position_of(std::size_t i) const {
    Vector<Dim> x;
    for (int d = 0; d < Dim; ++d) x[d] = position[d][i];
    return x;
  }
};

/// A set of particles (real or virtual) in structure-of-arrays form.
/// Throws std::invalid_argument (naming `who`) unless `order` holds each index
/// 0 .. count - 1 exactly once: a duplicate would lose a particle in a permute.
inline void require_permutation(const std::vector<std::uint32_t>& order, std::size_t count,
                                const std::string& who) {
  bool valid = order.size() == count;
  std::vector<char> seen(valid ? count : 0, 0);
  for (std::size_t k = 0; valid && k < order.size(); ++k) {
    valid = order[k] < count && !seen[order[k]];
    if (valid) seen[order[k]] = 1;
  }
  if (!valid)
    throw std::invalid_argument(who + ": order has " + std::to_string(order.size()) + " entries for " +
                                std::to_string(count) + " particles, or an index out of range or twice "
                                "(a permutation holds each index once)");
}

template <int Dim>
class ParticleSet {
 public:
  static_assert(Dim >= 1 && Dim <= 3, "ParticleSet: Dim must be 1, 2 or 3");
  static constexpr int dim = Dim;
  static constexpr int stress_count = stress_component_count<Dim>;

  /// Current position, and the position at t = 0 (for displacements).
  std::array<std::vector<double>, Dim> position;
  std::array<std::vector<double>, Dim> initial_position;  ///< optional (release_optional_fields)
  std::array<std::vector<double>, Dim> velocity;
  /// Displacement from the initial position (integrated in every kinematics mode);
  /// optional (release_optional_fields).
  std::array<std::vector<double>, Dim> displacement;
  std::array<std::vector<double>, stress_count> stress;
  std::vector<double> mass;
  std::vector<double> density;
  std::vector<double> volume;  ///< m / rho, kept in step with density
  /// Index of the particle when the set was created; survives every `permute`.
  /// Optional (release_optional_fields).
  std::vector<std::uint32_t> id;
  /// Index into the case's boundary-condition table, or kNoBoundary. Optional.
  std::vector<std::int32_t> boundary;
  /// User group number (from a particle file; 0 by default), for region selection. Optional.
  std::vector<std::int32_t> group;
  /// The internal variables of a plastic material model (engine/material/plastic_state.hpp),
  /// held by the real set of a plastic run only (carry_plastic_fields; 97 B per particle
  /// in 3D): the equivalent plastic strain, the plastic
  /// work per unit volume (J/m^3), the temperature (K, Johnson-Cook), the back stress
  /// (kinematic hardening; the stress components' order), whether the last update was
  /// plastic (0/1) and the hourglass stiffness's reference. On demand: empty unless
  /// carried, and `resize` does not create them.
  std::vector<double> plastic_strain;
  std::vector<double> plastic_work;
  std::vector<double> temperature;
  std::array<std::vector<double>, stress_count> back_stress;
  std::vector<std::uint8_t> yielding;
  /// The hourglass stiffness's reference in a plastic run (m): the smooth part of the
  /// residual it has taken in where the particle yielded (SolverSettings::hourglass_reference,
  /// stabilisation/hourglass_stiffness.hpp); zero until then. A plastic field.
  std::array<std::vector<double>, Dim> hourglass_reference;

  static constexpr std::int32_t kNoBoundary = -1;

  /// The particles of the set (the owned ones: ghosts, when attached, are not counted).
  std::size_t size() const { return mass.size() - ghost_count_; }
  /// Mirror ghosts (engine/solver/boundary/mirror_planes.hpp): images of owned particles
  /// across a mirror plane, held behind the owned ones in every carried field while a
  /// step runs, so that a neighbour list may index them like any source particle.
  /// Loops over size() never see them; storage_size() counts both.
  std::size_t ghost_count() const { return ghost_count_; }
  std::size_t storage_size() const { return mass.size(); }
  /// Appends `count` ghost slots behind the owned particles in every carried field
  /// (values unset: the caller fills them), replacing the ghosts held.
  void attach_ghosts(std::size_t count) {
    detach_ghosts();
    const std::size_t n = size();
    for_each_field([&](auto& field) {
      if (!field.empty()) field.resize(n + count);
    });
    ghost_count_ = count;
  }
  /// Drops the ghosts (the owned particles are untouched).
  void detach_ghosts() {
    if (ghost_count_ == 0) return;
    const std::size_t n = size();
    for_each_field([&](auto& field) {
      if (!field.empty()) field.resize(n);
    });
    ghost_count_ = 0;
  }

  /// Whether the set holds the optional field `field` (one of initial_position,
  /// displacement, id, boundary, group, or a component of them): every other field is
  /// always held; an optional one is either held for every particle or released (empty).
  template <class Field>
  bool carries(const Field& field) const {
    if constexpr (requires { field[0].size(); }) return field[0].size() == storage_size();
    else return field.size() == storage_size();
  }

  /// Releases the optional fields a stepper does not read for this set (memory: the
  /// virtual set of TaylorSph reads none of them, 44 B per particle in 2D, 60 B in 3D;
  /// bench/RESULTS.md, Memory): displacement, id, boundary and group, and
  /// initial_position unless `keep_initial_position`. `resize` and `permute` keep
  /// released fields released.
  void release_optional_fields(bool keep_initial_position) {
    auto release = [](auto& field) { std::decay_t<decltype(field)>().swap(field); };
    if (!keep_initial_position)
      for (auto& a : initial_position) release(a);
    for (auto& a : displacement) release(a);
    release(id);
    release(boundary);
    release(group);
    release_plastic_fields();
  }

  /// Whether `field` is a component of hourglass_reference (checkpoints of format 3 and 4
  /// hold none).
  bool is_hourglass_reference(const std::vector<double>& field) const {
    for (const auto& a : hourglass_reference)
      if (&field == &a) return true;
    return false;
  }

  /// Whether the set holds the plastic models' internal variables.
  bool carries_plastic_fields() const { return plastic_strain.size() == storage_size() && size() > 0; }
  /// Allocates the plastic fields (zero; the temperature at `temperature0`) unless held.
  void carry_plastic_fields(double temperature0) {
    if (carries_plastic_fields()) return;
    detach_ghosts();
    const std::size_t n = size();
    plastic_strain.assign(n, 0.0);
    plastic_work.assign(n, 0.0);
    temperature.assign(n, temperature0);
    for (auto& a : back_stress) a.assign(n, 0.0);
    yielding.assign(n, 0);
    for (auto& a : hourglass_reference) a.assign(n, 0.0);
  }
  void release_plastic_fields() {
    auto release = [](auto& field) { std::decay_t<decltype(field)>().swap(field); };
    release(plastic_strain);
    release(plastic_work);
    release(temperature);
    for (auto& a : back_stress) release(a);
    release(yielding);
    for (auto& a : hourglass_reference) release(a);
  }

  /// Throws std::invalid_argument (naming `who`) unless every field holds size()
  /// values, the optional ones size() or none (released).
  void check_field_sizes(const std::string& who) {
    const std::size_t n = storage_size();
    std::size_t index = 0;
    for_each_field([&](auto& field) {
      const bool optional = is_optional_field(field);
      if (field.size() != n && !(optional && field.empty()))
        throw std::invalid_argument(who + ": per-particle field " + std::to_string(index) + " holds " +
                                    std::to_string(field.size()) + " values for " + std::to_string(n) +
                                    " particles" + (optional ? " (an optional field holds all or none)" : ""));
      ++index;
    });
  }

  /// Visits every per-particle array. Adding a field means adding it here.
  template <class F>
  void for_each_field(F&& f) {
    for (auto& a : position) f(a);
    for (auto& a : initial_position) f(a);
    for (auto& a : velocity) f(a);
    for (auto& a : displacement) f(a);
    for (auto& a : stress) f(a);
    f(mass);
    f(density);
    f(volume);
    f(id);
    f(boundary);
    f(group);
    f(plastic_strain);
    f(plastic_work);
    f(temperature);
    for (auto& a : back_stress) f(a);
    f(yielding);
    for (auto& a : hourglass_reference) f(a);
  }

  /// Resizes every field; new particles are zeroed, ids numbered, unbounded. Optional
  /// fields released from a non-empty set stay released. Ghosts are dropped first.
  void resize(std::size_t n) {
    detach_ghosts();
    const std::size_t old = size();
    for_each_field([&](auto& field) {
      if ((old == 0 && !is_on_demand_field(field)) || !field.empty()) field.resize(n);
    });
    for (std::size_t i = old; i < n && i < id.size(); ++i) id[i] = static_cast<std::uint32_t>(i);
    for (std::size_t i = old; i < n && i < boundary.size(); ++i) boundary[i] = kNoBoundary;
  }

  /// Reorders every field so that new particle i is old particle order[i] (released
  /// optional fields stay released). Ghosts are dropped first.
  void permute(const std::vector<std::uint32_t>& order) {
    detach_ghosts();
    require_permutation(order, size(), "ParticleSet::permute");
    for_each_field([&order](auto& field) {
      if (field.empty()) return;  // released, or no particles
      auto reordered = field;
      for (std::size_t i = 0; i < order.size(); ++i) reordered[i] = field[order[i]];
      field.swap(reordered);
    });
  }

  ParticleView<Dim> view() {
    ParticleView<Dim> v;
    v.count = size();
    for (int d = 0; d < Dim; ++d) {
      v.position[d] = position[d].data();
      v.velocity[d] = velocity[d].data();
    }
    for (int s = 0; s < stress_count; ++s) v.stress[s] = stress[s].data();
    v.mass = mass.data();
    v.density = density.data();
    v.volume = volume.data();
    return v;
  }

  Vector<Dim> position_of(std::size_t i) const {
    Vector<Dim> x;
    for (int d = 0; d < Dim; ++d) x[d] = position[d][i];
    return x;
  }

 private:
  /// Whether `field` (a vector this set owns) is one of the optional fields.
  template <class Field>
  bool is_optional_field(const Field& field) const {
    for (int d = 0; d < Dim; ++d)
      if (static_cast<const void*>(&field) == &initial_position[d] ||
          static_cast<const void*>(&field) == &displacement[d])
        return true;
    return static_cast<const void*>(&field) == &id || static_cast<const void*>(&field) == &boundary ||
           static_cast<const void*>(&field) == &group || is_on_demand_field(field);
  }
  /// Whether `field` is one of the plastic fields (created by carry_plastic_fields only).
  template <class Field>
  bool is_on_demand_field(const Field& field) const {
    const void* f = &field;
    for (const auto& a : back_stress)
      if (f == &a) return true;
    for (const auto& a : hourglass_reference)
      if (f == &a) return true;
    return f == &plastic_strain || f == &plastic_work || f == &temperature || f == &yielding;
  }

  std::size_t ghost_count_ = 0;
};

}  // namespace tsph
