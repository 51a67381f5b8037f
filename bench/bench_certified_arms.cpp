// The arms people own, certified: for each arm, `design-gains --robot FILE --gamma 5` with numeric bounds (the
// optimisers' lower estimates) and with certified bounds at the default budget (120 reference seconds), printed as
// the Markdown table of docs/theory.md ("Certified bounds on the arms"), with the bracket of the constant the
// certified design rests on (L_T's where the scaled certificate is chosen). About 25 minutes on 2 cores.
// Run: build/bench/bench_certified_arms [BUDGET_SECONDS]
#include "obsgain/design/design.hpp"
#include "obsgain/model/input_error.hpp"
#include "obsgain/parsers/robots.hpp"

#include "cli.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

namespace {

struct Arm {
  std::string label, file;
  std::vector<double> armature;  // empty: the file's
};

struct Run {
  obsgain::Design design;
  double seconds = 0.0;
};

Run design(const obsgain::Model& model, obsgain::BoundMethod method, double budget) {
  obsgain::DesignOptions options;
  options.gamma = 5.0;
  options.bound_method = method;
  options.certified_bounds.budget_seconds = budget;
  const auto start = std::chrono::steady_clock::now();
  Run run{obsgain::design_gains(model, options), 0.0};
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  double budget = 120.0;
  try {
    if (argc > 2) throw obsgain::InputError(fmt::format("'{}' is one argument too many", argv[2]));
    if (argc > 1) budget = obsgain::parse_number("budget", argv[1]);
    if (budget < 0.0) throw obsgain::InputError(fmt::format("budget = {} must be >= 0", argv[1]));
  } catch (const obsgain::InputError& error) {
    fmt::print(stderr, "bench_certified_arms: {} (give one number of reference seconds, default 120)\n", error.what());
    return 2;
  }
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const std::vector<Arm> arms{
      {"Pendubot (built in)", "pendubot", {}},
      {"`examples/arm3.urdf`", examples + "/arm3.urdf", {}},
      {"`examples/arm6.urdf`", examples + "/arm6.urdf", {}},
      {"`examples/arm7.urdf`", examples + "/arm7.urdf", {}},
      {"UR5 as published", examples + "/ur5.urdf", {}},
      {"UR5, armature 0.6 (base to elbow), 0.2 (wrists)", examples + "/ur5.urdf", {0.6, 0.6, 0.6, 0.2, 0.2, 0.2}},
      {"Panda as published", examples + "/panda.urdf", {}},
      {"Panda, armature 0.1", examples + "/panda.urdf", std::vector<double>(7, 0.1)},
      {"iiwa 14, Drake's rotor inertia", examples + "/iiwa14.urdf", {}},
      {"Jaco2 as published", examples + "/jaco2.urdf", {}},
      {"Jaco2, armature 0.1", examples + "/jaco2.urdf", std::vector<double>(6, 0.1)},
  };
  fmt::print("budget {} reference seconds\n\n", budget);
  fmt::print("| arm | numeric: θ (time) | certified: θ (time) | θ ratio | L used: attained | certified bracket upper (gap) |\n");
  fmt::print("| --- | --- | --- | --- | --- | --- |\n");
  for (const Arm& arm : arms) {
    obsgain::RobotSource source;
    source.robot = arm.file;
    source.armature = arm.armature;
    const obsgain::Model model = obsgain::load_robot(source);
    const Run numeric = design(model, obsgain::BoundMethod::numeric, budget);
    const Run certified = design(model, obsgain::BoundMethod::certified, budget);
    // The bracket of the constant the design rests on: L_T's where the scaled certificate is chosen.
    const bool scaled = certified.design.certificate == obsgain::CertificateKind::scaled;
    const obsgain::BoundBracket& L = scaled ? certified.design.bounds.L_scaled_bracket : certified.design.bounds.L_joint_bracket;
    const double theta_numeric = numeric.design.selected().observer.theta;
    const std::string theta_certified =
        certified.design.unfinished.empty() ? fmt::format("{:.4g}", certified.design.selected().observer.theta) : "none";
    const std::string upper =
        std::isfinite(L.upper) ? fmt::format("{:.6g} ({:.1e})", L.upper, (L.upper - L.lower) / L.upper) : "none finite";
    fmt::print("| {} | {:.4g} ({:.1f} s) | {} ({:.0f} s) | {} | {}{:.6g} | {} |\n", arm.label, theta_numeric,
               numeric.seconds, theta_certified, certified.seconds,
               certified.design.unfinished.empty()
                   ? fmt::format("{:.3f}", certified.design.selected().observer.theta / theta_numeric)
                   : "-",
               scaled ? "L_T " : "", L.lower, upper);
    std::fflush(stdout);
  }
}
