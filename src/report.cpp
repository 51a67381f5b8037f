#include "obsgain/report.hpp"

#include <fmt/format.h>

#include <cmath>
#include <sstream>

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

std::string vec(const Eigen::VectorXd& v) {
  std::string s = "(";
  for (Eigen::Index i = 0; i < v.size(); ++i) s += fmt::format("{}{:.6g}", i ? ", " : "", v(i));
  return s + ")";
}

std::string where(const BoundMaximum& m) {
  std::string s = "q = " + vec(m.q);
  if (m.velocity_vertex.size()) s += ", v = " + vec(m.velocity_vertex);
  if (m.saturation_pattern.size()) s += ", D = diag" + vec(m.saturation_pattern);
  return s;
}

}  // namespace

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

nlohmann::json to_json(const BoundReport& b) {
  return {{"method", b.method},
          {"velocity_bounds", to_json(b.velocity_bounds)},
          {"M0", b.M0.value},
          {"B", b.B.value},
          {"F_norm", b.F_norm},
          {"L_paper", b.L_paper},
          {"L_joint", b.L_joint.value},
          {"search", {{"M0", bound_json(b.M0)}, {"B", bound_json(b.B)}, {"L_joint", bound_json(b.L_joint)}}},
          {"wall_seconds", b.wall_seconds}};
}

nlohmann::json to_json(const CertificateSummary& s) {
  return {{"theta_star", s.theta_star},
          {"theta", s.theta},
          {"gamma", s.gamma},
          {"envelope_gamma", s.envelope_gamma},
          {"k", number_or_null(s.k)},
          {"k1", s.k1},
          {"k2", s.k2},
          {"P", to_json(Eigen::MatrixXd(s.P))},
          {"lmi_max_eig", s.lmi_max_eig ? nlohmann::json(*s.lmi_max_eig) : nlohmann::json(nullptr)},
          {"certified", s.certified}};
}

nlohmann::json to_json(const Design& d) {
  nlohmann::json bounds = to_json(d.bounds);
  bounds["L_used"] = d.L_used;
  bounds["L_source"] = d.L_source;
  nlohmann::json design = to_json(d.selected());
  design["alpha"] = d.alpha;
  design["beta"] = d.beta;
  design["target_gamma"] = d.target_gamma ? nlohmann::json(*d.target_gamma) : nlohmann::json(nullptr);
  design["rate_margin"] = d.rate_margin;
  nlohmann::json j = {
      {"robot", {{"name", d.robot_name}, {"dof", d.dof}}},
      {"velocity_bounds", to_json(d.velocity_bounds)},
      {"bounds", bounds},
      {"lyapunov",
       {{"S", to_json(d.lyapunov.S)}, {"S_block", to_json(Eigen::MatrixXd(d.lyapunov.S2))},
        {"S_norm", d.lyapunov.S_norm}, {"residual", d.lyapunov.residual}}},
      {"certificate", to_string(d.certificate)},
      {"design", design},
      {"comparison", {{"paper", to_json(d.paper)}, {"tight", to_json(d.tight)}}},
      {"warnings", d.warnings},
      {"wall_seconds", d.wall_seconds}};
  if (d.shape.optimized) {
    j["shape"] = {{"objective", d.shape.objective},         {"alpha_global", d.shape.alpha_global},
                  {"alpha_polish", d.shape.alpha_polish},   {"objective_global", d.shape.objective_global},
                  {"objective_polish", d.shape.objective_polish}, {"evaluations", d.shape.evaluations}};
  }
  return j;
}

std::string format_report(const Design& d) {
  std::ostringstream out;
  const auto& b = d.bounds;
  out << fmt::format("obsgain design for '{}' ({} joints), velocity box |v_i| <= {}\n\n", d.robot_name, d.dof,
                     vec(d.velocity_bounds));
  out << fmt::format("Bounds ({} search: NLopt DIRECT-L, then Ipopt polish)\n", b.method);
  out << fmt::format("  {:<8} {:>14} {:>14} {:>14}   {}\n", "", "value", "NLopt", "Ipopt", "argmax");
  for (const auto& [name, m] : {std::pair{"M0", &b.M0}, {"B", &b.B}, {"L_joint", &b.L_joint}}) {
    out << fmt::format("  {:<8} {:>14.7f} {:>14.7f} {:>14.7f}   {}\n", name, m->value, m->global_value,
                       m->polish_value, where(*m));
  }
  out << fmt::format("  {:<8} {:>14.7f}\n", "||F||", b.F_norm);
  out << fmt::format("  {:<8} {:>14.7f}   = M0 (B + ||F||)\n", "L_paper", b.L_paper);
  out << fmt::format("  L used: {:.7g} ({})\n\n", d.L_used, d.L_source);

  const auto& S = d.lyapunov.S2;
  out << fmt::format("Lyapunov  G = [[-a, 1], [-b, 0]] (x) I,  a = {:.7g}, b = {:.7g}\n", d.alpha, d.beta);
  out << fmt::format("  S block = [[{:.7f}, {:.7f}], [{:.7f}, {:.7f}]]   ||S|| = {:.7f}   residual = {:.2e}\n", S(0, 0),
                     S(0, 1), S(1, 0), S(1, 1), d.lyapunov.S_norm, d.lyapunov.residual);
  if (d.shape.optimized) {
    out << fmt::format("  shape optimised (beta = 1, minimise {}): alpha = {:.7f} (NLopt {:.7f}, Ipopt {:.7f})\n",
                       d.shape.objective, d.alpha, d.shape.alpha_global, d.shape.alpha_polish);
  }
  out << "\n";

  out << fmt::format("Certificates{}\n", d.target_gamma ? fmt::format(" for target gamma = {:.6g}", *d.target_gamma)
                                                         : fmt::format(" at theta = {:.6g}", d.paper.theta));
  out << fmt::format("  {:<34} {:>16} {:>16}\n", "", "paper", "tight");
  const auto row = [&](const std::string& label, double p, double t) {
    out << fmt::format("  {:<34} {:>16.6g} {:>16.6g}\n", label, p, t);
  };
  row(d.target_gamma ? "theta* (smallest gain)" : "theta* (any positive rate)", d.paper.theta_star,
      d.tight.theta_star);
  row("theta (chosen)", d.paper.theta, d.tight.theta);
  row("gamma certified at theta", d.paper.gamma, d.tight.gamma);
  row("envelope rate", d.paper.envelope_gamma, d.tight.envelope_gamma);
  row("k (envelope constant)", d.paper.k, d.tight.k);
  row("k1 = theta alpha", d.paper.k1, d.tight.k1);
  row("k2 = theta^2 beta", d.paper.k2, d.tight.k2);
  if (d.tight.lmi_max_eig) out << fmt::format("  {:<34} {:>16} {:>16.3e}\n", "LMI largest eigenvalue", "", *d.tight.lmi_max_eig);
  out << "\n";

  const CertificateSummary& s = d.selected();
  out << fmt::format("Design ({} certificate): theta = {:.7g}, alpha = {:.7g}, beta = {:.7g}\n", to_string(d.certificate),
                     s.theta, d.alpha, d.beta);
  out << fmt::format("  gains k1 = {:.7g}, k2 = {:.7g}\n", s.k1, s.k2);
  if (s.certified) {
    out << fmt::format("  certified: ||e(t)|| <= {:.6g} ||e(0)|| exp(-{:.6g} t) while |v_i(t)| <= V_i\n", s.k,
                       s.envelope_gamma);
  } else {
    out << "  NOT CERTIFIED\n";
  }
  for (const auto& w : d.warnings) out << "warning: " << w << "\n";
  return out.str();
}

}  // namespace obsgain
