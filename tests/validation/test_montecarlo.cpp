#include "obsgain/validation/montecarlo.hpp"

#include <gtest/gtest.h>

namespace {

obsgain::ObserverCertificate design(const obsgain::Model& model, obsgain::DesignOptions options) {
  return obsgain::observer_certificate({obsgain::design_gains(model, options), std::nullopt});
}

obsgain::DesignOptions at_theta(double theta) {
  obsgain::DesignOptions o;
  o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  o.theta = theta;
  return o;
}

TEST(MonteCarlo, CertifiedDesignPasses1000Trials) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::MonteCarloOptions options;
  options.trials = 1000;
  options.simulation.horizon = 0.4;
  const auto report = obsgain::run_monte_carlo(model, design(model, at_theta(200.0)), options);
  // The default on the Pendubot is the scaled certificate: its Lyapunov levels are those of P₂ ⊗ T².
  EXPECT_EQ(report.certificate.observer.certificate, obsgain::CertificateKind::scaled);
  EXPECT_EQ(report.envelope_violations, 0);
  EXPECT_EQ(report.lyapunov_violations, 0);
  EXPECT_TRUE(report.certificate_held());
  EXPECT_LE(report.worst_envelope_ratio, 1.0);
  EXPECT_EQ(report.passed + report.assumption_violations, 1000);
  EXPECT_GT(report.passed, 900);
  // The observer really decays faster than certified (γ = 77.5 with L_T; 72.5 with L_joint), not slower.
  EXPECT_GT(report.decay_rate.min, report.certificate.observer.gamma);
}

TEST(MonteCarlo, LeavingTheVelocityBoxIsAnAssumptionViolation) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions o = at_theta(200.0);
  o.velocity_bounds = Eigen::Vector2d(1, 1);
  obsgain::MonteCarloOptions options;
  options.trials = 40;
  options.scenario = obsgain::Scenario::paper;
  options.simulation.horizon = 0.5;
  const auto report = obsgain::run_monte_carlo(model, design(model, o), options);
  EXPECT_EQ(report.assumption_violations, 40);
  EXPECT_EQ(report.passed, 0);
  EXPECT_EQ(report.envelope_violations, 0);
}

TEST(MonteCarlo, SameSeedSameReportWhateverTheThreadCount) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::ObserverCertificate c = design(model, at_theta(150.0));
  obsgain::MonteCarloOptions options;
  options.trials = 40;
  options.seed = 42;
  options.simulation.horizon = 0.3;
  options.threads = 1;
  const auto one = obsgain::run_monte_carlo(model, c, options);
  options.threads = 2;
  const auto two = obsgain::run_monte_carlo(model, c, options);
  EXPECT_EQ(one.threads, 1);
  EXPECT_EQ(two.threads, 2);
  ASSERT_EQ(one.records.size(), two.records.size());
  for (std::size_t i = 0; i < one.records.size(); ++i) {
    EXPECT_EQ(one.records[i].result.worst_envelope_ratio, two.records[i].result.worst_envelope_ratio);
    EXPECT_EQ(one.records[i].result.fitted_rate, two.records[i].result.fitted_rate);
    EXPECT_EQ(one.records[i].result.steps, two.records[i].result.steps);
  }
  EXPECT_EQ(one.decay_rate.median, two.decay_rate.median);
  options.seed = 43;
  const auto other = obsgain::run_monte_carlo(model, c, options);
  EXPECT_NE(other.decay_rate.median, one.decay_rate.median);
}

// L overridden far too small: the design claims a rate its gains cannot deliver, and the check says so.
TEST(MonteCarlo, UnderGainedDesignIsCaught) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions o;
  o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  o.gamma = 1.0;
  o.L_override = 0.01;
  obsgain::MonteCarloOptions options;
  options.trials = 50;
  options.initial_errors = obsgain::InitialErrors::practical;
  options.simulation.horizon = 3.0;
  const auto report = obsgain::run_monte_carlo(model, design(model, o), options);
  EXPECT_GT(report.envelope_violations, 0);
  EXPECT_GT(report.lyapunov_violations, 0);
  EXPECT_GT(report.worst_envelope_ratio, 1.2);
  EXPECT_FALSE(report.certificate_held());
}

TEST(MonteCarlo, RefusesWhatItCannotValidate) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions o = at_theta(100.0);
  o.certificate = obsgain::CertificateKind::paper;  // θ = 100 < 2||S||L: nothing certified
  EXPECT_THROW(design(model, o), obsgain::InputError);
  const obsgain::ObserverCertificate c = design(model, at_theta(200.0));
  obsgain::MonteCarloOptions options;
  options.trials = 0;
  EXPECT_THROW(obsgain::run_monte_carlo(model, c, options), obsgain::InputError);
  options.trials = 1;
  options.simulation.horizon = -1.0;
  EXPECT_THROW(obsgain::run_monte_carlo(model, c, options), obsgain::InputError);
}

}  // namespace

namespace {

// The step estimate against the integrator's own count: at θ = 2000 (α = β = 1, so the fastest error mode is θ) the
// run takes about the steps estimated (on average 40 to 44 per unit of θ t were measured there, against 60), and no
// trial far more.
TEST(MonteCarlo, EstimatedStepsMatchTheStepsTaken) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::ObserverCertificate c = design(model, at_theta(2000.0));
  obsgain::MonteCarloOptions options;
  options.trials = 24;
  options.simulation.horizon = 0.05;
  const double estimate = obsgain::estimated_steps(c, options);
  EXPECT_NEAR(estimate, 24 * (obsgain::kStepsPerStiffness * 2000.0 * 0.05 + 100.0), 1e-6);
  const auto report = obsgain::run_monte_carlo(model, c, options);
  ASSERT_EQ(report.records.size(), 24u);
  double steps = 0.0;
  for (const obsgain::TrialRecord& r : report.records) {
    steps += r.result.steps;
    EXPECT_LE(r.result.steps, 1.5 * estimate / 24);
  }
  EXPECT_GT(steps, 0.4 * estimate);
  EXPECT_LT(steps, 1.2 * estimate);
  // Overdamped: the fastest mode is the larger real root of s² + k1 s + k2, (k1 + sqrt(k1² - 4 k2)) / 2.
  obsgain::ObserverCertificate overdamped = c;
  overdamped.observer.k1 = 1000.0;
  overdamped.observer.k2 = 1e4;
  options.trials = 1;
  EXPECT_NEAR(obsgain::estimated_steps(overdamped, options),
              obsgain::kStepsPerStiffness * 0.5 * (1000.0 + std::sqrt(1e6 - 4e4)) * 0.05 + 100.0, 1e-9);
}

// A gain of 20,000 would take about 1.2e9 steps at the defaults (hours): the run is not started and says what helps;
// the same design on a run that fits the budget is simulated.
TEST(MonteCarlo, ARunPastTheStepBudgetIsNotStartedAndSaysWhatWouldHelp) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::ObserverCertificate c = design(model, at_theta(20000.0));
  obsgain::MonteCarloOptions options;
  const auto refused = obsgain::run_monte_carlo(model, c, options);
  EXPECT_FALSE(refused.not_run.empty());
  EXPECT_FALSE(refused.certificate_held());
  EXPECT_EQ(refused.trials, 0);
  EXPECT_TRUE(refused.records.empty());
  for (const char* hint : {"--trials", "--horizon", "--step-budget", "--armature"})
    EXPECT_NE(refused.not_run.find(hint), std::string::npos) << hint;
  options.trials = 4;
  options.simulation.horizon = 0.01;
  ASSERT_LT(obsgain::estimated_steps(c, options), options.step_budget);
  const auto run = obsgain::run_monte_carlo(model, c, options);
  EXPECT_TRUE(run.not_run.empty());
  EXPECT_EQ(run.passed + run.assumption_violations, 4);
  EXPECT_TRUE(run.certificate_held());
  options.step_budget = 0.0;
  EXPECT_THROW(obsgain::run_monte_carlo(model, c, options), obsgain::InputError);
}

}  // namespace
