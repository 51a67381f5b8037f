// The verification report a person reads: one self-contained HTML page with inline SVG plots.
#include "obsgain/report/report.hpp"

#include <fmt/format.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

namespace obsgain {

namespace {

namespace fs = std::filesystem;

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  if (!(out << text)) throw InputError("cannot write '" + path.string() + "'");
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

// The CSV behind each plot.
void write_data(const VerificationReport& r, const fs::path& dir) {
  std::ostringstream bounds;
  bounds << "angle,inverse_inertia_norm,jacobian_norm,joint_lipschitz_norm\n";
  for (const auto& p : r.bound_curve)
    bounds << fmt::format("{:.9g},{:.12g},{:.12g},{:.12g}\n", p.angle, p.inverse_inertia_norm, p.jacobian_norm,
                          p.joint_lipschitz_norm);
  write_file(dir / "bound_curves.csv", bounds.str());

  std::ostringstream paper;
  write_trajectory_csv(r.paper_run, paper);
  write_file(dir / "paper_scenario.csv", paper.str());

  // A plain CSV: one header row, one row per sample, the trial in the first column.
  std::ostringstream errors;
  errors << "trial,t,error_ratio,envelope_ratio\n";
  for (std::size_t trial = 0; trial < r.error_traces.size(); ++trial) {
    const auto& trace = r.error_traces[trial];
    const double e0 = trace.front().error_norm;
    for (const auto& s : trace)
      errors << fmt::format("{},{:.9g},{:.12g},{:.12g}\n", trial, s.t, s.error_norm / e0, s.envelope / e0);
  }
  write_file(dir / "monte_carlo_errors.csv", errors.str());

  std::ostringstream rates;
  const auto number_or_nan = [](double x) { return std::isnan(x) ? std::string("NaN") : fmt::format("{:.12g}", x); };
  rates << "theta,paper_gamma,tight_gamma,polytopic_gamma,scaled_gamma\n";
  for (const auto& p : r.rate_curve)
    rates << fmt::format("{:.9g},{:.12g},{:.12g},{},{}\n", p.theta, p.paper_gamma, p.tight_gamma,
                         number_or_nan(p.polytopic_gamma), number_or_nan(p.scaled_gamma));
  write_file(dir / "rate_vs_theta.csv", rates.str());

  if (r.design.deployment) {
    std::ostringstream tradeoff;
    tradeoff << "theta,alpha,gamma,k,ultimate_position_error_norm,ultimate_velocity_error_norm\n";
    for (const TradeoffPoint& p : r.design.deployment->tradeoff)
      tradeoff << fmt::format("{:.9g},{:.9g},{:.12g},{:.9g},{:.9g},{:.9g}\n", p.observer.theta, p.observer.alpha,
                              p.observer.gamma, p.observer.k, p.position_norm, p.velocity_norm);
    write_file(dir / "velocity_error_tradeoff.csv", tradeoff.str());
  }

  std::ofstream trials(dir / "monte_carlo_trials.csv");
  write_trials_csv(r.monte_carlo, trials);
}

struct Plot {
  std::string name, title, script;
};

const char* kPlotPreamble =
    "set terminal svg size 760,400 dynamic enhanced font 'sans,11'\nset datafile separator ','\n"
    "set key below\nset grid\nset format y '%.8g'\n";

// A sampled curve and, where the bound is finite, the value the design uses as a dashed line (an unfinished search's
// upper end is infinite: gnuplot has no such number).
std::string curve_and_bound(int column, double bound, const char* name) {
  std::string plot = fmt::format("plot 'bound_curves.csv' every ::1 using 1:{} with lines lw 2 title 'sampled'", column);
  if (std::isfinite(bound)) plot += fmt::format(", {:.12g} with lines dt 2 lw 2 title '{}'", bound, name);
  return plot + "\n";
}

Plot bound_curves_plot(const VerificationReport& r) {
  const auto& b = r.design.design.bounds;
  const std::string joint = fmt::format("q{}", r.curve_joint + 1);
  // A numeric estimate is never drawn as an upper bound.
  const std::string kind = b.certified ? "proven upper bound" : "numeric estimate, not proven";
  return {"bound_curves",
          fmt::format("The bounds' functions along {} (the other joints at the M0 argmax), max over the velocity "
                      "vertices and saturation patterns; dashed: the value the design uses ({}), where it is finite",
                      joint, kind),
          std::string(kPlotPreamble) +
              fmt::format("set multiplot layout 1,3\nset xlabel '{} [rad]'\n", joint) +
              "set title '||M(q)^{-1}|| [1/(kg m^2)]'\n" + curve_and_bound(2, b.M0.value, "M0") +
              "set title 'max_w ||J(q,w)|| [kg m^2/s]'\n" + curve_and_bound(3, b.B.value, "B") +
              "set title 'max_{w,D} ||M^{-1}(J D + F)|| [1/s]'\n" + curve_and_bound(4, b.L_joint.value, "L_{joint}") +
              "unset multiplot\n"};
}

// When and why the example run leaves the velocity box: from then on it is outside the theorem's assumption.
std::string left_box_note(const VerificationReport& r) {
  const Eigen::VectorXd& V = r.design.design.velocity_bounds;
  for (const TrajectorySample& sample : r.paper_run) {
    Eigen::Index joint = 0;
    if ((sample.v.array().abs() / V.array()).maxCoeff(&joint) > 1.0)
      return fmt::format(" — leaves the velocity box at t = {:.4g} s (|v{}| > V{} = {:g}): outside the theorem's "
                         "assumption from then on",
                         sample.t, joint + 1, joint + 1, V(joint));
  }
  return {};
}

Plot example_run_plot(const VerificationReport& r) {
  const int n = r.design.design.dof;
  std::string series;
  for (int i = 0; i < n; ++i)
    series += fmt::format("{}'paper_scenario.csv' every ::1 using 1:{} with lines lw 2 title 'v{}', "
                          "'paper_scenario.csv' every ::1 using 1:{} with lines dt 2 lw 2 title 'v{} estimate'",
                          i ? ", " : "", 2 + n + i, i + 1, 2 + 3 * n + i, i + 1);
  return {"paper_scenario",
          (r.example_scenario == "paper" ? "The paper's scenario: velocities and their estimates (the paper's Fig. 2)"
                                         : "Random trial 0: velocities and their estimates") + left_box_note(r),
          std::string(kPlotPreamble) + "set title \"joint velocities (solid) and the observer's estimates (dashed)\"\n"
                                       "set xlabel 't [s]'\nset ylabel 'velocity [rad/s]'\nplot " + series + "\n"};
}

Plot error_traces_plot(const VerificationReport& r) {
  const int traces = static_cast<int>(r.error_traces.size());
  return {"monte_carlo_errors",
          fmt::format("Observer error norms of {} of the {} Monte Carlo trials against the certified envelope", traces,
                      r.monte_carlo.trials),
          std::string(kPlotPreamble) +
              fmt::format("set title '||e(t)|| / ||e(0)||, {0} trials'\nset logscale y\nset format y '10^{{%T}}'\n"
                          "set xlabel 't [s]'\nset ylabel '||e(t)|| / ||e(0)|| (log scale)'\n"
                          "plot for [i=0:{1}] 'monte_carlo_errors.csv' every ::1 using 2:($1 == i ? $3 : NaN) "
                          "with lines lc rgb '#3070b0' notitle, 'monte_carlo_errors.csv' every ::1 using "
                          "2:($1 == 0 ? $4 : NaN) with lines lw 3 lc rgb '#c03020' title '{2}'\n",
                          traces, std::max(0, traces - 1),
                          r.design.deployment ? "envelope of trial 0, k exp(-gamma t) + offset/||e(0)|| (sampled, quantised)"
                                              : "envelope k exp(-gamma t)")};
}

Plot rate_plot(const VerificationReport& r) {
  const bool polytopic = r.design.design.certificate == CertificateKind::polytopic;
  const bool scaled = r.design.design.scaled.has_value();
  return {"rate_vs_theta", fmt::format("Certified rate against the gain: paper, tight{}{}", scaled ? ", scaled" : "",
                                       polytopic ? ", and the polytopic certificate's SDP estimate" : ""),
          std::string(kPlotPreamble) +
              fmt::format("set title \"dotted: the design's theta = {0:.6g}\"\nset xlabel 'theta [1/s]'\n"
                          "set ylabel 'certified gamma [1/s]'\n"
                          "set arrow from {0:.9g}, graph 0 to {0:.9g}, graph 1 nohead dt 3\n"
                          "plot 'rate_vs_theta.csv' every ::1 using 1:2 with lines lw 2 title 'paper', "
                          "'rate_vs_theta.csv' every ::1 using 1:3 with lines lw 2 title 'tight', {2}{1}"
                          "0 with lines lc rgb 'black' notitle\n",
                          r.design.design.selected().observer.theta,
                          polytopic ? "'rate_vs_theta.csv' every ::1 using 1:4 with points pt 7 ps 1.5 "
                                      "title 'polytopic (SDP estimate)', "
                                    : "",
                          scaled ? "'rate_vs_theta.csv' every ::1 using 1:5 with lines lw 2 title 'scaled (T e)', " : "")};
}

Plot tradeoff_plot(const VerificationReport& r) {
  return {"velocity_error_tradeoff",
          fmt::format("Deployment at T = {:g} s: the certified ultimate errors against the gain (each point certifies at "
                      "least the target rate); dotted: the design's theta",
                      r.design.deployment->certificate.sample_period),
          std::string(kPlotPreamble) +
              fmt::format("set multiplot layout 1,2\nset logscale xy\nset format y '%.3g'\n"
                          "set xlabel 'theta [1/s] (log scale)'\n"
                          "set arrow from {0:.9g}, graph 0 to {0:.9g}, graph 1 nohead dt 3\n"
                          "set title 'ultimate ||v^ - v|| [rad/s]'\n"
                          "plot 'velocity_error_tradeoff.csv' every ::1 using 1:6 with linespoints lw 2 "
                          "title 'certified ultimate velocity error'\n"
                          "set title 'ultimate ||q^ - q|| [rad]'\n"
                          "plot 'velocity_error_tradeoff.csv' every ::1 using 1:5 with linespoints lw 2 "
                          "title 'certified ultimate position error'\nunset multiplot\n",
                          r.design.design.selected().observer.theta)};
}

std::vector<Plot> plots(const VerificationReport& r) {
  // A design whose bounds support no certificate has only its bound curves to show.
  if (!r.design.design.unfinished.empty()) return {bound_curves_plot(r)};
  // Nor has a Monte Carlo run past its step budget any trajectory.
  if (!r.monte_carlo.not_run.empty()) return {bound_curves_plot(r), rate_plot(r)};
  std::vector<Plot> out{bound_curves_plot(r), example_run_plot(r), error_traces_plot(r), rate_plot(r)};
  if (r.design.deployment) out.push_back(tradeoff_plot(r));
  return out;
}

std::string inline_svg(const std::string& svg) {
  const auto start = svg.find("<svg");
  return start == std::string::npos ? std::string() : svg.substr(start);
}

// A table that scrolls inside the page when it is wider than it.
std::string table(const std::string& rows) { return "<div class='table'><table>\n" + rows + "</table></div>\n"; }

std::string table_row(const std::vector<std::string>& cells, bool header = false) {
  std::string row = "<tr>";
  for (const auto& c : cells) row += header ? "<th>" + c + "</th>" : "<td>" + c + "</td>";
  return row + "</tr>\n";
}

std::string number(double x) { return fmt::format("{:.7g}", x); }

std::string head(const VerificationReport& r) {
  return "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>obsgain verification: " + escape(r.robot) +
         "</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em;line-height:1.4;"
         "color:#222}.table{overflow-x:auto;margin:1em 0}table{border-collapse:collapse}"
         "td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right;white-space:nowrap}"
         "th{background:#eef}td:first-child,th:first-child{text-align:left}.ok{color:#060;font-weight:bold}"
         ".bad{color:#a00;font-weight:bold}.warn{background:#fff4d0;padding:.5em}figure{margin:1.5em 0}"
         "figure svg{max-width:100%;height:auto}figcaption{font-style:italic}</style></head><body>\n"
         "<h1>Observer verification report: " + escape(r.robot) + "</h1>\n";
}

std::string verdict_line(const Design& d) {
  const CertifiedObserver& o = d.selected().observer;
  if (o.certified && d.proven())
    return fmt::format("<span class='ok'>CERTIFIED</span>: ||e(t)|| ≤ {:.6g} ||e(0)|| e<sup>−{:.6g} t</sup> for every "
                       "initial observer error, while |v<sub>i</sub>(t)| ≤ V<sub>i</sub>.",
                       o.k, o.gamma);
  if (o.certified) return "<span class='bad'>NOT PROVEN</span>: " + escape(d.not_proven_reason) + ".";
  if (!d.unfinished.empty()) return "<span class='bad'>NOT CERTIFIED</span>: " + escape(d.unfinished) + ".";
  return "<span class='bad'>NOT CERTIFIED</span>: the chosen gain certifies no rate.";
}

// What the selected certificate rests on: L for the norm-bound ones; the polytopic one uses no L, but a proven
// polytope (two joints) or a proof of its P over the joint domain (docs/theory.md).
std::string certificate_basis(const Design& d) {
  if (d.certificate == CertificateKind::polytopic)
    return d.polytope && d.polytope->method == "search"
               ? "polytopic certificate (one full P, its LMI proven over the joint domain by branch and bound)"
               : "polytopic certificate (one full P, its LMI proven at every vertex of a proven polytope)";
  return fmt::format("{} certificate on L = {} ({})", to_string(d.certificate), number(d.selected().observer.L),
                     escape(d.certificate == CertificateKind::scaled ? std::string("L_T") : d.L_source));
}

// The relative gap of the constant the selected certificate rests on (Design::used_constant), then the largest of all:
// a wide bracket the design does not use costs nothing.
std::string bracket_gaps(const Design& d) {
  const auto& b = d.bounds;
  // (upper - lower) / upper, 1 for an upper end not yet finite (its limit).
  const auto gap = [](const BoundBracket& k) {
    return !std::isfinite(k.upper) ? 1.0 : k.upper > 0.0 ? (k.upper - k.lower) / k.upper : 0.0;
  };
  const std::pair<const char*, const BoundBracket*> brackets[] = {
      {"M0", &b.M0_bracket}, {"B", &b.B_bracket}, {"L_joint", &b.L_joint_bracket}, {"L_T", &b.L_scaled_bracket}};
  const std::pair<const char*, const BoundBracket*>* worst = &brackets[0];
  for (const auto& k : brackets)
    if (gap(*k.second) > gap(*worst->second)) worst = &k;
  const std::string largest = fmt::format("largest relative gap {:.1e} ({})", gap(*worst->second), worst->first);
  const Design::UsedConstant used = d.used_constant();
  if (!used.bracket) return largest;
  std::string text = fmt::format("relative gap of {}, which the design uses, {:.1e}", used.name, gap(*used.bracket));
  const double theta = d.selected().observer.theta;
  constexpr double same = Design::AtAttained::same_within;
  if (d.at_attained && d.target_gamma && theta > d.at_attained->theta * (1.0 + same))  // the proof's price in θ
    text += fmt::format(" (on its attained value the same certificate takes θ = {}, this design {:.4g} times that)",
                        number(d.at_attained->theta), theta / d.at_attained->theta);
  else if (d.at_attained && d.target_gamma)
    text += fmt::format(" (on its attained value the same certificate takes the same θ within {:g})", same);
  if (d.other_at_attained && d.target_gamma)
    text += fmt::format("; on {}'s attained value the {} certificate takes θ = {}, as the numeric estimate does (this "
                        "design {:.4g} times that)",
                        d.other_at_attained->constant, d.other_at_attained->certificate,
                        number(d.other_at_attained->theta), theta / d.other_at_attained->theta);
  return used.bracket == worst->second ? text : text + "; " + largest;
}

// The verdict first: what is proven, with which gains, on which bounds, and what the simulations said.
std::string verdict_section(const VerificationReport& r) {
  const Design& d = r.design.design;
  const auto& b = d.bounds;
  const CertifiedObserver& o = d.selected().observer;
  const MonteCarloReport& mc = r.monte_carlo;
  const bool proven = o.certified && d.proven();
  std::ostringstream h;
  h << "<div style='border:2px solid " << (proven ? "#060" : "#a00") << ";padding:.5em 1em;margin:1em 0'>\n<p>"
    << verdict_line(d) << "</p>\n";
  // Bounds that support no certificate leave no gains and no simulation: the verdict line says why.
  const std::string command = "<p style='font-size:90%'>Command: <code>" + escape(r.command_line) + "</code><br>" +
                              escape(version()) + ", " + escape(r.date) + "</p>\n</div>\n";
  if (!d.unfinished.empty()) return h.str() + command;
  h << "<p>Gains k1 = " << number(o.k1) << ", k2 = " << number(o.k2) << " (θ = "
    << number(o.theta) << ", α = " << number(d.alpha) << ", β = " << number(d.beta) << "), " << certificate_basis(d)
    << ". Bounds: "
    << (b.certified ? "proven by interval branch and bound, " + bracket_gaps(d) : std::string("numeric estimates (not proven)"))
    << ".</p>\n<p>Monte Carlo: "
    << (!mc.not_run.empty() ? "<span class='bad'>" + escape(mc.not_run) + "</span>.</p>\n"
        : fmt::format("{} trials, {}, {} left the velocity box.</p>\n", mc.trials,
                      mc.certificate_held() ? "<span class='ok'>no violation of the envelope or the Lyapunov level</span>"
                                            : "<span class='bad'>violations found</span>",
                      mc.assumption_violations));
  if (r.design.deployment) {
    const DeploymentCertificate& dep = r.design.deployment->certificate;
    h << fmt::format("<p>Deployed at T = {:g} s: {} ultimate errors ||q̂ − q|| ≤ {:.4g} rad, ||v̂ − v|| ≤ {:.4g} rad/s; "
                     "largest sample period within the {:.4g} rad/s tolerance {:.4g} s.</p>\n",
                     dep.sample_period, dep.proven() && proven ? "certified" : "estimated (not proven)",
                     dep.bounds.position_norm, dep.bounds.velocity_norm, dep.velocity_error_tolerance, dep.max_sample_period);
  }
  return h.str() + command;
}

std::string model_section(const VerificationReport& r) {
  const Design& d = r.design.design;
  std::ostringstream h;
  h << "<h2>1. Model and assumption</h2>\n<p>Robot <b>" << escape(r.robot) << "</b>, " << d.dof
    << " joints. Saturated Luenberger observer (Celani) with gains k1 = θα, k2 = θ²β. "
       "<b>Assumption:</b> the observed trajectory keeps its joint velocities in the box |v<sub>i</sub>| ≤ V<sub>i</sub>, V = "
    << format_vector(d.velocity_bounds)
    << " rad/s. Everything below is certified for every initial observer state, for every input, and only "
       "while that assumption holds.</p>\n";
  for (const auto& w : d.warnings) h << "<p class='warn'>Warning: " << escape(w) << "</p>\n";
  return h.str();
}

// What stopped an unfinished search, and its pace then: what a larger budget would buy (docs/usage.md).
std::string search_end(const BoundBracket& k) {
  const std::string stop = escape(stop_text(k.stop).name), pace = pace_text(k);
  return pace.empty() ? stop : stop + "; " + escape(pace);
}

std::string bound_row(const BoundReport& b, const std::string& name, const BoundMaximum& m, const BoundBracket& k) {
  std::string where = "q = " + format_vector(m.q);
  if (m.velocity_vertex.size()) where += ", v = " + format_vector(m.velocity_vertex);
  if (m.saturation_pattern.size()) where += ", D = diag" + format_vector(m.saturation_pattern);
  // Both ends to the same ten digits, so that they can be compared digit by digit.
  const auto digits = [](double x) { return fmt::format("{:.10g}", x); };
  // The search's end beside the gap it explains (the argmax column is wide, and the table scrolls).
  return table_row({name, digits(b.certified ? k.lower : m.value), b.certified ? digits(k.upper) : "—",
                    b.certified ? fmt::format("{:.1e}", (k.upper - k.lower) / k.upper) : "—",
                    !b.certified ? "—" : k.stop == SearchStop::gap ? "gap reached" : search_end(k), where,
                    number(m.global_value), number(m.polish_value), b.certified ? std::to_string(k.boxes) : "—"});
}

std::string bounds_section(const VerificationReport& r) {
  const Design& d = r.design.design;
  const auto& b = d.bounds;
  std::ostringstream h;
  h << "<h2>2. Bounds</h2>\n<p>Method: <b>" << b.method()
    << "</b>. The velocity enters through the vertices of the box only (the norms are convex in v and in the "
       "saturation pattern D). The numerical search (NLopt DIRECT-L, then Ipopt) gives values attained at a point; "
    << (b.certified ? "an interval branch and bound (Boost.Interval, outward rounding) gives upper bounds that provably "
                      "exceed the suprema. The design uses the upper ends."
                    : "no certified bracket is available for this model, so the design rests on these lower estimates.")
    << "</p>\n"
    << table(table_row({"constant", "lower (attained)", "upper (certified)", "gap", "search", "argmax", "NLopt", "Ipopt",
                        "boxes"},
                       true) +
             bound_row(b, "M0 = sup ||M⁻¹||", b.M0, b.M0_bracket) + bound_row(b, "B = sup ||∂A/∂v||", b.B, b.B_bracket) +
             bound_row(b, "L_joint", b.L_joint, b.L_joint_bracket) +
             (b.scaled() ? bound_row(b, "L_T = sup ||T Φ T⁻¹||", b.L_scaled, b.L_scaled_bracket) : std::string()))
    << "<p style='font-size:90%'><i>lower</i>: a value attained at a point (a lower bound of the "
       "supremum). <i>upper</i>: proven to be above the supremum over the whole joint domain. <i>gap</i>: "
       "(upper − lower)/upper. <i>search</i>: whether the search reached the gap target, or what stopped it first: "
       "<i>budget</i> (--bound-budget), <i>boxes</i> (the box limit), <i>wall-clock limit</i> (the safety limit: the "
       "bracket may differ between runs), or <i>race</i> (L_joint and L_T each searched a first share of their budget, "
       "and the other's upper end was then lower). <i>excess x p per doubling of the work</i>: the search's pace "
       "lately, its excess over the value attained multiplied by p per doubling of its work (an observation, not a "
       "bound). "
       "<i>boxes</i>: interval boxes of joint positions the branch and bound examined. "
       "<i>NLopt</i>, <i>Ipopt</i>: the two optimisers' attained values.</p>\n"
    << "<p>||F|| = " << number(b.F_norm) << ", L_paper = M0 (B + ||F||) = " << number(b.L_paper)
    << ". The certificate uses L = " << number(d.selected().observer.L) << " ("
    << (d.certificate == CertificateKind::scaled ? "L_T, similarity scaling T = " + format_scaling(b.scaling) : d.L_source)
    << ").</p>\n";
  return h.str();
}

std::string certificate_section(const VerificationReport& r) {
  const Design& d = r.design.design;
  const CertifiedObserver& o = d.selected().observer;
  std::ostringstream h;
  h << "<h2>3. Lyapunov equation</h2>\n<p>Gᵀ S + S G = −I with G = [[−α, 1], [−β, 0]] ⊗ I, α = " << number(d.alpha)
    << ", β = " << number(d.beta) << " (Bartels–Stewart): S block = [[" << number(d.lyapunov.S2(0, 0)) << ", "
    << number(d.lyapunov.S2(0, 1)) << "], [" << number(d.lyapunov.S2(1, 0)) << ", " << number(d.lyapunov.S2(1, 1))
    << "]], ||S|| = " << number(d.lyapunov.S_norm) << ", relative residual " << fmt::format("{:.1e}", d.lyapunov.residual)
    << ".</p>\n";
  if (d.shape.optimized) h << "<p>" << escape(shape_summary(d)) << ".</p>\n";
  std::vector<std::string> header = {"", "paper (Theorem 1)", "tight (bounded-real)"};
  if (d.scaled) header.push_back("scaled (bounded-real in T e)");  // T is given under the bounds
  if (d.polytopic) header.push_back("polytopic (full P, SDP)");
  std::string rows = table_row(header, true);
  for (const ComparisonRow& row : certificate_comparison(d)) {
    std::vector<std::string> cells = {row.label, number(row.paper), number(row.tight)};
    if (row.scaled) cells.push_back(number(*row.scaled));
    if (row.polytopic) cells.push_back(std::isnan(*row.polytopic) ? "—" : number(*row.polytopic));
    rows += table_row(cells);
  }
  h << "<h2>4. Certificates side by side</h2>\n" << table(rows) << "<p>Selected: <b>" << to_string(d.certificate) << "</b>. "
    << (!o.certified ? std::string("<span class='bad'>Not certified.</span>")
                     : fmt::format("{}: ||e(t)|| ≤ {:.6g} ||e(0)|| e<sup>−{:.6g} t</sup>.",
                                   d.proven() ? "<span class='ok'>Certified</span>"
                                              : "<span class='bad'>Estimate (numeric bounds, not proven)</span>",
                                   o.k, o.gamma) +
                           (d.proven() ? "" : " Not proven: " + escape(d.not_proven_reason) + "."))
    << (d.selected().lmi_max_eig
            ? fmt::format(" The {} certificate's LMI largest eigenvalue {:.2e} (negative certifies).",
                          to_string(d.certificate), *d.selected().lmi_max_eig)
            : "")
    << "</p>\n";
  return h.str();
}

std::string monte_carlo_section(const VerificationReport& r) {
  const MonteCarloReport& mc = r.monte_carlo;
  std::ostringstream h;
  if (!mc.not_run.empty()) return "<h2>5. Monte Carlo</h2>\n<p class='warn'>Monte Carlo " + escape(mc.not_run) + ".</p>\n";
  h << "<h2>5. Monte Carlo</h2>\n<p>" << mc.trials << " trials (" << mc.scenario << " scenario, " << mc.initial_errors
    << " initial errors, horizon " << mc.simulation.horizon << " s, seed " << mc.seed << "): "
    << (mc.certificate_held() ? "<span class='ok'>no trajectory left the certified envelope</span>"
                              : "<span class='bad'>CERTIFICATE VIOLATED</span>")
    << ".</p>\n"
    << table(table_row({"passed", "envelope violations", "Lyapunov violations", "left the velocity box",
                        "worst envelope ratio", "worst Lyapunov ratio", "fitted rate min / median / max", "certified γ"},
                       true) +
             table_row({std::to_string(mc.passed), std::to_string(mc.envelope_violations),
                        std::to_string(mc.lyapunov_violations), std::to_string(mc.assumption_violations),
                        fmt::format("{:.4g}", mc.worst_envelope_ratio), fmt::format("{:.4g}", mc.worst_lyapunov_ratio),
                        mc.decay_rate.trials > 0 ? fmt::format("{:.4g} / {:.4g} / {:.4g} ({} trials)", mc.decay_rate.min,
                                                               mc.decay_rate.median, mc.decay_rate.max, mc.decay_rate.trials)
                                                 : std::string("none to fit"),
                        number(mc.certificate.observer.gamma)}))
    << "<p style='font-size:90%'><i>envelope ratio</i>: the largest ||e(t)|| / (k ||e(0)|| e<sup>−γt</sup>) "
       "over a trial; <i>Lyapunov ratio</i>: the largest V(e(t)) / (V(e(0)) e<sup>−2γt</sup>) with V(e) = eᵀPe; "
       "both must stay at or below 1. <i>fitted rate</i>: the decay rate fitted to log ||e(t)|| (sampled: only over "
       "trials whose error decayed tenfold above twice the certified floor).</p>\n"
       "<p>Trials that leave the velocity box are outside the theorem's assumption: they prove nothing and "
       "are counted apart.</p>\n";
  return h.str();
}

std::string deployment_section(const VerificationReport& r) {
  if (!r.design.deployment) return {};
  const Design& d = r.design.design;
  const DeploymentCertificate& dep = r.design.deployment->certificate;
  const SampledErrorBounds& sb = dep.bounds;
  const bool proven = dep.proven() && d.proven() && d.selected().observer.certified;
  std::ostringstream h;
  h << "<h2>5b. Deployment: sampled, quantised observer</h2>\n<p>The Observer class runs every T = "
    << number(dep.sample_period) << " s on encoder positions of resolution " << format_vector(dep.encoder_resolution)
    << " rad, under the acceleration box |q''<sub>i</sub>| ≤ " << format_vector(dep.acceleration_bounds)
    << ". Its measurement (interpolated between samples) is within d = δ/2 + A T²/8 = "
    << format_vector(dep.measurement_error) << " of q(t), a bounded disturbance of the error equation "
    << "(docs/theory.md, Deployment). "
    << (proven ? "<span class='ok'>Certified</span>" : "<span class='bad'>Not proven</span>")
    << ":</p>\n<p>||e(t)|| ≤ " << number(dep.k) << " ||e(0)|| e<sup>−" << number(dep.gamma) << " t</sup> + "
    << number(sb.offset) << "</p>\n"
    << table(table_row({"C_q bracket", "M0 C_q", "ultimate ||q̂ − q||", "ultimate ||v̂ − v||", "tolerance",
                        "largest T within it", "RK4 sub-steps"},
                       true) +
             table_row({fmt::format("[{:.6g}, {:.6g}]", dep.position_sensitivity.lower, dep.position_sensitivity.upper),
                        number(dep.model_gain), number(sb.position_norm), number(sb.velocity_norm),
                        number(dep.velocity_error_tolerance), number(dep.max_sample_period), std::to_string(dep.substeps)}))
    << "<p style='font-size:90%'><i>C_q</i>: sup ||∂(M(q)a + A(q, v) + g(q))/∂q|| over the joint domain "
       "and the velocity and acceleration boxes (interval branch and bound): how far the model moves when it is "
       "evaluated at the measured position. The Monte Carlo above ran this class, sampled and quantised; its "
       "envelope and Lyapunov ratios include the offsets. Over the last fifth of the horizon ||v̂ − v|| reached "
    << number(r.monte_carlo.worst_final_velocity_error) << " rad/s.</p>\n";
  return h.str();
}

std::string plots_section(const std::vector<Plot>& plot_list, const std::vector<std::string>& svgs,
                          const std::string& plots_note) {
  std::ostringstream h;
  h << "<h2>6. Plots</h2>\n";
  if (!plots_note.empty()) h << "<p class='warn'>Plots are missing: " << escape(plots_note) << "</p>\n";
  for (std::size_t i = 0; i < plot_list.size() && i < svgs.size(); ++i)
    h << "<figure>" << svgs[i] << "<figcaption>(" << i + 1 << ") " << plot_list[i].title << " — data: "
      << plot_list[i].name << ".csv</figcaption></figure>\n";
  return h.str();
}

std::string html(const VerificationReport& r, const std::vector<Plot>& plot_list, const std::vector<std::string>& svgs,
                 const std::string& plots_note) {
  return head(r) + verdict_section(r) + model_section(r) + bounds_section(r) + certificate_section(r) +
         monte_carlo_section(r) + deployment_section(r) + plots_section(plot_list, svgs, plots_note) + "</body></html>\n";
}

enum class GnuplotRun { drawn, missing, failed };

// Runs gnuplot on `script` in `directory` with its output into `svg`, without a shell: the paths are arguments,
// never command text (the directory is the user's, and may hold any character).
GnuplotRun run_gnuplot(const fs::path& directory, const fs::path& script, const fs::path& svg, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, directory.c_str());
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, svg.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::string program = "gnuplot", argument = script.string();
  char* argv[] = {program.data(), argument.data(), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return GnuplotRun::missing;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return GnuplotRun::failed;
  // 127: the child could not execute gnuplot (glibc's posix_spawnp may report it that way).
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127) return GnuplotRun::missing;
  return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? GnuplotRun::drawn : GnuplotRun::failed;
}

// The plots as inline SVG, or why there are none.
std::vector<std::string> draw(const std::vector<Plot>& plot_list, const fs::path& dir, std::string& note) {
  std::vector<std::string> svgs;
  for (const Plot& p : plot_list) {
    const fs::path script = dir / (p.name + ".gp"), svg = dir / (p.name + ".svg"), log = dir / (p.name + ".log");
    write_file(script, p.script);
    const GnuplotRun run = run_gnuplot(dir, script, svg, log);
    if (run != GnuplotRun::drawn) {
      note = run == GnuplotRun::missing
                 ? "gnuplot is not installed (Debian package gnuplot-nox); the CSV data are in " + dir.string()
                 : "gnuplot failed on " + p.name + ".gp (see " + p.name + ".log)";
      return {};
    }
    const std::string inlined = inline_svg(read_file(svg));
    if (inlined.empty()) {
      note = "gnuplot failed on " + p.name + ".gp (see " + p.name + ".log)";
      return {};
    }
    svgs.push_back(inlined);
  }
  return svgs;
}

}  // namespace

void require_report_directory(const std::string& option, const std::string& directory) {
  const std::string named = option + " = '" + directory + "'";
  std::error_code error;
  const fs::path normal = fs::path(directory).lexically_normal();
  fs::path existing = normal;
  while (!existing.empty() && !fs::exists(existing, error)) existing = existing.parent_path();
  if (existing.empty()) existing = ".";
  if (!fs::is_directory(existing, error))
    throw InputError(existing == normal ? named + " is not a directory"
                                        : named + ": '" + existing.string() + "' is not a directory");
  if (access(existing.c_str(), W_OK) != 0)
    throw InputError(named + ": the directory '" + existing.string() + "' is not writable");
}

WrittenReport write_verification_report(const VerificationReport& r, const std::string& directory) {
  const fs::path dir = fs::absolute(fs::path(directory));
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) throw InputError("cannot create output directory '" + directory + "': " + error.message());
  write_data(r, dir);
  WrittenReport written;
  written.json = (dir / "report.json").string();
  written.html = (dir / "report.html").string();
  write_file(dir / "report.json", to_json_text(r));
  const std::vector<Plot> plot_list = plots(r);
  const std::vector<std::string> svgs = draw(plot_list, dir, written.plots_note);
  written.plots = written.plots_note.empty();
  write_file(dir / "report.html", html(r, plot_list, svgs, written.plots_note));
  return written;
}

}  // namespace obsgain
