// The material interface (docs/architecture.md, "The material interface").
//
// A material model M<Dim> is a small evaluator with value semantics that provides
//   StressVector<Dim> update_stress(const StressUpdate<Dim>& in) const;
//       sigma^{n+1} from the particle's state sigma^n and the velocity gradient L (rate
//       of deformation and spin), the objective (Jaumann) rate inside the model;
//   double strain_energy_density(const StressVector<Dim>& stress) const;
//   const LinearElastic<Dim>& elastic() const;
//       its elastic part: the wave speeds of the time step, the impedances of the
//       characteristic boundary (boundary/characteristics.hpp), the hourglass
//       stiffness's modulus.
// Internal variables of a model (the plastic strain of a J2 or Drucker-Prager model)
// are per-particle fields beside the stress; linear elasticity has none.
//
// Material<Dim> holds one of the models (a variant) and is dispatched once outside the
// particle loops (visit), like visit_kernel, so the loops stay monomorphic. A new model
// is one alternative of Material::Model and one file in engine/material/.
#pragma once

#include "engine/material/linear_elastic.hpp"
#include "engine/material/stress.hpp"
#include "engine/material/stress_update.hpp"

#include <utility>
#include <variant>

namespace tsph {

template <int Dim>
class Material {
 public:
  using Model = std::variant<LinearElastic<Dim>>;

  Material(LinearElastic<Dim> model) : model_(std::move(model)) {}  // NOLINT: implicit on purpose

  /// Calls f(model) with the model's own type (once per loop, not per particle).
  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit(std::forward<F>(f), model_);
  }
  const Model& model() const { return model_; }

  /// The elastic part of the model (see the file comment).
  const LinearElastic<Dim>& elastic() const {
    return std::visit([](const auto& m) -> const LinearElastic<Dim>& { return m.elastic(); }, model_);
  }
  double strain_energy_density(const StressVector<Dim>& stress) const {
    return visit([&](const auto& m) { return m.strain_energy_density(stress); });
  }

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
};

}  // namespace tsph
