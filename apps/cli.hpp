// The command-line options shared by design-gains, monte-carlo and verify-bounds, and their strict
// parsing into library options. The apps only wire these to CLI11 and print.
#pragma once

#include "obsgain/deployment/deployment.hpp"
#include "obsgain/validation/montecarlo.hpp"

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace obsgain {

// Raw text of the design options, parsed by to_design_options so that every error names the bad value.
struct DesignArguments {
  std::string robot = "pendubot";
  std::string base_link, tip_link, actuated, armature, joint_limits;
  std::string vmax, gamma, theta, alpha, beta, L, rate_margin, bound_budget, proof_budget, checkpoint, resume;
  std::string sample_period, encoder_counts, acceleration_bounds, velocity_error_tolerance, latency;
  std::string objective = "rate";
  std::string threads = "0";
  std::string lipschitz = "joint";
  std::string certificate;  // empty: tight, or scaled where it is better
  std::optional<int> polytope_cells;
  std::string bounds = "certified";
  bool optimize_shape = false;
  bool quiet = false;
  std::vector<const CLI::Option*> given;  // every design option, to tell which the user gave
};

void add_design_options(CLI::App& app, DesignArguments& arguments);

// What the design options ask for: the design, and the deployment when --sample-period and its companions are given.
struct DesignRequest {
  DesignOptions design;
  std::optional<DeploymentOptions> deployment;
};
// Progress lines go to stderr for robots of more than two joints (the Pendubot's design takes a tenth of a second),
// unless --quiet; on a terminal the running searches also rewrite a line in place.
DesignRequest to_design_request(const DesignArguments& arguments, const Model& model);
RobotSource to_robot_source(const DesignArguments& arguments);

struct MonteCarloArguments {
  std::string trials = "1000", seed = "1", horizon = "1", rtol = "1e-8", atol = "1e-10";
  std::string scenario = "random", initial_errors = "both";
  std::string step_budget;  // not given: MonteCarloOptions' default
  const CLI::Option* step_budget_option = nullptr;
};

void add_monte_carlo_options(CLI::App& app, MonteCarloArguments& arguments);

// `quiet`: no progress line (else one on a terminal, rewritten in place).
MonteCarloOptions to_monte_carlo_options(const MonteCarloArguments& arguments, const DesignArguments& design);

// What a validation runs against: a design computed from the design options, or one saved by design-gains.
struct ValidationTarget {
  Model model;
  ObserverCertificate certificate;
};
ValidationTarget load_validation_target(const DesignArguments& design, const std::string& design_file);

// The output files an app writes at its end, {option, path}, checked before any work (as the checkpoint is, opened
// with the request), so that a typo in a path does not cost a whole design: each directory exists and is writable,
// and no path is a directory ("" and "-" are none and stdout). Rank 0 writes the files, so rank 0 checks; its
// InputError ends an MPI job (run_app).
void require_writable(const std::vector<std::pair<std::string, std::string>>& outputs);

// A finite number, or InputError "<name> = '<text>' is not a number".
double parse_number(const std::string& name, const std::string& text);
// "1,2.5,3" -> (1, 2.5, 3).
Eigen::VectorXd parse_number_list(const std::string& name, const std::string& text);

// Clears the terminal's progress line (written in place while searches run) before other output.
void close_progress_line();

// A request that cannot be met (or proven within the budget): the apps exit 1 with its message.
class UnmetRequest : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Runs an app's body: bad input (InputError, CLI11 parse errors) prints one line on stderr and exits 2; an
// UnmetRequest exits 1;
// --help prints and exits 0; anything else unexpected prints and exits 3.
int run_app(CLI::App& app, int argc, char** argv, const std::function<int()>& body);

}  // namespace obsgain
