#include "obsgain/validation/montecarlo.hpp"

#include "obsgain/numerics/distributed.hpp"
#include "obsgain/numerics/parallel.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <numbers>
#include <random>
#include <thread>

namespace obsgain {

namespace {

// SplitMix64: decorrelates the seeds of neighbouring trials.
std::uint64_t mix(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double uniform(std::mt19937_64& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

Eigen::VectorXd uniform_box(std::mt19937_64& rng, const Eigen::VectorXd& half_width) {
  Eigen::VectorXd x(half_width.size());
  for (Eigen::Index i = 0; i < x.size(); ++i) x(i) = uniform(rng, -half_width(i), half_width(i));
  return x;
}

// H square and invertible: every joint can be driven, so a computed-torque law can track any reference.
bool fully_actuated(const Model& model) {
  const Eigen::MatrixXd& H = model.input_matrix;
  return H.rows() == H.cols() && Eigen::FullPivLU<Eigen::MatrixXd>(H).rank() == H.rows();
}

// Three sinusoids per joint, 0.5 to 4 rad/s, with Σ_j a_ij ω_ij = 0.6 V_i scale: the reference's speed stays
// inside the box, and its range inside the joint's limits.
TrackingReference random_reference(std::mt19937_64& rng, const Model& model, const Eigen::VectorXd& V, double scale) {
  const int n = model.dof(), terms = 3;
  TrackingReference r;
  r.centre.resize(n);
  r.amplitude.resize(n, terms);
  r.frequency.resize(n, terms);
  r.phase.resize(n, terms);
  for (int i = 0; i < n; ++i) {
    Eigen::Array3d weight, frequency;
    for (int j = 0; j < terms; ++j) {
      weight(j) = uniform(rng, 0.1, 1.0);
      frequency(j) = uniform(rng, 0.5, 4.0);
      r.phase(i, j) = uniform(rng, 0.0, 2.0 * std::numbers::pi);
    }
    Eigen::Array3d amplitude = 0.6 * V(i) * scale * weight / (weight.sum() * frequency);
    const JointDomain& joint = model.joints[i];
    const double room = joint.continuous ? std::numbers::pi : 0.4 * (joint.upper - joint.lower);
    if (amplitude.sum() > room) amplitude *= room / amplitude.sum();
    r.amplitude.row(i) = amplitude.matrix().transpose();
    r.frequency.row(i) = frequency.matrix().transpose();
    r.centre(i) = joint.continuous ? uniform(rng, -std::numbers::pi, std::numbers::pi)
                                   : uniform(rng, joint.lower + amplitude.sum(), joint.upper - amplitude.sum());
  }
  return r;
}

}  // namespace

ObserverCertificate observer_certificate(const DeployedDesign& design) {
  const CertificateSummary& s = design.design.selected();
  if (!s.observer.certified)
    throw InputError("the design certifies no exponential rate (gamma = " + std::to_string(s.rate) +
                     "): there is no envelope to validate");
  ObserverCertificate c{s.observer, std::nullopt};
  if (design.deployment) {
    const DeploymentCertificate& d = design.deployment->certificate;
    c.sampled = SampledCertificate{d.sample_period,       d.latency,      d.encoder_resolution, d.acceleration_bounds,
                                   d.bounds.level,        d.bounds.offset, d.bounds.position_norm,
                                   d.bounds.velocity_norm};
  }
  return c;
}

TrialSetup make_trial(const Model& model, const Eigen::VectorXd& V, const MonteCarloOptions& options, int index,
                      double input_scale) {
  const int n = model.dof();
  const auto m = model.input_matrix.cols();
  std::mt19937_64 rng(mix(options.seed ^ mix(static_cast<std::uint64_t>(index))));
  TrialSetup setup;
  // The paper's configuration: hanging at the lower equilibrium (q1 = -π/2, the other joints 0).
  Eigen::VectorXd hanging = Eigen::VectorXd::Zero(n);
  hanging(0) = -std::numbers::pi / 2.0;
  if (options.scenario == Scenario::paper) {
    // The paper's run: at rest there, u = 1.5 sin(100 t) on the first input.
    setup.initial.q = hanging;
    setup.initial.v = Eigen::VectorXd::Zero(n);
    setup.input.amplitude = Eigen::MatrixXd::Zero(m, 1);
    setup.input.amplitude(0, 0) = 1.5 * input_scale;
    setup.input.frequency = Eigen::MatrixXd::Constant(m, 1, 100.0);
    setup.input.phase = Eigen::MatrixXd::Zero(m, 1);
  } else if (fully_actuated(model)) {
    // Computed-torque tracking of a random smooth reference, started on it.
    setup.input.reference = random_reference(rng, model, V, input_scale);
    setup.initial.q.resize(n);
    setup.initial.v.resize(n);
    Eigen::VectorXd acceleration(n);
    setup.input.reference.evaluate(0.0, setup.initial.q, setup.initial.v, acceleration);
  } else {
    // Around the hanging configuration, so that gravity alone does not swing the arm out of the box;
    // the perturbation shrinks with the input on each retry.
    setup.initial.q = hanging + uniform_box(rng, Eigen::VectorXd::Constant(n, 0.5 * std::numbers::pi * input_scale));
    for (int i = 0; i < n; ++i)
      setup.initial.q(i) = std::clamp(setup.initial.q(i), model.joints[i].lower, model.joints[i].upper);
    setup.initial.v = uniform_box(rng, 0.2 * input_scale * V);
    // Three sinusoids per input: amplitudes up to 1.5 in all (the paper's), 1 to 30 rad/s, random phases.
    const int terms = 3;
    setup.input.amplitude.resize(m, terms);
    setup.input.frequency.resize(m, terms);
    setup.input.phase.resize(m, terms);
    for (Eigen::Index c = 0; c < m; ++c) {
      for (int j = 0; j < terms; ++j) {
        setup.input.amplitude(c, j) = input_scale * uniform(rng, 0.0, 1.5 / terms);
        setup.input.frequency(c, j) = uniform(rng, 1.0, 30.0);
        setup.input.phase(c, j) = uniform(rng, 0.0, 2.0 * std::numbers::pi);
      }
    }
  }
  if (options.scenario == Scenario::paper && index == 0) {
    // Trial 0 of the paper scenario is the paper's own run: observer started at (-π/2, 0, 2, 2), i.e.
    // e_q = 0, e_v = (2, 2) (the paper's Fig. 2).
    setup.initial.e_q = Eigen::VectorXd::Zero(n);
    setup.initial.e_v = Eigen::VectorXd::Constant(n, 2.0);
    return setup;
  }
  setup.global_error = options.initial_errors == InitialErrors::global ||
                       (options.initial_errors == InitialErrors::both && index % 2 == 1);
  if (setup.global_error) {
    // Far outside the practical set: the theorem is global.
    setup.initial.e_q = uniform_box(rng, Eigen::VectorXd::Constant(n, options.global_error_scale));
    setup.initial.e_v = uniform_box(rng, options.global_error_scale * V) - setup.initial.v;
  } else {
    // The paper's Remark: q̂(0) near the measured q(0), v̂(0) in the box.
    Eigen::VectorXd direction = uniform_box(rng, Eigen::VectorXd::Ones(n));
    setup.initial.e_q = direction.normalized() * uniform(rng, 0.0, options.practical_position_error);
    setup.initial.e_v = uniform_box(rng, V) - setup.initial.v;
  }
  return setup;
}

TrialRecord run_trial(const Model& model, const ObserverCertificate& certificate, const MonteCarloOptions& options,
                      int index) {
  TrialRecord record;
  record.index = index;
  const Eigen::VectorXd& V = certificate.observer.velocity_bounds;
  const int attempts = options.scenario == Scenario::random ? options.input_attempts : 1;
  for (int attempt = 0; attempt < attempts; ++attempt) {
    record.input_scale = std::pow(0.25, attempt);
    const TrialSetup setup = make_trial(model, V, options, index, record.input_scale);
    record.global_error = setup.global_error;
    record.initial_error = std::sqrt(setup.initial.e_q.squaredNorm() + setup.initial.e_v.squaredNorm());
    record.result = simulate_trial(model, certificate, setup.initial, setup.input, options.simulation);
    if (!record.result.left_velocity_box) break;
  }
  const double tolerance = 1.0 + options.simulation.violation_tolerance;
  record.envelope_violated = record.result.worst_envelope_ratio > tolerance;
  record.lyapunov_violated = record.result.worst_lyapunov_ratio > tolerance;
  return record;
}

std::vector<TrajectorySample> trial_trajectory(const Model& model, const ObserverCertificate& certificate,
                                               const MonteCarloOptions& options, const TrialRecord& record) {
  std::vector<TrajectorySample> samples;
  const TrialSetup trial = make_trial(model, certificate.observer.velocity_bounds, options, record.index, record.input_scale);
  simulate_trial(model, certificate, trial.initial, trial.input, options.simulation, &samples);
  return samples;
}

void validate_monte_carlo_options(const MonteCarloOptions& options) {
  // Tolerances the checks can trust (a loose integrator manufactures false counterexamples), a horizon that ends,
  // and no more threads than could ever help.
  const auto require_in = [](const char* name, double value, double lower, double upper) {
    if (!(value >= lower && value <= upper))
      throw InputError(fmt::format("--{} = {} must lie in [{:g}, {:g}]", name, value, lower, upper));
  };
  if (options.trials <= 0) throw InputError(fmt::format("trials = {} must be positive", options.trials));
  if (options.threads < 0 || options.threads > 256)
    throw InputError(fmt::format("--threads = {} must lie in [0, 256] (0: all cores)", options.threads));
  require_in("horizon", options.simulation.horizon, 1e-6, 1e3);
  require_in("rtol", options.simulation.rtol, 1e-13, 1e-4);
  require_in("atol", options.simulation.atol, 1e-20, 1e-6);
  if (!(options.step_budget >= 1.0))
    throw InputError(fmt::format("--step-budget = {} must be at least 1", options.step_budget));
}

double estimated_steps(const ObserverCertificate& certificate, const MonteCarloOptions& options) {
  const double horizon = options.simulation.horizon, trials = options.trials;
  if (certificate.sampled) return trials * 4.0 * horizon / certificate.sampled->sample_period;
  const CertifiedObserver& o = certificate.observer;
  // |roots of s² + k1 s + k2|: sqrt(k2) when they are complex, else the larger real one.
  const double discriminant = o.k1 * o.k1 - 4.0 * o.k2;
  const double fastest = discriminant < 0.0 ? std::sqrt(o.k2) : 0.5 * (o.k1 + std::sqrt(discriminant));
  return trials * (kStepsPerStiffness * fastest * horizon + 100.0);
}

namespace {

void validate_monte_carlo(const Model& model, const ObserverCertificate& certificate, const MonteCarloOptions& options) {
  validate_monte_carlo_options(options);
  const CertifiedObserver& o = certificate.observer;
  if (!(o.gamma > 0.0) || !(o.k >= 1.0)) throw InputError("the certificate to validate needs gamma > 0 and k >= 1");
  if (o.P.rows() != 2 * model.dof() || o.P.cols() != 2 * model.dof())
    throw InputError(fmt::format("the certificate's P is {} x {}: a robot of {} joints needs {} x {}", o.P.rows(),
                                 o.P.cols(), model.dof(), 2 * model.dof(), 2 * model.dof()));
  validate_velocity_bounds(model, o.velocity_bounds);
  if (certificate.sampled && certificate.sampled->latency > certificate.sampled->sample_period)
    throw InputError(fmt::format("latency = {} s is longer than a sample period ({} s): not simulated",
                                 certificate.sampled->latency, certificate.sampled->sample_period));
  if (certificate.sampled && options.simulation.horizon / certificate.sampled->sample_period > 1e7)
    throw InputError(fmt::format("horizon = {} s is more than 1e7 samples of {} s", options.simulation.horizon,
                                 certificate.sampled->sample_period));
}

// A trial record as doubles (its integers and flags are exact in a double), for the ranks to share.
constexpr int kRecordWidth = 15;

void pack(const TrialRecord& t, double* out) {
  const TrialResult& r = t.result;
  const double fields[kRecordWidth] = {static_cast<double>(t.index), static_cast<double>(t.global_error), t.input_scale,
                                       t.initial_error, static_cast<double>(t.envelope_violated),
                                       static_cast<double>(t.lyapunov_violated), static_cast<double>(r.left_velocity_box),
                                       r.max_velocity_ratio, r.max_acceleration_ratio, r.final_velocity_error,
                                       r.worst_envelope_ratio, r.worst_lyapunov_ratio, r.fitted_rate,
                                       r.final_log_error_ratio, static_cast<double>(r.steps)};
  std::copy(fields, fields + kRecordWidth, out);
}

TrialRecord unpack(const double* in) {
  TrialRecord t;
  t.index = static_cast<int>(in[0]);
  t.global_error = in[1] != 0.0;
  t.input_scale = in[2];
  t.initial_error = in[3];
  t.envelope_violated = in[4] != 0.0;
  t.lyapunov_violated = in[5] != 0.0;
  TrialResult& r = t.result;
  r.left_velocity_box = in[6] != 0.0;
  r.max_velocity_ratio = in[7];
  r.max_acceleration_ratio = in[8];
  r.final_velocity_error = in[9];
  r.worst_envelope_ratio = in[10];
  r.worst_lyapunov_ratio = in[11];
  r.fitted_rate = in[12];
  r.final_log_error_ratio = in[13];
  r.steps = static_cast<int>(in[14]);
  return t;
}

// Every rank's slice of the records, on every rank: the report is then the one-process report.
void share_records(std::vector<TrialRecord>& records, int begin, int end) {
  const int count = static_cast<int>(records.size());
  std::vector<double> values(static_cast<std::size_t>(count * kRecordWidth));
  for (int i = begin; i < end; ++i) pack(records[static_cast<std::size_t>(i)], &values[static_cast<std::size_t>(i * kRecordWidth)]);
  distributed::share_slices(values, count, kRecordWidth);
  for (int i = 0; i < count; ++i) records[static_cast<std::size_t>(i)] = unpack(&values[static_cast<std::size_t>(i * kRecordWidth)]);
}

// Why a run past its step budget is not started, and what would help (a shorter run, or a gain a controller runs).
std::string over_step_budget(const ObserverCertificate& certificate, const MonteCarloOptions& options, double steps) {
  const CertifiedObserver& o = certificate.observer;
  return fmt::format("not simulated: {} trials of {} s would take about {:.2g} integration steps, past the budget of "
                     "{:.2g} (--step-budget): the gains k1 = {:.6g}, k2 = {:.6g} make the error dynamics stiff for an "
                     "explicit integrator (hours of simulation). What would help: fewer --trials or a shorter --horizon "
                     "(the certified envelope falls by e^-5 within 5/gamma = {:.3g} s), or a design with a smaller gain "
                     "(the motors' rotor inertia, --armature, or a larger --bound-budget, narrow the bounds the gain pays for)",
                     options.trials, options.simulation.horizon, steps, options.step_budget, o.k1, o.k2, 5.0 / o.gamma);
}

// Trials outside the box are assumption violations: never passes, never observer failures.
void summarise(MonteCarloReport& report) {
  std::vector<double> rates;
  for (const TrialRecord& r : report.records) {
    report.max_acceleration_ratio = std::max(report.max_acceleration_ratio, r.result.max_acceleration_ratio);
    if (r.result.left_velocity_box) {
      ++report.assumption_violations;
      continue;
    }
    report.envelope_violations += r.envelope_violated;
    report.lyapunov_violations += r.lyapunov_violated;
    report.passed += !r.envelope_violated && !r.lyapunov_violated;
    report.worst_envelope_ratio = std::max(report.worst_envelope_ratio, r.result.worst_envelope_ratio);
    report.worst_lyapunov_ratio = std::max(report.worst_lyapunov_ratio, r.result.worst_lyapunov_ratio);
    report.worst_final_velocity_error = std::max(report.worst_final_velocity_error, r.result.final_velocity_error);
    if (std::isfinite(r.result.fitted_rate)) rates.push_back(r.result.fitted_rate);
  }
  if (rates.empty()) return;
  std::sort(rates.begin(), rates.end());
  const std::size_t mid = rates.size() / 2;
  report.decay_rate = {rates.front(), rates.size() % 2 ? rates[mid] : 0.5 * (rates[mid - 1] + rates[mid]), rates.back(),
                       static_cast<int>(rates.size())};
}

}  // namespace

MonteCarloReport run_monte_carlo(const Model& model, const ObserverCertificate& certificate,
                                 const MonteCarloOptions& options) {
  validate_monte_carlo(model, certificate, options);
  const auto start = std::chrono::steady_clock::now();
  MonteCarloReport report;
  report.trials = options.trials;
  report.seed = options.seed;
  report.certificate = certificate;
  report.simulation = options.simulation;
  report.scenario = options.scenario == Scenario::paper ? "paper" : "random";
  report.initial_errors = options.initial_errors == InitialErrors::practical ? "practical"
                          : options.initial_errors == InitialErrors::global  ? "global"
                                                                              : "both";
  report.threads = std::min(resolve_threads(options.threads), options.trials);
  if (const double steps = estimated_steps(certificate, options); steps > options.step_budget) {
    report.trials = 0;
    report.not_run = over_step_budget(certificate, options, steps);
    return report;
  }
  report.records.resize(options.trials);
  // Each trial is a pure function of (seed, index): the records do not depend on which thread ran which.
  std::atomic<int> done{0};
  std::atomic<bool> stop{false};
  // This rank's slice of the trials (all of them without MPI), then every rank's (numerics/distributed.hpp).
  const auto [begin, end] = distributed::slice(options.trials, distributed::rank(), distributed::size());
  auto trials = std::async(std::launch::async, [&, begin = begin, end = end] {
    ParallelFor pool(report.threads);
    pool.run(end - begin, [&](int k) {
      if (stop) return;
      report.records[static_cast<std::size_t>(begin + k)] = run_trial(model, certificate, options, begin + k);
      ++done;
    });
  });
  while (trials.wait_for(std::chrono::milliseconds(200)) != std::future_status::ready) {
    if (!options.progress) continue;
    try {
      options.progress(done.load(), options.trials, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    } catch (...) {  // the caller stops the run (Ctrl-C from Python): the trials not started are skipped
      stop = true;
      trials.wait();
      throw;
    }
  }
  trials.get();
  if (distributed::size() > 1) share_records(report.records, begin, end);
  summarise(report);
  report.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace obsgain
