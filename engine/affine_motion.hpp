// An affine motion prescribed by its spatial velocity field, v(x, t) = a + G x (x the
// current position, G the constant velocity gradient, a a constant velocity): the
// homogeneous deformations of the validation suite (uniaxial stretch, simple shear,
// rigid spin) and the `velocity_gradient` key of a velocity boundary (docs/cases.md).
//
// Along the motion, dx/dt = a + G x from x(0) = x0 gives
//   x(t) = exp(G t) x0 + Phi(t) a,   Phi(t) = int_0^t exp(G s) ds,
// both read off one exponential of the augmented matrix [[G, a], [0, 0]] t (Van Loan
// 1978); the velocity of the material point of initial position x0 is then
// v = a + G x(t), exact at every t (no time integration of the prescribed field).
#pragma once

#include "engine/particle_set.hpp"

#include <Eigen/Core>
#include <Eigen/LU>

#include <cmath>
#include <memory>
#include <mutex>

namespace tsph {

/// exp(A) by scaling and squaring with a Taylor series (small dense matrices: the
/// relative error is about 1e-15 for ||A|| up to hundreds; tested against closed forms).
template <int N>
Eigen::Matrix<double, N, N> matrix_exponential(const Eigen::Matrix<double, N, N>& a) {
  using M = Eigen::Matrix<double, N, N>;
  const double norm = a.cwiseAbs().rowwise().sum().maxCoeff();  // the infinity norm
  int squarings = 0;
  if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
  const M scaled = a / std::ldexp(1.0, squarings);
  M term = M::Identity(), sum = M::Identity();
  for (int k = 1; k <= 18; ++k) {  // ||scaled|| <= 0.5: 0.5^18 / 18! is far below 1e-16
    term = term * scaled / static_cast<double>(k);
    sum += term;
  }
  for (int k = 0; k < squarings; ++k) sum = sum * sum;
  return sum;
}

template <int Dim>
class AffineMotion {
 public:
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;

  AffineMotion(const Mat& gradient, const Vec& velocity) : gradient_(gradient), velocity_(velocity) {}

  const Mat& gradient() const { return gradient_; }

  /// x(t) of the material point that was at x0 at t = 0.
  Vec position(const Vec& x0, double t) const {
    const Augmented e = exponential(t);
    return e.template topLeftCorner<Dim, Dim>() * x0 + e.template topRightCorner<Dim, 1>();
  }
  /// v(t) = a + G x(t) of the material point that was at x0 at t = 0.
  Vec velocity(const Vec& x0, double t) const { return velocity_ + gradient_ * position(x0, t); }
  /// The deformation gradient F(t) = exp(G t).
  Mat deformation_gradient(double t) const { return exponential(t).template topLeftCorner<Dim, Dim>(); }

 private:
  using Augmented = Eigen::Matrix<double, Dim + 1, Dim + 1>;
  /// exp([[G, a], [0, 0]] t), cached for the last t (a boundary condition asks for the
  /// same time once per particle).
  Augmented exponential(double t) const {
    std::lock_guard<std::mutex> lock(cache_->mutex);
    if (!cache_->valid || cache_->time != t) {
      Augmented m = Augmented::Zero();
      m.template topLeftCorner<Dim, Dim>() = gradient_ * t;
      m.template topRightCorner<Dim, 1>() = velocity_ * t;
      cache_->value = matrix_exponential<Dim + 1>(m);
      cache_->time = t;
      cache_->valid = true;
    }
    return cache_->value;
  }
  struct Cache {
    std::mutex mutex;
    bool valid = false;
    double time = 0.0;
    Augmented value;
  };

  Mat gradient_;
  Vec velocity_;
  std::shared_ptr<Cache> cache_ = std::make_shared<Cache>();
};

}  // namespace tsph
