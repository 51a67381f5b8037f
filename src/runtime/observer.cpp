#include "obsgain/runtime/observer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace obsgain {

int observer_substeps(double k1, double k2, double L, double dt) {
  const double steps = std::ceil(dt * 2.0 * (std::abs(k1) + std::sqrt(std::abs(k2)) + std::abs(L)));
  if (!(steps <= Observer::max_substeps)) return Observer::max_substeps + 1;  // NaN too: refused by update()
  return steps < 1.0 ? 1 : static_cast<int>(steps);  // (a negative dt is refused by update())
}

Observer::Observer(const Model& model, const CertifiedObserver& gains, int substeps)
    : model_(model),
      gains_(gains),
      substeps_(substeps),
      n_(model.dof()),
      lower_(n_),
      upper_(n_),
      q_hat_(Eigen::VectorXd::Zero(n_)),
      v_hat_(Eigen::VectorXd::Zero(n_)),
      y_previous_(Eigen::VectorXd::Zero(n_)),
      y_current_(n_),
      u_(model.input_matrix.cols()),
      Hu_(n_),
      start_(model),
      middle_(model),
      end_(model),
      saturated_(n_),
      coriolis_(n_),
      k1q_(n_), k1v_(n_), k2q_(n_), k2v_(n_), k3q_(n_), k3v_(n_), k4q_(n_), k4v_(n_), q_stage_(n_), v_stage_(n_) {
  if (gains.velocity_bounds.size() != n_)
    throw InputError("observer: " + std::to_string(gains.velocity_bounds.size()) + " velocity bounds for a robot of " +
                     std::to_string(n_) + " joints");
  if (!(gains.k1 > 0.0) || !(gains.k2 > 0.0) || !std::isfinite(gains.k1) || !std::isfinite(gains.k2) ||
      !(gains.L >= 0.0) || !std::isfinite(gains.L) || substeps < 0 || substeps > max_substeps)
    throw InputError("observer: gains k1 = " + std::to_string(gains.k1) + ", k2 = " + std::to_string(gains.k2) +
                     " must be positive and finite, L >= 0, substeps in [0, " +
                     std::to_string(max_substeps) + "]");
  const double infinity = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n_; ++i) {
    const JointDomain& joint = model.joints[static_cast<std::size_t>(i)];
    lower_(i) = joint.continuous ? -infinity : joint.lower;
    upper_(i) = joint.continuous ? infinity : joint.upper;
  }
}

bool Observer::reset(const Eigen::Ref<const Eigen::VectorXd>& q_measured, const Eigen::Ref<const Eigen::VectorXd>& q_estimate,
                     const Eigen::Ref<const Eigen::VectorXd>& v_estimate) noexcept {
  if (q_measured.size() != n_ || q_estimate.size() != n_ || v_estimate.size() != n_ || !q_measured.allFinite() ||
      !q_estimate.allFinite() || !v_estimate.allFinite())
    return false;
  y_previous_ = q_measured;
  q_hat_ = q_estimate;
  v_hat_ = v_estimate;
  last_instant_ = -1;
  started_ = true;
  return true;
}

bool Observer::reset(const Eigen::Ref<const Eigen::VectorXd>& q_measured) noexcept {
  if (q_measured.size() != n_) return false;
  y_current_.setZero();
  return reset(q_measured, q_measured, y_current_);
}

void Observer::freeze(double fraction, Instant& instant) noexcept {
  if (fraction == 1.0)
    instant.y = y_current_;  // exactly: the next update starts from this instant
  else
    instant.y = y_previous_ + fraction * (y_current_ - y_previous_);
  // The true position lies inside the limits; clamping moves the model's point towards it, never away.
  instant.y_model = instant.y.cwiseMax(lower_).cwiseMin(upper_);
  instant.dynamics.set(instant.y_model);
  instant.dynamics.mass_matrix(instant.M);
  instant.llt.compute(instant.M);
  instant.dynamics.gravity(instant.g);
  instant.bias = Hu_ - instant.g;
}

void Observer::derivative(const Instant& instant, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                          Eigen::VectorXd& dq, Eigen::VectorXd& dv) noexcept {
  saturated_ = v.cwiseMax(-gains_.velocity_bounds).cwiseMin(gains_.velocity_bounds);
  instant.dynamics.coriolis(saturated_, coriolis_);
  dv = instant.bias - coriolis_;
  dv.noalias() -= model_.friction * v;
  instant.llt.solveInPlace(dv);
  dq = q - instant.y;  // the innovation, reused below
  dv -= gains_.k2 * dq;
  dq = v - gains_.k1 * dq;
}

Observer::Estimate Observer::update(const Eigen::Ref<const Eigen::VectorXd>& q_measured,
                                    const Eigen::Ref<const Eigen::VectorXd>& u, double dt) noexcept {
  const int steps = substeps(dt);
  if (!started_ || q_measured.size() != n_ || u.size() != u_.size() || !q_measured.allFinite() || !u.allFinite() ||
      !(dt > 0.0) || !std::isfinite(dt) || steps > max_substeps)
    return {q_hat_, v_hat_, false};
  y_current_ = q_measured;
  u_ = u;
  Hu_.noalias() = model_.input_matrix * u_;
  const double h = dt / steps;
  // The end of one sub-step is the start of the next, and the last update's end this one's start: swap the
  // roles, never the buffers (and never let both roles share one).
  Instant* start = last_instant_ == 1 ? &end_ : &start_;
  Instant* end = start == &start_ ? &end_ : &start_;
  if (last_instant_ < 0)
    freeze(0.0, *start);
  else
    start->bias = Hu_ - start->g;  // same measurement, new input
  for (int step = 0; step < steps; ++step) {
    const double s = static_cast<double>(step) / steps;
    freeze(s + 0.5 / steps, middle_);
    freeze(static_cast<double>(step + 1) / steps, *end);
    derivative(*start, q_hat_, v_hat_, k1q_, k1v_);
    q_stage_ = q_hat_ + 0.5 * h * k1q_;
    v_stage_ = v_hat_ + 0.5 * h * k1v_;
    derivative(middle_, q_stage_, v_stage_, k2q_, k2v_);
    q_stage_ = q_hat_ + 0.5 * h * k2q_;
    v_stage_ = v_hat_ + 0.5 * h * k2v_;
    derivative(middle_, q_stage_, v_stage_, k3q_, k3v_);
    q_stage_ = q_hat_ + h * k3q_;
    v_stage_ = v_hat_ + h * k3v_;
    derivative(*end, q_stage_, v_stage_, k4q_, k4v_);
    q_hat_ += (h / 6.0) * (k1q_ + 2.0 * k2q_ + 2.0 * k3q_ + k4q_);
    v_hat_ += (h / 6.0) * (k1v_ + 2.0 * k2v_ + 2.0 * k3v_ + k4v_);
    std::swap(start, end);
  }
  y_previous_ = y_current_;
  last_instant_ = start == &start_ ? 0 : 1;
  return {q_hat_, v_hat_, true};
}

}  // namespace obsgain
