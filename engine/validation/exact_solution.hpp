// Exact solutions that a case is compared with (seed section 4): one small interface,
// so that the run loop, the frames and `tsph table1` / `tsph converge` treat every
// solution alike. A solution names its scalar fields (written as exact_<name> in the
// frames) and appends its error figures at a time (summary.json "errors").
#pragma once

#include "engine/particle_set.hpp"

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace tsph {

/// One error figure of a run at a time (summary.json "errors").
struct ErrorRecord {
  double time = 0.0;
  std::string name;  ///< e.g. velocity_x_l2_percent, tip_error_percent
  double value = 0.0;
};

/// A scalar field of the exact solution and the same quantity of the run.
template <int Dim>
struct ExactField {
  std::string name;  ///< velocity_x, stress_xx, displacement_y
  std::function<double(const Vector<Dim>& x0, double t)> exact;  ///< material coordinates x0
  std::function<double(const ParticleSet<Dim>& set, std::size_t i)> numerical;
};

template <int Dim>
class ExactSolution {
 public:
  virtual ~ExactSolution() = default;
  /// The fields compared over every real particle (relative L2, "<name>_l2_percent").
  virtual const std::vector<ExactField<Dim>>& fields() const = 0;
  /// Appends the error figures at time t: the fields' relative L2 errors, then any
  /// figure of the solution's own (a tip deflection).
  virtual void errors(const ParticleSet<Dim>& real, double t, std::vector<ErrorRecord>& out) const;
};

/// The relative L2 error in percent, 100 sqrt(sum (a-b)^2 / sum b^2); NaN if b is 0.
inline double relative_l2_percent(const std::vector<double>& numerical, const std::vector<double>& exact) {
  double difference = 0.0, reference = 0.0;
  for (std::size_t i = 0; i < exact.size(); ++i) {
    difference += (numerical[i] - exact[i]) * (numerical[i] - exact[i]);
    reference += exact[i] * exact[i];
  }
  // No relative error against a zero reference: NaN, so that no check passes by accident.
  return reference > 0.0 ? 100.0 * std::sqrt(difference / reference) : std::numeric_limits<double>::quiet_NaN();
}

template <int Dim>
void ExactSolution<Dim>::errors(const ParticleSet<Dim>& r, double t, std::vector<ErrorRecord>& out) const {
  for (const auto& e : fields()) {
    std::vector<double> numerical(r.size()), exact(r.size());
    for (std::size_t i = 0; i < r.size(); ++i) {
      Vector<Dim> x0;
      for (int d = 0; d < Dim; ++d) x0[d] = r.initial_position[d][i];
      numerical[i] = e.numerical(r, i);
      exact[i] = e.exact(x0, t);
    }
    out.push_back({t, e.name + "_l2_percent", relative_l2_percent(numerical, exact)});
  }
}

}  // namespace tsph
