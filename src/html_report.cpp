// The verification report a person reads: one self-contained HTML page with inline SVG plots.
#include "obsgain/report.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

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
  rates << "theta,paper_gamma,tight_gamma\n";
  for (const auto& p : r.rate_curve) rates << fmt::format("{:.9g},{:.12g},{:.12g}\n", p.theta, p.paper_gamma, p.tight_gamma);
  write_file(dir / "rate_vs_theta.csv", rates.str());

  if (r.design.deployment) {
    std::ostringstream tradeoff;
    tradeoff << "theta,alpha,gamma,k,ultimate_position_error_norm,ultimate_velocity_error_norm\n";
    for (const TradeoffPoint& p : r.design.tradeoff)
      tradeoff << fmt::format("{:.9g},{:.9g},{:.12g},{:.9g},{:.9g},{:.9g}\n", p.theta, p.alpha, p.gamma, p.k,
                              p.position_norm, p.velocity_norm);
    write_file(dir / "velocity_error_tradeoff.csv", tradeoff.str());
  }

  std::ofstream trials(dir / "monte_carlo_trials.csv");
  write_trials_csv(r.monte_carlo, trials);
}

struct Plot {
  std::string name, title, script;
};

std::vector<Plot> plots(const VerificationReport& r) {
  const Design& d = r.design;
  const auto& b = d.bounds;
  const std::string joint = fmt::format("q{}", r.curve_joint + 1);
  const std::string common = "set terminal svg size 760,400 dynamic enhanced font 'sans,11'\nset datafile separator ','\n"
                             "set key below\nset grid\nset format y '%.8g'\n";
  std::vector<Plot> out;
  // A numeric estimate is never drawn as an upper bound.
  const std::string kind = b.certified ? "proven upper bound" : "numeric estimate, not proven";
  out.push_back({"bound_curves",
                 fmt::format("The bounds' functions along {} (the other joints at the M0 argmax), max over the velocity "
                             "vertices and saturation patterns; dashed: the value the design uses ({})",
                             joint, kind),
                 common + fmt::format("set multiplot layout 1,3\nset xlabel '{0} [rad]'\n"
                                      "set title '||M(q)^{{-1}}|| [1/(kg m^2)]'\n"
                                      "plot 'bound_curves.csv' every ::1 using 1:2 with lines lw 2 title 'sampled', "
                                      "{1:.12g} with lines dt 2 lw 2 title 'M0'\n"
                                      "set title 'max_w ||J(q,w)|| [kg m^2/s]'\n"
                                      "plot 'bound_curves.csv' every ::1 using 1:3 with lines lw 2 title 'sampled', "
                                      "{2:.12g} with lines dt 2 lw 2 title 'B'\n"
                                      "set title 'max_{{w,D}} ||M^{{-1}}(J D + F)|| [1/s]'\n"
                                      "plot 'bound_curves.csv' every ::1 using 1:4 with lines lw 2 title 'sampled', "
                                      "{3:.12g} with lines dt 2 lw 2 title 'L_{{joint}}'\nunset multiplot\n",
                                      joint, b.M0.value, b.B.value, b.L_joint.value)});
  const int n = d.dof;
  std::string series;
  for (int i = 0; i < n; ++i) {
    series += fmt::format("{}'paper_scenario.csv' every ::1 using 1:{} with lines lw 2 title 'v{}', "
                          "'paper_scenario.csv' every ::1 using 1:{} with lines dt 2 lw 2 title 'v{} estimate'",
                          i ? ", " : "", 2 + n + i, i + 1, 2 + 3 * n + i, i + 1);
  }
  // Say when and why the run leaves the velocity box: from then on it is outside the theorem's assumption.
  std::string left_box;
  for (const TrajectorySample& sample : r.paper_run) {
    Eigen::Index joint = 0;
    if ((sample.v.array().abs() / d.velocity_bounds.array()).maxCoeff(&joint) > 1.0) {
      left_box = fmt::format(" — leaves the velocity box at t = {:.4g} s (|v{}| > V{} = {:g}): outside the theorem's "
                             "assumption from then on",
                             sample.t, joint + 1, joint + 1, d.velocity_bounds(joint));
      break;
    }
  }
  out.push_back({"paper_scenario",
                 (r.example_scenario == "paper" ? "The paper's scenario: velocities and their estimates (the paper's Fig. 2)"
                                                : "Random trial 0: velocities and their estimates") + left_box,
                 common + "set title \"joint velocities (solid) and the observer's estimates (dashed)\"\n"
                          "set xlabel 't [s]'\nset ylabel 'velocity [rad/s]'\nplot " + series + "\n"});
  const int traces = static_cast<int>(r.error_traces.size());
  out.push_back({"monte_carlo_errors",
                 fmt::format("Observer error norms of {} of the {} Monte Carlo trials against the certified envelope",
                             traces, r.monte_carlo.trials),
                 common + fmt::format("set title '||e(t)|| / ||e(0)||, {0} trials'\nset logscale y\nset format y '10^{{%T}}'\n"
                                      "set xlabel 't [s]'\nset ylabel '||e(t)|| / ||e(0)|| (log scale)'\n"
                                      "plot for [i=0:{1}] 'monte_carlo_errors.csv' every ::1 using 2:($1 == i ? $3 : NaN) "
                                      "with lines lc rgb '#3070b0' notitle, 'monte_carlo_errors.csv' every ::1 using "
                                      "2:($1 == 0 ? $4 : NaN) with lines lw 3 lc rgb '#c03020' title '{2}'\n",
                                      traces, std::max(0, traces - 1),
                                      d.deployment ? "envelope of trial 0, k exp(-gamma t) + offset/||e(0)|| (sampled, quantised)"
                                                   : "envelope k exp(-gamma t)")});
  out.push_back({"rate_vs_theta", "Certified rate against the gain, both certificates",
                 common + fmt::format("set title \"dotted: the design's theta = {0:.6g}\"\nset xlabel 'theta [1/s]'\n"
                                      "set ylabel 'certified gamma [1/s]'\n"
                                      "set arrow from {0:.9g}, graph 0 to {0:.9g}, graph 1 nohead dt 3\n"
                                      "plot 'rate_vs_theta.csv' every ::1 using 1:2 with lines lw 2 title 'paper', "
                                      "'rate_vs_theta.csv' every ::1 using 1:3 with lines lw 2 title 'tight', "
                                      "0 with lines lc rgb 'black' notitle\n",
                                      d.selected().theta)});
  if (const auto& dep = d.deployment) {
    out.push_back({"velocity_error_tradeoff",
                   fmt::format("Deployment at T = {:g} s: the certified ultimate errors against the gain (each point "
                               "certifies at least the target rate); dotted: the design's theta",
                               dep->sample_period),
                   common + fmt::format("set multiplot layout 1,2\nset logscale xy\nset format y '%.3g'\n"
                                        "set xlabel 'theta [1/s] (log scale)'\n"
                                        "set arrow from {0:.9g}, graph 0 to {0:.9g}, graph 1 nohead dt 3\n"
                                        "set title 'ultimate ||v^ - v|| [rad/s]'\n"
                                        "plot 'velocity_error_tradeoff.csv' every ::1 using 1:6 with linespoints lw 2 "
                                        "title 'certified ultimate velocity error'\n"
                                        "set title 'ultimate ||q^ - q|| [rad]'\n"
                                        "plot 'velocity_error_tradeoff.csv' every ::1 using 1:5 with linespoints lw 2 "
                                        "title 'certified ultimate position error'\nunset multiplot\n",
                                        d.selected().theta)});
  }
  return out;
}

std::string inline_svg(const std::string& svg) {
  const auto start = svg.find("<svg");
  return start == std::string::npos ? std::string() : svg.substr(start);
}

std::string table_row(const std::vector<std::string>& cells, bool header = false) {
  std::string row = "<tr>";
  for (const auto& c : cells) row += header ? "<th>" + c + "</th>" : "<td>" + c + "</td>";
  return row + "</tr>\n";
}

std::string number(double x) { return fmt::format("{:.7g}", x); }

std::string html(const VerificationReport& r, const std::vector<Plot>& plot_list, const std::vector<std::string>& svgs,
                 const std::string& plots_note) {
  const Design& d = r.design;
  const auto& b = d.bounds;
  const MonteCarloReport& mc = r.monte_carlo;
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>obsgain verification: " << escape(r.robot)
    << "</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4;color:#222}"
       "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right;white-space:nowrap}"
       "th{background:#eef}td:first-child,th:first-child{text-align:left}.ok{color:#060;font-weight:bold}"
       ".bad{color:#a00;font-weight:bold}.warn{background:#fff4d0;padding:.5em}figure{margin:1.5em 0}"
       "figcaption{font-style:italic}</style></head><body>\n";
  h << "<h1>Observer verification report: " << escape(r.robot) << "</h1>\n";

  // The verdict first: what is proven, with which gains, on which bounds, and what the simulations said.
  const CertificateSummary& s = d.selected();
  const bool proven = s.certified && d.proven();
  double worst_gap = 0.0;
  if (b.certified)
    for (const BoundBracket* k : {&b.M0_bracket, &b.B_bracket, &b.L_joint_bracket})
      worst_gap = std::max(worst_gap, (k->upper - k->lower) / k->upper);
  h << "<div style='border:2px solid " << (proven ? "#060" : "#a00") << ";padding:.5em 1em;margin:1em 0'>\n<p>"
    << (proven ? fmt::format("<span class='ok'>CERTIFIED</span>: ||e(t)|| ≤ {:.6g} ||e(0)|| e<sup>−{:.6g} t</sup> for every "
                             "initial observer error, while |v<sub>i</sub>(t)| ≤ V<sub>i</sub>.",
                             s.k, s.envelope_gamma)
               : s.certified ? "<span class='bad'>NOT PROVEN</span>: " + escape(d.not_proven_reason) + "."
                             : std::string("<span class='bad'>NOT CERTIFIED</span>: the chosen gain certifies no rate."))
    << "</p>\n<p>Gains k1 = " << number(s.k1) << ", k2 = " << number(s.k2) << " (θ = " << number(s.theta)
    << ", α = " << number(d.alpha) << ", β = " << number(d.beta) << "), " << to_string(d.certificate)
    << " certificate on L = " << number(d.L_used) << " (" << escape(d.L_source) << "). Bounds: "
    << (b.certified ? fmt::format("proven by interval branch and bound, largest relative gap {:.1e}", worst_gap)
                    : std::string("numeric estimates (not proven)"))
    << ".</p>\n<p>Monte Carlo: " << mc.trials << " trials, "
    << (mc.certificate_held() ? "<span class='ok'>no violation of the envelope or the Lyapunov level</span>"
                              : "<span class='bad'>violations found</span>")
    << ", " << mc.assumption_violations << " left the velocity box.</p>\n"
    << (d.deployment ? fmt::format("<p>Deployed at T = {:g} s: {} ultimate errors ||q̂ − q|| ≤ {:.4g} rad, ||v̂ − v|| ≤ "
                                   "{:.4g} rad/s; largest sample period within the {:.4g} rad/s tolerance {:.4g} s.</p>\n",
                                   d.deployment->sample_period,
                                   d.deployment->proven() && proven ? "certified" : "estimated (not proven)",
                                   d.deployment->bounds.position_norm, d.deployment->bounds.velocity_norm,
                                   d.deployment->velocity_error_tolerance, d.deployment->max_sample_period)
                     : std::string())
    << "<p style='font-size:90%'>Command: <code>"
    << escape(r.command_line) << "</code><br>" << escape(version()) << ", " << escape(r.date) << "</p>\n</div>\n";

  h << "<h2>1. Model and assumption</h2>\n<p>Robot <b>" << escape(r.robot) << "</b>, " << d.dof
    << " joints. Saturated Luenberger observer (Celani) with gains k1 = θα, k2 = θ²β. "
       "<b>Assumption:</b> the observed trajectory keeps its joint velocities in the box |v<sub>i</sub>| ≤ V<sub>i</sub>, V = "
    << format_vector(d.velocity_bounds)
    << " rad/s. Everything below is certified for every initial observer state, for every input, and only "
       "while that assumption holds.</p>\n";
  for (const auto& w : d.warnings) h << "<p class='warn'>Warning: " << escape(w) << "</p>\n";

  h << "<h2>2. Bounds</h2>\n<p>Method: <b>" << b.method()
    << "</b>. The velocity enters through the vertices of the box only (the norms are convex in v and in the "
       "saturation pattern D). The numerical search (NLopt DIRECT-L, then Ipopt) gives values attained at a point; "
    << (b.certified ? "an interval branch and bound (Boost.Interval, outward rounding) gives upper bounds that provably "
                      "exceed the suprema. The design uses the upper ends."
                    : "no certified bracket is available for this model, so the design rests on these lower estimates.")
    << "</p>\n<table>\n"
    << table_row({"constant", "lower (attained)", "upper (certified)", "gap", "argmax", "NLopt", "Ipopt", "boxes"}, true);
  const auto bound_row = [&](const std::string& name, const BoundMaximum& m, const BoundBracket& k) {
    std::string where = "q = " + format_vector(m.q);
    if (m.velocity_vertex.size()) where += ", v = " + format_vector(m.velocity_vertex);
    if (m.saturation_pattern.size()) where += ", D = diag" + format_vector(m.saturation_pattern);
    // Both ends to the same ten digits, so that they can be compared digit by digit.
    const auto digits = [](double x) { return fmt::format("{:.10g}", x); };
    h << table_row({name, digits(b.certified ? k.lower : m.value), b.certified ? digits(k.upper) : "—",
                    b.certified ? fmt::format("{:.1e}", (k.upper - k.lower) / k.upper) : "—", where,
                    number(m.global_value), number(m.polish_value), b.certified ? std::to_string(k.boxes) : "—"});
  };
  bound_row("M0 = sup ||M⁻¹||", b.M0, b.M0_bracket);
  bound_row("B = sup ||∂A/∂v||", b.B, b.B_bracket);
  bound_row("L_joint", b.L_joint, b.L_joint_bracket);
  h << "</table>\n<p style='font-size:90%'><i>lower</i>: a value attained at a point (a lower bound of the "
       "supremum). <i>upper</i>: proven to be above the supremum over the whole joint domain. <i>gap</i>: "
       "(upper − lower)/upper. <i>boxes</i>: interval boxes of joint positions the branch and bound examined. "
       "<i>NLopt</i>, <i>Ipopt</i>: the two optimisers' attained values.</p>\n"
    << "<p>||F|| = " << number(b.F_norm) << ", L_paper = M0 (B + ||F||) = " << number(b.L_paper)
    << ". The certificate uses L = " << number(d.L_used) << " (" << d.L_source << ").</p>\n";

  h << "<h2>3. Lyapunov equation</h2>\n<p>Gᵀ S + S G = −I with G = [[−α, 1], [−β, 0]] ⊗ I, α = " << number(d.alpha)
    << ", β = " << number(d.beta) << " (Bartels–Stewart): S block = [[" << number(d.lyapunov.S2(0, 0)) << ", "
    << number(d.lyapunov.S2(0, 1)) << "], [" << number(d.lyapunov.S2(1, 0)) << ", " << number(d.lyapunov.S2(1, 1))
    << "]], ||S|| = " << number(d.lyapunov.S_norm) << ", relative residual " << fmt::format("{:.1e}", d.lyapunov.residual)
    << ".</p>\n";

  h << "<h2>4. Certificates side by side</h2>\n<table>\n" << table_row({"", "paper (Theorem 1)", "tight (bounded-real)"}, true);
  for (const ComparisonRow& row : certificate_comparison(d)) h << table_row({row.label, number(row.paper), number(row.tight)});
  h << "</table>\n<p>Selected: <b>" << to_string(d.certificate) << "</b>. "
    << (!d.selected().certified
            ? std::string("<span class='bad'>Not certified.</span>")
            : fmt::format("{}: ||e(t)|| ≤ {:.6g} ||e(0)|| e<sup>−{:.6g} t</sup>.",
                          d.proven() ? "<span class='ok'>Certified</span>"
                                     : "<span class='bad'>Estimate (numeric bounds, not proven)</span>",
                          d.selected().k, d.selected().envelope_gamma) +
                  (d.proven() ? "" : " Not proven: " + d.not_proven_reason + "."))
    << (d.tight.lmi_max_eig ? fmt::format(" Tight certificate LMI largest eigenvalue {:.2e} (negative certifies).",
                                          *d.tight.lmi_max_eig)
                            : "")
    << "</p>\n";

  h << "<h2>5. Monte Carlo</h2>\n<p>" << mc.trials << " trials (" << mc.scenario << " scenario, " << mc.initial_errors
    << " initial errors, horizon " << mc.simulation.horizon << " s, seed " << mc.seed << "): "
    << (mc.certificate_held() ? "<span class='ok'>no trajectory left the certified envelope</span>"
                              : "<span class='bad'>CERTIFICATE VIOLATED</span>")
    << ".</p>\n<table>\n"
    << table_row({"passed", "envelope violations", "Lyapunov violations", "left the velocity box", "worst envelope ratio",
                  "worst Lyapunov ratio", "fitted rate min / median / max", "certified γ"},
                 true)
    << table_row({std::to_string(mc.passed), std::to_string(mc.envelope_violations), std::to_string(mc.lyapunov_violations),
                  std::to_string(mc.assumption_violations), fmt::format("{:.4g}", mc.worst_envelope_ratio),
                  fmt::format("{:.4g}", mc.worst_lyapunov_ratio),
                  fmt::format("{:.4g} / {:.4g} / {:.4g}", mc.decay_rate.min, mc.decay_rate.median, mc.decay_rate.max),
                  number(mc.certificate.gamma)})
    << "</table>\n<p style='font-size:90%'><i>envelope ratio</i>: the largest ||e(t)|| / (k ||e(0)|| e<sup>−γt</sup>) "
       "over a trial; <i>Lyapunov ratio</i>: the largest V(e(t)) / (V(e(0)) e<sup>−2γt</sup>) with V(e) = eᵀ(P ⊗ I)e; "
       "both must stay at or below 1. <i>fitted rate</i>: the decay rate fitted to log ||e(t)||.</p>\n"
       "<p>Trials that leave the velocity box are outside the theorem's assumption: they prove nothing and "
       "are counted apart.</p>\n";

  if (const auto& dep = d.deployment) {
    const SampledErrorBounds& sb = dep->bounds;
    h << "<h2>5b. Deployment: sampled, quantised observer</h2>\n<p>The Observer class runs every T = "
      << number(dep->sample_period) << " s on encoder positions of resolution " << format_vector(dep->encoder_resolution)
      << " rad, under the acceleration box |q''<sub>i</sub>| ≤ " << format_vector(dep->acceleration_bounds)
      << ". Its measurement (interpolated between samples) is within d = δ/2 + A T²/8 = "
      << format_vector(dep->measurement_error) << " of q(t), a bounded disturbance of the error equation "
      << "(docs/theory.md, Deployment). "
      << (dep->proven() && proven ? "<span class='ok'>Certified</span>" : "<span class='bad'>Not proven</span>")
      << ":</p>\n<p>||e(t)|| ≤ " << number(dep->k) << " ||e(0)|| e<sup>−" << number(dep->gamma) << " t</sup> + "
      << number(sb.offset) << "</p>\n<table>\n"
      << table_row({"C_q bracket", "M0 C_q", "ultimate ||q̂ − q||", "ultimate ||v̂ − v||", "tolerance",
                    "largest T within it", "RK4 sub-steps"},
                   true)
      << table_row({fmt::format("[{:.6g}, {:.6g}]", dep->position_sensitivity.lower, dep->position_sensitivity.upper),
                    number(dep->model_gain), number(sb.position_norm), number(sb.velocity_norm),
                    number(dep->velocity_error_tolerance), number(dep->max_sample_period), std::to_string(dep->substeps)})
      << "</table>\n<p style='font-size:90%'><i>C_q</i>: sup ||∂(M(q)a + A(q, v) + g(q))/∂q|| over the joint domain "
         "and the velocity and acceleration boxes (interval branch and bound): how far the model moves when it is "
         "evaluated at the measured position. The Monte Carlo above ran this class, sampled and quantised; its "
         "envelope and Lyapunov ratios include the offsets. Over the last fifth of the horizon ||v̂ − v|| reached "
      << number(mc.worst_final_velocity_error) << " rad/s.</p>\n";
  }

  h << "<h2>6. Plots</h2>\n";
  if (!plots_note.empty()) h << "<p class='warn'>Plots are missing: " << escape(plots_note) << "</p>\n";
  for (std::size_t i = 0; i < plot_list.size() && i < svgs.size(); ++i)
    h << "<figure>" << svgs[i] << "<figcaption>(" << i + 1 << ") " << plot_list[i].title << " — data: "
      << plot_list[i].name << ".csv</figcaption></figure>\n";
  h << "</body></html>\n";
  return h.str();
}

}  // namespace

WrittenReport write_verification_report(const VerificationReport& r, const std::string& directory) {
  const fs::path dir(directory);
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) throw InputError("cannot create output directory '" + directory + "': " + error.message());
  write_data(r, dir);
  WrittenReport written;
  written.json = (dir / "report.json").string();
  written.html = (dir / "report.html").string();
  write_file(dir / "report.json", to_json_text(r));

  const std::vector<Plot> plot_list = plots(r);
  std::vector<std::string> svgs;
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    written.plots_note = "gnuplot is not installed (Debian package gnuplot-nox); the CSV data are in " + directory;
  } else {
    for (const Plot& p : plot_list) {
      write_file(dir / (p.name + ".gp"), p.script);
      const std::string command = fmt::format("cd '{}' && gnuplot '{}.gp' > '{}.svg' 2>'{}.log'", dir.string(), p.name,
                                              p.name, p.name);
      const std::string svg = std::system(command.c_str()) == 0 ? inline_svg(read_file(dir / (p.name + ".svg"))) : "";
      if (svg.empty()) {
        written.plots_note = "gnuplot failed on " + p.name + ".gp (see " + p.name + ".log)";
        break;
      }
      svgs.push_back(svg);
    }
  }
  written.plots = written.plots_note.empty();
  write_file(dir / "report.html", html(r, plot_list, written.plots ? svgs : std::vector<std::string>{}, written.plots_note));
  return written;
}

}  // namespace obsgain
