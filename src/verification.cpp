#include "obsgain/verification.hpp"

#include "obsgain/bounds.hpp"
#include "obsgain/certificate.hpp"

#include <numbers>

namespace obsgain {

VerificationReport verify_design(const Model& model, const VerificationOptions& options) {
  VerificationReport report;
  report.robot = model.name;
  report.design = design_gains(model, options.design);
  const Design& d = report.design;
  const ObserverCertificate certificate = observer_certificate(d);
  report.monte_carlo = run_monte_carlo(model, d.velocity_bounds, certificate, options.monte_carlo);

  // Bound curves along the first joint that M and C depend on.
  report.curve_joint = model.dynamics->configuration_joints().front();
  const JointDomain& joint = model.joints[report.curve_joint];
  const double lo = joint.continuous ? -std::numbers::pi : joint.lower;
  const double hi = joint.continuous ? std::numbers::pi : joint.upper;
  const Eigen::MatrixXd vertices = box_vertices(d.velocity_bounds);
  const int n = model.dof();
  for (int k = 0; k < options.curve_points; ++k) {
    Eigen::VectorXd q = d.bounds.M0.q;
    q(report.curve_joint) = lo + (hi - lo) * k / (options.curve_points - 1);
    BoundCurvePoint p{q(report.curve_joint), inverse_inertia_norm(model, q), 0.0, 0.0};
    for (Eigen::Index c = 0; c < vertices.cols(); ++c) {
      p.jacobian_norm = std::max(p.jacobian_norm, coriolis_jacobian_norm(model, q, vertices.col(c)));
      for (unsigned s = 0; s < (1u << n); ++s) {
        Eigen::VectorXd D(n);
        for (int i = 0; i < n; ++i) D(i) = ((s >> i) & 1u) ? 1.0 : 0.0;
        p.joint_lipschitz_norm = std::max(p.joint_lipschitz_norm, joint_lipschitz_norm(model, q, vertices.col(c), D));
      }
    }
    report.bound_curve.push_back(p);
  }

  MonteCarloOptions paper = options.monte_carlo;
  paper.scenario = Scenario::paper;
  paper.simulation.horizon = std::min(options.monte_carlo.simulation.horizon, 0.5);
  report.paper_run = trial_trajectory(model, d.velocity_bounds, certificate, paper, 0);
  for (int i = 0; i < std::min(options.error_traces, options.monte_carlo.trials); ++i) {
    if (report.monte_carlo.records[i].result.left_velocity_box) continue;
    report.error_traces.push_back(trial_trajectory(model, d.velocity_bounds, certificate, options.monte_carlo, i,
                                                  report.monte_carlo.records[i].input_scale));
  }

  // Certified rate against θ for both certificates, around the chosen gain.
  const double theta = d.selected().theta;
  for (int k = 0; k <= 200; ++k) {
    const double t = theta * (0.1 + 2.9 * k / 200.0);
    report.rate_curve.push_back({t, paper_rate(d.lyapunov.S_norm, t, d.L_used),
                                 tight_rate(t * d.alpha, t * t * d.beta, d.L_used)});
  }
  return report;
}

}  // namespace obsgain
