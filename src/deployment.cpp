#include "obsgain/deployment.hpp"

#include "obsgain/certificate.hpp"
#include "obsgain/design.hpp"
#include "obsgain/observer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace obsgain {

using boost::numeric::square;

namespace {

// M0 C_q rounded up: ||ψ|| <= M0 C_q ||η||.
double model_gain_upper(double M0, double C_q) {
  const UpwardRounding upward;
  return (Interval(M0) * Interval(C_q)).upper();
}

// ||d||₂ rounded up.
double norm_upper(const Eigen::VectorXd& d) {
  const UpwardRounding upward;
  Interval sum(0.0);
  for (Eigen::Index i = 0; i < d.size(); ++i) sum += square(Interval(d(i)));
  return boost::numeric::sqrt(sum).upper();
}

}  // namespace

Eigen::VectorXd encoder_resolution_from_counts(const Eigen::VectorXd& counts) {
  Eigen::VectorXd resolution(counts.size());
  for (Eigen::Index i = 0; i < counts.size(); ++i) {
    if (!std::isfinite(counts(i)) || counts(i) < 1.0 || counts(i) != std::floor(counts(i)) || counts(i) > 1e12)
      throw InputError(fmt::format("--encoder-counts: N{} = {} must be a whole number of counts per revolution in [1, 1e12]",
                                   i + 1, counts(i)));
    resolution(i) = 2.0 * std::numbers::pi / counts(i);
  }
  return resolution;
}

void validate_deployment_options(const DeploymentOptions& o, int dof) {
  if (!std::isfinite(o.sample_period) || o.sample_period <= 0.0 || o.sample_period > 1.0)
    throw InputError(fmt::format("--sample-period = {} must lie in (0, 1] seconds", o.sample_period));
  const auto check = [&](const char* name, const Eigen::VectorXd& values, const char* symbol, double upper) {
    if (values.size() != dof)
      throw InputError(fmt::format("--{}: {} values for a robot of {} joints (give one, or one per joint)", name,
                                   values.size(), dof));
    for (Eigen::Index i = 0; i < values.size(); ++i)
      if (!std::isfinite(values(i)) || values(i) <= 0.0 || values(i) > upper)
        throw InputError(fmt::format("--{}: {}{} = {} must lie in (0, {:g}]", name, symbol, i + 1, values(i), upper));
  };
  check("encoder-counts", o.encoder_resolution, "resolution of joint ", 2.0 * std::numbers::pi);
  check("acceleration-bounds", o.acceleration_bounds, "A", 1e9);
  if (!std::isfinite(o.latency) || o.latency < 0.0 || o.latency > 1.0)
    throw InputError(fmt::format("--latency = {} must lie in [0, 1] seconds", o.latency));
  if (!std::isfinite(o.velocity_error_tolerance) || o.velocity_error_tolerance < 0.0)
    throw InputError(fmt::format("--velocity-error-tolerance = {} must be >= 0 (0: the smallest velocity bound)",
                                 o.velocity_error_tolerance));
}

Eigen::VectorXd measurement_error_bound(const DeploymentOptions& o, const Eigen::VectorXd& V, double T) {
  const UpwardRounding upward;
  Eigen::VectorXd d(o.encoder_resolution.size());
  for (Eigen::Index i = 0; i < d.size(); ++i)
    d(i) = (Interval(o.encoder_resolution(i)) / 2.0 + Interval(o.acceleration_bounds(i)) * square(Interval(T)) / 8.0 +
            Interval(V(i)) * Interval(o.latency))
               .upper();
  return d;
}

SampledErrorBounds sampled_error_bounds(const Eigen::Matrix2d& P, double gamma, double k1, double k2,
                                        double model_gain, double d_norm) {
  const UpwardRounding upward;
  using boost::numeric::sqrt;
  const Interval p11(P(0, 0)), p12(std::abs(P(0, 1))), p22(P(1, 1)), dn(d_norm);
  const Interval a = Interval(k1) * dn, b = (Interval(k2) + Interval(model_gain)) * dn;
  // max of wᵀ(P ⊗ I)w over ||w_q|| <= a, ||w_v|| <= b: the cross term is at most |p12| a b by Cauchy–Schwarz.
  const Interval level = sqrt(p11 * square(a) + 2.0 * p12 * a * b + p22 * square(b)) / Interval(gamma);
  const Interval det = p11 * p22 - square(p12);
  const Interval lambda_min = (p11 + p22) / 2.0 - sqrt(square((p11 - p22) / 2.0) + square(p12));
  SampledErrorBounds s;
  s.disturbance_position = a.upper();
  s.disturbance_velocity = b.upper();
  s.level = level.upper();
  const double inf = std::numeric_limits<double>::infinity();
  s.offset = lambda_min.lower() > 0.0 ? (level / sqrt(Interval(lambda_min.lower()))).upper() : inf;
  s.position_norm = det.lower() > 0.0 ? (level * sqrt(p22 / Interval(det.lower()))).upper() : inf;
  s.velocity_norm = det.lower() > 0.0 ? (level * sqrt(p11 / Interval(det.lower()))).upper() : inf;
  return s;
}

DeploymentCertificate deployment_certificate(const Design& design, const DeploymentOptions& options,
                                             const BoundBracket& sensitivity, bool sensitivity_proven) {
  const CertificateSummary& s = design.selected();
  DeploymentCertificate c;
  c.sample_period = options.sample_period;
  c.latency = options.latency;
  c.encoder_resolution = options.encoder_resolution;
  c.acceleration_bounds = options.acceleration_bounds;
  c.position_sensitivity = sensitivity;
  c.sensitivity_proven = sensitivity_proven;
  c.M0 = design.bounds.M0.value;
  c.model_gain = model_gain_upper(c.M0, sensitivity.upper);
  c.gamma = s.envelope_gamma;
  c.k = s.k;
  const auto bounds_at = [&](double T) {
    return sampled_error_bounds(s.P, c.gamma, s.k1, s.k2, c.model_gain,
                                norm_upper(measurement_error_bound(options, design.velocity_bounds, T)));
  };
  c.measurement_error = measurement_error_bound(options, design.velocity_bounds, c.sample_period);
  c.bounds = bounds_at(c.sample_period);
  const auto n = design.dof;
  // The ellipsoid W <= R is round across joints, so a joint's bound is the norm's.
  c.ultimate_position_error = Eigen::VectorXd::Constant(n, c.bounds.position_norm);
  c.ultimate_velocity_error = Eigen::VectorXd::Constant(n, c.bounds.velocity_norm);
  c.velocity_error_tolerance =
      options.velocity_error_tolerance > 0.0 ? options.velocity_error_tolerance : design.velocity_bounds.minCoeff();
  // The ultimate velocity error grows with T (through A T² / 8): bisect for the largest T within tolerance, up to
  // the longest period accepted (1 s).
  const auto within = [&](double T) { return bounds_at(T).velocity_norm <= c.velocity_error_tolerance; };
  if (s.certified && within(0.0)) {
    double good = 0.0, bad = 1.0;
    if (within(bad)) good = bad;
    for (int i = 0; i < 100 && bad - good > 1e-12 * bad; ++i) {
      const double middle = 0.5 * (good + bad);
      (within(middle) ? good : bad) = middle;
    }
    c.max_sample_period = good;
  }
  c.substeps = observer_substeps(s.k1, s.k2, design.L_used, c.sample_period);
  if (!design.proven())
    c.not_proven_reason = design.not_proven_reason;
  else if (!sensitivity_proven)
    c.not_proven_reason = "the position sensitivity C_q is an estimate";
  else if (!s.certified)
    c.not_proven_reason = "the design certifies no rate";
  return c;
}

}  // namespace obsgain

namespace obsgain {

namespace {

TradeoffPoint tradeoff_point(const Design& d, double model_gain, double d_norm) {
  const CertificateSummary& s = d.selected();
  const double inf = std::numeric_limits<double>::infinity();
  TradeoffPoint p{s.theta, d.alpha, s.envelope_gamma, s.k, inf, inf};
  if (s.certified) {
    const SampledErrorBounds b = sampled_error_bounds(s.P, s.envelope_gamma, s.k1, s.k2, model_gain, d_norm);
    p.position_norm = b.position_norm;
    p.velocity_norm = b.velocity_norm;
  }
  return p;
}

// The options of the rate design evaluated at one gain (α, θ), β as the design has it.
DesignOptions at_gain(const DesignOptions& options, double beta, double alpha, double theta) {
  DesignOptions o = options;
  o.gamma.reset();
  o.theta = theta;
  o.optimize_shape = false;
  o.alpha = alpha;
  o.beta = beta;
  o.deployment.reset();
  o.objective = DesignObjective::rate;
  return o;
}

}  // namespace

Design deployed_design(const Model& model, const BoundReport& bounds, const DesignOptions& options,
                       const BoundBracket& sensitivity) {
  const DeploymentOptions& deployment = *options.deployment;
  DesignOptions rate_options = options;
  rate_options.deployment.reset();
  rate_options.objective = DesignObjective::rate;
  // The rate design: the smallest θ (and with --optimize-shape the α) that certifies the target.
  const Design base = design_from_bounds(model, bounds, rate_options);
  const double model_gain = model_gain_upper(bounds.M0.value, sensitivity.upper);
  const double d_norm = norm_upper(measurement_error_bound(deployment, bounds.velocity_bounds, deployment.sample_period));
  const auto evaluate = [&](double alpha, double theta) {
    return design_from_bounds(model, bounds, at_gain(options, base.beta, alpha, theta));
  };
  const auto admissible = [&](const Design& d) {
    return d.selected().certified && (!options.gamma || d.selected().envelope_gamma >= *options.gamma);
  };

  Design chosen = base;
  const double theta_min = base.selected().theta;
  // The trade-off the user chooses along: the ultimate errors from the smallest certifying θ up, at the rate
  // design's α (the velocity-error search below may move α, and then sweeps again).
  const auto sweep = [&](double alpha) {
    std::vector<TradeoffPoint> points;
    for (int j = 0; j <= 8; ++j) {
      const Design d = evaluate(alpha, theta_min * std::pow(20.0, j / 8.0));
      if (admissible(d)) points.push_back(tradeoff_point(d, model_gain, d_norm));
    }
    return points;
  };
  std::vector<TradeoffPoint> tradeoff = sweep(base.alpha);
  if (options.objective == DesignObjective::velocity_error && base.selected().certified) {
    // A log grid in θ from the rate design's θ up (and in α around its α with --optimize-shape), then golden
    // section in log θ around the best point. The ultimate error is not convex in general, and slightly rough
    // (P minimises k numerically at every θ): the grid finds the basin, the section its floor, and the answer is
    // the best point evaluated anywhere, the sweep's included.
    double best_error = tradeoff_point(base, model_gain, d_norm).velocity_norm;
    double best_alpha = base.alpha, best_theta = theta_min;
    const auto consider = [&](double alpha, double theta) {
      const Design d = evaluate(alpha, theta);
      const double error = admissible(d) ? tradeoff_point(d, model_gain, d_norm).velocity_norm
                                         : std::numeric_limits<double>::infinity();
      if (error < best_error) {
        best_error = error;
        best_alpha = alpha;
        best_theta = theta;
      }
      return error;
    };
    std::vector<double> alphas{base.alpha};
    if (options.optimize_shape)
      for (int k = -4; k <= 4; ++k)
        if (k != 0) alphas.push_back(base.alpha * std::pow(2.0, 0.5 * k));
    const double span = 30.0, grid = 24;
    for (const double alpha : alphas)
      for (int j = 0; j <= grid; ++j) consider(alpha, theta_min * std::pow(span, j / grid));
    const auto adopt = [&](const std::vector<TradeoffPoint>& points) {
      for (const TradeoffPoint& p : points)
        if (p.velocity_norm < best_error) best_error = p.velocity_norm, best_alpha = p.alpha, best_theta = p.theta;
    };
    adopt(tradeoff);
    const double step = std::pow(span, 1.0 / grid), section_alpha = best_alpha;
    double lo = std::log(std::max(theta_min, best_theta / step)), hi = std::log(best_theta * step);
    const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
    const auto error_at = [&](double log_theta) { return consider(section_alpha, std::exp(log_theta)); };
    double a = hi - ratio * (hi - lo), b = lo + ratio * (hi - lo);
    double fa = error_at(a), fb = error_at(b);
    for (int i = 0; i < 40 && hi - lo > 1e-6; ++i) {
      if (fa <= fb) {
        hi = b, b = a, fb = fa;
        a = hi - ratio * (hi - lo), fa = error_at(a);
      } else {
        lo = a, a = b, fa = fb;
        b = lo + ratio * (hi - lo), fb = error_at(b);
      }
    }
    if (best_alpha != base.alpha) {
      tradeoff = sweep(best_alpha);
      adopt(tradeoff);
    }
    chosen = evaluate(best_alpha, best_theta);
    // Report θ* for the target, as a rate design does, and the shape search that preceded.
    chosen.target_gamma = options.gamma;
    chosen.shape = base.shape;
    chosen.tight.theta_star = tight_theta_star(chosen.alpha, chosen.beta, *options.gamma, chosen.L_used);
    chosen.paper.theta_star = paper_theta_star(chosen.lyapunov.S_norm, *options.gamma, chosen.L_used);
  }
  chosen.objective = options.objective;
  chosen.deployment = deployment_certificate(chosen, deployment, sensitivity, true);
  chosen.tradeoff = tradeoff;
  const TradeoffPoint own = tradeoff_point(chosen, model_gain, d_norm);
  if (std::none_of(chosen.tradeoff.begin(), chosen.tradeoff.end(),
                   [&](const TradeoffPoint& p) { return std::abs(p.theta - own.theta) <= 1e-9 * own.theta; }))
    chosen.tradeoff.push_back(own);
  std::sort(chosen.tradeoff.begin(), chosen.tradeoff.end(),
            [](const TradeoffPoint& a, const TradeoffPoint& b) { return a.theta < b.theta; });
  return chosen;
}

}  // namespace obsgain
