// Plant and observer error simulated together, state (q, v, e_q, e_v), with Boost.Odeint's adaptive
// Dormand–Prince and dense output. The error is carried as e = exp(ρ) u with ||u|| held at 1, so that its
// relative precision survives any decay (a γ = 70 envelope falls below 1e-30 within a second); the
// certificate checks are then made in log space and there is no numerical floor.
#pragma once

#include "obsgain/model/model.hpp"
#include "obsgain/runtime/certified_observer.hpp"

#include <Eigen/Dense>

#include <optional>
#include <string>
#include <vector>

namespace obsgain {

// The deployed observer's certificate (deployment.hpp) as a simulation checks it: at every sample,
// W(e) = sqrt(eᵀPe) <= e^{-γt} W(e(0)) + level and ||e|| <= k e^{-γt} ||e(0)|| + offset.
struct SampledCertificate {
  double sample_period = 0.0;
  double latency = 0.0;            // the sample used at t_k is taken at t_k - latency (at most one period)
  Eigen::VectorXd encoder_resolution, acceleration_bounds;
  double level = 0.0, offset = 0.0;
  double position_norm = 0.0, velocity_norm = 0.0;  // the ultimate bounds
};

// What is being validated: the observer (gains, rate, envelope constant k, Lyapunov matrix P: V(t) <= V(0) e^{-2γt})
// and, when it runs sampled and quantised (the Observer class), the offsets its envelopes gain.
struct ObserverCertificate {
  CertifiedObserver observer;
  std::optional<SampledCertificate> sampled;
};

// A smooth reference q_r(t)_i = centre_i + Σ_j amplitude(i, j) sin(frequency(i, j) t + phase(i, j)).
struct TrackingReference {
  Eigen::VectorXd centre;
  Eigen::MatrixXd amplitude, frequency, phase;
  double stiffness = 400.0, damping = 40.0;  // Kp = stiffness I, Kd = damping I (critically damped, 20 rad/s)
  bool active() const { return centre.size() > 0; }
  void evaluate(double t, Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v, Eigen::Ref<Eigen::VectorXd> a) const;
};

// What drives the plant. Open loop: u(t)_c = Σ_j amplitude(c, j) sin(frequency(c, j) t + phase(c, j)), one row
// per input channel. With an active reference (fully actuated arms, H invertible): the computed-torque law
// H u = M(q) a_c + A(q, v) + F v + g(q), a_c = a_r + Kd (v_r - v) + Kp (q_r - q), built from the model itself,
// so that the plant moves with q'' = a_c.
// Either way the observer error does not depend on u, which the observer knows.
struct InputSignal {
  Eigen::MatrixXd amplitude, frequency, phase;
  TrackingReference reference;
  void evaluate(double t, Eigen::Ref<Eigen::VectorXd> u) const;
};

struct SimulationOptions {
  double horizon = 1.0;
  double rtol = 1e-8;
  double atol = 1e-10;
  double grid_step = 1e-3;  // dense-output checks between accepted steps
  // A ratio to a bound above 1 + violation_tolerance is a violation; below, integration error. At the
  // default tolerances a saturated trial's error is accurate to ~3e-5 relative (tests/test_simulation.cpp).
  double violation_tolerance = 1e-4;
};

struct TrialInitialState {
  Eigen::VectorXd q, v;      // plant
  Eigen::VectorXd e_q, e_v;  // observer error q̂(0) - q(0), v̂(0) - v(0)
};

struct TrajectorySample {
  double t;
  Eigen::VectorXd q, v, e_q, e_v;
  double error_norm, envelope;
};

struct TrialResult {
  bool left_velocity_box = false;    // the theorem's assumption failed: the trial proves nothing
  double max_velocity_ratio = 0.0;   // max_t max_i |v_i(t)| / V_i
  double max_acceleration_ratio = 0.0;  // sampled: max_t max_i |q''_i(t)| / A_i (above 1: assumption failed too)
  double final_velocity_error = 0.0;    // sampled: max ||v̂ - v|| over the last fifth of the horizon
  double worst_envelope_ratio = 0.0; // max_t ||e(t)|| / (k ||e(0)|| e^{-γt})
  double worst_lyapunov_ratio = 0.0; // max_t V(e(t)) / (V(e(0)) e^{-2γt})
  // -slope of log ||e(t)|| (least squares) over the horizon; sampled, over the samples where the error is above twice
  // the certified floor, and NaN when those do not span a tenfold decay (nothing to fit: the error started near it).
  double fitted_rate = 0.0;
  double final_log_error_ratio = 0.0;  // log(||e(T)|| / ||e(0)||)
  int steps = 0;
};

// With certificate.sampled: the continuous plant (Odeint, input held between samples: the open-loop signal's
// value at the sample, or the computed torque from the sampled state) and the Observer class updated at every
// sample with the quantised position, checked there against the sampled certificate's envelopes.
// Integrates one trial. Stops early when the plant leaves the velocity box. Thread-safe; appends the
// dense-grid samples to trajectory when given.
TrialResult simulate_trial(const Model& model, const ObserverCertificate& certificate, const TrialInitialState& initial,
                           const InputSignal& input, const SimulationOptions& options,
                           std::vector<TrajectorySample>* trajectory = nullptr);

}  // namespace obsgain
