#include "obsgain/simulation.hpp"

#include "obsgain/observer.hpp"

#include <boost/numeric/odeint.hpp>

#include <cmath>
#include <limits>

namespace obsgain {

void InputSignal::evaluate(double t, Eigen::Ref<Eigen::VectorXd> u) const {
  for (Eigen::Index c = 0; c < amplitude.rows(); ++c) {
    double sum = 0.0;
    for (Eigen::Index j = 0; j < amplitude.cols(); ++j) sum += amplitude(c, j) * std::sin(frequency(c, j) * t + phase(c, j));
    u(c) = sum;
  }
}

void TrackingReference::evaluate(double t, Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v,
                                 Eigen::Ref<Eigen::VectorXd> a) const {
  for (Eigen::Index i = 0; i < centre.size(); ++i) {
    q(i) = centre(i);
    v(i) = 0.0;
    a(i) = 0.0;
    for (Eigen::Index j = 0; j < amplitude.cols(); ++j) {
      const double w = frequency(i, j), angle = w * t + phase(i, j);
      q(i) += amplitude(i, j) * std::sin(angle);
      v(i) += amplitude(i, j) * w * std::cos(angle);
      a(i) -= amplitude(i, j) * w * w * std::sin(angle);
    }
  }
}

namespace {

using State = std::vector<double>;

// Right-hand side of (q, v, u_q, u_v, ρ) with e = exp(ρ) (u_q, u_v). Dim is the joint count when known at
// compile time (2 for the planar two-link family), else Eigen::Dynamic. Owns its work buffers, so that
// evaluating it allocates nothing after construction.
template <int Dim>
class ErrorSystem {
  using Vector = Eigen::Matrix<double, Dim, 1>;
  using Matrix = Eigen::Matrix<double, Dim, Dim>;
  using ConstVectorMap = Eigen::Map<const Vector>;
  using VectorMap = Eigen::Map<Vector>;

 public:
  ErrorSystem(const Model& model, const ObserverCertificate& c, const Eigen::VectorXd& V, const InputSignal& input)
      : model_(model), c_(c), V_(V), input_(input), n_(model.dof()), M_(n_, n_), llt_(n_), F_(model.friction),
        H_(model.input_matrix), u_(model.input_matrix.cols()), rhs_(n_), a_(n_), g_(n_), delta_(n_), sum_(n_), dA_(n_),
        q_r_(n_), v_r_(n_), a_r_(n_) {}

  void operator()(const State& x, State& dxdt, double t) {
    const int n = n_;
    const ConstVectorMap q(x.data(), n), v(x.data() + n, n), uq(x.data() + 2 * n, n), uv(x.data() + 3 * n, n);
    const double rho = x[4 * n];
    VectorMap dq(dxdt.data(), n), dv(dxdt.data() + n, n), duq(dxdt.data() + 2 * n, n), duv(dxdt.data() + 3 * n, n);

    model_.dynamics->mass_matrix(q, M_);
    llt_.compute(M_);
    dq = v;
    if (input_.reference.active()) {
      // The computed torque is built from this same model, H u = M a_c + A + F v + g, so the plant's
      // M q'' = H u - A - F v - g is q'' = a_c exactly: no need to form the torque only to cancel it.
      input_.reference.evaluate(t, q_r_, v_r_, a_r_);
      dv = a_r_ + input_.reference.damping * (v_r_ - v) + input_.reference.stiffness * (q_r_ - q);
    } else {
      model_.dynamics->coriolis(q, v, a_);
      model_.dynamics->gravity(q, g_);
      input_.evaluate(t, u_);
      rhs_.noalias() = H_ * u_;
      rhs_ -= a_ + g_;
      rhs_.noalias() -= F_ * v;
      llt_.solveInPlace(rhs_);
      dv = rhs_;
    }

    // The error equation uses A(q, σ(v + e_v)) - A(q, σ(v)): the plant's A(q, v) while |v| <= V (the paper's
    // reduction); a trial whose plant leaves the box is stopped and reported as an assumption violation.
    // With w = σ(v + e_v), y = σ(v): e^{-ρ}(A(w) - A(y)) = δ̃ᵀ N_i (w + y), δ̃ = e^{-ρ}(w - y). σ is 1-Lipschitz,
    // so |δ̃_i| <= |u_v_i| at every scale (also in the trial stages of over-long steps); where nothing
    // saturates, δ̃_i = u_v_i exactly: no cancellation however small the error.
    const double scale = std::exp(rho);
    for (int i = 0; i < n; ++i) {
      const double s = v(i) + scale * uv(i);
      const double w = std::clamp(s, -V_(i), V_(i));
      const double y = std::clamp(v(i), -V_(i), V_(i));
      if (std::abs(s) <= V_(i) && std::abs(v(i)) <= V_(i)) {
        delta_(i) = uv(i);
      } else if (scale > 1e-300) {
        delta_(i) = (w - y) / scale;
      } else {
        delta_(i) = std::abs(v(i)) < V_(i) ? uv(i) : 0.0;  // the derivative of σ at v
      }
      sum_(i) = w + y;
    }
    model_.dynamics->coriolis_bilinear(q, delta_, sum_, dA_);
    dA_.noalias() += F_ * uv;
    llt_.solveInPlace(dA_);
    duq = -c_.k1 * uq + uv;
    duv = -c_.k2 * uq - dA_;
    // ρ' absorbs the growth of u so that ||u|| stays 1 (any choice is exact; this one keeps u well scaled).
    const double growth = (uq.dot(duq) + uv.dot(duv)) / (uq.squaredNorm() + uv.squaredNorm());
    duq -= growth * uq;
    duv -= growth * uv;
    dxdt[4 * n] = growth;
  }

 private:
  const Model& model_;
  const ObserverCertificate& c_;
  const Eigen::VectorXd& V_;
  const InputSignal& input_;
  int n_;
  Matrix M_;
  Eigen::LLT<Matrix> llt_;
  Matrix F_;
  Eigen::Matrix<double, Dim, Eigen::Dynamic> H_;
  Eigen::VectorXd u_;
  Vector rhs_, a_, g_, delta_, sum_, dA_, q_r_, v_r_, a_r_;
};

// The per-point checks, in log space: log ||e|| = ρ + log ||u||.
class TrialMonitor {
 public:
  TrialMonitor(const ObserverCertificate& c, const Eigen::VectorXd& V, int n, const State& x0)
      : c_(c), V_(V), n_(n) {
    log_e0_ = log_error_norm(x0);
    log_V0_ = log_lyapunov(x0);
  }

  // Returns false once the plant has left the velocity box.
  bool check(double t, const State& x, TrialResult& r) {
    const Eigen::Map<const Eigen::VectorXd> v(x.data() + n_, n_);
    const double velocity_ratio = (v.array().abs() / V_.array()).maxCoeff();
    r.max_velocity_ratio = std::max(r.max_velocity_ratio, velocity_ratio);
    if (velocity_ratio > 1.0) {
      r.left_velocity_box = true;
      return false;
    }
    const double log_e = log_error_norm(x);
    r.worst_envelope_ratio = std::max(r.worst_envelope_ratio, std::exp(log_e - log_e0_ - std::log(c_.k) + c_.gamma * t));
    r.worst_lyapunov_ratio = std::max(r.worst_lyapunov_ratio, std::exp(log_lyapunov(x) - log_V0_ + 2.0 * c_.gamma * t));
    // Least-squares fit of log ||e(t)/e(0)|| = -rate t + b.
    const double y = log_e - log_e0_;
    ++count_;
    st_ += t;
    stt_ += t * t;
    sy_ += y;
    sty_ += t * y;
    r.final_log_error_ratio = y;
    return true;
  }

  double fitted_rate() const {
    const double denominator = count_ * stt_ - st_ * st_;
    return denominator > 0.0 ? -(count_ * sty_ - st_ * sy_) / denominator : 0.0;
  }

  double log_error_norm(const State& x) const {
    double sum = 0.0;
    for (int i = 2 * n_; i < 4 * n_; ++i) sum += x[i] * x[i];
    return x[4 * n_] + 0.5 * std::log(sum);
  }

 private:
  double log_lyapunov(const State& x) const {
    double value = 0.0;
    for (int i = 0; i < n_; ++i) {
      const double eq = x[2 * n_ + i], ev = x[3 * n_ + i];
      value += c_.P(0, 0) * eq * eq + 2.0 * c_.P(0, 1) * eq * ev + c_.P(1, 1) * ev * ev;
    }
    return 2.0 * x[4 * n_] + std::log(value);
  }

  const ObserverCertificate& c_;
  const Eigen::VectorXd& V_;
  int n_;
  double log_e0_ = 0.0, log_V0_ = 0.0;
  double count_ = 0.0, st_ = 0.0, stt_ = 0.0, sy_ = 0.0, sty_ = 0.0;
};

template <int Dim>
TrialResult integrate_trial(const Model& model, const ObserverCertificate& certificate,
                            const Eigen::VectorXd& velocity_bounds, const TrialInitialState& initial,
                            const InputSignal& input, const SimulationOptions& options,
                            std::vector<TrajectorySample>* trajectory) {
  namespace odeint = boost::numeric::odeint;
  const int n = model.dof();
  const double e0 = std::sqrt(initial.e_q.squaredNorm() + initial.e_v.squaredNorm());
  if (!(e0 > 0.0) || !std::isfinite(e0)) throw InputError("a trial needs a non-zero, finite initial error");

  State x(4 * n + 1);
  Eigen::Map<Eigen::VectorXd>(x.data(), n) = initial.q;
  Eigen::Map<Eigen::VectorXd>(x.data() + n, n) = initial.v;
  Eigen::Map<Eigen::VectorXd>(x.data() + 2 * n, n) = initial.e_q / e0;
  Eigen::Map<Eigen::VectorXd>(x.data() + 3 * n, n) = initial.e_v / e0;
  x[4 * n] = std::log(e0);

  ErrorSystem<Dim> system(model, certificate, velocity_bounds, input);
  TrialMonitor monitor(certificate, velocity_bounds, n, x);
  TrialResult result;
  State sample(x.size());
  const auto record = [&](double t, const State& state) {
    const bool inside = monitor.check(t, state, result);
    if (trajectory) {
      const double scale = std::exp(state[4 * n]);
      TrajectorySample s{t,
                         Eigen::Map<const Eigen::VectorXd>(state.data(), n),
                         Eigen::Map<const Eigen::VectorXd>(state.data() + n, n),
                         scale * Eigen::Map<const Eigen::VectorXd>(state.data() + 2 * n, n),
                         scale * Eigen::Map<const Eigen::VectorXd>(state.data() + 3 * n, n),
                         std::exp(monitor.log_error_norm(state)),
                         certificate.k * e0 * std::exp(-certificate.gamma * t)};
      trajectory->push_back(std::move(s));
    }
    return inside;
  };

  auto stepper = odeint::make_dense_output(options.atol, options.rtol, odeint::runge_kutta_dopri5<State>());
  stepper.initialize(x, 0.0, std::min(1e-5, options.horizon));
  if (!record(0.0, x)) return result;
  double next_grid = options.grid_step;
  while (stepper.current_time() < options.horizon) {
    stepper.do_step(std::ref(system));
    ++result.steps;
    const double t = std::min(stepper.current_time(), options.horizon);
    for (; next_grid < t; next_grid += options.grid_step) {
      stepper.calc_state(next_grid, sample);
      if (!record(next_grid, sample)) return result;
    }
    if (stepper.current_time() <= options.horizon) {
      if (!record(t, stepper.current_state())) return result;
    } else {
      stepper.calc_state(options.horizon, sample);
      if (!record(options.horizon, sample)) return result;
    }
  }
  result.fitted_rate = monitor.fitted_rate();
  return result;
}

// The plant alone, M q'' = H u - A - F v - g with u held, for the sampled trials.
class Plant {
 public:
  Plant(const Model& model, const Eigen::VectorXd& u)
      : model_(model), u_(u), n_(model.dof()), M_(n_, n_), llt_(n_), rhs_(n_), a_(n_), g_(n_) {}

  void operator()(const State& x, State& dxdt, double) {
    const Eigen::Map<const Eigen::VectorXd> q(x.data(), n_), v(x.data() + n_, n_);
    Eigen::Map<Eigen::VectorXd>(dxdt.data(), n_) = v;
    acceleration(q, v, Eigen::Map<Eigen::VectorXd>(dxdt.data() + n_, n_));
  }

  void acceleration(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                    Eigen::Ref<Eigen::VectorXd> a) {
    model_.dynamics->mass_matrix(q, M_);
    llt_.compute(M_);
    model_.dynamics->coriolis(q, v, a_);
    model_.dynamics->gravity(q, g_);
    rhs_.noalias() = model_.input_matrix * u_;
    rhs_ -= a_ + g_;
    rhs_.noalias() -= model_.friction * v;
    a = llt_.solve(rhs_);
  }

 private:
  const Model& model_;
  const Eigen::VectorXd& u_;
  int n_;
  Eigen::MatrixXd M_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::VectorXd rhs_, a_, g_;
};

// The input held over the next sample interval: the open-loop signal at t, or the computed torque of the
// reference from the state sampled at t (H invertible: fully actuated).
void held_input(const Model& model, const InputSignal& input, double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                Eigen::VectorXd& u) {
  if (!input.reference.active()) {
    input.evaluate(t, u);
    return;
  }
  const int n = model.dof();
  Eigen::VectorXd q_r(n), v_r(n), a_r(n), A(n), g(n);
  Eigen::MatrixXd M(n, n);
  input.reference.evaluate(t, q_r, v_r, a_r);
  const Eigen::VectorXd a_c = a_r + input.reference.damping * (v_r - v) + input.reference.stiffness * (q_r - q);
  model.dynamics->mass_matrix(q, M);
  model.dynamics->coriolis(q, v, A);
  model.dynamics->gravity(q, g);
  u = model.input_matrix.fullPivLu().solve(M * a_c + A + model.friction * v + g);
}

TrialResult sampled_trial(const Model& model, const ObserverCertificate& c, const Eigen::VectorXd& V,
                          const TrialInitialState& initial, const InputSignal& input, const SimulationOptions& options,
                          std::vector<TrajectorySample>* trajectory) {
  namespace odeint = boost::numeric::odeint;
  const SampledCertificate& sampled = *c.sampled;
  const int n = model.dof();
  const double T = sampled.sample_period;
  const Eigen::VectorXd& delta = sampled.encoder_resolution;
  const auto quantised = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
    return (q.array() / delta.array()).round() * delta.array();
  };
  const auto W = [&](const Eigen::VectorXd& eq, const Eigen::VectorXd& ev) {
    return std::sqrt(c.P(0, 0) * eq.squaredNorm() + 2.0 * c.P(0, 1) * eq.dot(ev) + c.P(1, 1) * ev.squaredNorm());
  };
  Observer observer(model, ObserverGains{c.k1, c.k2, sampled.L, V, 0});
  Eigen::VectorXd q = initial.q, v = initial.v, u(model.input_matrix.cols());
  observer.reset(quantised(q), q + initial.e_q, v + initial.e_v);
  const double e0 = std::sqrt(initial.e_q.squaredNorm() + initial.e_v.squaredNorm());
  const double W0 = W(initial.e_q, initial.e_v);
  Plant plant(model, u);
  State x(2 * n);
  Eigen::VectorXd a(n);
  TrialResult result;
  // Least-squares fit of log ||e|| while the error is well above the floor.
  double count = 0.0, st = 0.0, stt = 0.0, sy = 0.0, sty = 0.0;
  const auto inside = [&](const Eigen::VectorXd& qq, const Eigen::VectorXd& vv) {
    plant.acceleration(qq, vv, a);
    const double velocity_ratio = (vv.array().abs() / V.array()).maxCoeff();
    const double acceleration_ratio = (a.array().abs() / sampled.acceleration_bounds.array()).maxCoeff();
    result.max_velocity_ratio = std::max(result.max_velocity_ratio, velocity_ratio);
    result.max_acceleration_ratio = std::max(result.max_acceleration_ratio, acceleration_ratio);
    if (velocity_ratio > 1.0 || acceleration_ratio > 1.0) result.left_velocity_box = true;
    return !result.left_velocity_box;
  };
  const int samples = static_cast<int>(std::ceil(options.horizon / T));
  for (int k = 0; k <= samples; ++k) {
    const double t = k * T;
    const Eigen::VectorXd eq = observer.position() - q, ev = observer.velocity() - v;
    const double e = std::sqrt(eq.squaredNorm() + ev.squaredNorm());
    const double decay = std::exp(-c.gamma * t);
    result.worst_envelope_ratio = std::max(result.worst_envelope_ratio, e / (c.k * e0 * decay + sampled.offset));
    result.worst_lyapunov_ratio = std::max(result.worst_lyapunov_ratio, W(eq, ev) / (W0 * decay + sampled.level));
    if (k >= 0.8 * samples) result.final_velocity_error = std::max(result.final_velocity_error, ev.norm());
    if (e > 2.0 * sampled.offset) {
      const double y = std::log(e / e0);
      count += 1.0, st += t, stt += t * t, sy += y, sty += t * y;
      result.final_log_error_ratio = y;
    }
    if (trajectory) trajectory->push_back({t, q, v, eq, ev, e, c.k * e0 * decay + sampled.offset});
    if (k == samples) break;
    held_input(model, input, t, q, v, u);
    x.assign(q.data(), q.data() + n);
    x.insert(x.end(), v.data(), v.data() + n);
    bool ok = inside(q, v);
    const auto integrate = [&](double from, double until) {
      if (until <= from) return;
      odeint::integrate_adaptive(
          odeint::make_controlled(options.atol, options.rtol, odeint::runge_kutta_dopri5<State>()), std::ref(plant), x,
          from, until, T / 4.0, [&](const State& state, double) {
            ok = inside(Eigen::Map<const Eigen::VectorXd>(state.data(), n),
                        Eigen::Map<const Eigen::VectorXd>(state.data() + n, n)) && ok;
            ++result.steps;
          });
    };
    // The encoder is read latency seconds before the update that uses it.
    const double read_at = t + T - sampled.latency;
    integrate(t, read_at);
    const Eigen::VectorXd measured = Eigen::Map<const Eigen::VectorXd>(x.data(), n);
    integrate(read_at, t + T);
    if (!ok) return result;
    q = Eigen::Map<const Eigen::VectorXd>(x.data(), n);
    v = Eigen::Map<const Eigen::VectorXd>(x.data() + n, n);
    observer.update(quantised(measured), u, T);
  }
  const double denominator = count * stt - st * st;
  // A trial whose error starts near the floor has no decay to fit.
  result.fitted_rate = count >= 3.0 && denominator > 0.0 ? -(count * sty - st * sy) / denominator
                                                         : std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace

TrialResult simulate_trial(const Model& model, const ObserverCertificate& certificate,
                           const Eigen::VectorXd& velocity_bounds, const TrialInitialState& initial,
                           const InputSignal& input, const SimulationOptions& options,
                           std::vector<TrajectorySample>* trajectory) {
  if (certificate.sampled) return sampled_trial(model, certificate, velocity_bounds, initial, input, options, trajectory);
  if (model.dof() == 2)
    return integrate_trial<2>(model, certificate, velocity_bounds, initial, input, options, trajectory);
  return integrate_trial<Eigen::Dynamic>(model, certificate, velocity_bounds, initial, input, options, trajectory);
}

}  // namespace obsgain
