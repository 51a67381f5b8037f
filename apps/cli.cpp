#include "cli.hpp"

#include "obsgain/numerics/distributed.hpp"
#include "obsgain/parsers/robots.hpp"
#include "obsgain/report/design_file.hpp"
#include "obsgain/report/report.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <fcntl.h>
#include <unistd.h>

namespace obsgain {

double parse_number(const std::string& name, const std::string& text) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  const bool out_of_range = errno == ERANGE;
  // Decimal only: strtod would also take "0x10" (16) and "infinity".
  const bool decimal = text.find_first_of("xXpP") == std::string::npos && text.find_first_not_of("0123456789+-.eE") == std::string::npos;
  if (text.empty() || end == begin || *end != '\0' || !decimal)
    throw InputError(fmt::format("{} = '{}' is not a decimal number", name, text.substr(0, 40)));
  if (!std::isfinite(value)) throw InputError(fmt::format("{} = {} must be finite", name, text));
  // A value too small for a normal double: strtod returns 0 or a subnormal, which would be used in its place.
  if (out_of_range)
    throw InputError(fmt::format("{} = {} is below the smallest normal double (2.2e-308) in magnitude: give 0 or a "
                                 "larger value", name, text.substr(0, 40)));
  return value;
}

namespace {

// Every item between commas, a last empty one too: "1,2," is refused as "1,,2" is (getline would drop it).
std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> items;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    items.push_back(text.substr(start, comma == std::string::npos ? comma : comma - start));
    if (comma == std::string::npos) return items;
    start = comma + 1;
  }
}

}  // namespace

Eigen::VectorXd parse_number_list(const std::string& name, const std::string& text) {
  if (text.empty()) throw InputError(fmt::format("{} = '' is empty", name));
  std::vector<double> values;
  for (const std::string& item : split_list(text)) values.push_back(parse_number(name, item));
  return Eigen::Map<Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
}

namespace {

int parse_count(const std::string& name, const std::string& text, int minimum) {
  const double value = parse_number(name, text);
  if (value != std::floor(value) || value < minimum || value > 1e9)
    throw InputError(fmt::format("{} = {} must be a whole number >= {}", name, text, minimum));
  return static_cast<int>(value);
}

// No more threads than could ever help.
int parse_threads(const std::string& text) {
  const int threads = parse_count("--threads", text, 0);
  if (threads > 256) throw InputError(fmt::format("--threads = {} must lie in [0, 256] (0: all cores)", text));
  return threads;
}

// Which robot, and its velocity box.
void add_robot_options(CLI::App& app, DesignArguments& a) {
  app.add_option("--robot", a.robot, "built-in robot name (pendubot), model file (*.json) or URDF (*.urdf)")
      ->capture_default_str()
      ->type_name("NAME|FILE");
  app.add_option("--base-link", a.base_link, "URDF: the chain's base link (default: the root)")
      ->type_name("LINK");
  app.add_option("--tip-link", a.tip_link, "URDF: the chain's tip link (default: the arm's movable path, grippers locked)")
      ->type_name("LINK");
  app.add_option("--actuated", a.actuated, "URDF: 0/1 per joint, e.g. 1,0 for a Pendubot (default: all)")
      ->type_name("0/1,...");
  app.add_option("--armature", a.armature,
                 "URDF or model file: reflected rotor inertia per joint a1,...,an [kg m^2] (default: the file's)")
      ->type_name("KG_M2,...");
  app.add_option("--joint-limits", a.joint_limits,
                 "URDF: joint ranges lo1:hi1,lo2:hi2,... [rad or m], c for the full circle (default: the file's <limit>)")
      ->type_name("LO:HI|c,...");
  app.add_option("--vmax", a.vmax, "velocity bounds V1,...,Vn [rad/s] (default: the model's)")
      ->type_name("RAD_S,...");
}

// What to certify and how: rate or gain, shape, Lipschitz constant, certificate, bounds.
void add_certificate_options(CLI::App& app, DesignArguments& a) {
  app.add_option("--gamma", a.gamma, "target convergence rate [1/s]: theta is the smallest gain certifying it (give exactly one of --gamma, --theta)")
      ->type_name("RATE");
  app.add_option("--theta", a.theta, "evaluate this gain theta and report the certified rate (exactly one of --gamma, --theta)")
      ->type_name("GAIN");
  app.add_option("--alpha", a.alpha, "observer shape alpha (default 1)")
      ->type_name("NUMBER");
  app.add_option("--beta", a.beta, "observer shape beta (default 1)")
      ->type_name("NUMBER");
  app.add_flag("--optimize-shape", a.optimize_shape, "beta = 1 and the best alpha for the certificate");
  app.add_option("--lipschitz", a.lipschitz, "Lipschitz constant: joint (docs/theory.md) or paper")
      ->check(CLI::IsMember({"joint", "paper"}))
      ->capture_default_str()
      ->type_name("joint|paper");
  app.add_option("--L", a.L, "override the Lipschitz constant (e.g. the paper's 54.01)")
      ->type_name("NUMBER");
  app.add_option("--certificate", a.certificate,
                 "tight (bounded-real lemma), scaled (the same in the coordinates of a similarity T), paper (Theorem 1) or "
                 "polytopic (one full P over a proven polytope of the perturbation, SDP; falls back when its check "
                 "fails). Default: scaled where the bounds kept a similarity scaling with a smaller L, else tight")
      ->check(CLI::IsMember({"tight", "scaled", "paper", "polytopic"}))
      ->type_name("tight|scaled|paper|polytopic");
  app.add_option("--polytope-cells", a.polytope_cells,
                 "polytopic certificate: cells covering the joint domain (default 32; more: tighter and slower)")
      ->type_name("N");
  app.add_option("--bounds", a.bounds, "certified (interval branch and bound) or numeric (optimisers only)")
      ->check(CLI::IsMember({"certified", "numeric"}))
      ->capture_default_str()
      ->type_name("certified|numeric");
  app.add_option("--bound-budget", a.bound_budget,
                 "certified bounds: the interval search's work in seconds, counted (about the wall time on a 2-core "
                 "machine; the same boxes on any machine and thread count; default 120; 0: until the gap target); the "
                 "design uses the proven upper ends reached, whatever the gap")
      ->type_name("SECONDS");
  app.add_option("--proof-budget", a.proof_budget,
                 "polytopic certificate above two joints: counted work in seconds for the branch and bound that proves "
                 "the P chosen on samples (default 60); past it the certificate falls back to the norm bound")
      ->type_name("SECONDS");
  app.add_option("--checkpoint", a.checkpoint,
                 "certified bounds: save the searches to FILE every 5 s, so that a killed job can --resume FILE")
      ->type_name("FILE");
  app.add_option("--resume", a.resume,
                 "certified bounds: continue the searches FILE holds (a checkpoint of the same robot and request), "
                 "saving there")
      ->type_name("FILE");
  app.add_option("--rate-margin", a.rate_margin,
                 "tight certificate: P is computed at gamma_sup (1 - margin) (default 0.01)")
      ->type_name("FRACTION");
}

// The observer as deployed: sampled, quantised, late.
void add_deployment_options(CLI::App& app, DesignArguments& a) {
  app.add_option("--sample-period", a.sample_period,
                 "deployment: the observer runs every T seconds on encoder counts; adds the sampled, quantised "
                 "certificate (needs --encoder-counts and --acceleration-bounds)")
      ->type_name("SECONDS");
  app.add_option("--encoder-counts", a.encoder_counts,
                 "deployment: encoder counts per revolution, one for all joints or N1,...,Nn")
      ->type_name("COUNTS[,...]");
  app.add_option("--acceleration-bounds", a.acceleration_bounds,
                 "deployment: |q''_i| <= A_i along the observed motion, one for all joints or A1,...,An [rad/s^2]")
      ->type_name("RAD_S2[,...]");
  app.add_option("--latency", a.latency,
                 "deployment: the encoder sample used at an update was read this long before it (default 0)")
      ->type_name("SECONDS");
  app.add_option("--velocity-error-tolerance", a.velocity_error_tolerance,
                 "deployment: the largest certified ultimate velocity error accepted [rad/s] (default: the smallest "
                 "velocity bound); sets max_sample_period")
      ->type_name("RAD_S");
  app.add_option("--objective", a.objective,
                 "rate: the smallest theta certifying --gamma; velocity-error: the theta (and alpha with "
                 "--optimize-shape) with the smallest certified ultimate velocity error that still certifies --gamma")
      ->check(CLI::IsMember({"rate", "velocity-error"}))
      ->capture_default_str()
      ->type_name("rate|velocity-error");
}

}  // namespace

void add_design_options(CLI::App& app, DesignArguments& a) {
  const std::size_t before = app.get_options().size();
  add_robot_options(app, a);
  add_certificate_options(app, a);
  app.add_flag("--quiet", a.quiet, "no progress lines on stderr");
  app.add_option("--threads", a.threads,
                 "worker threads for the bound search and the Monte Carlo trials, processes for the numeric search's "
                 "Ipopt polishes (0: all cores); the results do not depend on it")
      ->capture_default_str()
      ->type_name("COUNT");
  add_deployment_options(app, a);
  const auto options = app.get_options();
  a.given.assign(options.begin() + static_cast<std::ptrdiff_t>(before), options.end());
}

namespace {

bool progress_line_open = false;

}  // namespace

void close_progress_line() {
  if (progress_line_open) std::cerr << "\r\033[K" << std::flush;
  progress_line_open = false;
}

namespace {

void print_search_progress(const SearchProgress& p) {
  const std::string left = std::isfinite(p.work_budget)
                               ? fmt::format("{:.0f} % of its budget", 100.0 * p.work / std::max(p.work_budget, 1e-9))
                               : std::string("no budget: until the gap");
  std::cerr << fmt::format("\r\033[K  {}: {} boxes, [{:.8g}, {:.8g}], gap {:.1e} (target {:.0e}), {:.0f} s, {}",
                           p.bound, p.boxes, p.lower, p.upper, p.relative_gap, p.target_gap, p.seconds, left)
            << std::flush;
  progress_line_open = true;
}

}  // namespace

namespace {

// The deployment options given (deployment_options says which combinations mean a deployment).
std::optional<DeploymentOptions> to_deployment_options(const DesignArguments& a) {
  DeploymentRequest r;
  const auto number = [](const char* name, const std::string& text) {
    return text.empty() ? std::nullopt : std::optional<double>(parse_number(name, text));
  };
  const auto list = [](const char* name, const std::string& text) {
    return text.empty() ? std::nullopt : std::optional<Eigen::VectorXd>(parse_number_list(name, text));
  };
  r.sample_period = number("--sample-period", a.sample_period);
  r.latency = number("--latency", a.latency);
  r.velocity_error_tolerance = number("--velocity-error-tolerance", a.velocity_error_tolerance);
  r.encoder_counts = list("--encoder-counts", a.encoder_counts);
  r.acceleration_bounds = list("--acceleration-bounds", a.acceleration_bounds);
  r.objective = a.objective == "velocity-error" ? DesignObjective::velocity_error : DesignObjective::rate;
  return deployment_options(r);
}

// An option given with an empty value ("--vmax ''") would otherwise read as not given at all.
void refuse_empty_values(const DesignArguments& a) {
  for (const CLI::Option* option : a.given)
    for (const std::string& value : option->results())
      if (option->get_type_size() != 0 && value.empty())
        throw InputError(fmt::format("{} = '' is empty: give a value or leave the option out", option->get_name()));
}

}  // namespace

DesignRequest to_design_request(const DesignArguments& a, const Model& model) {
  refuse_empty_values(a);
  DesignOptions o;
  if (!a.gamma.empty()) o.gamma = parse_number("--gamma", a.gamma);
  if (!a.theta.empty()) o.theta = parse_number("--theta", a.theta);
  if (a.optimize_shape && (!a.alpha.empty() || !a.beta.empty()))
    throw InputError("--optimize-shape chooses alpha and beta: do not give --alpha or --beta with it");
  if (!a.alpha.empty()) o.alpha = parse_number("--alpha", a.alpha);
  if (!a.beta.empty()) o.beta = parse_number("--beta", a.beta);
  o.optimize_shape = a.optimize_shape;
  if (!a.quiet && model.dof() > 2)
    o.progress = [](const std::string& phase) {
      close_progress_line();
      std::cerr << phase << std::endl;
    };
  if (!a.quiet && isatty(STDERR_FILENO) != 0) o.certified_bounds.progress = print_search_progress;
  o.lipschitz = a.lipschitz == "paper" ? LipschitzKind::paper : LipschitzKind::joint;
  if (!a.certificate.empty()) o.certificate = certificate_kind(a.certificate).value();  // CLI11 checked the name
  if (a.polytope_cells) o.polytope.cells = *a.polytope_cells;
  o.bound_method = a.bounds == "numeric" ? BoundMethod::numeric : BoundMethod::certified;
  if (!a.L.empty()) o.L_override = parse_number("--L", a.L);
  if (!a.rate_margin.empty()) o.rate_margin = parse_number("--rate-margin", a.rate_margin);
  if (!a.bound_budget.empty()) o.certified_bounds.budget_seconds = parse_number("--bound-budget", a.bound_budget);
  if (!a.proof_budget.empty()) o.polytopic_search.proof_budget = parse_number("--proof-budget", a.proof_budget);
  o.certified_bounds.threads = parse_threads(a.threads);
  o.certified_bounds.journal = open_search_journal(a.checkpoint, a.resume);
  if (!a.vmax.empty()) o.velocity_bounds = parse_number_list("--vmax", a.vmax);
  validate_design_options(o);
  return {o, to_deployment_options(a)};
}

RobotSource to_robot_source(const DesignArguments& a) {
  RobotSource source{a.robot, a.base_link, a.tip_link, {}, {}, {}};
  if (!a.joint_limits.empty()) {
    for (const std::string& item : split_list(a.joint_limits)) {
      const auto i = source.joint_limits.size() + 1;
      JointDomain domain;
      if (item != "c") {
        const auto colon = item.find(':');
        if (colon == std::string::npos)
          throw InputError(fmt::format("--joint-limits: range {} = '{}' is not lower:upper or c", i, item));
        domain.continuous = false;
        domain.lower = parse_number(fmt::format("--joint-limits lower {}", i), item.substr(0, colon));
        domain.upper = parse_number(fmt::format("--joint-limits upper {}", i), item.substr(colon + 1));
        if (!(domain.lower < domain.upper))
          throw InputError(fmt::format("--joint-limits: range {} = '{}' needs lower < upper", i, item));
      }
      source.joint_limits.push_back(domain);
    }
  }
  if (!a.armature.empty()) {
    const Eigen::VectorXd armature = parse_number_list("--armature", a.armature);
    source.armature.assign(armature.data(), armature.data() + armature.size());
  }
  // The loaders check the values (load_urdf: flags 0 or 1; armature >= 0); here only that a flag is a whole number.
  if (!a.actuated.empty()) {
    const Eigen::VectorXd flags = parse_number_list("--actuated", a.actuated);
    for (Eigen::Index i = 0; i < flags.size(); ++i) {
      if (flags(i) != std::floor(flags(i)) || std::abs(flags(i)) > 1e9)
        throw InputError(fmt::format("--actuated: flag {} = {} must be 0 or 1", i + 1, flags(i)));
      source.actuated.push_back(static_cast<int>(flags(i)));
    }
  }
  return source;
}

void add_monte_carlo_options(CLI::App& app, MonteCarloArguments& a) {
  app.add_option("--trials", a.trials, "number of trials")->capture_default_str()
      ->type_name("COUNT");
  app.add_option("--seed", a.seed, "random seed; a trial's draw depends on (seed, trial index) only")->capture_default_str()
      ->type_name("COUNT");
  app.add_option("--horizon", a.horizon, "simulated time per trial [s]")->capture_default_str()
      ->type_name("SECONDS");
  app.add_option("--rtol", a.rtol, "integrator relative tolerance")->capture_default_str()
      ->type_name("NUMBER");
  app.add_option("--atol", a.atol, "integrator absolute tolerance")->capture_default_str()
      ->type_name("NUMBER");
  a.step_budget_option = app.add_option("--step-budget", a.step_budget,
                 "integration steps the run may take, estimated before it starts (default 5e7, minutes on two cores); "
                 "past it no trial runs and the message says what would help")
      ->type_name("STEPS");
  app.add_option("--scenario", a.scenario, "paper (lower equilibrium, u = 1.5 sin 100t) or random (computed-torque tracking when fully actuated)")
      ->check(CLI::IsMember({"paper", "random"}))
      ->capture_default_str()
      ->type_name("paper|random");
  app.add_option("--initial-errors", a.initial_errors, "practical (the paper's Remark), global, or both")
      ->check(CLI::IsMember({"practical", "global", "both"}))
      ->capture_default_str()
      ->type_name("practical|global|both");
}

MonteCarloOptions to_monte_carlo_options(const MonteCarloArguments& a, const DesignArguments& design) {
  const bool quiet = design.quiet;
  MonteCarloOptions o;
  if (!quiet && isatty(STDERR_FILENO) != 0)
    o.progress = [](int done, int total, double seconds) {
      std::cerr << (done > 0 ? fmt::format("\r\033[Kmonte-carlo: {} / {} trials, {:.0f} s, about {:.0f} s left", done,
                                           total, seconds, seconds / done * (total - done))
                             : fmt::format("\r\033[Kmonte-carlo: 0 / {} trials, {:.0f} s", total, seconds))
                << std::flush;
      progress_line_open = true;
    };
  o.trials = parse_count("--trials", a.trials, 1);
  const double seed = parse_number("--seed", a.seed);
  if (seed < 0 || seed != std::floor(seed) || seed > 9e15) throw InputError(fmt::format("--seed = {} must be a whole number >= 0", a.seed));
  o.seed = static_cast<std::uint64_t>(seed);
  o.threads = parse_threads(design.threads);
  o.simulation.horizon = parse_number("--horizon", a.horizon);
  o.simulation.rtol = parse_number("--rtol", a.rtol);
  o.simulation.atol = parse_number("--atol", a.atol);
  if (a.step_budget_option && a.step_budget_option->count() > 0) o.step_budget = parse_number("--step-budget", a.step_budget);
  o.scenario = a.scenario == "paper" ? Scenario::paper : Scenario::random;
  o.initial_errors = a.initial_errors == "practical" ? InitialErrors::practical
                     : a.initial_errors == "global"  ? InitialErrors::global
                                                     : InitialErrors::both;
  validate_monte_carlo_options(o);
  return o;
}

ValidationTarget load_validation_target(const DesignArguments& design, const std::string& design_file) {
  if (design_file.empty()) {
    Model model = load_robot(to_robot_source(design));
    const DesignRequest request = to_design_request(design, model);
    const DeployedDesign d = design_observer(model, request.design, request.deployment);
    if (!d.design.unfinished.empty()) throw UnmetRequest(d.design.unfinished);
    ObserverCertificate certificate = observer_certificate(d);  // refuses a design with no rate: one error line
    close_progress_line();
    std::cerr << format_warnings(d.design);
    // Validated all the same (the envelope it has is still a statement to test), but never silently.
    if (const std::string unmet = unmet_request(d, request.design); !unmet.empty())
      std::cerr << "warning: the design does not meet the request: " << unmet << "\n";
    return {std::move(model), std::move(certificate)};
  }
  std::error_code error;
  if (!std::filesystem::is_regular_file(design_file, error))
    throw InputError("cannot read design file '" + design_file + "' (not a file)");
  for (const CLI::Option* option : design.given)
    if (option->count() > 0 && option->get_name() != "--quiet" && option->get_name() != "--threads")
      throw InputError("--design " + design_file + " fixes the robot and the gains: " + option->get_name() +
                       " cannot be given with it");
  std::ifstream file(design_file);
  if (!file) throw InputError("cannot read design file '" + design_file + "'");
  const std::string text{std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
  SavedDesign saved;
  try {
    saved = saved_design_from_json_text(text);
  } catch (const InputError& e) {
    throw InputError("design file '" + design_file + "': " + e.what());
  }
  Model model = load_robot(saved.robot);
  check_saved_design_model(saved, model, "design file '" + design_file + "'");
  return {std::move(model), saved.certificate};
}

void require_writable(const std::vector<std::pair<std::string, std::string>>& outputs) {
  if (!distributed::output_rank()) return;
  namespace fs = std::filesystem;
  for (const auto& [option, path] : outputs) {
    if (path.empty() || path == "-") continue;
    const std::string named = option + " = '" + path + "'";
    std::error_code error;
    if (fs::is_directory(path, error)) throw InputError(named + " is a directory, not a file");
    const fs::path parent = fs::path(path).has_parent_path() ? fs::path(path).parent_path() : fs::path(".");
    if (!fs::is_directory(parent, error))
      throw InputError(named + ": its directory '" + parent.string() + "' does not exist");
    if (access(parent.c_str(), W_OK) != 0)
      throw InputError(named + ": its directory '" + parent.string() + "' is not writable");
    // A directory can pass access() and still refuse the file: as root every permission check passes, and a
    // pseudo-file system such as /proc still refuses. Opening the file, created and removed again where it did not
    // exist, is the test. A device or a pipe (/dev/null, a FIFO) is written as it is, when the work is done.
    const bool existed = fs::exists(path, error);
    if (existed && !fs::is_regular_file(path, error)) continue;
    const int descriptor = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (descriptor < 0) throw InputError(named + " cannot be written: " + std::strerror(errno));
    ::close(descriptor);
    if (!existed) fs::remove(path, error);
  }
}

int run_app(CLI::App& app, int argc, char** argv, const std::function<int()>& body) {
  const distributed::Session mpi(argc, argv);
  // Every rank computes the same answer; rank 0 prints it (the apps write their files on rank 0 only).
  if (!distributed::output_rank()) {
    std::cout.rdbuf(nullptr);
    std::cerr.rdbuf(nullptr);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << app.get_name() << ": error: " << e.what() << "\n";
    return 2;
  }
  // Under MPI an error may be one rank's alone (a file it cannot write): it ends the job rather than leave the other
  // ranks waiting. A request that cannot be met is every rank's answer, and ends normally.
  const auto failed = [](int code) {
    if (distributed::size() > 1) {
      std::cerr.flush();
      distributed::abort_job(code);
    }
    return code;
  };
  try {
    const int code = body();
    close_progress_line();
    return code;
  } catch (const InputError& e) {
    close_progress_line();
    std::cerr << app.get_name() << ": error: " << e.what() << "\n";
    return failed(2);
  } catch (const UnmetRequest& e) {
    close_progress_line();
    std::cerr << app.get_name() << ": error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    close_progress_line();
    std::cerr << app.get_name() << ": internal error: " << e.what() << "\n";
    return failed(3);
  }
}

}  // namespace obsgain
