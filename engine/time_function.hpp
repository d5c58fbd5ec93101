// Scalar functions of time for prescribed velocities and tractions: constant,
// rectangular pulse, linear ramp and a piecewise-linear table.
//
// Switching instants are compared with a tolerance of 1e-9 of the function's time
// scale, so that a step landing on t_end up to round-off (50 * 5e-5 vs 2.5e-3) is
// counted on the same side every time: a pulse is "on" for t_start < t <= t_end.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

class TimeFunction {
 public:
  enum class Kind { constant, rectangular_pulse, linear_ramp, table };

  static TimeFunction constant(double value) {
    TimeFunction f(Kind::constant);
    f.amplitude_ = value;
    return f;
  }
  /// `amplitude` for t_start < t <= t_end, zero otherwise.
  static TimeFunction rectangular_pulse(double amplitude, double t_start, double t_end) {
    require_interval(t_start, t_end, "rectangular pulse");
    TimeFunction f(Kind::rectangular_pulse);
    f.amplitude_ = amplitude;
    f.t_start_ = t_start;
    f.t_end_ = t_end;
    return f;
  }
  /// Zero until t_start, linear up to `amplitude` at t_end, then constant.
  static TimeFunction linear_ramp(double amplitude, double t_start, double t_end) {
    require_interval(t_start, t_end, "linear ramp");
    TimeFunction f(Kind::linear_ramp);
    f.amplitude_ = amplitude;
    f.t_start_ = t_start;
    f.t_end_ = t_end;
    return f;
  }
  /// Piecewise-linear through (times[k], values[k]); constant beyond the ends.
  static TimeFunction table(std::vector<double> times, std::vector<double> values) {
    if (times.empty() || times.size() != values.size())
      throw std::invalid_argument("time table: needs as many values as times, at least one (got " +
                                  std::to_string(times.size()) + " times, " +
                                  std::to_string(values.size()) + " values)");
    for (std::size_t k = 0; k < times.size(); ++k) {
      if (!std::isfinite(times[k]) || !std::isfinite(values[k]))
        throw std::invalid_argument("time table: entry " + std::to_string(k) + " is not finite");
      if (k > 0 && !(times[k] > times[k - 1]))
        throw std::invalid_argument("time table: times must increase strictly (entry " +
                                    std::to_string(k) + ")");
    }
    TimeFunction f(Kind::table);
    f.times_ = std::move(times);
    f.values_ = std::move(values);
    return f;
  }

  Kind kind() const { return kind_; }

  /// Whether f(t) = 0 for every t (a zero amplitude, or a table of zeros).
  bool is_zero() const {
    if (kind_ == Kind::table) return std::all_of(values_.begin(), values_.end(), [](double v) { return v == 0.0; });
    return amplitude_ == 0.0;
  }

  /// int_0^t f(s) ds (t >= 0; 0 for t < 0), exact for every kind: a velocity gradient
  /// scaled by f moves the material along exp(G int_0^t f) (engine/affine_motion.hpp). The
  /// pulse is integrated over [t_start, t_end] exactly (operator() switches 1e-9 of the
  /// time scale later: a difference of that order).
  double integral(double t) const {
    // int_0^t of a function linear on [a, b] between the values fa and fb, clipped to [0, t].
    auto linear_piece = [t](double a, double b, double fa, double fb) {
      const double lo = std::max(a, 0.0), hi = std::min(b, t);
      if (!(hi > lo)) return 0.0;
      const auto at = [&](double x) { return b > a ? fa + (fb - fa) * (x - a) / (b - a) : fa; };
      return 0.5 * (at(lo) + at(hi)) * (hi - lo);
    };
    const double inf = std::numeric_limits<double>::infinity();
    switch (kind_) {
      case Kind::constant: return amplitude_ * std::max(t, 0.0);
      case Kind::rectangular_pulse: return linear_piece(t_start_, t_end_, amplitude_, amplitude_);
      case Kind::linear_ramp:
        return linear_piece(t_start_, t_end_, 0.0, amplitude_) + amplitude_ * std::max(0.0, t - std::max(t_end_, 0.0));
      case Kind::table: {
        double sum = 0.0;
        if (t > 0.0 && times_.front() > 0.0) sum += values_.front() * (std::min(t, times_.front()));
        for (std::size_t k = 1; k < times_.size(); ++k)
          sum += linear_piece(times_[k - 1], times_[k], values_[k - 1], values_[k]);
        sum += linear_piece(std::max(times_.back(), 0.0), inf, values_.back(), values_.back());
        return sum;
      }
    }
    return 0.0;
  }

  double operator()(double t) const {
    switch (kind_) {
      case Kind::constant: return amplitude_;
      case Kind::rectangular_pulse: {
        const double tol = tolerance();
        return (t > t_start_ + tol && t <= t_end_ + tol) ? amplitude_ : 0.0;
      }
      case Kind::linear_ramp: {
        if (t <= t_start_) return 0.0;
        if (t >= t_end_) return amplitude_;
        return amplitude_ * (t - t_start_) / (t_end_ - t_start_);
      }
      case Kind::table: {
        if (t <= times_.front()) return values_.front();
        if (t >= times_.back()) return values_.back();
        const auto upper = std::upper_bound(times_.begin(), times_.end(), t);
        const std::size_t k = static_cast<std::size_t>(upper - times_.begin());
        const double s = (t - times_[k - 1]) / (times_[k] - times_[k - 1]);
        return values_[k - 1] + s * (values_[k] - values_[k - 1]);
      }
    }
    return 0.0;
  }

 private:
  explicit TimeFunction(Kind kind) : kind_(kind) {}
  static void require_interval(double t_start, double t_end, const char* what) {
    if (!std::isfinite(t_start) || !std::isfinite(t_end) || !(t_end > t_start))
      throw std::invalid_argument(std::string(what) + ": needs t_start < t_end (got " +
                                  std::to_string(t_start) + ", " + std::to_string(t_end) + ")");
  }
  double tolerance() const { return 1e-9 * std::max(std::abs(t_start_), std::abs(t_end_)); }

  Kind kind_;
  double amplitude_ = 0.0;
  double t_start_ = 0.0;
  double t_end_ = 0.0;
  std::vector<double> times_;
  std::vector<double> values_;
};

}  // namespace tsph
