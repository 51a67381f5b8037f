#include "obsgain/report/report.hpp"

#include "json.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <tuple>

namespace obsgain {

namespace {

nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json bound_json(const BoundMaximum& m) {
  nlohmann::json j = {{"value", m.value},
                      {"global_value", m.global_value},
                      {"polish_value", m.polish_value},
                      {"argmax_q", to_json(m.q)},
                      {"global_evaluations", m.global_evaluations},
                      {"polish_evaluations", m.polish_evaluations}};
  if (m.velocity_vertex.size()) j["velocity_vertex"] = to_json(m.velocity_vertex);
  if (m.saturation_pattern.size()) j["saturation_pattern"] = to_json(m.saturation_pattern);
  return j;
}

// The text report's note after a bracket: nothing when the gap was reached; else what stopped it, and its pace then.
std::string stop_note(const BoundBracket& b) {
  const std::string reason = stop_text(b.stop).reason, pace = pace_text(b);
  if (reason.empty()) return reason;
  return " (" + reason + (pace.empty() ? pace : "; " + pace) + ")";
}

nlohmann::json bracket_json(const BoundBracket& b) {
  const std::optional<double> pace = excess_per_doubling(b);
  return {{"lower", b.lower}, {"upper", b.upper}, {"argmax_q", to_json(b.argmax)}, {"boxes", b.boxes},
          {"work", b.work},   {"stop", stop_text(b.stop).name}, {"seconds", b.seconds},
          {"excess_per_doubling", pace ? nlohmann::json(*pace) : nlohmann::json(nullptr)}};
}

std::string where(const BoundMaximum& m) {
  std::string s = "q = " + format_vector(m.q);
  if (m.velocity_vertex.size()) s += ", v = " + format_vector(m.velocity_vertex);
  if (m.saturation_pattern.size()) s += ", D = diag" + format_vector(m.saturation_pattern);
  return s;
}

}  // namespace

StopText stop_text(SearchStop stop) {
  switch (stop) {
    case SearchStop::gap: return {"gap", ""};
    case SearchStop::boxes: return {"boxes", "stopped by the box limit"};
    case SearchStop::budget: return {"budget", "stopped by the budget, --bound-budget"};
    case SearchStop::time:
      return {"wall-clock limit", "stopped by the wall-clock safety limit: may differ between runs"};
    case SearchStop::race:
      return {"race", "stopped after its first share: the other constant's upper end was lower"};
  }
  return {"", ""};
}

std::string pace_text(const BoundBracket& bracket) {
  const std::optional<double> pace = excess_per_doubling(bracket);
  return pace ? fmt::format("excess x {:.2g} per doubling of the work", *pace) : std::string();
}

std::string format_vector(const Eigen::VectorXd& v) {
  std::string s = "(";
  for (Eigen::Index i = 0; i < v.size(); ++i) s += fmt::format("{}{:.6g}", i ? ", " : "", v(i));
  return s + ")";
}

std::string format_scaling(const Eigen::MatrixXd& T) {
  if (T.isDiagonal(0.0)) return "diag" + format_vector(T.diagonal());
  std::string s = "[";
  for (Eigen::Index i = 0; i < T.rows(); ++i) {
    const std::string row = format_vector(T.row(i).transpose());  // (a, b, ...)
    s += (i ? ", [" : "[") + row.substr(1, row.size() - 2) + "]";
  }
  return s + "]";
}

std::string shape_summary(const Design& d) {
  if (const auto& p = d.shape.polytopic)
    return fmt::format("shape optimised (beta = 1, minimise {0}): tight certificate NLopt {1:.7f}, Ipopt {2:.7f}; then "
                       "the polytopic certificate's {0} (estimates; a search in log alpha, {3} bisections of SDPs): "
                       "alpha = {4:.7f}, {0} = {5:.6g} ({6:.6g} at the tight alpha)",
                       d.shape.objective, d.shape.alpha_global, d.shape.alpha_polish, p->evaluations, p->alpha,
                       p->objective, p->objective_at_norm_bound_alpha);
  if (d.shape.optimized)
    return fmt::format("shape optimised (beta = 1, minimise {}): alpha = {:.7f} (NLopt {:.7f}, Ipopt {:.7f})",
                       d.shape.objective, d.alpha, d.shape.alpha_global, d.shape.alpha_polish);
  return {};
}

std::vector<ComparisonRow> certificate_comparison(const Design& d) {
  const CertifiedObserver &p = d.paper.observer, &t = d.tight.observer;
  std::vector<ComparisonRow> rows = {
      {d.target_gamma ? "theta* (smallest gain for the target)" : "theta* (any positive rate)", d.paper.theta_star,
       d.tight.theta_star},
      {"theta (chosen)", p.theta, t.theta},
      {"gamma certified at theta", d.paper.rate, d.tight.rate},
      {"envelope rate", p.gamma, t.gamma},
      {"k (envelope constant)", p.k, t.k},
      {"k1 = theta alpha", p.k1, t.k1},
      {"k2 = theta^2 beta", p.k2, t.k2}};
  const auto column = [&](const CertificateSummary& s, std::optional<double> ComparisonRow::*cell) {
    const std::vector<double> values = {s.theta_star, s.observer.theta, s.rate, s.observer.gamma, s.observer.k,
                                        s.observer.k1, s.observer.k2};
    for (std::size_t i = 0; i < rows.size(); ++i) rows[i].*cell = values[i];
  };
  if (d.scaled) column(*d.scaled, &ComparisonRow::scaled);
  if (d.polytopic) {
    column(*d.polytopic, &ComparisonRow::polytopic);
    // A polytopic P that was not proven certifies nothing: its rows "gamma certified at theta", "envelope rate" and
    // "k" held the target asked and no k, not results.
    if (!d.polytopic->observer.certified)
      for (std::size_t i : {2u, 3u, 4u}) rows[i].polytopic = std::numeric_limits<double>::quiet_NaN();
  }
  return rows;
}

nlohmann::json to_json(const Eigen::MatrixXd& matrix) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index j = 0; j < matrix.cols(); ++j) row.push_back(matrix(i, j));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json to_json(const Eigen::VectorXd& vector) {
  nlohmann::json values = nlohmann::json::array();
  for (Eigen::Index i = 0; i < vector.size(); ++i) values.push_back(vector(i));
  return values;
}

nlohmann::json certified_json(const BoundReport& b) {
  nlohmann::json j = {{"M0", bracket_json(b.M0_bracket)}, {"B", bracket_json(b.B_bracket)}, {"L_joint", bracket_json(b.L_joint_bracket)}};
  if (b.scaled()) j["L_scaled"] = bracket_json(b.L_scaled_bracket);
  return j;
}

nlohmann::json to_json(const BoundReport& b) {
  nlohmann::json j = {{"method", b.method()},
          {"velocity_bounds", to_json(b.velocity_bounds)},
          {"M0", b.M0.value},
          {"B", b.B.value},
          {"F_norm", b.F_norm},
          {"L_paper", b.L_paper},
          {"L_joint", b.L_joint.value},
          {"search", {{"M0", bound_json(b.M0)}, {"B", bound_json(b.B)}, {"L_joint", bound_json(b.L_joint)}}},
          {"wall_seconds", b.wall_seconds}};
  if (b.scaled()) {
    j["scaling"] = to_json(b.scaling);
    j["L_scaled"] = b.L_scaled.value;
    j["search"]["L_scaled"] = bound_json(b.L_scaled);
  }
  return j;
}

nlohmann::json to_json(const CertificateSummary& s) {
  const CertifiedObserver& o = s.observer;
  return {{"certificate", to_string(o.certificate)},
          {"theta_star", s.theta_star},
          {"theta", o.theta},
          {"gamma", s.rate},
          {"envelope_gamma", o.gamma},
          {"k", number_or_null(o.k)},
          {"k1", o.k1},
          {"k2", o.k2},
          {"L", o.L},
          {"P", to_json(o.P)},
          {"lmi_max_eig", s.lmi_max_eig ? nlohmann::json(*s.lmi_max_eig) : nlohmann::json(nullptr)},
          {"status", s.status},
          {"certified", o.certified}};
}

nlohmann::json to_json(const Deployment& deployment) {
  const DeploymentCertificate& c = deployment.certificate;
  const SampledErrorBounds& b = c.bounds;
  nlohmann::json sweep = nlohmann::json::array();
  for (const TradeoffPoint& p : deployment.tradeoff)
    sweep.push_back({{"theta", p.observer.theta}, {"alpha", p.observer.alpha}, {"gamma", p.observer.gamma},
                     {"k", p.observer.k}, {"ultimate_position_error_norm", p.position_norm},
                     {"ultimate_velocity_error_norm", p.velocity_norm}});
  nlohmann::json j = {
      {"sample_period", c.sample_period},
      {"latency", c.latency},
      {"encoder_resolution", to_json(c.encoder_resolution)},
      {"acceleration_bounds", to_json(c.acceleration_bounds)},
      {"measurement_error", to_json(c.measurement_error)},
      {"position_sensitivity", bracket_json(c.position_sensitivity)},
      {"M0", c.M0},
      {"model_gain", c.model_gain},
      {"ultimate_position_error", to_json(c.ultimate_position_error)},
      {"ultimate_position_error_norm", b.position_norm},
      {"ultimate_velocity_error", to_json(c.ultimate_velocity_error)},
      {"ultimate_velocity_error_norm", b.velocity_norm},
      {"iss_envelope",
       {{"k", c.k}, {"gamma", c.gamma}, {"offset", b.offset}, {"level", b.level},
        {"disturbance_position", b.disturbance_position}, {"disturbance_velocity", b.disturbance_velocity}}},
      {"velocity_error_tolerance", c.velocity_error_tolerance},
      {"max_sample_period", c.max_sample_period},
      {"substeps", c.substeps},
      {"objective", deployment.objective == DesignObjective::velocity_error ? "velocity-error" : "rate"},
      {"tradeoff", sweep},
      {"certified", c.proven()}};
  if (!c.proven()) j["certified_reason"] = c.not_proven_reason;
  return j;
}

nlohmann::json to_json(const DeployedDesign& deployed) {
  nlohmann::json j = to_json(deployed.design);
  if (deployed.deployment) j["deployment"] = to_json(*deployed.deployment);
  return j;
}

namespace {

// The design chosen: its certificate's numbers, the shape and the target it was chosen for.
nlohmann::json design_json(const Design& d) {
  nlohmann::json design = to_json(d.selected());
  design["alpha"] = d.alpha;
  design["beta"] = d.beta;
  design["target_gamma"] = d.target_gamma ? nlohmann::json(*d.target_gamma) : nlohmann::json(nullptr);
  design["rate_margin"] = d.rate_margin;
  if (d.certificate == CertificateKind::scaled) design["scaling"] = to_json(d.bounds.scaling);
  const auto at_attained = [](const std::optional<Design::AtAttained>& a) {
    return a ? nlohmann::json{{"constant", a->constant}, {"certificate", a->certificate}, {"L", a->L},
                              {"theta", a->theta}, {"gamma", a->rate}}
             : nlohmann::json(nullptr);
  };
  design["at_attained"] = at_attained(d.at_attained);
  design["other_at_attained"] = at_attained(d.other_at_attained);
  return design;
}

// What monte-carlo needs to load the same robot again: the source, the armature and the --joint-limits override.
nlohmann::json robot_json(const Design& d) {
  nlohmann::json robot = {{"name", d.robot_name},
                          {"dof", d.dof},
                          {"source", d.robot_source.robot},
                          {"base_link", d.robot_source.base_link},
                          {"tip_link", d.robot_source.tip_link},
                          {"actuated", d.robot_source.actuated},
                          {"armature", to_json(d.armature)},
                          {"fingerprint", d.robot_fingerprint}};
  if (!d.robot_source.joint_limits.empty()) {
    nlohmann::json limits = nlohmann::json::array();
    for (const JointDomain& domain : d.robot_source.joint_limits)
      limits.push_back(domain.continuous ? nlohmann::json("c") : nlohmann::json{domain.lower, domain.upper});
    robot["joint_limits"] = limits;
  }
  return robot;
}

nlohmann::json to_json(const PolytopeSummary& p) {
  return {{"method", p.method},         {"cells", p.cells},           {"vertices", p.vertices},
          {"grid", p.grid},             {"samples", p.samples},       {"cuts", p.cuts},
          {"proof_boxes", p.proof_boxes}, {"proof_work", p.proof_work}, {"refuted", p.refuted},
          {"unproven", p.unproven},     {"seconds", p.seconds}};
}

nlohmann::json to_json(const ShapeReport& shape) {
  nlohmann::json j = {{"objective", shape.objective},         {"alpha_global", shape.alpha_global},
                      {"alpha_polish", shape.alpha_polish},   {"objective_global", shape.objective_global},
                      {"objective_polish", shape.objective_polish}, {"evaluations", shape.evaluations}};
  if (const auto& p = shape.polytopic)
    j["polytopic"] = {{"alpha", p->alpha},
                      {"objective", p->objective},
                      {"objective_at_norm_bound_alpha", p->objective_at_norm_bound_alpha},
                      {"evaluations", p->evaluations}};
  return j;
}

}  // namespace

nlohmann::json to_json(const Design& d) {
  nlohmann::json bounds = to_json(d.bounds);
  bounds["L_used"] = d.L_used;
  bounds["L_source"] = d.L_source;
  if (d.bounds.certified) bounds["brackets"] = certified_json(d.bounds);
  nlohmann::json j = {
      {"robot", robot_json(d)},
      {"velocity_bounds", to_json(d.velocity_bounds)},
      {"bounds", bounds},
      {"lyapunov",
       {{"S", to_json(d.lyapunov.S)}, {"S_block", to_json(Eigen::MatrixXd(d.lyapunov.S2))},
        {"S_norm", d.lyapunov.S_norm}, {"residual", d.lyapunov.residual}}},
      {"certificate", to_string(d.certificate)},
      {"design", design_json(d)},
      {"comparison", {{"paper", to_json(d.paper)}, {"tight", to_json(d.tight)}}},
      {"warnings", d.warnings},
      {"notes", d.notes},
      {"wall_seconds", d.wall_seconds}};
  // The verdict a tool reads first: proven, or an estimate and why.
  j["certified"] = d.selected().observer.certified && d.proven();
  if (!d.unfinished.empty())
    j["certified_reason"] = d.unfinished;
  else if (!d.proven())
    j["certified_reason"] = d.not_proven_reason;
  if (d.scaled) j["comparison"]["scaled"] = to_json(*d.scaled);
  if (d.polytopic) j["comparison"]["polytopic"] = to_json(*d.polytopic);
  if (d.polytope) j["polytope"] = to_json(*d.polytope);
  if (d.shape.optimized) j["shape"] = to_json(d.shape);
  return j;
}

namespace {

// The deployment section of the design table (rate_proven: the design's own certificate is a proof).
std::string format_deployment(const Deployment& deployment, bool rate_proven) {
  const DeploymentCertificate& c = deployment.certificate;
  std::ostringstream out;
  const SampledErrorBounds& b = c.bounds;
  out << fmt::format("Deployment: sampled every T = {:g} s, encoders of {} rad, |q''_i| <= {}\n", c.sample_period,
                     format_vector(c.encoder_resolution), format_vector(c.acceleration_bounds));
  out << fmt::format("  measurement error |y_i - q_i| <= d_i = delta_i/2 + A_i T^2/8{} = {}\n",
                     c.latency > 0.0 ? fmt::format(" + V_i {:g} s (latency)", c.latency) : std::string(),
                     format_vector(c.measurement_error));
  out << fmt::format("  C_q = sup ||d/dq (M a + A + g)||  [{:.6g}, {:.6g}] ({} boxes, {:.2f} s); M0 C_q = {:.6g}\n",
                     c.position_sensitivity.lower, c.position_sensitivity.upper, c.position_sensitivity.boxes,
                     c.position_sensitivity.seconds, c.model_gain);
  const bool proven = c.proven() && rate_proven;
  out << fmt::format("  {}: ||e(t)|| <= {:.6g} ||e(0)|| exp(-{:.6g} t) + {:.4g}\n",
                     proven ? "certified" : "estimate (not proven)", c.k, c.gamma, b.offset);
  out << fmt::format("  ultimate errors: ||q^ - q|| <= {:.4g} rad, ||v^ - v|| <= {:.4g} rad/s (each joint too)\n",
                     b.position_norm, b.velocity_norm);
  out << fmt::format("  largest sample period keeping ||v^ - v|| <= {:.4g}: {:.4g} s; the Observer class takes {} RK4 "
                     "sub-step(s) per sample\n",
                     c.velocity_error_tolerance, c.max_sample_period, c.substeps);
  if (!c.proven()) out << "  not proven: " << c.not_proven_reason << "\n";
  if (!deployment.tradeoff.empty()) {
    out << "  trade-off (faster convergence vs smaller error floor, same T and encoders):\n";
    out << fmt::format("    {:>12} {:>10} {:>12} {:>10} {:>14} {:>14}\n", "theta", "alpha", "gamma", "k", "||e_q|| ult",
                       "||e_v|| ult");
    for (const TradeoffPoint& p : deployment.tradeoff)
      out << fmt::format("    {:>12.6g} {:>10.5g} {:>12.6g} {:>10.4g} {:>14.4g} {:>14.4g}\n", p.observer.theta,
                         p.observer.alpha, p.observer.gamma, p.observer.k, p.position_norm, p.velocity_norm);
  }
  return out.str();
}

std::string format_bounds(const Design& d) {
  std::ostringstream out;
  const auto& b = d.bounds;
  out << fmt::format("Bounds ({}: NLopt DIRECT-L, then Ipopt polish{})\n", b.method(),
                     b.certified ? "; then interval branch and bound" : "");
  out << fmt::format("  {:<8} {:>14} {:>14} {:>14}   {}\n", "", "value", "NLopt", "Ipopt", "argmax");
  std::vector<std::tuple<const char*, const BoundMaximum*, const BoundBracket*>> rows = {
      {"M0", &b.M0, &b.M0_bracket}, {"B", &b.B, &b.B_bracket}, {"L_joint", &b.L_joint, &b.L_joint_bracket}};
  if (b.scaled()) rows.emplace_back("L_T", &b.L_scaled, &b.L_scaled_bracket);
  for (const auto& [name, m, k] : rows) {
    out << fmt::format("  {:<8} {:>14.7f} {:>14.7f} {:>14.7f}   {}\n", name, m->value, m->global_value,
                       m->polish_value, where(*m));
  }
  if (b.scaled()) out << fmt::format("  (L_T = sup ||T Phi T^-1||, similarity scaling T = {})\n", format_scaling(b.scaling));
  if (b.certified) {
    out << "  certified brackets [attained, proven upper] (interval branch and bound; the design uses the upper ends):\n";
    for (const auto& [name, m, k] : rows)
      out << fmt::format("  {:<8} [{:.10g}, {:.10g}]  {}, {} boxes, {:.2f} s{}\n", name, k->lower, k->upper,
                         std::isfinite(k->upper) ? fmt::format("gap {:.1e}", (k->upper - k->lower) / k->upper)
                                                 : std::string("no finite upper bound yet"),
                         k->boxes, k->seconds, stop_note(*k));
  }
  out << fmt::format("  {:<8} {:>14.7f}\n", "||F||", b.F_norm);
  out << fmt::format("  {:<8} {:>14.7f}   = M0 (B + ||F||)\n", "L_paper", b.L_paper);
  if (d.certificate == CertificateKind::scaled)
    out << fmt::format("  L used: {:.7g} (L_T, similarity scaled; L_joint = {:.7g})\n", d.selected().observer.L, d.L_used);
  else
    out << fmt::format("  L used: {:.7g} ({})\n", d.L_used, d.L_source);
  return out.str();
}

std::string format_certificates(const Design& d) {
  std::ostringstream out;
  const auto& S = d.lyapunov.S2;
  out << fmt::format("Lyapunov  G = [[-a, 1], [-b, 0]] (x) I,  a = {:.7g}, b = {:.7g}\n", d.alpha, d.beta);
  out << fmt::format("  S block = [[{:.7f}, {:.7f}], [{:.7f}, {:.7f}]]   ||S|| = {:.7f}   residual = {:.2e}\n", S(0, 0),
                     S(0, 1), S(1, 0), S(1, 1), d.lyapunov.S_norm, d.lyapunov.residual);
  if (d.shape.optimized) out << "  " << shape_summary(d) << "\n";
  out << fmt::format("\nCertificates{}\n", d.target_gamma ? fmt::format(" for target gamma = {:.6g}", *d.target_gamma)
                                                             : fmt::format(" at theta = {:.6g}", d.paper.observer.theta));
  const auto cell = [](const std::optional<double>& x) {
    return !x ? std::string() : std::isnan(*x) ? fmt::format(" {:>16}", "-") : fmt::format(" {:>16.6g}", *x);
  };
  out << fmt::format("  {:<38} {:>14} {:>16}{}{}\n", "", "paper", "tight", d.scaled ? fmt::format(" {:>16}", "scaled") : "",
                     d.polytopic ? fmt::format(" {:>16}", "polytopic") : "");
  for (const ComparisonRow& row : certificate_comparison(d))
    out << fmt::format("  {:<38} {:>14.6g} {:>16.6g}{}{}\n", row.label, row.paper, row.tight, cell(row.scaled),
                       cell(row.polytopic));
  if (d.tight.lmi_max_eig)
    out << fmt::format("  {:<38} {:>14} {:>16.3e}{}\n", "LMI largest eigenvalue", "", *d.tight.lmi_max_eig,
                       d.scaled && d.scaled->lmi_max_eig ? fmt::format(" {:>16.3e}", *d.scaled->lmi_max_eig) : "");
  if (d.scaled)
    out << fmt::format("  scaled: T = {}, cond(T) = {:.4g}; L_T = {:.7g} where L_joint = {:.7g}\n",
                       format_scaling(d.bounds.scaling), condition_number(d.bounds.scaling), d.bounds.L_scaled.value,
                       d.L_used);
  if (d.polytope && d.polytope->method == "search")
    out << fmt::format("  polytopic by search: P chosen on {} sampled configurations ({} LMIs in the SDP), proof by "
                       "branch and bound over {} boxes{}{}; {:.1f} s\n",
                       d.polytope->samples, d.polytope->cuts, d.polytope->proof_boxes,
                       d.polytope->refuted ? fmt::format(", {} refuted P", d.polytope->refuted) : "",
                       d.polytope->unproven.empty() ? "" : " — not available: " + d.polytope->unproven, d.polytope->seconds);
  else if (d.polytope)
    out << fmt::format("  polytope: {} cells ({} per searched joint), {} vertices{}; {:.1f} s\n", d.polytope->cells,
                       d.polytope->grid, d.polytope->vertices,
                       d.polytope->unproven.empty() ? "" : " — not proven: " + d.polytope->unproven, d.polytope->seconds);
  if (d.polytopic) out << "  polytopic: " << d.polytopic->status << "\n";
  return out.str();
}

// The proof's price (Design::AtAttained): the selected certificate on its constant's attained value, and the other
// norm-bound certificate on its constant's where that does better.
std::string format_price(const Design& d) {
  std::ostringstream out;
  const CertifiedObserver& o = d.selected().observer;
  constexpr double same = Design::AtAttained::same_within;
  if (const auto& a = d.at_attained; a && d.target_gamma && o.theta > a->theta * (1.0 + same))
    out << fmt::format("  the proof's price: on {}'s attained value {:.7g} the same certificate takes theta = {:.7g}; "
                       "this design's is {:.4g} times it (a larger --bound-budget lowers that)\n",
                       a->constant, a->L, a->theta, o.theta / a->theta);
  else if (a && d.target_gamma)
    out << fmt::format("  the proof's price: none (on {}'s attained value {:.7g} theta is the same within {:g})\n",
                       a->constant, a->L, same);
  else if (a && a->rate <= d.selected().rate * (1.0 + same))
    out << fmt::format("  the proof's price: none (on {}'s attained value {:.7g} the rate is the same within {:g})\n",
                       a->constant, a->L, same);
  else if (a)
    out << fmt::format("  the proof's price: on {}'s attained value {:.7g} the same certificate proves {:.7g} 1/s, "
                       "this design {:.7g} 1/s (a larger --bound-budget closes the distance)\n",
                       a->constant, a->L, a->rate, d.selected().rate);
  if (const auto& b = d.other_at_attained; b && d.target_gamma)
    out << fmt::format("  on {}'s attained value {:.7g} the {} certificate takes theta = {:.7g}, as the numeric estimate "
                       "does; this design's is {:.4g} times it ({}'s proof went less far)\n",
                       b->constant, b->L, b->certificate, b->theta, o.theta / b->theta, b->constant);
  else if (b)
    out << fmt::format("  on {}'s attained value {:.7g} the {} certificate proves {:.7g} 1/s, this design {:.7g} 1/s ({}'s "
                       "proof went less far)\n",
                       b->constant, b->L, b->certificate, b->rate, d.selected().rate, b->constant);
  return out.str();
}

std::string format_gains(const Design& d) {
  std::ostringstream out;
  const CertifiedObserver& o = d.selected().observer;
  out << fmt::format("Design ({} certificate): theta = {:.7g}, alpha = {:.7g}, beta = {:.7g}\n", to_string(d.certificate),
                     o.theta, d.alpha, d.beta);
  out << fmt::format("  gains k1 = {:.7g}, k2 = {:.7g}\n", o.k1, o.k2);
  if (!o.certified) return out.str() + "  NOT CERTIFIED\n";
  // Never the word "certified" on a certificate that rests on estimated bounds.
  out << fmt::format("  {}: ||e(t)|| <= {:.6g} ||e(0)|| exp(-{:.6g} t) while |v_i(t)| <= V_i\n",
                     d.proven() ? "certified" : "estimate (numeric bounds, not proven)", o.k, o.gamma);
  if (!d.proven()) out << "  not proven: " << d.not_proven_reason << "\n";
  return out.str() + format_price(d);
}

}  // namespace

std::string format_report(const Design& d) {
  std::ostringstream out;
  out << fmt::format("obsgain design for '{}' ({} joints), velocity box |v_i| <= {}\n", d.robot_name, d.dof,
                     format_vector(d.velocity_bounds));
  if (d.armature.size() > 0 && !d.armature.isZero(0.0))
    out << fmt::format("  armature (reflected rotor inertia on M's diagonal) [kg m^2]: {}\n", format_vector(d.armature));
  for (const auto& note : d.notes) out << "  note: " << note << "\n";
  out << "\n" << format_bounds(d) << "\n";
  // Bounds that support no certificate leave no gains to show (they would read as zeros): only why, and what helps.
  if (!d.unfinished.empty()) return out.str() + "Design: NOT CERTIFIED: " + d.unfinished + "\n";
  out << format_certificates(d) << "\n" << format_gains(d);
  return out.str();
}

std::string format_report(const DeployedDesign& deployed) {
  const Design& d = deployed.design;
  std::string out = format_report(d);
  if (deployed.deployment) {
    out += '\n';
    out += format_deployment(*deployed.deployment, d.proven() && d.selected().observer.certified);
  }
  return out;
}

std::string version() { return "obsgain " OBSGAIN_VERSION; }

std::string format_warnings(const Design& d) {
  std::string out;
  for (const auto& w : d.warnings) out += "warning: " + w + "\n";
  return out;
}

nlohmann::json to_json(const MonteCarloReport& r) {
  const ObserverCertificate& c = r.certificate;
  nlohmann::json j = {{"trials", r.trials},
          {"passed", r.passed},
          {"envelope_violations", r.envelope_violations},
          {"lyapunov_violations", r.lyapunov_violations},
          {"assumption_violations", r.assumption_violations},
          {"worst_envelope_ratio", r.worst_envelope_ratio},
          {"worst_lyapunov_ratio", r.worst_lyapunov_ratio},
          {"decay_rate",
           {{"min", r.decay_rate.min}, {"median", r.decay_rate.median}, {"max", r.decay_rate.max},
            {"trials", r.decay_rate.trials}}},
          {"certified_gamma", c.observer.gamma},
          {"certificate", to_string(c.observer.certificate)},
          {"k", c.observer.k},
          {"k1", c.observer.k1},
          {"k2", c.observer.k2},
          {"seed", r.seed},
          {"threads", r.threads},
          {"wall_seconds", r.wall_seconds},
          {"scenario", r.scenario},
          {"initial_errors", r.initial_errors},
          {"horizon", r.simulation.horizon},
          {"rtol", r.simulation.rtol},
          {"atol", r.simulation.atol},
          {"violation_tolerance", r.simulation.violation_tolerance},
          {"numerical_floor", "none: the error is integrated as exp(rho) u with ||u|| = 1 and checked in log space"},
          {"certificate_held", r.certificate_held()}};
  if (!r.not_run.empty()) j["not_run"] = r.not_run;
  if (c.sampled) {
    const SampledCertificate& d = *c.sampled;
    j["numerical_floor"] = "sampled: the plant is integrated alone and the Observer class runs as deployed";
    j["sampled"] = {{"sample_period", d.sample_period},
                    {"latency", d.latency},
                    {"encoder_resolution", to_json(d.encoder_resolution)},
                    {"acceleration_bounds", to_json(d.acceleration_bounds)},
                    {"offset", d.offset},
                    {"level", d.level},
                    {"ultimate_velocity_error_norm", d.velocity_norm},
                    {"worst_final_velocity_error", r.worst_final_velocity_error},
                    {"max_acceleration_ratio", r.max_acceleration_ratio}};
  }
  return j;
}

std::string format_report(const MonteCarloReport& r) {
  std::ostringstream out;
  const ObserverCertificate& c = r.certificate;
  out << fmt::format("monte-carlo: {} trials ({} scenario, {} initial errors, horizon {} s), seed {}, {} threads, {:.2f} s\n",
                     r.trials, r.scenario, r.initial_errors, r.simulation.horizon, r.seed, r.threads, r.wall_seconds);
  const CertifiedObserver& o = c.observer;
  out << fmt::format("  certificate ({}): ||e(t)|| <= {:.6g} ||e(0)|| exp(-{:.6g} t), gains k1 = {:.6g}, k2 = {:.6g}\n",
                     to_string(o.certificate), o.k, o.gamma, o.k1, o.k2);
  if (!r.not_run.empty()) return out.str() + "  " + r.not_run + "\n";
  out << fmt::format("  passed {} | envelope violations {} | Lyapunov violations {} | left the velocity box {}\n",
                     r.passed, r.envelope_violations, r.lyapunov_violations, r.assumption_violations);
  out << fmt::format("  worst ratio to the envelope {:.4g}, to the Lyapunov level {:.4g} (violation above 1 + {:.0e})\n",
                     r.worst_envelope_ratio, r.worst_lyapunov_ratio, r.simulation.violation_tolerance);
  if (r.decay_rate.trials > 0)
    out << fmt::format("  fitted decay rate min {:.4g} / median {:.4g} / max {:.4g} 1/s against certified {:.4g} "
                       "({} trials{})\n",
                       r.decay_rate.min, r.decay_rate.median, r.decay_rate.max, o.gamma, r.decay_rate.trials,
                       c.sampled ? ": those whose error decayed tenfold above twice the certified floor" : "");
  else
    out << "  fitted decay rate: none (no trial's error decayed tenfold above twice the certified floor)\n";
  if (c.sampled) {
    out << fmt::format("  sampled every {:g} s on encoders of {} rad{} (the Observer class as deployed); envelope "
                       "offset {:.4g}, Lyapunov level offset {:.4g}\n",
                       c.sampled->sample_period, format_vector(c.sampled->encoder_resolution),
                       c.sampled->latency > 0.0 ? fmt::format(", read {:g} s before use", c.sampled->latency) : std::string(),
                       c.sampled->offset, c.sampled->level);
    out << fmt::format("  over the last fifth of the horizon ||v^ - v|| reached {:.4g} rad/s (certified ultimate bound "
                       "{:.4g}); largest |q''_i| / A_i {:.3g}\n",
                       r.worst_final_velocity_error, c.sampled->velocity_norm, r.max_acceleration_ratio);
  }
  if (r.assumption_violations > 0)
    out << fmt::format("  {} trial(s) left the velocity{} box: outside the theorem's assumption, they prove nothing\n",
                       r.assumption_violations, c.sampled ? " or acceleration" : "");
  out << (r.certificate_held() ? "  verdict: no trajectory left the certified envelope\n"
                               : "  verdict: CERTIFICATE VIOLATED\n");
  return out.str();
}

void write_trials_csv(const MonteCarloReport& r, std::ostream& out) {
  out << "trial,initial_errors,initial_error_norm,input_scale,left_velocity_box,max_velocity_ratio,"
         "worst_envelope_ratio,worst_lyapunov_ratio,fitted_rate,final_log_error_ratio,steps\n";
  for (const TrialRecord& t : r.records) {
    out << fmt::format("{},{},{:.10g},{:.6g},{},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{}\n", t.index,
                       t.global_error ? "global" : "practical", t.initial_error, t.input_scale,
                       t.result.left_velocity_box ? 1 : 0, t.result.max_velocity_ratio, t.result.worst_envelope_ratio,
                       t.result.worst_lyapunov_ratio, t.result.fitted_rate, t.result.final_log_error_ratio,
                       t.result.steps);
  }
}

void write_trajectory_csv(const std::vector<TrajectorySample>& samples, std::ostream& out) {
  if (samples.empty()) return;
  const auto n = samples.front().q.size();
  out << "t";
  for (const char* name : {"q", "v", "qhat", "vhat"})
    for (Eigen::Index i = 0; i < n; ++i) out << "," << name << i + 1;
  out << ",error_norm,envelope\n";
  for (const TrajectorySample& s : samples) {
    out << fmt::format("{:.9g}", s.t);
    const Eigen::VectorXd qhat = s.q + s.e_q, vhat = s.v + s.e_v;
    for (const Eigen::VectorXd* x : {&s.q, &s.v, &qhat, &vhat})
      for (Eigen::Index i = 0; i < n; ++i) out << fmt::format(",{:.12g}", (*x)(i));
    out << fmt::format(",{:.12g},{:.12g}\n", s.error_norm, s.envelope);
  }
}

nlohmann::json to_json(const VerificationReport& r) {
  nlohmann::json j = to_json(r.design);
  // verify-bounds' report.json keeps the brackets under "certified" (its command-line contract); the design's
  // verdict is then "design_certified".
  j["design_certified"] = j["certified"];
  j.erase("certified");
  if (r.design.design.bounds.certified) j["certified"] = certified_json(r.design.design.bounds);
  j["monte_carlo"] = to_json(r.monte_carlo);
  return j;
}

std::string to_json_text(const Design& design) { return to_json(design).dump(2) + "\n"; }
std::string to_json_text(const DeployedDesign& design) { return to_json(design).dump(2) + "\n"; }
std::string to_json_text(const MonteCarloReport& report) { return to_json(report).dump(2) + "\n"; }
std::string to_json_text(const VerificationReport& report) { return to_json(report).dump(2) + "\n"; }

}  // namespace obsgain
