// Validation of a design by simulation: many trials from randomised initial errors (and plant states and
// inputs), each checked against the certificate's envelope and Lyapunov level, on all cores.
#pragma once

#include "obsgain/deployment/deployment.hpp"
#include "obsgain/validation/simulation.hpp"

#include <functional>
#include <string>
#include <vector>

namespace obsgain {

enum class Scenario { paper, random };
enum class InitialErrors { practical, global, both };

struct MonteCarloOptions {
  int trials = 1000;
  std::uint64_t seed = 1;
  int threads = 0;  // 0: all cores
  Scenario scenario = Scenario::random;  // fully actuated arms: computed-torque tracking; else open-loop inputs
  InitialErrors initial_errors = InitialErrors::both;
  SimulationOptions simulation;
  double practical_position_error = 0.05;  // ||q̂(0) - q(0)|| bound of the practical set [rad]
  double global_error_scale = 10.0;        // global set: |e_q| <= this [rad], |v̂(0)| <= this × V
  int input_attempts = 4;                  // random scenario: input and initial perturbation quartered after each exit from V̄
  // Integration steps the whole run may take, estimated before it starts (estimated_steps): gains in the tens of
  // thousands make the error dynamics stiff, and the run would take hours. Past it no trial is simulated and the
  // report says what would help (about 10 minutes of a seven-joint arm on two cores).
  double step_budget = 5e7;
  // Told how many trials are done, about five times a second (from the calling thread). An exception it throws
  // stops the run within the trials under way, and leaves run_monte_carlo.
  std::function<void(int done, int total, double seconds)> progress;
};

struct TrialRecord {
  int index = 0;
  bool global_error = false;  // from the global set (else the practical one)
  double input_scale = 1.0;   // the amplitude factor of the attempt that was kept
  double initial_error = 0.0;
  TrialResult result;
  bool envelope_violated = false, lyapunov_violated = false;
};

// Over the trials inside the box whose error decayed enough to fit a rate to (simulation.hpp, fitted_rate).
struct DecayRates {
  double min = 0.0, median = 0.0, max = 0.0;
  int trials = 0;
};

struct MonteCarloReport {
  int trials = 0;
  int passed = 0;  // inside the box, no violation
  int envelope_violations = 0;
  int lyapunov_violations = 0;
  int assumption_violations = 0;  // left the velocity box: proves nothing either way
  double worst_envelope_ratio = 0.0;
  double worst_lyapunov_ratio = 0.0;
  double worst_final_velocity_error = 0.0;  // sampled: max over trials in the boxes of their final ||v̂ - v||
  double max_acceleration_ratio = 0.0;      // sampled: max over all trials of max |q''_i| / A_i
  DecayRates decay_rate;  // fitted, over trials that stayed in the box
  ObserverCertificate certificate;
  std::uint64_t seed = 0;
  int threads = 0;
  double wall_seconds = 0.0;
  std::string scenario, initial_errors;
  SimulationOptions simulation;
  std::vector<TrialRecord> records;
  // Why no trial was simulated (the run's estimated steps exceed the budget), and what would help; empty when they ran.
  std::string not_run;

  bool certificate_held() const { return not_run.empty() && envelope_violations == 0 && lyapunov_violations == 0; }
};

// Throws InputError naming the bad value: trials >= 1, threads in [0, 256], horizon in [1e-6, 1e3] s, rtol in
// [1e-13, 1e-4], atol in [1e-20, 1e-6], step budget >= 1.
void validate_monte_carlo_options(const MonteCarloOptions& options);

// The certificate a design delivers: its selected observer, and the sampled offsets when it is deployed. InputError
// when the design certifies no rate (there is no envelope to validate).
ObserverCertificate observer_certificate(const DeployedDesign& design);

// The initial state and input of one trial: a pure function of (seed, index, attempt).
struct TrialSetup {
  TrialInitialState initial;
  InputSignal input;
  bool global_error = false;
};
TrialSetup make_trial(const Model& model, const Eigen::VectorXd& velocity_bounds, const MonteCarloOptions& options,
                      int index, double input_scale);

// One trial as the statistics count it: the random scenario retries with quartered inputs while a trial leaves the
// velocity box, and keeps the last attempt.
TrialRecord run_trial(const Model& model, const ObserverCertificate& certificate, const MonteCarloOptions& options,
                      int index);

// The dense-grid time series of a counted trial (trial 0 of the paper scenario is the paper's Fig. 2).
std::vector<TrajectorySample> trial_trajectory(const Model& model, const ObserverCertificate& certificate,
                                               const MonteCarloOptions& options, const TrialRecord& record);

// The integration steps a run is expected to take. Continuous observer: about kStepsPerStiffness per unit of ω t per
// trial, ω the fastest mode of the linear error dynamics s² + k1 s + k2 (per joint), which limits an explicit
// Runge–Kutta method's step (measured at the default tolerances on the Pendubot, θ = 200 to 20,000, 60 trials each:
// 30 to 58 steps per unit on average, 10 to 83 for single trials; a six-joint arm alike). Sampled: the plant alone,
// counted as 4 steps per sample period (measured: 3, the Pendubot at 1 kHz, 20 trials).
inline constexpr double kStepsPerStiffness = 60.0;
double estimated_steps(const ObserverCertificate& certificate, const MonteCarloOptions& options);

// Past options.step_budget no trial runs: the report's not_run says why and what would help.
MonteCarloReport run_monte_carlo(const Model& model, const ObserverCertificate& certificate,
                                 const MonteCarloOptions& options);

}  // namespace obsgain
