#include "obsgain/model/dynamics.hpp"
#include "obsgain/validation/montecarlo.hpp"
#include "obsgain/validation/simulation.hpp"

#include <gtest/gtest.h>
#include <map>
#include <unsupported/Eigen/MatrixFunctions>

namespace {

// Constant inertia, no Coriolis, no gravity, viscous friction: plant and error dynamics are linear. The planar
// family with π3 = π4 = π5 = 0 is such a robot: M = [[π1 + π2 + a1, π2], [π2, π2 + a2]] = [[2, 0.3], [0.3, 1]].
obsgain::Model linear_model() {
  const obsgain::Planar2RParameters linear{{1.7, 0.3, 0.0, 0.0, 0.0}, 9.81, {0.0, 0.7}};
  return obsgain::make_planar_2r("linear", linear, Eigen::Vector2d(0.5, 0.2), Eigen::Matrix2d::Identity(),
                                 Eigen::Vector2d(10, 10));
}

obsgain::InputSignal no_input() {
  return {Eigen::MatrixXd::Zero(2, 1), Eigen::MatrixXd::Zero(2, 1), Eigen::MatrixXd::Zero(2, 1)};
}

// e(T) = exp(A T) e(0) with A = [[-k1 I, I], [-k2 I, -M⁻¹F]]; the error decays to ~1e-40 and must keep
// its relative precision all the way (the log-scaled error state).
TEST(Simulation, ClosedFormLinearCaseKeepsRelativePrecision) {
  const obsgain::Model model = linear_model();
  obsgain::CertifiedObserver observer;
  observer.k1 = 200.0;
  observer.k2 = 40000.0;
  observer.gamma = 1.0;
  observer.k = 1e6;
  observer.P = Eigen::Matrix4d::Identity();
  observer.velocity_bounds = model.velocity_bounds;
  const obsgain::ObserverCertificate c{observer, std::nullopt};
  obsgain::TrialInitialState initial{Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d(1.0, -2.0), Eigen::Vector2d(0.3, -0.1),
                                     Eigen::Vector2d(4.0, 1.5)};
  std::vector<obsgain::TrajectorySample> samples;
  obsgain::SimulationOptions options;
  options.horizon = 0.9;
  obsgain::simulate_trial(model, c, initial, no_input(), options, &samples);

  Eigen::Matrix2d M;
  obsgain::mass_matrix(model, Eigen::Vector2d::Zero(), M);
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
  A.topLeftCorner<2, 2>() = -c.observer.k1 * Eigen::Matrix2d::Identity();
  A.topRightCorner<2, 2>() = Eigen::Matrix2d::Identity();
  A.bottomLeftCorner<2, 2>() = -c.observer.k2 * Eigen::Matrix2d::Identity();
  A.bottomRightCorner<2, 2>() = -M.inverse() * model.friction;
  Eigen::Vector4d e0;
  e0 << initial.e_q, initial.e_v;
  for (const auto& s : samples) {
    if (std::abs(s.t - 0.3) > 1e-12 && std::abs(s.t - 0.9) > 1e-12) continue;
    const Eigen::Vector4d exact = (A * s.t).exp() * e0;
    Eigen::Vector4d simulated;
    simulated << s.e_q, s.e_v;
    if (s.t > 0.5) EXPECT_LT(exact.norm(), 1e-30);
    EXPECT_LE((simulated - exact).norm(), 1e-6 * exact.norm()) << "t = " << s.t;
    // The plant: v(t) = exp(-M⁻¹F t) v(0).
    const Eigen::Vector2d v = (-M.inverse() * model.friction * s.t).exp() * initial.v;
    EXPECT_LE((s.v - v).norm(), 1e-7 * v.norm());
  }
}

// A large initial error saturates σ_V: the right-hand side has kinks. The adaptive step must still
// deliver the requested accuracy: compare with a reference at far tighter tolerances.
TEST(Simulation, SaturatedTrialMatchesTightReference) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions design;
  design.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  design.theta = 200.0;
  const obsgain::ObserverCertificate c = obsgain::observer_certificate({obsgain::design_gains(model, design), std::nullopt});
  obsgain::MonteCarloOptions mc;
  mc.scenario = obsgain::Scenario::paper;
  mc.initial_errors = obsgain::InitialErrors::global;
  const obsgain::TrialSetup trial = obsgain::make_trial(model, model.velocity_bounds, mc, 3, 1.0);
  ASSERT_GT(trial.initial.e_v.cwiseAbs().maxCoeff(), 20.0);  // far outside the box: saturated at the start
  obsgain::SimulationOptions normal, tight;
  normal.horizon = tight.horizon = 0.5;
  tight.rtol = 1e-12;
  tight.atol = 1e-14;
  std::vector<obsgain::TrajectorySample> sa, sb;
  const auto a = obsgain::simulate_trial(model, c, trial.initial, trial.input, normal, &sa);
  const auto b = obsgain::simulate_trial(model, c, trial.initial, trial.input, tight, &sb);
  ASSERT_FALSE(a.left_velocity_box);
  EXPECT_LT(a.final_log_error_ratio, -30.0);
  EXPECT_NEAR(a.final_log_error_ratio, b.final_log_error_ratio, 1e-5);
  EXPECT_GT(b.steps, a.steps);
  // On the shared dense grid (1 ms) the error agrees to 5e-5 relative throughout (2.9e-5 measured).
  std::map<double, double> reference;
  for (const auto& s : sb) reference[s.t] = s.error_norm;
  int compared = 0;
  for (const auto& s : sa) {
    const auto it = reference.find(s.t);
    if (it == reference.end()) continue;
    EXPECT_NEAR(std::log(s.error_norm), std::log(it->second), 5e-5) << "t = " << s.t;
    ++compared;
  }
  EXPECT_GE(compared, 499);
}

TEST(Simulation, PaperScenarioConverges) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions design;  // the paper's design: θ = 200, α = β = 1, its L
  design.bound_method = obsgain::BoundMethod::numeric;
  design.theta = 200.0;
  design.L_override = 54.01;
  design.certificate = obsgain::CertificateKind::paper;
  const obsgain::ObserverCertificate c = obsgain::observer_certificate({obsgain::design_gains(model, design), std::nullopt});
  obsgain::MonteCarloOptions mc;
  mc.scenario = obsgain::Scenario::paper;
  mc.simulation.horizon = 0.5;
  const auto samples = obsgain::trial_trajectory(model, c, mc, obsgain::run_trial(model, c, mc, 0));
  ASSERT_FALSE(samples.empty());
  EXPECT_EQ(samples.front().e_v, Eigen::Vector2d(2, 2));  // the paper's observer start (-π/2, 0, 2, 2)
  for (const auto& s : samples) {
    if (s.t >= 0.3) EXPECT_LT(s.error_norm, 1e-6) << "t = " << s.t;
    EXPECT_LE(s.error_norm, s.envelope);
  }
}

}  // namespace
