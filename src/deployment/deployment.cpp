#include "obsgain/deployment/deployment.hpp"

#include "obsgain/certificate/certificate.hpp"
#include "obsgain/numerics/optimize.hpp"
#include "obsgain/numerics/spectrum.hpp"
#include "obsgain/runtime/observer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
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

// What the bounds need of P's geometry, each proven (numerics/spectrum.hpp): the blocks' extreme eigenvalues, and
// the squared half-axes of the ellipsoid eᵀPe <= 1 along the positions and the velocities, λmax((P⁻¹)_qq) =
// 1 / λmin(P_qq - P_qv P_vv⁻¹ P_vq) and likewise. μ is a lower bound of the Schur complement's λmin exactly when
// P - μ [[I, 0], [0, 0]] ⪰ 0: a floating estimate, shrunk, then checked.
struct EllipsoidGeometry {
  double qq = 0.0, qv = 0.0, vv = 0.0, smallest = 0.0;  // λmax(P_qq), ||P_qv||, λmax(P_vv), λmin(P)
  double measurement = 0.0;  // λmax(GᵀPG), G = (k1 I, k2 I): what a measurement error η costs in V
  double position_axis2 = kInfinity, velocity_axis2 = kInfinity;
};

double schur_lower(const Eigen::MatrixXd& P, int n, bool positions) {
  const int a = positions ? 0 : n, b = positions ? n : 0;
  const Eigen::MatrixXd Paa = P.block(a, a, n, n), Pab = P.block(a, b, n, n), Pbb = P.block(b, b, n, n);
  const Eigen::MatrixXd schur = Paa - Pab * Pbb.ldlt().solve(Pab.transpose());
  const double estimate = symmetric_eigenvalues(schur)(0);
  for (double shrink = 1e-9; shrink < 0.5 && estimate > 0.0; shrink *= 10.0) {
    const double mu = estimate * (1.0 - shrink);
    Eigen::MatrixXd shifted = P;
    shifted.block(a, a, n, n).diagonal().array() -= mu;
    if (smallest_eigenvalue_lower(shifted) >= 0.0) return mu;
  }
  return 0.0;
}

// GᵀPG = k1² P_qq + k1 k2 (P_qv + P_vq) + k2² P_vv in interval arithmetic: its terms nearly cancel when P is
// correlated, so the rounding of forming it must be counted.
double measurement_gain_upper(const Eigen::MatrixXd& P, double k1, double k2) {
  const int n = static_cast<int>(P.rows() / 2);
  const Interval a(k1), b(k2);
  IntervalMatrix S(n, n);
  for (int j = 0; j < n; ++j)
    for (int i = j; i < n; ++i)
      S(i, j) = square(a) * Interval(P(i, j)) + a * b * (Interval(P(i, n + j)) + Interval(P(n + i, j))) +
                square(b) * Interval(P(n + i, n + j));
  return largest_eigenvalue_upper_over(S);
}

EllipsoidGeometry ellipsoid_geometry(const Eigen::MatrixXd& P, double k1, double k2) {
  const int n = static_cast<int>(P.rows() / 2);
  EllipsoidGeometry g;
  g.measurement = measurement_gain_upper(P, k1, k2);
  g.qq = largest_eigenvalue_upper(P.topLeftCorner(n, n));
  g.qv = spectral_norm_upper(P.topRightCorner(n, n));
  g.vv = largest_eigenvalue_upper(P.bottomRightCorner(n, n));
  g.smallest = smallest_eigenvalue_lower(P);
  const UpwardRounding upward;
  for (const bool positions : {true, false}) {
    const double mu = schur_lower(P, n, positions);
    (positions ? g.position_axis2 : g.velocity_axis2) = mu > 0.0 ? (Interval(1.0) / Interval(mu)).upper() : kInfinity;
  }
  return g;
}

}  // namespace

std::optional<DeploymentOptions> deployment_options(const DeploymentRequest& r) {
  if (!r.sample_period && !r.encoder_counts && !r.acceleration_bounds && !r.latency && !r.velocity_error_tolerance) {
    if (r.objective == DesignObjective::velocity_error)
      throw InputError("--objective velocity-error needs a deployment: --sample-period, --encoder-counts, --acceleration-bounds");
    return std::nullopt;
  }
  if (!r.sample_period || !r.encoder_counts || !r.acceleration_bounds)
    throw InputError("a deployment needs all three of --sample-period, --encoder-counts and --acceleration-bounds");
  DeploymentOptions d;
  d.sample_period = *r.sample_period;
  d.encoder_resolution = encoder_resolution_from_counts(*r.encoder_counts);
  d.acceleration_bounds = *r.acceleration_bounds;
  d.latency = r.latency.value_or(d.latency);
  d.velocity_error_tolerance = r.velocity_error_tolerance.value_or(d.velocity_error_tolerance);
  d.objective = r.objective;
  return d;
}

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

SampledErrorBounds sampled_error_bounds(const CertifiedObserver& o, double model_gain, double d_norm) {
  const EllipsoidGeometry g = ellipsoid_geometry(o.P, o.k1, o.k2);
  const UpwardRounding upward;
  using boost::numeric::sqrt;
  const Interval dn(d_norm);
  const Interval a = Interval(o.k1) * dn, b = (Interval(o.k2) + Interval(model_gain)) * dn;
  // Two bounds of ||P^½ w||, w = (k1 η, k2 η + ψ), each proven; the smaller is kept (docs/theory.md, "Deployment").
  // Blockwise: over ||w_q|| <= a, ||w_v|| <= b, the cross term at most ||P_qv|| a b by Cauchy–Schwarz.
  const Interval blockwise = sqrt(Interval(g.qq) * square(a) + 2.0 * Interval(g.qv) * a * b + Interval(g.vv) * square(b));
  // Structured: ||P^½ (k1, k2) η|| + ||P^½ (0, ψ)||, which keeps the cancellation between k1 η and k2 η.
  const Interval structured = sqrt(Interval(g.measurement)) * dn + sqrt(Interval(g.vv)) * Interval(model_gain) * dn;
  const Interval level = Interval(std::min(blockwise.upper(), structured.upper())) / Interval(o.gamma);
  SampledErrorBounds s;
  s.disturbance_position = a.upper();
  s.disturbance_velocity = b.upper();
  s.level = level.upper();
  s.offset = g.smallest > 0.0 ? (level / sqrt(Interval(g.smallest))).upper() : kInfinity;
  s.position_norm = std::isfinite(g.position_axis2) ? (level * sqrt(Interval(g.position_axis2))).upper() : kInfinity;
  s.velocity_norm = std::isfinite(g.velocity_axis2) ? (level * sqrt(Interval(g.velocity_axis2))).upper() : kInfinity;
  return s;
}

namespace {

// The largest T <= 1 s whose certified ultimate velocity error stays within the tolerance (it grows with T through
// A T² / 8): a bisection, 0 when even T -> 0 is beyond it.
double largest_sample_period(const std::function<double(double)>& velocity_error_at, double tolerance) {
  const auto within = [&](double T) { return velocity_error_at(T) <= tolerance; };
  if (!within(0.0)) return 0.0;
  double good = 0.0, bad = 1.0;
  if (within(bad)) return bad;
  for (int i = 0; i < 100 && bad - good > 1e-12 * bad; ++i) {
    const double middle = 0.5 * (good + bad);
    (within(middle) ? good : bad) = middle;
  }
  return good;
}

}  // namespace

DeploymentCertificate deployment_certificate(const Design& design, const DeploymentOptions& options,
                                             const BoundBracket& sensitivity, bool sensitivity_proven) {
  const CertifiedObserver& o = design.selected().observer;
  DeploymentCertificate c;
  c.sample_period = options.sample_period;
  c.latency = options.latency;
  c.encoder_resolution = options.encoder_resolution;
  c.acceleration_bounds = options.acceleration_bounds;
  c.position_sensitivity = sensitivity;
  c.M0 = design.bounds.M0.value;
  c.model_gain = model_gain_upper(c.M0, sensitivity.upper);
  c.gamma = o.gamma;
  c.k = o.k;
  const auto bounds_at = [&](double T) {
    return sampled_error_bounds(o, c.model_gain, norm_upper(measurement_error_bound(options, design.velocity_bounds, T)));
  };
  c.measurement_error = measurement_error_bound(options, design.velocity_bounds, c.sample_period);
  c.bounds = bounds_at(c.sample_period);
  // Each joint's error is a component of the vector: at most the norm's bound.
  c.ultimate_position_error = Eigen::VectorXd::Constant(design.dof, c.bounds.position_norm);
  c.ultimate_velocity_error = Eigen::VectorXd::Constant(design.dof, c.bounds.velocity_norm);
  c.velocity_error_tolerance =
      options.velocity_error_tolerance > 0.0 ? options.velocity_error_tolerance : design.velocity_bounds.minCoeff();
  if (o.certified)
    c.max_sample_period = largest_sample_period([&](double T) { return bounds_at(T).velocity_norm; }, c.velocity_error_tolerance);
  c.substeps = observer_substeps(o.k1, o.k2, design.L_used, c.sample_period);
  if (!design.proven())
    c.not_proven_reason = design.not_proven_reason;
  else if (!sensitivity_proven)
    c.not_proven_reason = "the position sensitivity C_q is an estimate";
  else if (!o.certified)
    c.not_proven_reason = "the design certifies no rate";
  return c;
}

namespace {

// The search of the velocity-error objective, over designs that differ only in their gain (α, θ).
class GainSearch {
 public:
  GainSearch(const Model& model, const BoundReport& bounds, const DesignOptions& options, const Design& rate_design,
             double model_gain, double d_norm)
      : model_(model), bounds_(bounds), options_(options), base_(rate_design), model_gain_(model_gain), d_norm_(d_norm) {}

  Design evaluate(double alpha, double theta) const {
    DesignOptions o = options_;
    o.gamma.reset();
    o.theta = theta;
    o.optimize_shape = false;
    o.alpha = alpha;
    o.beta = base_.beta;
    return design_from_bounds(model_, bounds_, o);
  }

  // The sampled bounds of a design that still certifies the target rate; +∞ for one that does not.
  TradeoffPoint point(const Design& d) const {
    const CertifiedObserver& o = d.selected().observer;
    TradeoffPoint p{o, kInfinity, kInfinity};
    if (o.certified && (!options_.gamma || o.gamma >= *options_.gamma)) {
      const SampledErrorBounds b = sampled_error_bounds(o, model_gain_, d_norm_);
      p.position_norm = b.position_norm;
      p.velocity_norm = b.velocity_norm;
    }
    return p;
  }

  // The trade-off the user chooses along: the ultimate errors from the smallest certifying θ up to 20 times it.
  std::vector<TradeoffPoint> sweep(double alpha) const {
    std::vector<TradeoffPoint> points;
    for (int j = 0; j <= 8; ++j) {
      const TradeoffPoint p = point(evaluate(alpha, theta_min() * std::pow(20.0, j / 8.0)));
      if (std::isfinite(p.velocity_norm)) points.push_back(p);
    }
    return points;
  }

  double theta_min() const { return base_.selected().observer.theta; }

 private:
  const Model& model_;
  const BoundReport& bounds_;
  const DesignOptions& options_;
  const Design& base_;
  double model_gain_, d_norm_;
};

// The (α, θ) with the smallest certified ultimate velocity error. The error is not convex in general, and slightly
// rough (P minimises k numerically at every θ): a log grid in θ from the rate design's θ up to 30 times it (and in
// α around its α by factors of √2 with --optimize-shape) finds the basin, golden section in log θ its floor, and
// the answer is the best point evaluated anywhere, the sweep's included.
TradeoffPoint least_velocity_error(const GainSearch& search, const Design& base, bool optimize_shape,
                                   const std::vector<TradeoffPoint>& sweep) {
  TradeoffPoint best = search.point(base);
  const auto consider = [&](const TradeoffPoint& p) {
    if (p.velocity_norm < best.velocity_norm) best = p;
    return p.velocity_norm;
  };
  std::vector<double> alphas{base.alpha};
  if (optimize_shape)
    for (int k = -4; k <= 4; ++k)
      if (k != 0) alphas.push_back(base.alpha * std::pow(2.0, 0.5 * k));
  const double span = 30.0, grid = 24;
  for (const double alpha : alphas)
    for (int j = 0; j <= grid; ++j) consider(search.point(search.evaluate(alpha, search.theta_min() * std::pow(span, j / grid))));
  for (const TradeoffPoint& p : sweep) consider(p);
  const double step = std::pow(span, 1.0 / grid), alpha = best.observer.alpha, theta = best.observer.theta;
  minimize_golden([&](double log_theta) { return consider(search.point(search.evaluate(alpha, std::exp(log_theta)))); },
                  std::log(std::max(search.theta_min(), theta / step)), std::log(theta * step), 1e-6, 40);
  return best;
}

// The deployment of an already chosen design: C_q's bracket, the objective's gain, the certificate, the sweep.
DeployedDesign deploy(const Model& model, const BoundReport& bounds, const DesignOptions& options,
                      const DeploymentOptions& deployment, const BoundBracket& sensitivity) {
  const double model_gain = model_gain_upper(bounds.M0.value, sensitivity.upper);
  DesignOptions sampled = options;
  if (!sampled.sampled_floor) sampled.sampled_floor.emplace();
  sampled.sampled_floor->model_gain = model_gain;
  const Design base = design_from_bounds(model, bounds, sampled);
  if (!base.unfinished.empty()) return {base, std::nullopt};  // no rate, nothing to deploy
  const double d_norm = norm_upper(measurement_error_bound(deployment, bounds.velocity_bounds, deployment.sample_period));
  const GainSearch search(model, bounds, sampled, base, model_gain, d_norm);
  DeployedDesign result{base, Deployment{}};
  Deployment& dep = *result.deployment;
  dep.objective = deployment.objective;
  // The polytopic certificate's sweep would be a search of SDPs per point: its deployment is the design's own.
  if (base.certificate != CertificateKind::polytopic) dep.tradeoff = search.sweep(base.alpha);
  if (deployment.objective == DesignObjective::velocity_error && base.selected().observer.certified) {
    TradeoffPoint best = least_velocity_error(search, base, options.optimize_shape, dep.tradeoff);
    if (best.observer.alpha != base.alpha) {  // the sweep follows the chosen shape, and may hold a better point
      dep.tradeoff = search.sweep(best.observer.alpha);
      for (const TradeoffPoint& p : dep.tradeoff)
        if (p.velocity_norm < best.velocity_norm) best = p;
    }
    Design& chosen = result.design;
    chosen = search.evaluate(best.observer.alpha, best.observer.theta);
    // Report θ* for the target, as a rate design does, and the shape search that preceded.
    chosen.target_gamma = options.gamma;
    chosen.shape = base.shape;
    chosen.tight.theta_star = tight_theta_star(chosen.alpha, chosen.beta, *options.gamma, chosen.L_used);
    if (chosen.scaled)
      chosen.scaled->theta_star = tight_theta_star(chosen.alpha, chosen.beta, *options.gamma, chosen.bounds.L_scaled.value);
    chosen.paper.theta_star = paper_theta_star(chosen.lyapunov.S_norm, *options.gamma, chosen.L_used);
  }
  dep.certificate = deployment_certificate(result.design, deployment, sensitivity, true);
  const TradeoffPoint own = search.point(result.design);
  if (std::none_of(dep.tradeoff.begin(), dep.tradeoff.end(), [&](const TradeoffPoint& p) {
        return std::abs(p.observer.theta - own.observer.theta) <= 1e-9 * own.observer.theta;
      }))
    dep.tradeoff.push_back(own);
  std::sort(dep.tradeoff.begin(), dep.tradeoff.end(),
            [](const TradeoffPoint& a, const TradeoffPoint& b) { return a.observer.theta < b.observer.theta; });
  return result;
}

// One value stands for every joint.
DeploymentOptions per_joint(DeploymentOptions options, int dof) {
  for (Eigen::VectorXd* values : {&options.encoder_resolution, &options.acceleration_bounds})
    if (values->size() == 1) *values = Eigen::VectorXd::Constant(dof, (*values)(0));
  return options;
}

// C_q's search: its own gap, and a tenth of the design's bound budget within [1, 60] s unless given.
CertifiedOptions sensitivity_options(const DesignOptions& design, const DeploymentOptions& deployment) {
  CertifiedOptions o = design.certified_bounds;
  o.relative_gap = deployment.sensitivity_gap;
  const double budget = design.certified_bounds.budget_seconds;
  o.budget_seconds = deployment.sensitivity_budget_seconds.value_or(budget > 0.0 ? std::clamp(0.1 * budget, 1.0, 60.0) : 60.0);
  return o;
}

// The rate objective without a certificate named: the default (the scaled certificate where its θ is smaller), unless
// its floor exceeds the tolerance where the tight certificate's is within it; the tight one is then used, and a note
// says why (Pendubot at 1 kHz, 4096 counts, a tolerance of 8: scaled θ 33.03 gives 9.48 rad/s, tight θ 65.67 gives 6.97).
DeployedDesign deploy_within_tolerance(const Model& model, const BoundReport& bounds, const DesignOptions& options,
                                       const DeploymentOptions& deployment, const BoundBracket& sensitivity) {
  const auto within = [](const DeployedDesign& d) {
    return d.deployment && d.design.selected().observer.certified && d.deployment->certificate.within_tolerance();
  };
  DeployedDesign chosen = deploy(model, bounds, options, deployment, sensitivity);
  if (within(chosen) || chosen.design.certificate != CertificateKind::scaled) return chosen;
  DesignOptions tight = options;
  tight.certificate = CertificateKind::tight;
  DeployedDesign other = deploy(model, bounds, tight, deployment, sensitivity);
  if (!within(other)) return chosen;
  other.design.notes.push_back(fmt::format(
      "rate objective: the scaled certificate's θ = {:.6g} certifies an ultimate velocity error of {:.4g} rad/s, above "
      "the tolerance {:.4g}; the tight certificate's θ = {:.6g} certifies {:.4g} and is used",
      chosen.design.selected().observer.theta, chosen.deployment->certificate.bounds.velocity_norm,
      chosen.deployment->certificate.velocity_error_tolerance, other.design.selected().observer.theta,
      other.deployment->certificate.bounds.velocity_norm));
  return other;
}

// The velocity-error objective asks for the smallest floor: without a certificate named, the tight and the scaled
// certificate are each searched and the lower floor is kept (the scaled one's smaller θ comes with the geometry of
// P₂ ⊗ TᵀT, which can raise the floor; docs/theory.md, "Similarity scaling").
DeployedDesign deploy_best(const Model& model, const BoundReport& bounds, const DesignOptions& options,
                           const DeploymentOptions& deployment, const BoundBracket& sensitivity) {
  if (options.certificate || !bounds.scaled()) return deploy(model, bounds, options, deployment, sensitivity);
  if (deployment.objective != DesignObjective::velocity_error)
    return deploy_within_tolerance(model, bounds, options, deployment, sensitivity);
  DesignOptions tight = options, scaled = options;
  tight.certificate = CertificateKind::tight;
  scaled.certificate = CertificateKind::scaled;
  DeployedDesign a = deploy(model, bounds, tight, deployment, sensitivity);
  DeployedDesign b = deploy(model, bounds, scaled, deployment, sensitivity);
  const auto floor = [](const DeployedDesign& d) {
    return d.deployment && d.design.selected().observer.certified ? d.deployment->certificate.bounds.velocity_norm : kInfinity;
  };
  return floor(b) < floor(a) ? b : a;
}

// The velocity-error objective with the polytopic certificate: a search of SDPs at every gain would take minutes, so
// the norm-bound search chooses the gain, and at that gain the polytopic P and its rate (at least the target, up to
// the largest θ proves) are chosen for the floor. The lower of the two floors is kept, and the choice is said.
DeployedDesign deploy_polytopic(const Model& model, const BoundReport& bounds, const DesignOptions& options,
                                const DeploymentOptions& deployment, const BoundBracket& sensitivity) {
  DesignOptions norm_bound = options;
  norm_bound.certificate.reset();
  DeployedDesign searched = deploy_best(model, bounds, norm_bound, deployment, sensitivity);
  const CertifiedObserver& gain = searched.design.selected().observer;
  if (!searched.deployment || !gain.certified) return searched;
  DesignOptions at = options;
  at.gamma.reset();
  at.theta = gain.theta;
  at.alpha = gain.alpha;
  at.beta = gain.beta;
  at.optimize_shape = false;
  at.sampled_floor = DesignOptions::SampledFloor{.lowest_rate = *options.gamma};  // deploy() adds the model gain
  DeploymentOptions rate = deployment;
  rate.objective = DesignObjective::rate;
  DeployedDesign polytopic = deploy(model, bounds, at, rate, sensitivity);
  const CertifiedObserver& chosen = polytopic.design.selected().observer;
  // A polytopic design that fell back (no proven polytope, a failed check) has no polytopic P to offer.
  const bool proven = polytopic.design.certificate == CertificateKind::polytopic && chosen.certified;
  const double floor = polytopic.deployment && proven && chosen.gamma >= *options.gamma
                           ? polytopic.deployment->certificate.bounds.velocity_norm
                           : kInfinity;
  const double norm_bound_floor = searched.deployment->certificate.bounds.velocity_norm;
  DeployedDesign& kept = floor < norm_bound_floor ? polytopic : searched;
  kept.deployment->objective = DesignObjective::velocity_error;
  kept.design.target_gamma = options.gamma;
  const std::string polytopic_result =
      std::isfinite(floor) ? fmt::format("the polytopic P certifies an ultimate velocity error of {:.4g} rad/s", floor)
      : proven            ? fmt::format("the polytopic P certifies only γ = {:.4g}", chosen.gamma)
      : polytopic.design.polytopic ? "the polytopic certificate proves nothing (" + polytopic.design.polytopic->status + ")"
                                   : "the polytopic certificate proves nothing (no proven polytope)";
  kept.design.notes.push_back(fmt::format(
      "velocity-error objective: the gain θ = {:.6g} from the {} certificate's search; at it {}, the {} certificate "
      "{:.4g} rad/s: the {} is used",
      gain.theta, to_string(searched.design.certificate), polytopic_result, to_string(searched.design.certificate),
      norm_bound_floor, floor < norm_bound_floor ? "polytopic P" : "norm-bound certificate"));
  return kept;
}

}  // namespace

DeployedDesign design_observer(const Model& model, const DesignOptions& options,
                               const std::optional<DeploymentOptions>& requested) {
  if (!requested) return {design_gains(model, options), std::nullopt};
  validate_design_options(options);
  const DeploymentOptions deployment = per_joint(*requested, model.dof());
  validate_deployment_options(deployment, model.dof());
  if (const std::string why = sensitivity_unavailable(model); !why.empty())
    throw InputError("--sample-period: the sampled certificate needs C_q on intervals, but " + why);
  if (deployment.objective == DesignObjective::velocity_error && !options.gamma)
    throw InputError("--objective velocity-error needs --gamma: the rate the design must still certify");
  const auto start = std::chrono::steady_clock::now();
  const Eigen::VectorXd V = requested_velocity_bounds(model, options);
  std::vector<std::string> warnings;
  const BoundReport bounds = design_bounds(model, V, options, warnings);
  const CertifiedOptions sensitivity = sensitivity_options(options, deployment);
  if (options.progress)
    options.progress(fmt::format("deployment: position sensitivity C_q, interval branch and bound, budget {:g} s",
                                 sensitivity.budget_seconds));
  const auto C_q = certify_position_sensitivity(model, V, deployment.acceleration_bounds, sensitivity);
  DeployedDesign result =
      deployment.objective == DesignObjective::velocity_error && options.certificate == CertificateKind::polytopic
          ? deploy_polytopic(model, bounds, options, deployment, *C_q)
          : deploy_best(model, bounds, options, deployment, *C_q);
  result.design.warnings.insert(result.design.warnings.begin(), warnings.begin(), warnings.end());
  result.design.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::string unmet_request(const DeployedDesign& result, const DesignOptions& options) {
  if (result.deployment && result.design.selected().observer.certified &&
      !result.deployment->certificate.within_tolerance()) {
    const DeploymentCertificate& dep = result.deployment->certificate;
    return fmt::format("at T = {:g} s the certified ultimate velocity error {:.4g} exceeds the tolerance {:.4g} ({})",
                       dep.sample_period, dep.bounds.velocity_norm, dep.velocity_error_tolerance,
                       dep.max_sample_period > 0.0
                           ? fmt::format("largest sample period within it: {:.4g} s", dep.max_sample_period)
                           : fmt::format("no sample period is within it at these gains and encoders: try {}finer "
                                         "encoders or --velocity-error-tolerance",
                                         result.deployment->objective == DesignObjective::velocity_error
                                             ? ""
                                             : "--objective velocity-error, "));
  }
  return unmet_request(result.design, options);
}

}  // namespace obsgain
