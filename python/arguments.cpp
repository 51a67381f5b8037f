// Keyword arguments to the library's options: the command line's option names (snake_case), its defaults and its
// checks (the library's validate_* functions), so that the same request gives the same numbers and messages.
#include "bindings.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

namespace obsgain::python {

namespace {

// Removes `name` from the arguments and converts it; None and absent are the default. A value of the wrong
// type is bad input, named.
template <class T>
std::optional<T> take(py::dict& arguments, const char* name) {
  if (!arguments.contains(name)) return std::nullopt;
  const py::object value = arguments.attr("pop")(name);
  if (value.is_none()) return std::nullopt;
  try {
    return value.cast<T>();
  } catch (const py::cast_error&) {
    throw InputError(fmt::format("{} = {} has the wrong type", name, py::repr(value).cast<std::string>()));
  }
}

// A number for every joint, or one for all (encoder counts, acceleration bounds).
std::optional<Eigen::VectorXd> take_values(py::dict& arguments, const char* name) {
  if (arguments.contains(name) && (py::isinstance<py::float_>(arguments[name]) || py::isinstance<py::int_>(arguments[name])))
    return Eigen::VectorXd::Constant(1, *take<double>(arguments, name));
  return take<Eigen::VectorXd>(arguments, name);
}

// One of the words the command line accepts for the option.
std::string choice(py::dict& arguments, const char* name, std::initializer_list<const char*> words) {
  const std::string value = take<std::string>(arguments, name).value_or(*words.begin());
  for (const char* word : words)
    if (value == word) return value;
  std::string list;
  for (const char* word : words) list += (list.empty() ? "" : ", ") + std::string(word);
  throw InputError(fmt::format("{} = '{}' must be one of {}", name, value, list));
}

// The shape, the Lipschitz constant, the certificate and the bounds it rests on.
void take_certificate(py::dict& a, DesignOptions& o) {
  o.gamma = take<double>(a, "gamma");
  o.theta = take<double>(a, "theta");
  o.optimize_shape = take<bool>(a, "optimize_shape").value_or(false);
  const auto alpha = take<double>(a, "alpha"), beta = take<double>(a, "beta");
  if (o.optimize_shape && (alpha || beta))
    throw InputError("--optimize-shape chooses alpha and beta: do not give --alpha or --beta with it");
  o.alpha = alpha.value_or(o.alpha);
  o.beta = beta.value_or(o.beta);
  o.lipschitz = choice(a, "lipschitz", {"joint", "paper"}) == "paper" ? LipschitzKind::paper : LipschitzKind::joint;
  o.L_override = take<double>(a, "L");
  // Not given: tight, or scaled where it is better (DesignOptions::certificate).
  if (a.contains("certificate")) o.certificate = certificate_kind(choice(a, "certificate", {"tight", "scaled", "paper", "polytopic"})).value();
  o.polytope.cells = take<int>(a, "polytope_cells").value_or(o.polytope.cells);
  o.bound_method = choice(a, "bounds", {"certified", "numeric"}) == "numeric" ? BoundMethod::numeric : BoundMethod::certified;
  o.certified_bounds.budget_seconds = take<double>(a, "bound_budget").value_or(o.certified_bounds.budget_seconds);
  o.polytopic_search.proof_budget = take<double>(a, "proof_budget").value_or(o.polytopic_search.proof_budget);
  o.rate_margin = take<double>(a, "rate_margin").value_or(o.rate_margin);
  if (const auto vmax = take<Eigen::VectorXd>(a, "vmax")) {
    if (vmax->size() == 0) throw InputError("--vmax = '' is empty: give a value or leave the option out");
    o.velocity_bounds = *vmax;
  }
  o.certified_bounds.journal = open_search_journal(take<std::string>(a, "checkpoint").value_or(""),
                                                   take<std::string>(a, "resume").value_or(""));
}

// The deployment's keywords (deployment_options says which combinations mean a deployment).
std::optional<DeploymentOptions> take_deployment(py::dict& a) {
  DeploymentRequest r;
  r.objective = choice(a, "objective", {"rate", "velocity-error"}) == "velocity-error" ? DesignObjective::velocity_error
                                                                                      : DesignObjective::rate;
  r.sample_period = take<double>(a, "sample_period");
  r.encoder_counts = take_values(a, "encoder_counts");
  r.acceleration_bounds = take_values(a, "acceleration_bounds");
  r.latency = take<double>(a, "latency");
  r.velocity_error_tolerance = take<double>(a, "velocity_error_tolerance");
  return deployment_options(r);
}

}  // namespace

int thread_count(py::dict& arguments) {
  const int threads = take<int>(arguments, "threads").value_or(0);
  if (threads < 0 || threads > 256) throw InputError(fmt::format("--threads = {} must lie in [0, 256] (0: all cores)", threads));
  return threads;
}

DesignRequest design_request(py::dict& arguments, const ProgressHooks& hooks, int threads) {
  DesignRequest request;
  DesignOptions& o = request.design;
  take_certificate(arguments, o);
  o.certified_bounds.threads = threads;
  o.progress = hooks.phase();
  o.certified_bounds.progress = hooks.search();
  request.deployment = take_deployment(arguments);
  return request;
}

MonteCarloOptions monte_carlo_options(py::dict& arguments, const ProgressHooks& hooks, int default_trials, int threads) {
  MonteCarloOptions o;
  o.trials = take<int>(arguments, "trials").value_or(default_trials);
  o.seed = take<std::uint64_t>(arguments, "seed").value_or(o.seed);
  o.threads = threads;
  o.simulation.horizon = take<double>(arguments, "horizon").value_or(o.simulation.horizon);
  o.simulation.rtol = take<double>(arguments, "rtol").value_or(o.simulation.rtol);
  o.simulation.atol = take<double>(arguments, "atol").value_or(o.simulation.atol);
  o.step_budget = take<double>(arguments, "step_budget").value_or(o.step_budget);
  o.scenario = choice(arguments, "scenario", {"random", "paper"}) == "paper" ? Scenario::paper : Scenario::random;
  const std::string errors = choice(arguments, "initial_errors", {"both", "practical", "global"});
  o.initial_errors = errors == "practical" ? InitialErrors::practical
                     : errors == "global"  ? InitialErrors::global
                                           : InitialErrors::both;
  o.progress = hooks.trials();
  return o;
}

void refuse_unknown(const py::dict& remaining, const char* function) {
  for (const auto& item : remaining)
    throw py::type_error(fmt::format("{}() got an unexpected keyword argument '{}'", function, item.first.cast<std::string>()));
}

}  // namespace obsgain::python
