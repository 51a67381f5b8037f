#include "obsgain/validation/simulation.hpp"

#include "obsgain/model/dynamics.hpp"
#include "obsgain/runtime/observer.hpp"

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

// The computed-torque law's acceleration a_c = a_r + Kd (v_r - v) + Kp (q_r - q): under computed torque built from
// the model itself, the plant moves with q'' = a_c exactly.
class ReferenceTracking {
 public:
  ReferenceTracking(const TrackingReference& reference, int n) : reference_(reference), q_r_(n), v_r_(n), a_r_(n) {}
  void acceleration(double t, const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                    Eigen::Ref<Eigen::VectorXd> a) {
    reference_.evaluate(t, q_r_, v_r_, a_r_);
    a = a_r_ + reference_.damping * (v_r_ - v) + reference_.stiffness * (q_r_ - q);
  }

 private:
  const TrackingReference& reference_;
  Eigen::VectorXd q_r_, v_r_, a_r_;
};

// Least-squares slope of log ||e(t) / e(0)| against t.
class DecayFit {
 public:
  void add(double t, double log_ratio) {
    count_ += 1.0, st_ += t, stt_ += t * t, sy_ += log_ratio, sty_ += t * log_ratio;
    lowest_ = std::min(lowest_, log_ratio);
    highest_ = std::max(highest_, log_ratio);
  }
  double rate() const {
    const double denominator = count_ * stt_ - st_ * st_;
    return count_ >= 2.0 && denominator > 0.0 ? -(count_ * sty_ - st_ * sy_) / denominator : 0.0;
  }
  // The points span a decay of at least `factor`: a slope over less is the noise of the floor.
  bool spans(double factor) const { return count_ >= 3.0 && highest_ - lowest_ >= std::log(factor); }

 private:
  double count_ = 0.0, st_ = 0.0, stt_ = 0.0, sy_ = 0.0, sty_ = 0.0;
  double lowest_ = std::numeric_limits<double>::infinity(), highest_ = -std::numeric_limits<double>::infinity();
};

// V(e) = eᵀ P e for e = (e_q, e_v).
double lyapunov_value(const Eigen::MatrixXd& P, const Eigen::Ref<const Eigen::VectorXd>& eq,
                      const Eigen::Ref<const Eigen::VectorXd>& ev) {
  const auto n = eq.size();
  return eq.dot(P.topLeftCorner(n, n) * eq) + 2.0 * eq.dot(P.topRightCorner(n, n) * ev) + ev.dot(P.bottomRightCorner(n, n) * ev);
}

// Right-hand side of (q, v, u_q, u_v, ρ) with e = exp(ρ) (u_q, u_v). Owns its work buffers, so that evaluating it
// allocates nothing after construction.
class ErrorSystem {
 public:
  ErrorSystem(const Model& model, const CertifiedObserver& c, const InputSignal& input)
      : model_(model), c_(c), input_(input), n_(model.dof()), at_(model), work_(n_), tracking_(input.reference, n_),
        u_(model.input_matrix.cols()), tau_(n_), delta_(n_), sum_(n_), dA_(n_) {}

  void operator()(const State& x, State& dxdt, double t) {
    const int n = n_;
    const Eigen::Map<const Eigen::VectorXd> q(x.data(), n), v(x.data() + n, n), uq(x.data() + 2 * n, n),
        uv(x.data() + 3 * n, n);
    Eigen::Map<Eigen::VectorXd> dq(dxdt.data(), n), dv(dxdt.data() + n, n), duq(dxdt.data() + 2 * n, n),
        duv(dxdt.data() + 3 * n, n);
    at_.set(q);
    at_.mass_matrix(work_.M);
    work_.llt.compute(work_.M);
    dq = v;
    if (input_.reference.active()) {
      tracking_.acceleration(t, q, v, dv);
    } else {
      input_.evaluate(t, u_);
      tau_.noalias() = model_.input_matrix * u_;
      plant_acceleration(model_, at_, work_.llt, v, tau_, dv, work_);
    }
    error_derivative(x[4 * n], v, uq, uv, duq, duv);
    // ρ' absorbs the growth of u so that ||u|| stays 1 (any choice is exact; this one keeps u well scaled).
    const double growth = (uq.dot(duq) + uv.dot(duv)) / (uq.squaredNorm() + uv.squaredNorm());
    duq -= growth * uq;
    duv -= growth * uv;
    dxdt[4 * n] = growth;
  }

 private:
  // The error equation uses A(q, σ(v + e_v)) - A(q, σ(v)): the plant's A(q, v) while |v| <= V (the paper's
  // reduction); a trial whose plant leaves the box is stopped and reported as an assumption violation.
  // With w = σ(v + e_v), y = σ(v): e^{-ρ}(A(w) - A(y)) = δ̃ᵀ N_i (w + y), δ̃ = e^{-ρ}(w - y). σ is 1-Lipschitz,
  // so |δ̃_i| <= |u_v_i| at every scale (also in the trial stages of over-long steps); where nothing saturates,
  // δ̃_i = u_v_i exactly: no cancellation however small the error.
  void error_derivative(double rho, const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& uq,
                        const Eigen::Ref<const Eigen::VectorXd>& uv, Eigen::Ref<Eigen::VectorXd> duq,
                        Eigen::Ref<Eigen::VectorXd> duv) {
    const Eigen::VectorXd& V = c_.velocity_bounds;
    const double scale = std::exp(rho);
    for (int i = 0; i < n_; ++i) {
      const double s = v(i) + scale * uv(i);
      const double w = std::clamp(s, -V(i), V(i));
      const double y = std::clamp(v(i), -V(i), V(i));
      if (std::abs(s) <= V(i) && std::abs(v(i)) <= V(i)) {
        delta_(i) = uv(i);
      } else if (scale > 1e-300) {
        delta_(i) = (w - y) / scale;
      } else {
        delta_(i) = std::abs(v(i)) < V(i) ? uv(i) : 0.0;  // the derivative of σ at v
      }
      sum_(i) = w + y;
    }
    at_.coriolis_bilinear(delta_, sum_, dA_);
    dA_.noalias() += model_.friction * uv;
    work_.llt.solveInPlace(dA_);
    duq = -c_.k1 * uq + uv;
    duv = -c_.k2 * uq - dA_;
  }

  const Model& model_;
  const CertifiedObserver& c_;
  const InputSignal& input_;
  int n_;
  ConfigurationDynamics at_;
  DynamicsWorkspace work_;
  ReferenceTracking tracking_;
  Eigen::VectorXd u_, tau_, delta_, sum_, dA_;
};

// The per-point checks, in log space: log ||e|| = ρ + log ||u||.
class TrialMonitor {
 public:
  TrialMonitor(const CertifiedObserver& c, int n, const State& x0) : c_(c), n_(n) {
    log_e0_ = log_error_norm(x0);
    log_V0_ = log_lyapunov(x0);
  }

  // Returns false once the plant has left the velocity box.
  bool check(double t, const State& x, TrialResult& r) {
    const Eigen::Map<const Eigen::VectorXd> v(x.data() + n_, n_);
    const double velocity_ratio = (v.array().abs() / c_.velocity_bounds.array()).maxCoeff();
    r.max_velocity_ratio = std::max(r.max_velocity_ratio, velocity_ratio);
    if (velocity_ratio > 1.0) {
      r.left_velocity_box = true;
      return false;
    }
    const double log_e = log_error_norm(x);
    r.worst_envelope_ratio = std::max(r.worst_envelope_ratio, std::exp(log_e - log_e0_ - std::log(c_.k) + c_.gamma * t));
    r.worst_lyapunov_ratio = std::max(r.worst_lyapunov_ratio, std::exp(log_lyapunov(x) - log_V0_ + 2.0 * c_.gamma * t));
    fit_.add(t, log_e - log_e0_);
    r.final_log_error_ratio = log_e - log_e0_;
    return true;
  }

  double fitted_rate() const { return fit_.rate(); }

  double log_error_norm(const State& x) const {
    double sum = 0.0;
    for (int i = 2 * n_; i < 4 * n_; ++i) sum += x[i] * x[i];
    return x[4 * n_] + 0.5 * std::log(sum);
  }

 private:
  double log_lyapunov(const State& x) const {
    const Eigen::Map<const Eigen::VectorXd> uq(x.data() + 2 * n_, n_), uv(x.data() + 3 * n_, n_);
    return 2.0 * x[4 * n_] + std::log(lyapunov_value(c_.P, uq, uv));
  }

  const CertifiedObserver& c_;
  int n_;
  double log_e0_ = 0.0, log_V0_ = 0.0;
  DecayFit fit_;
};

TrialResult continuous_trial(const Model& model, const CertifiedObserver& certificate, const TrialInitialState& initial,
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

  ErrorSystem system(model, certificate, input);
  TrialMonitor monitor(certificate, n, x);
  TrialResult result;
  State sample(x.size());
  const auto record = [&](double t, const State& state) {
    const bool inside = monitor.check(t, state, result);
    if (trajectory) {
      const double scale = std::exp(state[4 * n]);
      trajectory->push_back({t, Eigen::Map<const Eigen::VectorXd>(state.data(), n),
                             Eigen::Map<const Eigen::VectorXd>(state.data() + n, n),
                             scale * Eigen::Map<const Eigen::VectorXd>(state.data() + 2 * n, n),
                             scale * Eigen::Map<const Eigen::VectorXd>(state.data() + 3 * n, n),
                             std::exp(monitor.log_error_norm(state)), certificate.k * e0 * std::exp(-certificate.gamma * t)});
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
  Plant(const Model& model, const Eigen::VectorXd& u) : model_(model), u_(u), n_(model.dof()), work_(n_), tau_(n_) {}

  void operator()(const State& x, State& dxdt, double) {
    const Eigen::Map<const Eigen::VectorXd> q(x.data(), n_), v(x.data() + n_, n_);
    Eigen::Map<Eigen::VectorXd>(dxdt.data(), n_) = v;
    acceleration(q, v, Eigen::Map<Eigen::VectorXd>(dxdt.data() + n_, n_));
  }

  void acceleration(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                    Eigen::Ref<Eigen::VectorXd> a) {
    tau_.noalias() = model_.input_matrix * u_;
    forward_dynamics(model_, q, v, tau_, a, work_);
  }

 private:
  const Model& model_;
  const Eigen::VectorXd& u_;
  int n_;
  DynamicsWorkspace work_;
  Eigen::VectorXd tau_;
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
  ReferenceTracking tracking(input.reference, n);
  DynamicsWorkspace work(n);
  Eigen::VectorXd a_c(n), tau(n);
  tracking.acceleration(t, q, v, a_c);
  inverse_dynamics(model, q, v, a_c, tau, work);
  u = model.input_matrix.fullPivLu().solve(tau);
}

// The quantities the sampled checks follow along a trial.
struct SampledChecks {
  const ObserverCertificate& c;
  double e0, W0;
  TrialResult result;
  DecayFit fit;

  // The envelope and Lyapunov level at one sample, the final velocity error, and the decay fit above the floor.
  void at_sample(double t, const Eigen::VectorXd& eq, const Eigen::VectorXd& ev, bool final_fifth) {
    const SampledCertificate& sampled = *c.sampled;
    const double e = std::sqrt(eq.squaredNorm() + ev.squaredNorm());
    const double decay = std::exp(-c.observer.gamma * t);
    result.worst_envelope_ratio = std::max(result.worst_envelope_ratio, e / (c.observer.k * e0 * decay + sampled.offset));
    const double W = std::sqrt(lyapunov_value(c.observer.P, eq, ev));
    result.worst_lyapunov_ratio = std::max(result.worst_lyapunov_ratio, W / (W0 * decay + sampled.level));
    if (final_fifth) result.final_velocity_error = std::max(result.final_velocity_error, ev.norm());
    if (e > 2.0 * sampled.offset) {
      fit.add(t, std::log(e / e0));
      result.final_log_error_ratio = std::log(e / e0);
    }
  }
};

TrialResult sampled_trial(const Model& model, const ObserverCertificate& c, const TrialInitialState& initial,
                          const InputSignal& input, const SimulationOptions& options,
                          std::vector<TrajectorySample>* trajectory) {
  namespace odeint = boost::numeric::odeint;
  const SampledCertificate& sampled = *c.sampled;
  const Eigen::VectorXd& V = c.observer.velocity_bounds;
  const int n = model.dof();
  const double T = sampled.sample_period;
  const Eigen::VectorXd& delta = sampled.encoder_resolution;
  const auto quantised = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
    return (q.array() / delta.array()).round() * delta.array();
  };
  Observer observer(model, c.observer);
  Eigen::VectorXd q = initial.q, v = initial.v, u(model.input_matrix.cols());
  observer.reset(quantised(q), q + initial.e_q, v + initial.e_v);
  SampledChecks checks{c, std::sqrt(initial.e_q.squaredNorm() + initial.e_v.squaredNorm()),
                       std::sqrt(lyapunov_value(c.observer.P, initial.e_q, initial.e_v)), {}, {}};
  TrialResult& result = checks.result;
  Plant plant(model, u);
  State x(2 * n);
  Eigen::VectorXd a(n);
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
    checks.at_sample(t, eq, ev, k >= 0.8 * samples);
    if (trajectory)
      trajectory->push_back({t, q, v, eq, ev, std::sqrt(eq.squaredNorm() + ev.squaredNorm()),
                             c.observer.k * checks.e0 * std::exp(-c.observer.gamma * t) + sampled.offset});
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
  result.fitted_rate = checks.fit.spans(10.0) ? checks.fit.rate() : std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace

TrialResult simulate_trial(const Model& model, const ObserverCertificate& certificate, const TrialInitialState& initial,
                           const InputSignal& input, const SimulationOptions& options,
                           std::vector<TrajectorySample>* trajectory) {
  if (certificate.sampled) return sampled_trial(model, certificate, initial, input, options, trajectory);
  return continuous_trial(model, certificate.observer, initial, input, options, trajectory);
}

}  // namespace obsgain
