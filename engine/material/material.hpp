// The material interface (docs/architecture.md, "The material interface").
//
// A material model M<Dim> is a small evaluator with value semantics that provides
//   StressVector<Dim> update_stress(const StressUpdate<Dim>& in) const;   (elastic)
//   StressVector<Dim> update_stress(const StressUpdate<Dim>& in, PlasticState& state) const;
//   StressVector<Dim> return_map(const StressVector<Dim>& trial, PlasticState& state, double dt) const;
//       (plastic: material/j2_plasticity.hpp, drucker_prager.hpp)
//       sigma^{n+1} from the particle's state sigma^n and the velocity gradient L (rate
//       of deformation and spin), the objective (Jaumann) rate inside the model;
//   double strain_energy_density(const StressVector<Dim>& stress) const;
//   const LinearElastic<Dim>& elastic() const;
//       its elastic part: the wave speeds of the time step, the impedances of the
//       characteristic boundary (boundary/characteristics.hpp), the hourglass
//       stiffness's modulus.
// Internal variables of a model (the plastic strain of a J2 or Drucker-Prager model)
// are per-particle fields beside the stress (ParticleSet::plastic_strain, ...; the real
// set only: a virtual particle's state at n+1/2 is interpolated from its real
// neighbours); linear elasticity has none.
//
// Material<Dim> holds one of the models (a variant). The loops take the Material itself
// and call update_stress per particle: the elastic model inline (a copy of the model's
// elastic part is kept beside the variant), the plastic ones (issue 16) out of line with
// the particle's PlasticState, so that the stages are compiled once per kernel, not per
// kernel and model. visit(f) calls f with the model's own type, once outside the loops
// (energies). A new model is one alternative of Material::Model and one file in
// engine/material/.
#pragma once

#include "engine/material/drucker_prager.hpp"
#include "engine/material/j2_plasticity.hpp"
#include "engine/material/linear_elastic.hpp"
#include "engine/material/plastic_state.hpp"
#include "engine/material/stress.hpp"
#include "engine/material/stress_update.hpp"

#include <utility>
#include <variant>

namespace tsph {

template <int Dim>
class Material {
 public:
  using Model = std::variant<LinearElastic<Dim>, J2Plasticity<Dim>, DruckerPrager<Dim>>;

  // Implicit on purpose: a model is a Material.
  Material(LinearElastic<Dim> model) : model_(std::move(model)), elastic_(std::get<0>(model_)) {}  // NOLINT
  Material(J2Plasticity<Dim> model) : model_(std::move(model)), elastic_(std::get<1>(model_).elastic()) {}  // NOLINT
  Material(DruckerPrager<Dim> model) : model_(std::move(model)), elastic_(std::get<2>(model_).elastic()) {}  // NOLINT

  /// Calls f(model) with the model's own type (once per loop, not per particle).
  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit(std::forward<F>(f), model_);
  }
  const Model& model() const { return model_; }
  /// A model with internal variables (the real set then carries the plastic fields).
  bool plastic() const { return model_.index() != 0; }
  /// The case-file name of the model: elastic, j2, johnson_cook, drucker_prager.
  const char* name() const {
    if (model_.index() == 0) return "elastic";
    if (const auto* j2 = std::get_if<1>(&model_)) return j2->is_johnson_cook() ? "johnson_cook" : "j2";
    return "drucker_prager";
  }
  /// Whether the model reads the back stress and the temperature of its state (the
  /// half step interpolates only what it reads; SolverState::interpolated_plastic_state).
  bool reads_back_stress() const { return reads_back_stress_; }
  /// A plastic model whose yield function does not read the pressure (J2, Johnson-Cook,
  /// Drucker-Prager with phi = 0 and no tension cut-off; in 2D in plane strain, where the
  /// in-plane pressure is the pressure): its return commutes with a change of the
  /// pressure (SolverSettings::volumetric_average).
  bool pressure_independent_yield() const {
    if (Dim == 2 && plane_mode() != PlaneMode::plane_strain) return false;
    if (model_.index() == 1) return true;
    if (const auto* dp = std::get_if<2>(&model_)) return dp->pressure_independent_yield();
    return false;
  }
  bool reads_temperature() const { return reads_temperature_; }
  /// A virgin particle's internal variables.
  PlasticState initial_state() const {
    return visit([](const auto& m) {
      if constexpr (requires { m.initial_state(); }) return m.initial_state();
      else return PlasticState{};
    });
  }

  /// The elastic stress update (material/stress_update.hpp); elastic models only.
  [[gnu::always_inline]] StressVector<Dim> update_stress(const StressUpdate<Dim>& in) const {
    return elastic_.update_stress(in);
  }
  /// The stress update of a plastic model with the particle's state, updated in place.
  [[gnu::noinline]] StressVector<Dim> update_stress(const StressUpdate<Dim>& in, PlasticState& state) const {
    return visit([&](const auto& m) -> StressVector<Dim> {
      if constexpr (requires { m.update_stress(in, state); }) return m.update_stress(in, state);
      else return m.update_stress(in);
    });
  }
  /// The plastic correction alone of a stress reached elastically over dt (the
  /// characteristic boundary's): the return mapping with the particle's state.
  [[gnu::noinline]] StressVector<Dim> return_map(const StressVector<Dim>& trial, PlasticState& state, double dt) const {
    return visit([&](const auto& m) -> StressVector<Dim> {
      if constexpr (requires { m.return_map(trial, state, dt); }) return m.return_map(trial, state, dt);
      else return trial;
    });
  }

  /// The elastic part of the model (see the file comment).
  const LinearElastic<Dim>& elastic() const { return elastic_; }
  double strain_energy_density(const StressVector<Dim>& stress) const { return elastic_.strain_energy_density(stress); }

  // The elastic constants, as callers of LinearElastic read them.
  double young_modulus() const { return elastic().young_modulus(); }
  double poisson_ratio() const { return elastic().poisson_ratio(); }
  double reference_density() const { return elastic().reference_density(); }
  PlaneMode plane_mode() const { return elastic().plane_mode(); }
  double shear_modulus() const { return elastic().shear_modulus(); }
  double model_lame() const { return elastic().model_lame(); }
  double p_wave_modulus() const { return elastic().p_wave_modulus(); }
  double s_wave_speed(double density) const { return elastic().s_wave_speed(density); }
  double p_wave_speed(double density) const { return elastic().p_wave_speed(density); }

 private:
  Model model_;
  LinearElastic<Dim> elastic_;  ///< the model's elastic part, for the inline elastic path
  bool reads_back_stress_ = visit([](const auto& m) {
    if constexpr (requires { m.reads_back_stress(); }) return m.reads_back_stress();
    else return false;
  });
  bool reads_temperature_ = visit([](const auto& m) {
    if constexpr (requires { m.reads_temperature(); }) return m.reads_temperature();
    else return false;
  });
};

}  // namespace tsph
