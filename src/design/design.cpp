#include "obsgain/design/design.hpp"

#include "obsgain/bounds/certified_bounds.hpp"
#include "obsgain/certificate/certificate.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/optimize.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

namespace obsgain {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

// The observer at gain θ of the design's shape, before anything is certified about it.
CertifiedObserver observer_at(const Design& d, CertificateKind kind, double theta) {
  CertifiedObserver o;
  o.certificate = kind;
  o.alpha = d.alpha;
  o.beta = d.beta;
  o.theta = theta;
  o.k1 = theta * d.alpha;
  o.k2 = theta * theta * d.beta;
  o.L = d.L_used;
  o.velocity_bounds = d.velocity_bounds;
  o.P = Eigen::MatrixXd::Zero(2 * d.dof, 2 * d.dof);
  return o;
}

CertificateSummary paper_summary(const Design& d, std::optional<double> target, std::optional<double> theta) {
  CertificateSummary s;
  const double S_norm = d.lyapunov.S_norm;
  s.theta_star = paper_theta_star(S_norm, target.value_or(0.0), d.L_used);
  s.observer = observer_at(d, CertificateKind::paper, target ? s.theta_star : *theta);
  s.rate = target ? *target : paper_rate(S_norm, s.observer.theta, d.L_used);
  const Eigen::Matrix2d P2 = paper_certificate_matrix(d.lyapunov.S2, s.observer.theta);
  s.observer.gamma = s.rate;
  s.observer.P = per_joint_matrix(P2, d.dof);
  s.observer.k = envelope_constant(P2);
  s.observer.certified = s.rate > 0.0;
  return s;
}

// Similarity scaling applies to the computed L_joint: not to L_paper, nor to the user's own L.
bool scalable(const Design& d) { return d.bounds.scaled() && d.L_source == to_string(LipschitzKind::joint); }

// Of the two norm-bound certificates, the one on the smaller L.
CertificateKind better_norm_bound(const Design& d) {
  return scalable(d) && d.bounds.L_scaled.value < d.L_used ? CertificateKind::scaled : CertificateKind::tight;
}


// The Lipschitz constant the certificate uses: L_T for the scaled one.
double certificate_L(const Design& d, CertificateKind kind) {
  return kind == CertificateKind::scaled ? d.bounds.L_scaled.value : d.L_used;
}

// The bounded-real lemma on L: tight, or scaled (on L_T in the coordinates T e: P = P₂ ⊗ TᵀT in original
// coordinates, whose envelope constant is P₂'s times cond(T); docs/theory.md, "Similarity scaling").
CertificateSummary tight_summary(const Design& d, std::optional<double> target, std::optional<double> theta,
                                 CertificateKind kind = CertificateKind::tight) {
  CertificateSummary s;
  const double m = d.rate_margin, L = certificate_L(d, kind);
  s.theta_star = tight_theta_star(d.alpha, d.beta, target.value_or(0.0), L);
  RiccatiCertificate cert;
  // For a target, θ is solved at γ / (1 - m). Where θ >> γ (a bound far above the attained value) that leaves L·peak
  // at γ within about 2e-6 of 1 (on arm6 5e-3), too close for the Riccati solve; each retry raises θ by the same
  // margin, up to 4 times.
  const double first_theta = target ? tight_theta_star(d.alpha, d.beta, *target / (1.0 - m), L) : *theta;
  for (int retry = 0; retry <= (target ? 4 : 0) && !cert.exists; ++retry) {
    s.observer = observer_at(d, kind, first_theta * std::pow(1.0 + m, retry));
    s.rate = tight_rate(s.observer.k1, s.observer.k2, L);
    s.observer.gamma = target ? *target : s.rate - m * std::abs(s.rate);
    cert = tight_certificate(s.observer.k1, s.observer.k2, L, s.observer.gamma);
  }
  CertifiedObserver& o = s.observer;
  o.L = L;
  if (cert.exists) {
    const Eigen::MatrixXd& T = d.bounds.scaling;
    o.P = kind == CertificateKind::scaled ? scaled_per_joint_matrix(cert.P, T) : per_joint_matrix(cert.P, d.dof);
    o.k = kind == CertificateKind::scaled ? cert.k * condition_number(T) : cert.k;
    s.lmi_max_eig = cert.lmi_max_eig;
  }
  o.certified = cert.exists && o.gamma > 0.0;
  return s;
}

// The observer of a polytopic summary takes the proven certificate's P, k and rate.
void adopt(CertificateSummary& s, const PolytopicCertificate& cert) {
  s.status = cert.status;
  CertifiedObserver& o = s.observer;
  if (cert.exists) {
    o.P = cert.P;
    o.k = cert.k;
    o.gamma = cert.gamma;
  }
  o.certified = cert.exists && o.gamma > 0.0;
}

// The polytopic certificate at the target's smallest θ, or at the given θ for its largest rate (bisections on the SDP
// solver's answer); then the interval check of the P found.
CertificateSummary polytopic_summary(const Design& d, const PerturbationPolytope& polytope, const DesignOptions& options) {
  PolytopicOptions po = options.polytopic;
  po.rate_margin = d.rate_margin;
  CertificateSummary s;
  const std::optional<double> target = options.gamma;
  s.theta_star = target ? polytopic_theta_star(polytope, d.alpha, d.beta, *target, po) : kNaN;
  s.observer = observer_at(d, CertificateKind::polytopic, target ? s.theta_star : *options.theta);
  CertifiedObserver& o = s.observer;
  if (!std::isfinite(o.theta)) {
    s.status = "the SDP solver found no P at any gain up to 1e8";
    return s;
  }
  s.rate = target ? *target : polytopic_rate(polytope, o.k1, o.k2, po);
  o.gamma = target ? *target : s.rate * (1.0 - d.rate_margin);
  const PolytopicCertificate cert =
      options.sampled_floor
          ? polytopic_floor_certificate(
                polytope, o.k1, o.k2,
                target ? o.gamma : std::max(po.floor_lowest_rate_fraction * o.gamma, options.sampled_floor->lowest_rate),
                o.gamma, options.sampled_floor->model_gain, po)
          : polytopic_certificate(polytope, o.k1, o.k2, o.gamma, po);
  adopt(s, cert);
  return s;
}

// --certificate polytopic: the polytope the certificate rests on, its summary in d.polytope.
PerturbationPolytope polytope_for(Design& d, const Model& model, const DesignOptions& options) {
  PolytopeSummary summary;
  const std::string unavailable = certification_unavailable(model);
  PerturbationPolytope polytope;
  if (unavailable.empty()) {
    PolytopeOptions po = options.polytope;
    po.threads = options.certified_bounds.threads;
    polytope = perturbation_polytope(model, d.velocity_bounds, po);
    summary.unproven = polytope.unproven;
  } else {
    summary.unproven = unavailable;
  }
  summary.cells = static_cast<int>(polytope.cells.size());
  summary.vertices = polytope.vertex_count();
  summary.grid = polytope.grid;
  d.polytope = summary;
  return polytope;
}

// --optimize-shape with --certificate polytopic: the same objective on the polytopic certificate, from the norm-bound
// certificate's best α. A step of the search's resolution either way that does not improve it keeps that α; else a
// golden section in log α searches the improving side (docs/theory.md, "Shape optimisation").
void choose_polytopic_shape(Design& d, const PerturbationPolytope& polytope, const DesignOptions& options) {
  PolytopicOptions po = options.polytopic;
  po.rate_margin = d.rate_margin;
  po.relative_tolerance = po.shape_relative_tolerance;
  ShapeReport::Polytopic shape;
  const auto objective = [&](double log_alpha) {
    ++shape.evaluations;
    const double alpha = std::exp(log_alpha);
    if (options.gamma) return polytopic_theta_star(polytope, alpha, d.beta, *options.gamma, po);
    const double theta = *options.theta;
    return -polytopic_rate(polytope, theta * alpha, theta * theta * d.beta, po);
  };
  const double centre = std::log(d.alpha), step = po.shape_log_tolerance, span = std::log(po.shape_span);
  double best_x = centre;
  shape.objective = shape.objective_at_norm_bound_alpha = objective(centre);
  for (const double side : {1.0, -1.0}) {
    const double stepped = objective(centre + side * step);
    if (stepped >= shape.objective) continue;
    best_x = centre + side * step;
    shape.objective = stepped;
    const double far = centre + side * span;
    const ScalarOptimum searched = minimize_golden(objective, std::min(centre, far), std::max(centre, far), step,
                                                   po.shape_iterations);
    if (searched.value < stepped) {
      best_x = searched.x;
      shape.objective = searched.value;
    }
    break;
  }
  shape.alpha = d.alpha = std::exp(best_x);
  d.shape.polytopic = shape;
}

// --certificate polytopic: the certificate on the polytope, and the fall-back to the better norm-bound certificate
// when either fails.
void certify_polytopic(Design& d, const PerturbationPolytope& polytope, const DesignOptions& options) {
  if (polytope.proven()) d.polytopic = polytopic_summary(d, polytope, options);
  if (!d.polytopic || !d.polytopic->observer.certified) {
    d.certificate = better_norm_bound(d);
    d.warnings.push_back(fmt::format("the polytopic certificate failed ({}): the {} certificate is used",
                                     d.polytopic ? d.polytopic->status : "no proven polytope: " + d.polytope->unproven,
                                     to_string(d.certificate)));
  }
}

// The configurations where the bounds' searches found their maxima: the search's first samples.
std::vector<Eigen::VectorXd> bound_maximisers(const Design& d) {
  std::vector<Eigen::VectorXd> seeds;
  for (const BoundMaximum* m : {&d.bounds.L_joint, &d.bounds.M0, &d.bounds.B})
    if (m->q.size() == d.dof) seeds.push_back(m->q);
  return seeds;
}

// Above two joints: the smallest θ the SDP finds a P for on the samples (from the norm-bound certificate's), or the
// largest rate at the given θ; then the proof, retried at a θ one rate margin higher (or a rate one margin lower)
// while it fails (docs/theory.md, "The polytopic certificate by search").
CertificateSummary searched_polytopic_summary(const Design& d, PolytopicSearch& search, const DesignOptions& options) {
  const double m = options.polytopic_search.rate_margin;
  const std::optional<double> target = options.gamma;
  const CertificateSummary& norm = better_norm_bound(d) == CertificateKind::scaled && d.scaled ? *d.scaled : d.tight;
  CertificateSummary s;
  const double from = target && std::isfinite(norm.theta_star) && norm.theta_star > 0.0 ? norm.theta_star : 1.0;
  s.theta_star = target ? search.theta_star(d.alpha, d.beta, *target, from) : kNaN;
  s.observer = observer_at(d, CertificateKind::polytopic, target ? s.theta_star : *options.theta);
  if (!std::isfinite(s.observer.theta)) {
    s.status = "the SDP solver found no P at any gain up to 1e8";
    return s;
  }
  if (!target) s.rate = search.rate(s.observer.k1, s.observer.k2);
  PolytopicCertificate cert;
  for (int retry = 0; retry <= options.polytopic_search.retries && !cert.exists; ++retry) {
    if (target) s.observer = observer_at(d, CertificateKind::polytopic, s.theta_star * std::pow(1.0 + m, retry));
    CertifiedObserver& o = s.observer;
    o.gamma = target ? *target : s.rate * std::pow(1.0 - m, retry + 1);
    if (!(o.gamma > 0.0)) break;
    if (target) s.rate = *target;
    cert = search.certificate(o.k1, o.k2, o.gamma);
  }
  adopt(s, cert);
  return s;
}

// --certificate polytopic above two joints: P chosen on samples and proven by branch and bound.
void certify_polytopic_by_search(Design& d, const Model& model, const DesignOptions& options) {
  PolytopeSummary summary;
  summary.method = "search";
  summary.unproven = certification_unavailable(model);
  if (summary.unproven.empty()) {
    PolytopicSearch search = polytopic_search_for(model, d, options);
    d.polytopic = searched_polytopic_summary(d, search, options);
    const PolytopicSearchReport& r = search.report();
    summary.samples = r.samples;
    summary.cuts = r.cuts;
    summary.proof_boxes = r.proof_boxes;
    summary.refuted = r.refuted;
    summary.proof_work = r.proof_work;
  }
  d.polytope = summary;
  if (!d.polytopic || !d.polytopic->observer.certified) {
    d.certificate = better_norm_bound(d);
    const bool budget_spent = summary.proof_work >= options.polytopic_search.proof_budget;
    d.warnings.push_back(fmt::format("the polytopic certificate failed ({}): the {} certificate is used{}",
                                     d.polytopic ? d.polytopic->status : summary.unproven, to_string(d.certificate),
                                     budget_spent ? " (a larger --proof-budget lets the proof go further; on six and "
                                                    "more joints it needs far more than minutes: docs/theory.md)"
                                                  : ""));
  }
}

}  // namespace

PolytopicSearch polytopic_search_for(const Model& model, const Design& design, const DesignOptions& options) {
  PolytopicSearchOptions po = options.polytopic_search;
  po.threads = options.certified_bounds.threads;
  po.sdp = options.polytopic.sdp;
  return PolytopicSearch(model, design.velocity_bounds, bound_maximisers(design), po);
}

const char* to_string(LipschitzKind kind) { return kind == LipschitzKind::paper ? "paper" : "joint"; }

Design::UsedConstant Design::used_constant() const {
  if (certificate == CertificateKind::polytopic || L_source != to_string(LipschitzKind::joint)) return {};
  if (certificate == CertificateKind::scaled) return {"L_T", &bounds.L_scaled_bracket};
  return {"L_joint", &bounds.L_joint_bracket};
}

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
  const double proof = options.polytopic_search.proof_budget;
  if (!std::isfinite(proof) || proof <= 0.0 || proof > 1e6)
    throw InputError(fmt::format("--proof-budget = {} must lie in (0, 1e6] seconds", proof));
  if (options.polytope.cells < 1 || options.polytope.cells > 4096)
    throw InputError(fmt::format("--polytope-cells = {} must lie in [1, 4096]", options.polytope.cells));
  if (!std::isfinite(options.rate_margin) || options.rate_margin <= 0.0 || options.rate_margin >= 0.5)
    throw InputError(fmt::format("rate margin = {} must lie in (0, 0.5)", options.rate_margin));
}

namespace {

// The Lipschitz constant the certificates use: the computed one the options name, or the user's own.
void choose_lipschitz(Design& d, const BoundReport& bounds, const DesignOptions& options) {
  const double computed = options.lipschitz == LipschitzKind::joint ? bounds.L_joint.value : bounds.L_paper;
  d.L_used = options.L_override.value_or(computed);
  d.L_source = options.L_override ? "override" : to_string(options.lipschitz);
  if (!std::isfinite(d.L_used))
    d.unfinished = fmt::format("L_{} has no finite proven upper bound: the interval search stopped before it could bound "
                               "M(q)⁻¹ on every box (raise --bound-budget; real arms have rotor inertia: "
                               "--armature)",
                               to_string(options.lipschitz));
  if (options.L_override) {
    d.warnings.push_back(fmt::format("L overridden by the user: {} (the model gives L_joint = {:.6g}, L_paper = {:.6g})",
                                     d.L_used, bounds.L_joint.value, bounds.L_paper));
    if (d.L_used < bounds.L_joint.value)
      d.warnings.push_back("the overriding L is below the model's L_joint: the certificate rests on the user's L, "
                           "not on the model");
  }
  // Two local maxima that differ say the estimate may be below the supremum. Certified bounds use their brackets'
  // proven upper ends, whatever the optimisers found: the disagreement is then no warning.
  if (bounds.certified) return;
  const std::pair<const char*, const BoundMaximum*> named[] = {{"M0", &bounds.M0}, {"B", &bounds.B}, {"L_joint", &bounds.L_joint}};
  for (const auto& [name, bound] : named) {
    if (std::abs(bound->global_value - bound->polish_value) > 1e-6 * std::max(bound->global_value, bound->polish_value))
      d.warnings.push_back(fmt::format("bound search: {}: NLopt ({:.10g}) and Ipopt ({:.10g}) disagree beyond 1e-6 (the "
                                       "larger is used; the supremum may be higher: --bounds certified proves it)",
                                       name, bound->global_value, bound->polish_value));
  }
}

// The certificate asked for; unset, the scaled one where its proven L_T is below L_joint (the same lemma on a smaller
// L: a smaller θ for a target and a larger rate at a θ), else the tight one.
void choose_certificate(Design& d, const DesignOptions& options) {
  d.certificate = options.certificate.value_or(better_norm_bound(d));
  if (d.certificate == CertificateKind::scaled && !scalable(d)) {
    d.warnings.push_back(fmt::format("--certificate scaled: {}; the tight certificate is used",
                                     d.L_source != to_string(LipschitzKind::joint)
                                         ? "similarity scaling applies to the computed L_joint only"
                                         : "the bounds kept no similarity scaling (none lowered L_joint's estimate)"));
    d.certificate = CertificateKind::tight;
  } else if (options.certificate == CertificateKind::scaled && d.bounds.L_scaled.value >= d.L_used) {
    // Named, it is used as asked; where L_T's search lost the race it rests on the larger constant.
    d.warnings.push_back(fmt::format("--certificate scaled: L_T = {:.7g} is not below L_joint = {:.7g} (L_T's proof "
                                     "went less far), so the scaled certificate needs the larger theta; without "
                                     "--certificate the better of the two is chosen",
                                     d.bounds.L_scaled.value, d.L_used));
  }
}

// α and β: the options', or with --optimize-shape β = 1 and the α that is best for the certificate (for the polytopic
// one, the tight certificate's: choose_polytopic_shape refines it once the polytope is built, and
// reshape_for_fall_back replaces it when the polytopic certificate falls back).
void choose_shape(Design& d, const DesignOptions& options) {
  d.alpha = options.alpha;
  d.beta = options.beta;
  if (!options.optimize_shape) return;
  d.beta = 1.0;
  if (options.certificate == CertificateKind::paper) {
    d.shape = optimize_alpha("S_norm", [](double a) { return observer_lyapunov(a, 1.0, 1).S_norm; });
  } else if (options.gamma) {
    const double L = certificate_L(d, d.certificate);
    d.shape = optimize_alpha("theta_star", [&](double a) { return tight_theta_star(a, 1.0, *options.gamma, L); });
  } else {
    const double L = certificate_L(d, d.certificate);
    d.shape = optimize_alpha("-gamma", [&](double a) { return -tight_rate(*options.theta * a, *options.theta * *options.theta, L); });
  }
  const bool polish_better = d.shape.objective_polish <= d.shape.objective_global;
  d.alpha = polish_better ? d.shape.alpha_polish : d.shape.alpha_global;
  const double scale = std::max(1.0, std::abs(d.shape.objective_global));
  if (std::abs(d.shape.objective_global - d.shape.objective_polish) > 1e-6 * scale)
    d.warnings.push_back("shape optimisation: NLopt and Ipopt disagree beyond 1e-6");
}

// The paper's and the norm-bound certificates at the design's α and β.
void certify_norm_bound(Design& d, const DesignOptions& options) {
  d.lyapunov = observer_lyapunov(d.alpha, d.beta, d.dof);
  d.paper = paper_summary(d, options.gamma, options.theta);
  d.tight = tight_summary(d, options.gamma, options.theta);
  if (scalable(d)) d.scaled = tight_summary(d, options.gamma, options.theta, CertificateKind::scaled);
}

// --optimize-shape, when the polytopic certificate falls back: the norm-bound certificate used gets its own best α,
// not the one chosen for the polytope (or for the tight certificate, when the scaled one is used). The shape report
// is then that certificate's search; the warning names the α it replaces.
void reshape_for_fall_back(Design& d, const DesignOptions& options) {
  const double polytopic_alpha = d.alpha;
  choose_shape(d, options);
  if (d.alpha == polytopic_alpha) return;
  certify_norm_bound(d, options);
  d.warnings.push_back(fmt::format("--optimize-shape: alpha = {:.6g} is the {} certificate's own best (not {:.6g}, "
                                   "chosen for the polytopic certificate)",
                                   d.alpha, to_string(d.certificate), polytopic_alpha));
}

// The budget at which the search's pace would bring its excess over the value attained down to `wanted`; none past
// DesignOptions::extrapolate_budget_up_to times the budget given.
std::optional<double> budget_for_excess(const BoundBracket& bracket, double pace, double wanted,
                                        const DesignOptions& options) {
  const double excess = bracket.upper - bracket.lower, budget = options.certified_bounds.budget_seconds;
  if (!(wanted > 0.0) || !(pace < 1.0)) return std::nullopt;
  const double doublings = std::log2(wanted / excess) / std::log2(pace);
  if (doublings > std::log2(options.extrapolate_budget_up_to)) return std::nullopt;
  return budget * std::exp2(std::max(doublings, 0.0));
}

// The constant's value below which the selected norm-bound certificate's θ for the target is within
// DesignOptions::theta_within of its θ on the value attained (θ grows with L); none without a target, or when the
// design is within it already.
std::optional<double> L_for_usable_theta(const Design& d, const BoundBracket& bracket, const DesignOptions& options) {
  if (!options.gamma) return std::nullopt;
  const auto theta = [&](double L) { return tight_theta_star(d.alpha, d.beta, *options.gamma / (1.0 - d.rate_margin), L); };
  const double wanted = options.theta_within * theta(bracket.lower);
  double lo = bracket.lower, hi = bracket.upper;
  if (theta(hi) <= wanted) return std::nullopt;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (theta(mid) <= wanted ? lo : hi) = mid;
  }
  return lo;
}

// What the search's pace says a larger budget would buy: its excess per doubling of the work, carried on to the budget
// that brings the bracket within DesignOptions::wide_bracket, and θ within DesignOptions::theta_within of its value on
// the value attained. Extrapolations, and the warning says so.
std::string budget_pace(const Design& d, const BoundBracket& bracket, const DesignOptions& options) {
  const std::optional<double> pace = excess_per_doubling(bracket);
  if (!pace || !(options.certified_bounds.budget_seconds > 0.0)) return "";
  const std::string wide = fmt::format("it within {:.3g} times", options.wide_bracket);
  const std::optional<double> wide_budget =
      budget_for_excess(bracket, *pace, (options.wide_bracket - 1.0) * bracket.lower, options);
  const std::string reach = fmt::format("even --bound-budget {:.3g} ({:.3g} times this one) would not bring ",
                                        options.certified_bounds.budget_seconds * options.extrapolate_budget_up_to,
                                        options.extrapolate_budget_up_to);
  std::string text = fmt::format(
      "; per doubling of its work, its excess over the value attained fell to {:.2g} of itself lately: at that pace {}",
      *pace, wide_budget ? fmt::format("--bound-budget {:.3g} would bring {}", *wide_budget, wide) : reach + wide);
  if (const std::optional<double> L = L_for_usable_theta(d, bracket, options)) {
    const std::string usable = fmt::format("theta within {:.3g} times its value on the value attained", options.theta_within);
    const std::optional<double> usable_budget = budget_for_excess(bracket, *pace, *L - bracket.lower, options);
    if (usable_budget)
      text += fmt::format(", and --bound-budget {:.3g} would bring {}", *usable_budget, usable);
    else
      text += (wide_budget ? ", but " + reach : ", nor ") + usable;
  }
  return text + " (an extrapolation, not a bound)";
}

// A proof far above the value attained is still a proof, but the gains pay for the gap: named for the constant the
// selected certificate rests on, L_T for the scaled one and L_joint for the others (not for a proven polytopic one,
// which rests on its polytope).
void name_a_wide_bracket(Design& d, const DesignOptions& options) {
  const Design::UsedConstant used = d.used_constant();
  if (!d.bounds.certified || !used.bracket) return;
  const BoundBracket& bracket = *used.bracket;
  if (!(bracket.lower > 0.0 && bracket.upper > options.wide_bracket * bracket.lower)) return;
  d.warnings.push_back(fmt::format(
      "{}'s proven upper end {:.6g} is {:.3g} times the value attained ({:.6g}): the certified gains pay for that gap "
      "(a larger --bound-budget narrows it{}){}",
      used.name, bracket.upper, bracket.upper / bracket.lower, bracket.lower,
      d.armature.isZero(0.0) ? "; real arms have rotor inertia: --armature" : "", budget_pace(d, bracket, options)));
}

// The norm-bound certificate (the same lemma, tight on L_joint or scaled on L_T) on a constant's attained value.
Design::AtAttained at_attained_value(const Design& d, const DesignOptions& options, bool on_scaled, double L) {
  const CertifiedObserver& o = d.selected().observer;
  Design::AtAttained a{on_scaled ? "L_T" : "L_joint", on_scaled ? "scaled" : "tight", L};
  a.theta = options.gamma ? tight_theta_star(d.alpha, d.beta, *options.gamma / (1.0 - d.rate_margin), L) : o.theta;
  a.rate = options.gamma ? *options.gamma : tight_rate(o.k1, o.k2, L);
  return a;
}

// The selected norm-bound certificate on its constant's attained value (Design::AtAttained), and the other one on
// its constant's where that does better: with both constants' brackets closed the design would be the better of the
// two, as the numeric estimate's is.
void compare_with_attained(Design& d, const DesignOptions& options) {
  const Design::UsedConstant used = d.used_constant();
  const bool norm_bound = d.certificate == CertificateKind::tight || d.certificate == CertificateKind::scaled;
  if (!d.bounds.certified || !used.bracket || !norm_bound || !(used.bracket->lower > 0.0)) return;
  const bool on_scaled = d.certificate == CertificateKind::scaled;
  d.at_attained = at_attained_value(d, options, on_scaled, used.bracket->lower);
  if (!scalable(d)) return;
  const BoundBracket& other = on_scaled ? d.bounds.L_joint_bracket : d.bounds.L_scaled_bracket;
  if (!(other.lower > 0.0)) return;
  const Design::AtAttained a = at_attained_value(d, options, !on_scaled, other.lower);
  constexpr double same = Design::AtAttained::same_within;
  const bool better = options.gamma ? a.theta < d.at_attained->theta * (1.0 - same)
                                    : a.rate > d.at_attained->rate * (1.0 + same);
  if (better) d.other_at_attained = a;
}

// Both certificates, side by side, and what the selected one proves.
void certify(Design& d, const Model& model, const BoundReport& bounds, const DesignOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const bool polytopic = options.certificate == CertificateKind::polytopic;
  const bool by_search = polytopic && model.dof() > options.polytope.separate_cells_up_to_dof;
  std::optional<PerturbationPolytope> polytope;
  if (polytopic && !by_search) {
    polytope = polytope_for(d, model, options);
    if (options.optimize_shape && polytope->proven()) choose_polytopic_shape(d, *polytope, options);
  }
  certify_norm_bound(d, options);
  if (polytope) certify_polytopic(d, *polytope, options);
  if (by_search) certify_polytopic_by_search(d, model, options);
  if (polytopic) {
    if (options.optimize_shape && d.certificate != CertificateKind::polytopic) reshape_for_fall_back(d, options);
    d.polytope->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  // Both certificates use L alone: proven bounds, or the user's own L, make the certificate a proof.
  if (!bounds.certified && !options.L_override) {
    d.not_proven_reason = options.bound_method == BoundMethod::numeric
                              ? "numeric bounds (--bounds numeric) are lower estimates of the suprema, not proven"
                              : "numeric bounds: " + certification_unavailable(model) + ", so its suprema are estimates";
  }
  name_a_wide_bracket(d, options);
  compare_with_attained(d, options);
  const CertificateSummary& s = d.selected();
  if (!s.observer.certified && s.rate > 0.0) {
    d.warnings.push_back(fmt::format("theta = {:.6g}: the {} certificate's rate {:.6g} is positive, but no certificate "
                                     "matrix P was found at the envelope rate {:.6g} (the Riccati solve fails at these "
                                     "extreme gains): nothing is certified",
                                     s.observer.theta, to_string(d.certificate), s.rate, s.observer.gamma));
  } else if (!s.observer.certified) {
    d.warnings.push_back(fmt::format("theta = {:.6g} certifies no exponential rate with the {} certificate (gamma = {:.6g})",
                                     s.observer.theta, to_string(d.certificate), s.rate));
  }
}

}  // namespace

Design design_from_bounds(const Model& model, const BoundReport& bounds, const DesignOptions& options) {
  validate_design_options(options);
  Design d;
  d.robot_name = model.name;
  d.robot_source = model.source;
  d.dof = model.dof();
  d.notes = model.notes;
  d.armature = armature(model);
  d.robot_fingerprint = model.fingerprint;
  d.velocity_bounds = bounds.velocity_bounds;
  d.bounds = bounds;
  d.certificate = options.certificate.value_or(CertificateKind::tight);
  d.target_gamma = options.gamma;
  d.rate_margin = options.rate_margin;
  choose_lipschitz(d, bounds, options);
  if (!d.unfinished.empty()) return d;  // nothing can be certified on an unbounded L
  choose_certificate(d, options);
  choose_shape(d, options);
  certify(d, model, bounds, options);
  return d;
}

BoundReport design_bounds(const Model& model, const Eigen::VectorXd& V, const DesignOptions& options,
                          std::vector<std::string>& warnings) {
  const auto phase = [&](const std::string& text) {
    if (options.progress) options.progress(text);
  };
  std::vector<std::string> searched;
  for (const int j : configuration_joints(model)) searched.push_back(fmt::format("q{}", j + 1));
  phase(fmt::format("bounds: numeric search over {} (M and C do not depend on the other joints; NLopt DIRECT-L, then Ipopt)",
                    searched.empty() ? std::string("no joint") : fmt::format("{}", fmt::join(searched, ", "))));
  // A similarity scaling serves the scaled certificate only (the polytopic one falls back to it): it is not searched
  // when another certificate is named, or when the certificate rests on L_paper or the user's L.
  BoundOptions bound_options = options.bounds;
  bound_options.threads = options.certified_bounds.threads;
  const bool scalable_request = !options.L_override && options.lipschitz == LipschitzKind::joint &&
                                options.certificate.value_or(CertificateKind::scaled) != CertificateKind::tight &&
                                options.certificate != CertificateKind::paper;
  if (!scalable_request) bound_options.diagonal_scaling = false;
  if (options.certificate == CertificateKind::scaled || options.certificate == CertificateKind::polytopic)
    bound_options.scaling_min_gain = bound_options.named_scaling_min_gain;
  BoundReport bounds = compute_bounds(model, V, bound_options);
  if (options.bound_method == BoundMethod::certified) {
    phase(options.certified_bounds.budget_seconds > 0.0
              ? fmt::format("bounds: interval branch and bound, budget {:g} s (--bound-budget)",
                            options.certified_bounds.budget_seconds)
              : std::string("bounds: interval branch and bound until the 1e-6 gap (no budget)"));
    CertifiedOptions certified_options = options.certified_bounds;
    certified_options.focus = options.lipschitz == LipschitzKind::paper ? LipschitzFocus::paper : LipschitzFocus::joint;
    if (const auto certified = certify_bounds(model, bounds, certified_options)) {
      apply_certified_bounds(bounds, *certified);
    } else {
      warnings.push_back(certification_unavailable(model) +
                         ": numeric bounds used (lower estimates of the suprema); the design is not proven");
    }
  }
  return bounds;
}

std::string unmet_request(const Design& d, const DesignOptions& options) {
  if (!d.unfinished.empty()) return d.unfinished;
  if (!options.gamma) return {};
  if (!d.selected().observer.certified) return fmt::format("the design does not certify gamma = {}", *options.gamma);
  if (!d.proven() && options.bound_method == BoundMethod::certified)
    return fmt::format("gamma = {} is not certified: {} (--bounds numeric accepts an estimate)", *options.gamma,
                       d.not_proven_reason);
  return {};
}

Eigen::VectorXd requested_velocity_bounds(const Model& model, const DesignOptions& options) {
  const Eigen::VectorXd V = options.velocity_bounds.size() ? options.velocity_bounds : model.velocity_bounds;
  if (V.size() == 0)
    throw InputError("model '" + model.name + "' gives no velocity bounds" +
                     (model.missing_velocity_bounds.empty() ? "" : " (" + model.missing_velocity_bounds + ")") +
                     ": pass --vmax V1,...,Vn");
  validate_velocity_bounds(model, V);
  return V;
}

Design design_gains(const Model& model, const DesignOptions& options) {
  validate_design_options(options);
  const auto start = std::chrono::steady_clock::now();
  const Eigen::VectorXd V = requested_velocity_bounds(model, options);
  std::vector<std::string> warnings;
  const BoundReport bounds = design_bounds(model, V, options, warnings);
  Design d = design_from_bounds(model, bounds, options);
  d.warnings.insert(d.warnings.begin(), warnings.begin(), warnings.end());
  d.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return d;
}

}  // namespace obsgain
