// The validation layer and the report: monte_carlo with per-trial arrays and trajectories, verify_bounds.
#include "bindings.hpp"

#include "obsgain/report/report.hpp"
#include "obsgain/validation/verification.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

namespace obsgain::python {

namespace {

// A Monte Carlo report with what its trajectories are simulated from.
struct PyMonteCarlo {
  std::shared_ptr<const Model> model;
  MonteCarloOptions options;  // without the progress hook
  MonteCarloReport report;
};

PyMonteCarlo run(const PyDesign& design, const std::optional<Robot>& robot, const py::object& progress,
                 const py::kwargs& keywords) {
  py::dict arguments(keywords);
  const ProgressHooks hooks(progress);
  MonteCarloOptions options = monte_carlo_options(arguments, hooks, 1000, thread_count(arguments));
  refuse_unknown(arguments, "monte_carlo");
  validate_monte_carlo_options(options);
  std::shared_ptr<const Model> model = robot ? robot->model : design.robot_model();
  const ObserverCertificate certificate =
      design.computed ? observer_certificate(*design.computed) : *design.certificate;  // refuses a design with no rate
  MonteCarloReport report = without_gil([&] { return run_monte_carlo(*model, certificate, options); });
  options.progress = nullptr;
  return {std::move(model), std::move(options), std::move(report)};
}

// One array per field of the trial records, in trial order.
py::dict per_trial(const MonteCarloReport& r) {
  const auto column = [&](auto field) {
    py::array_t<double> a(static_cast<py::ssize_t>(r.records.size()));
    auto out = a.mutable_unchecked<1>();
    for (std::size_t i = 0; i < r.records.size(); ++i) out(static_cast<py::ssize_t>(i)) = static_cast<double>(field(r.records[i]));
    return a;
  };
  py::dict d;
  d["index"] = column([](const TrialRecord& t) { return t.index; });
  d["global_error"] = column([](const TrialRecord& t) { return t.global_error; });
  d["input_scale"] = column([](const TrialRecord& t) { return t.input_scale; });
  d["initial_error"] = column([](const TrialRecord& t) { return t.initial_error; });
  d["left_velocity_box"] = column([](const TrialRecord& t) { return t.result.left_velocity_box; });
  d["envelope_violated"] = column([](const TrialRecord& t) { return t.envelope_violated; });
  d["lyapunov_violated"] = column([](const TrialRecord& t) { return t.lyapunov_violated; });
  d["worst_envelope_ratio"] = column([](const TrialRecord& t) { return t.result.worst_envelope_ratio; });
  d["worst_lyapunov_ratio"] = column([](const TrialRecord& t) { return t.result.worst_lyapunov_ratio; });
  d["fitted_rate"] = column([](const TrialRecord& t) { return t.result.fitted_rate; });
  d["max_velocity_ratio"] = column([](const TrialRecord& t) { return t.result.max_velocity_ratio; });
  d["max_acceleration_ratio"] = column([](const TrialRecord& t) { return t.result.max_acceleration_ratio; });
  d["final_velocity_error"] = column([](const TrialRecord& t) { return t.result.final_velocity_error; });
  return d;
}

// The samples as arrays: t (N), q, v, q_hat, v_hat (N x n), error_norm and envelope (N).
py::dict trajectory_arrays(const std::vector<TrajectorySample>& samples, int n) {
  const auto rows = static_cast<Eigen::Index>(samples.size());
  Eigen::VectorXd t(rows), error(rows), envelope(rows);
  Eigen::MatrixXd q(rows, n), v(rows, n), q_hat(rows, n), v_hat(rows, n);
  for (Eigen::Index i = 0; i < rows; ++i) {
    const TrajectorySample& s = samples[static_cast<std::size_t>(i)];
    t(i) = s.t;
    q.row(i) = s.q.transpose();
    v.row(i) = s.v.transpose();
    q_hat.row(i) = (s.q + s.e_q).transpose();
    v_hat.row(i) = (s.v + s.e_v).transpose();
    error(i) = s.error_norm;
    envelope(i) = s.envelope;
  }
  py::dict d;
  d["t"] = t;
  d["q"] = q;
  d["v"] = v;
  d["q_hat"] = q_hat;
  d["v_hat"] = v_hat;
  d["error_norm"] = error;
  d["envelope"] = envelope;
  return d;
}

py::dict trajectory(const PyMonteCarlo& m, int trial) {
  if (trial < 0 || trial >= static_cast<int>(m.report.records.size()))
    throw InputError(fmt::format("trial = {} must lie in [0, {}]", trial, m.report.records.size() - 1));
  const auto samples = without_gil([&] {
    return trial_trajectory(*m.model, m.report.certificate, m.options, m.report.records[static_cast<std::size_t>(trial)]);
  });
  return trajectory_arrays(samples, m.model->dof());
}

void bind_monte_carlo(py::module_& m) {
  py::class_<PyMonteCarlo>(m, "MonteCarloReport",
                           "Trials against the certified envelope (include/obsgain/validation/montecarlo.hpp).")
      .def_property_readonly("trials", [](const PyMonteCarlo& r) { return r.report.trials; })
      .def_property_readonly("passed", [](const PyMonteCarlo& r) { return r.report.passed; })
      .def_property_readonly("envelope_violations", [](const PyMonteCarlo& r) { return r.report.envelope_violations; })
      .def_property_readonly("lyapunov_violations", [](const PyMonteCarlo& r) { return r.report.lyapunov_violations; })
      .def_property_readonly("assumption_violations", [](const PyMonteCarlo& r) { return r.report.assumption_violations; },
                             "Trials that left the velocity box: outside the theorem's assumption, they prove nothing.")
      .def_property_readonly("worst_envelope_ratio", [](const PyMonteCarlo& r) { return r.report.worst_envelope_ratio; })
      .def_property_readonly("worst_lyapunov_ratio", [](const PyMonteCarlo& r) { return r.report.worst_lyapunov_ratio; })
      .def_property_readonly("decay_rate", [](const PyMonteCarlo& r) {
         const DecayRates& d = r.report.decay_rate;
         return py::dict(py::arg("min") = d.min, py::arg("median") = d.median, py::arg("max") = d.max,
                         py::arg("trials") = d.trials);
       }, "Fitted decay rates over the trials that stayed in the box.")
      .def_property_readonly("certificate_held", [](const PyMonteCarlo& r) { return r.report.certificate_held(); })
      .def_property_readonly("not_run", [](const PyMonteCarlo& r) { return r.report.not_run; },
                             "Why no trial was simulated (the run's estimated integration steps exceed step_budget), "
                             "and what would help; empty when the trials ran.")
      .def_property_readonly("per_trial", [](const PyMonteCarlo& r) { return per_trial(r.report); },
                             "One NumPy array per trial field (index, worst ratios, fitted_rate, assumption flags, ...).")
      .def("trajectory", &trajectory, py::arg("trial") = 0,
           "The trial's time series on the dense grid: t, q, v, q_hat, v_hat, error_norm and its envelope.")
      .def("summary", [](const PyMonteCarlo& r) { return format_report(r.report); }, "The table monte-carlo prints.")
      .def("to_json", [](const PyMonteCarlo& r) { return to_json_text(r.report); }, "The JSON monte-carlo --json writes.");
  m.def("monte_carlo", &run, py::arg("design"), py::kw_only(), py::arg("robot") = py::none(),
        py::arg("progress") = py::none(),
        "Validates a design by simulating plant and observer from randomised errors: monte-carlo from Python.\n\n"
        "Keywords: trials=1000, seed=1, threads=0, horizon=1 [s], rtol=1e-8, atol=1e-10, scenario='random' | "
        "'paper', initial_errors='both' | 'practical' | 'global', step_budget=5e7 (past it no trial runs: not_run says "
        "why).\n"
        "robot: the robot the design was made for (default: the design's own, loaded again for a design read from "
        "JSON). A trial depends on (seed, index) only: the report does not depend on threads.");
}

std::string command_line(const Robot& robot, const std::string& out, const py::kwargs& keywords) {
  std::string line = fmt::format("obsgain.verify_bounds(load_robot('{}'), '{}'", robot.model->source.robot, out);
  for (const auto& [key, value] : keywords)
    line += fmt::format(", {}={}", key.cast<std::string>(), py::repr(value).cast<std::string>());
  return line + ")";
}

py::dict verify(const Robot& robot, const std::string& out, const py::object& progress, const py::kwargs& keywords) {
  py::dict arguments(keywords);
  const ProgressHooks hooks(progress);
  VerificationOptions options;
  options.command_line = command_line(robot, out, keywords);
  const int threads = thread_count(arguments);
  options.monte_carlo = monte_carlo_options(arguments, hooks, options.monte_carlo.trials, threads);
  DesignRequest request = design_request(arguments, hooks, threads);
  refuse_unknown(arguments, "verify_bounds");
  require_report_directory("out", out);
  validate_monte_carlo_options(options.monte_carlo);
  validate_design_options(request.design);
  options.design = request.design;
  options.deployment = request.deployment;
  const auto [report, written] = without_gil([&] {
    VerificationReport r = verify_design(*robot.model, options);
    return std::pair{r, write_verification_report(r, out)};
  });
  options.monte_carlo.progress = nullptr;
  py::dict d;
  d["design"] = computed_design(robot, report.design, request.design);
  d["monte_carlo"] = PyMonteCarlo{robot.model, options.monte_carlo, report.monte_carlo};
  d["html"] = written.html;
  d["json"] = written.json;
  d["plots"] = written.plots;
  d["plots_note"] = written.plots_note;
  return d;
}

}  // namespace

void bind_validation(py::module_& m) {
  bind_monte_carlo(m);
  m.def("verify_bounds", &verify, py::arg("robot"), py::arg("out"), py::kw_only(), py::arg("progress") = py::none(),
        "Writes the verification report to the directory `out` (report.html, report.json, the plots' CSVs and "
        "SVGs): verify-bounds from Python.\n\n"
        "Keywords: design_gains' (gamma or theta, certificate, bounds, deployment, ...) and monte_carlo's "
        "(trials=200, seed, horizon, ...).\n"
        "Returns a dict: design (Design), monte_carlo (MonteCarloReport), html and json (paths), plots (gnuplot drew "
        "them) and plots_note.");
}

}  // namespace obsgain::python
