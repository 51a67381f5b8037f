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
      q_hat_(Eigen::VectorXd::Zero(n_)),
      v_hat_(Eigen::VectorXd::Zero(n_)),
      start_(model),
      middle_(model),
      end_(model),
      saturated_(n_),
      bias_(n_) {
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
    lower_[i] = joint.continuous ? -infinity : joint.lower;
    upper_[i] = joint.continuous ? infinity : joint.upper;
  }
}

bool Observer::reset(const Eigen::Ref<const Eigen::VectorXd>& q_measured, const Eigen::Ref<const Eigen::VectorXd>& q_estimate,
                     const Eigen::Ref<const Eigen::VectorXd>& v_estimate) noexcept {
  if (q_measured.size() != n_ || q_estimate.size() != n_ || v_estimate.size() != n_ || !q_measured.allFinite() ||
      !q_estimate.allFinite() || !v_estimate.allFinite())
    return false;
  for (int i = 0; i < n_; ++i) y_previous_[i] = q_measured(i);
  q_hat_ = q_estimate;
  v_hat_ = v_estimate;
  last_instant_ = -1;
  started_ = true;
  return true;
}

bool Observer::reset(const Eigen::Ref<const Eigen::VectorXd>& q_measured) noexcept {
  if (q_measured.size() != n_) return false;
  saturated_.setZero();
  return reset(q_measured, q_measured, saturated_);
}

template <int N>
void Observer::freeze(double fraction, Instant& instant) noexcept {
  for (int i = 0; i < n_; ++i) {
    // fraction 1 exactly: the next update starts from this instant
    instant.y[i] = fraction == 1.0 ? y_current_[i] : y_previous_[i] + fraction * (y_current_[i] - y_previous_[i]);
    // The true position lies inside the limits; clamping moves the model's point towards it, never away.
    instant.y_model[i] = std::min(std::max(instant.y[i], lower_[i]), upper_[i]);
  }
  instant.dynamics.set(Eigen::Map<const Eigen::VectorXd>(instant.y_model.data(), n_));
  instant.dynamics.mass_matrix(instant.M);
  invert<N>(instant);
}

// M⁻¹ = L⁻ᵀ L⁻¹ from M = L Lᵀ. M is positive definite at every configuration (a model that is not is refused when
// it is loaded). The stages then multiply by M⁻¹: a product of independent terms, where two triangular solves
// would be chains of dependent ones.
template <int N>
void Observer::invert(Instant& instant) noexcept {
  const int n = N > 0 ? N : n_;  // a constant where the size is known: loops the compiler unrolls
  Joints2 L, Linv;  // only their lower triangles are written and read
  for (int j = 0; j < n; ++j) {
    double d = instant.M(j, j);
    for (int k = 0; k < j; ++k) d -= L[j * n + k] * L[j * n + k];
    L[j * n + j] = std::sqrt(d);
    for (int i = j + 1; i < n; ++i) {
      double x = instant.M(i, j);
      for (int k = 0; k < j; ++k) x -= L[i * n + k] * L[j * n + k];
      L[i * n + j] = x / L[j * n + j];
    }
  }
  for (int j = 0; j < n; ++j) {
    Linv[j * n + j] = 1.0 / L[j * n + j];
    for (int i = j + 1; i < n; ++i) {
      double sum = 0.0;
      for (int k = j; k < i; ++k) sum += L[i * n + k] * Linv[k * n + j];
      Linv[i * n + j] = -sum / L[i * n + i];
    }
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j) {
      double sum = 0.0;
      for (int k = i; k < n; ++k) sum += Linv[k * n + i] * Linv[k * n + j];
      instant.inverse[i * n + j] = sum;
      instant.inverse[j * n + i] = sum;
    }
}

template <int N>
void Observer::derivative(const Instant& instant, const Joints& q, const Joints& v, Joints& dq, Joints& dv) noexcept {
  const int n = N > 0 ? N : n_;
  const Eigen::VectorXd& V = gains_.velocity_bounds;
  for (int i = 0; i < n; ++i) saturated_(i) = std::min(std::max(v[i], -V(i)), V(i));
  instant.dynamics.bias_forces(saturated_, bias_);  // A(y, σ(v̂)) + g(y), one pass
  Joints force;
  for (int i = 0; i < n; ++i) {
    force[i] = Hu_[i] - bias_(i);
    for (int j = 0; j < n; ++j) force[i] -= model_.friction(i, j) * v[j];
  }
  for (int i = 0; i < n; ++i) {
    const double innovation = q[i] - instant.y[i];
    double acceleration = 0.0;
    for (int j = 0; j < n; ++j) acceleration += instant.inverse[i * n + j] * force[j];
    dv[i] = acceleration - gains_.k2 * innovation;
    dq[i] = v[i] - gains_.k1 * innovation;
  }
}

template <int N>
void Observer::step(Instant& start, Instant& end, double h) noexcept {
  const int n = N > 0 ? N : n_;
  double* q = q_hat_.data();
  double* v = v_hat_.data();
  const auto stage = [&](double weight, int k) {  // the state at q̂ + weight h k-th slope
    for (int i = 0; i < n; ++i) {
      q_stage_[i] = q[i] + weight * h * kq_[k][i];
      v_stage_[i] = v[i] + weight * h * kv_[k][i];
    }
  };
  Joints q0{}, v0{};
  std::copy(q, q + n, q0.begin());
  std::copy(v, v + n, v0.begin());
  derivative<N>(start, q0, v0, kq_[0], kv_[0]);
  stage(0.5, 0);
  derivative<N>(middle_, q_stage_, v_stage_, kq_[1], kv_[1]);
  stage(0.5, 1);
  derivative<N>(middle_, q_stage_, v_stage_, kq_[2], kv_[2]);
  stage(1.0, 2);
  derivative<N>(end, q_stage_, v_stage_, kq_[3], kv_[3]);
  for (int i = 0; i < n; ++i) {
    q[i] += (h / 6.0) * (kq_[0][i] + 2.0 * kq_[1][i] + 2.0 * kq_[2][i] + kq_[3][i]);
    v[i] += (h / 6.0) * (kv_[0][i] + 2.0 * kv_[1][i] + 2.0 * kv_[2][i] + kv_[3][i]);
  }
}

Observer::Estimate Observer::update(const Eigen::Ref<const Eigen::VectorXd>& q_measured,
                                    const Eigen::Ref<const Eigen::VectorXd>& u, double dt) noexcept {
  const int steps = substeps(dt);
  if (!started_ || q_measured.size() != n_ || u.size() != model_.input_matrix.cols() || !q_measured.allFinite() || !u.allFinite() ||
      !(dt > 0.0) || !std::isfinite(dt) || steps > max_substeps)
    return {q_hat_, v_hat_, false};
  for (int i = 0; i < n_; ++i) {
    y_current_[i] = q_measured(i);
    double force = 0.0;
    for (Eigen::Index c = 0; c < u.size(); ++c) force += model_.input_matrix(i, c) * u(c);
    Hu_[i] = force;
  }
  std::copy_n(q_hat_.data(), n_, q_before_.begin());
  std::copy_n(v_hat_.data(), n_, v_before_.begin());
  // The sizes of the planar family and of the common arms are compiled in (0: any other).
  switch (n_) {
    case 2: integrate<2>(dt, steps); break;
    case 6: integrate<6>(dt, steps); break;
    case 7: integrate<7>(dt, steps); break;
    default: integrate<0>(dt, steps); break;
  }
  if (!q_hat_.allFinite() || !v_hat_.allFinite()) {
    std::copy_n(q_before_.begin(), n_, q_hat_.data());
    std::copy_n(v_before_.begin(), n_, v_hat_.data());
    last_instant_ = -1;  // the instants hold this sample's measurement: the next update starts from y_previous_ again
    return {q_hat_, v_hat_, false};
  }
  y_previous_ = y_current_;
  return {q_hat_, v_hat_, true};
}

template <int N>
void Observer::integrate(double dt, int steps) noexcept {
  const double h = dt / steps;
  // The end of one sub-step is the start of the next, and the last update's end this one's start: swap the
  // roles, never the buffers (and never let both roles share one).
  Instant* start = last_instant_ == 1 ? &end_ : &start_;
  Instant* end = start == &start_ ? &end_ : &start_;
  if (last_instant_ < 0) freeze<N>(0.0, *start);  // else: the same measurement as the last update's end
  for (int step_index = 0; step_index < steps; ++step_index) {
    freeze<N>((step_index + 0.5) / steps, middle_);
    freeze<N>(static_cast<double>(step_index + 1) / steps, *end);
    step<N>(*start, *end, h);
    std::swap(start, end);
  }
  last_instant_ = start == &start_ ? 0 : 1;
}

}  // namespace obsgain
