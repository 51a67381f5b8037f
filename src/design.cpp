#include "obsgain/design.hpp"

#include "obsgain/certificate.hpp"
#include "obsgain/certified_bounds.hpp"
#include "obsgain/optimize.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

namespace obsgain {

namespace {

// The admissible ranges: wide enough for any robot and observer that can be built, narrow enough that the
// certificates' arithmetic (θ², L θ, bisections over θ) stays finite and terminates.
void require_in(const char* name, double value, double lower, double upper) {
  if (!std::isfinite(value) || value < lower || value > upper || value <= 0.0)
    throw InputError(fmt::format("--{} = {} must lie in [{:g}, {:g}]", name, value, lower, upper));
}

// β = 1, minimise objective(α) over α ∈ [1e-2, 1e2] (searched in log α): DIRECT-L, then Ipopt.
ShapeReport optimize_alpha(const std::string& name, const std::function<double(double)>& objective) {
  ShapeReport shape;
  shape.optimized = true;
  shape.objective = name;
  const Objective negated = [&](const Eigen::VectorXd& x) { return -objective(std::exp(x(0))); };
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(1, std::log(1e-2));
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(1, std::log(1e2));
  const OptimumPoint global = maximize_global(negated, lower, upper, 400);
  const OptimumPoint polish = maximize_local(negated, global.x, lower, upper);
  shape.alpha_global = std::exp(global.x(0));
  shape.objective_global = -global.value;
  shape.alpha_polish = std::exp(polish.x(0));
  shape.objective_polish = -polish.value;
  shape.evaluations = global.evaluations + polish.evaluations;
  return shape;
}

CertificateSummary paper_summary(const Design& d, std::optional<double> target, std::optional<double> theta) {
  CertificateSummary s;
  const double S_norm = d.lyapunov.S_norm;
  s.theta_star = paper_theta_star(S_norm, target.value_or(0.0), d.L_used);
  s.theta = target ? s.theta_star : *theta;
  s.gamma = target ? *target : paper_rate(S_norm, s.theta, d.L_used);
  s.envelope_gamma = s.gamma;
  s.k1 = s.theta * d.alpha;
  s.k2 = s.theta * s.theta * d.beta;
  s.P = paper_certificate_matrix(d.lyapunov.S2, s.theta);
  s.k = envelope_constant(s.P);
  s.certified = s.gamma > 0.0;
  return s;
}

CertificateSummary tight_summary(const Design& d, std::optional<double> target, std::optional<double> theta) {
  CertificateSummary s;
  const double m = d.rate_margin;
  s.theta_star = tight_theta_star(d.alpha, d.beta, target.value_or(0.0), d.L_used);
  s.theta = target ? tight_theta_star(d.alpha, d.beta, *target / (1.0 - m), d.L_used) : *theta;
  s.k1 = s.theta * d.alpha;
  s.k2 = s.theta * s.theta * d.beta;
  s.gamma = tight_rate(s.k1, s.k2, d.L_used);
  s.envelope_gamma = target ? *target : s.gamma - m * std::abs(s.gamma);
  const RiccatiCertificate cert = tight_certificate(s.k1, s.k2, d.L_used, s.envelope_gamma);
  if (cert.exists) {
    s.P = cert.P;
    s.k = cert.k;
    s.lmi_max_eig = cert.lmi_max_eig;
  }
  s.certified = cert.exists && s.envelope_gamma > 0.0;
  return s;
}

}  // namespace

const char* to_string(CertificateKind kind) { return kind == CertificateKind::paper ? "paper" : "tight"; }
const char* to_string(LipschitzKind kind) { return kind == LipschitzKind::paper ? "paper" : "joint"; }

void validate_design_options(const DesignOptions& options) {
  if (options.gamma.has_value() == options.theta.has_value())
    throw InputError("give exactly one of --gamma (target rate) and --theta (gain to evaluate)");
  if (options.gamma) require_in("gamma", *options.gamma, 1e-9, 1e6);
  if (options.theta) require_in("theta", *options.theta, 1e-6, 1e8);
  if (!options.optimize_shape) {
    require_in("alpha", options.alpha, 1e-6, 1e6);
    require_in("beta", options.beta, 1e-6, 1e6);
  }
  if (options.L_override) require_in("L", *options.L_override, 1e-12, 1e12);
  const double budget = options.certified_bounds.budget_seconds;
  if (!std::isfinite(budget) || budget < 0.0 || budget > 1e6)
    throw InputError(fmt::format("--bound-budget = {} must lie in [0, 1e6] seconds (0: until the gap is reached)", budget));
  if (!std::isfinite(options.rate_margin) || options.rate_margin <= 0.0 || options.rate_margin >= 0.5)
    throw InputError(fmt::format("rate margin = {} must lie in (0, 0.5)", options.rate_margin));
}

Design design_from_bounds(const Model& model, const BoundReport& bounds, const DesignOptions& options) {
  validate_design_options(options);
  Design d;
  d.robot_name = model.name;
  d.robot_source = model.source;
  d.dof = model.dof();
  d.velocity_bounds = bounds.velocity_bounds;
  d.bounds = bounds;
  d.certificate = options.certificate;
  d.target_gamma = options.gamma;
  d.rate_margin = options.rate_margin;

  const double L_computed = options.lipschitz == LipschitzKind::joint ? bounds.L_joint.value : bounds.L_paper;
  if (!options.L_override && !std::isfinite(L_computed))
    throw InputError(fmt::format("L_{} has no finite proven upper bound yet after the bound budget of {} s: raise "
                                 "--bound-budget (0: no limit)",
                                 to_string(options.lipschitz), options.certified_bounds.budget_seconds));
  d.L_used = options.L_override.value_or(L_computed);
  d.L_source = options.L_override ? "override" : to_string(options.lipschitz);
  if (options.L_override) {
    d.warnings.push_back(fmt::format("L overridden by the user: {} (the model gives L_joint = {:.6g}, L_paper = {:.6g})",
                                     d.L_used, bounds.L_joint.value, bounds.L_paper));
    if (d.L_used < bounds.L_joint.value)
      d.warnings.push_back("the overriding L is below the model's L_joint: the certificate rests on the user's L, "
                           "not on the model");
  }
  for (const auto* bound : {&bounds.M0, &bounds.B, &bounds.L_joint}) {
    if (std::abs(bound->global_value - bound->polish_value) > 1e-6 * std::max(bound->global_value, bound->polish_value))
      d.warnings.push_back(fmt::format("bound search: NLopt ({:.10g}) and Ipopt ({:.10g}) disagree beyond 1e-6",
                                       bound->global_value, bound->polish_value));
  }

  d.alpha = options.alpha;
  d.beta = options.beta;
  if (options.optimize_shape) {
    d.beta = 1.0;
    if (options.certificate == CertificateKind::paper) {
      d.shape = optimize_alpha("S_norm", [](double a) { return observer_lyapunov(a, 1.0, 1).S_norm; });
    } else if (options.gamma) {
      d.shape = optimize_alpha("theta_star", [&](double a) { return tight_theta_star(a, 1.0, *options.gamma, d.L_used); });
    } else {
      d.shape = optimize_alpha("-gamma", [&](double a) {
        return -tight_rate(*options.theta * a, *options.theta * *options.theta, d.L_used);
      });
    }
    const bool polish_better = d.shape.objective_polish <= d.shape.objective_global;
    d.alpha = polish_better ? d.shape.alpha_polish : d.shape.alpha_global;
    const double scale = std::max(1.0, std::abs(d.shape.objective_global));
    if (std::abs(d.shape.objective_global - d.shape.objective_polish) > 1e-6 * scale)
      d.warnings.push_back("shape optimisation: NLopt and Ipopt disagree beyond 1e-6");
  }
  d.lyapunov = observer_lyapunov(d.alpha, d.beta, d.dof);

  d.paper = paper_summary(d, options.gamma, options.theta);
  d.tight = tight_summary(d, options.gamma, options.theta);

  // Both certificates use L alone: proven bounds, or the user's own L, make the certificate a proof.
  if (!bounds.certified && !options.L_override) {
    d.not_proven_reason = options.bound_method == BoundMethod::numeric
                              ? "numeric bounds (--bounds numeric) are lower estimates of the suprema, not proven"
                              : "numeric bounds: " + certification_unavailable(model) + ", so its suprema are estimates";
  }
  const CertificateSummary& s = d.selected();
  if (!s.certified && s.gamma > 0.0) {
    d.warnings.push_back(fmt::format("theta = {:.6g}: the {} certificate's rate {:.6g} is positive, but no certificate "
                                     "matrix P was found at the envelope rate {:.6g} (the Riccati solve fails at these "
                                     "extreme gains): nothing is certified",
                                     s.theta, to_string(d.certificate), s.gamma, s.envelope_gamma));
  } else if (!s.certified) {
    d.warnings.push_back(fmt::format("theta = {:.6g} certifies no exponential rate with the {} certificate (gamma = {:.6g})",
                                     s.theta, to_string(d.certificate), s.gamma));
  }
  return d;
}

BoundReport design_bounds(const Model& model, const Eigen::VectorXd& V, const DesignOptions& options,
                          std::vector<std::string>& warnings) {
  const auto phase = [&](const std::string& text) {
    if (options.progress && model.dof() > 2) options.progress(text);
  };
  phase(fmt::format("bounds: numeric search over {} joints (NLopt DIRECT-L, then Ipopt)",
                    model.dynamics->configuration_joints().size()));
  BoundReport bounds = compute_bounds(model, V, options.bounds);
  if (options.bound_method == BoundMethod::certified) {
    phase(options.certified_bounds.budget_seconds > 0.0
              ? fmt::format("bounds: interval branch and bound, budget {:g} s (--bound-budget)",
                            options.certified_bounds.budget_seconds)
              : std::string("bounds: interval branch and bound until the 1e-6 gap (no budget)"));
    if (const auto certified = certify_bounds(model, bounds, options.certified_bounds)) {
      apply_certified_bounds(bounds, *certified);
    } else {
      warnings.push_back(certification_unavailable(model) +
                         ": numeric bounds used (lower estimates of the suprema); the design is not proven");
    }
  }
  return bounds;
}

std::string unmet_request(const Design& d, const DesignOptions& options) {
  if (d.deployment && d.selected().certified && !d.deployment->within_tolerance()) {
    const DeploymentCertificate& dep = *d.deployment;
    return fmt::format("at T = {:g} s the certified ultimate velocity error {:.4g} exceeds the tolerance {:.4g} ({})",
                       dep.sample_period, dep.bounds.velocity_norm, dep.velocity_error_tolerance,
                       dep.max_sample_period > 0.0
                           ? fmt::format("largest sample period within it: {:.4g} s", dep.max_sample_period)
                           : std::string("no sample period is within it at these gains and encoders: try --objective "
                                         "velocity-error, finer encoders or --velocity-error-tolerance"));
  }
  if (!options.gamma) return {};
  if (!d.selected().certified) return fmt::format("the design does not certify gamma = {}", *options.gamma);
  if (!d.proven() && options.bound_method == BoundMethod::certified)
    return fmt::format("gamma = {} is not certified: {} (--bounds numeric accepts an estimate)", *options.gamma,
                       d.not_proven_reason);
  return {};
}

Design design_gains(const Model& model, const DesignOptions& requested) {
  validate_design_options(requested);
  const auto start = std::chrono::steady_clock::now();
  DesignOptions options = requested;
  const Eigen::VectorXd V = options.velocity_bounds.size() ? options.velocity_bounds : model.velocity_bounds;
  if (V.size() == 0)
    throw InputError("model '" + model.name + "' gives no velocity bounds" +
                     (model.missing_velocity_bounds.empty() ? "" : " (" + model.missing_velocity_bounds + ")") +
                     ": pass --vmax V1,...,Vn");
  validate_velocity_bounds(model, V);
  if (options.deployment) {
    // One value stands for every joint.
    for (Eigen::VectorXd* values : {&options.deployment->encoder_resolution, &options.deployment->acceleration_bounds})
      if (values->size() == 1) *values = Eigen::VectorXd::Constant(model.dof(), (*values)(0));
    validate_deployment_options(*options.deployment, model.dof());
    if (const std::string why = sensitivity_unavailable(model); !why.empty())
      throw InputError("--sample-period: the sampled certificate needs C_q on intervals, but " + why);
    if (options.objective == DesignObjective::velocity_error && !options.gamma)
      throw InputError("--objective velocity-error needs --gamma: the rate the design must still certify");
  } else if (options.objective == DesignObjective::velocity_error) {
    throw InputError("--objective velocity-error needs a deployment: --sample-period, --encoder-counts, --acceleration-bounds");
  }
  std::vector<std::string> warnings;
  const BoundReport bounds = design_bounds(model, V, options, warnings);
  Design d;
  if (options.deployment) {
    if (options.progress && model.dof() > 2)
      options.progress(fmt::format("deployment: position sensitivity C_q, interval branch and bound, budget {:g} s",
                                   options.deployment->sensitivity.budget_seconds));
    const auto sensitivity =
        certify_position_sensitivity(model, V, options.deployment->acceleration_bounds, options.deployment->sensitivity);
    d = deployed_design(model, bounds, options, *sensitivity);
  } else {
    d = design_from_bounds(model, bounds, options);
  }
  d.notes = model.notes;
  d.armature = model.armature;
  d.robot_fingerprint = model.fingerprint;
  d.warnings.insert(d.warnings.begin(), warnings.begin(), warnings.end());
  d.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return d;
}

}  // namespace obsgain
