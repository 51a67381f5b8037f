#include "obsgain/validation/verification.hpp"

#include "obsgain/bounds/bounds.hpp"
#include "obsgain/certificate/certificate.hpp"
#include "obsgain/model/dynamics.hpp"

#include <fmt/format.h>

#include <cmath>
#include <ctime>
#include <limits>
#include <numbers>
#include <optional>

namespace obsgain {

namespace {

// The bounds' functions along the first joint that M and C depend on (the others at the M0 argmax); along q1 when
// they depend on none (a single joint): flat curves.
void bound_curves(const Model& model, const Design& d, const VerificationOptions& options, VerificationReport& report) {
  const std::vector<int> searched = configuration_joints(model);
  report.curve_joint = searched.empty() ? 0 : searched.front();
  const JointDomain& joint = model.joints[report.curve_joint];
  const double lo = joint.continuous ? -std::numbers::pi : joint.lower;
  const double hi = joint.continuous ? std::numbers::pi : joint.upper;
  if (options.design.progress)
    options.design.progress(fmt::format("bound curves: {} configurations along joint {}", options.curve_points, report.curve_joint + 1));
  for (int k = 0; k < options.curve_points; ++k) {
    Eigen::VectorXd q = d.bounds.M0.q;
    q(report.curve_joint) = lo + (hi - lo) * k / (options.curve_points - 1);
    // The searches' own maxima over vertices and patterns (pruned: 4ⁿ choices cost a few eigensolves).
    const BoundCurvePoint p{q(report.curve_joint), inverse_inertia_norm(model, q),
                            max_coriolis_jacobian_norm(model, q, d.velocity_bounds),
                            max_joint_lipschitz_norm(model, q, d.velocity_bounds)};
    report.bound_curve.push_back(p);
  }
}

}  // namespace

namespace {

// Certified rate against θ for every certificate, around the chosen gain. The polytopic one (a bisection of SDPs
// per point, at 1 % resolution) on every 25th point only: on two joints over the design's polytope, above two by the
// design's search on sampled configurations (docs/theory.md, "The polytopic certificate by search"); both estimates.
std::vector<RateCurvePoint> rate_curve(const Model& model, const Design& d, const DesignOptions& options) {
  const double theta = d.selected().observer.theta;
  const bool polytopic = d.certificate == CertificateKind::polytopic;
  const bool by_search = polytopic && model.dof() > options.polytope.separate_cells_up_to_dof;
  PerturbationPolytope polytope;
  PolytopicOptions coarse = options.polytopic;
  coarse.relative_tolerance = 1e-2;
  if (polytopic && !by_search) polytope = perturbation_polytope(model, d.velocity_bounds, options.polytope);
  DesignOptions searched = options;
  searched.polytopic_search.relative_tolerance = 1e-2;
  std::optional<PolytopicSearch> search;
  if (by_search) search.emplace(polytopic_search_for(model, d, searched));
  const auto polytopic_gamma = [&](double k1, double k2) {
    if (!search) return polytopic_rate(polytope, k1, k2, coarse);
    const double rate = search->rate(k1, k2);
    return std::isfinite(rate) ? rate : std::numeric_limits<double>::quiet_NaN();  // no P even for γ = 0
  };
  std::vector<RateCurvePoint> curve;
  for (int k = 0; k <= 200; ++k) {
    const double t = theta * (0.1 + 2.9 * k / 200.0);
    const double k1 = t * d.alpha, k2 = t * t * d.beta;
    curve.push_back({t, paper_rate(d.lyapunov.S_norm, t, d.L_used), tight_rate(k1, k2, d.L_used),
                     d.scaled ? tight_rate(k1, k2, d.scaled->observer.L) : std::numeric_limits<double>::quiet_NaN(),
                     polytopic && k % 25 == 0 ? polytopic_gamma(k1, k2) : std::numeric_limits<double>::quiet_NaN()});
  }
  return curve;
}

}  // namespace

VerificationReport verify_design(const Model& model, const VerificationOptions& options) {
  VerificationReport report;
  report.robot = model.name;
  report.command_line = options.command_line;
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", &utc);
  report.date = date;
  report.design = design_observer(model, options.design, options.deployment);
  const Design& d = report.design.design;
  const auto phase = [&](const std::string& text) {
    if (options.design.progress) options.design.progress(text);
  };
  bound_curves(model, d, options, report);
  // Bounds that support no certificate leave nothing to simulate against: the report shows them as they are.
  if (!d.unfinished.empty()) return report;
  const ObserverCertificate certificate = observer_certificate(report.design);
  phase(fmt::format("Monte Carlo: {} trials", options.monte_carlo.trials));
  report.monte_carlo = run_monte_carlo(model, certificate, options.monte_carlo);
  phase("certified rate against the gain");
  report.rate_curve = rate_curve(model, d, options.design);
  // Past the step budget no trial ran, and the example trajectories would be as stiff: the report says why.
  if (!report.monte_carlo.not_run.empty()) return report;

  // The paper's scenario (hanging, u = 1.5 sin 100t) belongs to its two-link family; another arm would leave the
  // velocity box within milliseconds. Other robots show their first random trial (computed-torque tracking
  // when fully actuated).
  phase("trajectories for the plots");
  MonteCarloOptions example = options.monte_carlo;
  example.scenario = is_planar_2r(model) ? Scenario::paper : Scenario::random;
  report.example_scenario = is_planar_2r(model) ? "paper" : "random";
  example.simulation.horizon = std::min(options.monte_carlo.simulation.horizon, 0.5);
  report.paper_run = trial_trajectory(model, certificate, example, run_trial(model, certificate, example, 0));
  for (int i = 0; i < std::min(options.error_traces, options.monte_carlo.trials); ++i) {
    if (report.monte_carlo.records[i].result.left_velocity_box) continue;
    report.error_traces.push_back(trial_trajectory(model, certificate, options.monte_carlo, report.monte_carlo.records[i]));
  }
  return report;
}

}  // namespace obsgain
