// The design and deployment layers: design_gains, the Design it returns, its JSON and its exports.
#include "bindings.hpp"

#include "obsgain/parsers/robots.hpp"
#include "obsgain/report/export.hpp"
#include "obsgain/report/report.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

namespace obsgain::python {

const CertifiedObserver& PyDesign::observer() const {
  if (computed) return computed->design.selected().observer;
  return saved.certificate.observer;
}

std::shared_ptr<const Model> PyDesign::robot_model() const {
  if (model) return model;
  auto loaded = std::make_shared<const Model>(load_robot(saved.robot));
  check_saved_design_model(saved, *loaded, "the design");
  return loaded;
}

PyDesign computed_design(const Robot& robot, DeployedDesign design, DesignOptions options) {
  options.progress = nullptr;  // the hooks lived as long as the call only
  options.certified_bounds.progress = nullptr;
  PyDesign d;
  d.model = robot.model;
  d.json = to_json_text(design);
  d.saved.robot = robot.model->source;
  d.saved.fingerprint = robot.model->fingerprint;
  try {
    d.saved.certificate = observer_certificate(design);
    d.certificate = d.saved.certificate;
  } catch (const InputError&) {
    // No rate certified: the design is still a result (meets_request says so); only a validation refuses it.
  }
  d.computed = std::move(design);
  d.options = std::move(options);
  return d;
}

namespace {

const DeployedDesign& computed(const PyDesign& d, const char* what) {
  if (!d.computed)
    throw InputError(fmt::format("{} needs a design computed by design_gains (a design read from JSON carries its "
                                 "certificate only)", what));
  return *d.computed;
}

PyDesign design(const Robot& robot, const py::object& progress, const py::kwargs& keywords) {
  py::dict arguments(keywords);
  const ProgressHooks hooks(progress);
  const int threads = thread_count(arguments);
  DesignRequest request = design_request(arguments, hooks, threads);
  refuse_unknown(arguments, "design_gains");
  validate_design_options(request.design);
  DeployedDesign result = without_gil([&] { return design_observer(*robot.model, request.design, request.deployment); });
  return computed_design(robot, std::move(result), std::move(request.design));
}

PyDesign from_json(const std::string& text) {
  PyDesign d;
  d.saved = saved_design_from_json_text(text);
  d.certificate = d.saved.certificate;
  d.json = text;
  return d;
}

py::object data(const PyDesign& d) { return py::module_::import("json").attr("loads")(d.json); }

void bind_gains(py::class_<PyDesign>& c) {
  c.def_property_readonly("theta", [](const PyDesign& d) { return d.observer().theta; }, "The gain theta.")
      .def_property_readonly("alpha", [](const PyDesign& d) { return d.observer().alpha; })
      .def_property_readonly("beta", [](const PyDesign& d) { return d.observer().beta; })
      .def_property_readonly("k1", [](const PyDesign& d) { return d.observer().k1; }, "Position gain theta alpha.")
      .def_property_readonly("k2", [](const PyDesign& d) { return d.observer().k2; }, "Velocity gain theta^2 beta.")
      .def_property_readonly("gamma", [](const PyDesign& d) { return d.observer().gamma; },
                             "The certified rate: ||e(t)|| <= k ||e(0)|| exp(-gamma t).")
      .def_property_readonly("k", [](const PyDesign& d) { return d.observer().k; }, "The envelope constant.")
      .def_property_readonly("L", [](const PyDesign& d) { return d.observer().L; }, "The Lipschitz constant used.")
      .def_property_readonly("P", [](const PyDesign& d) { return d.observer().P; },
                             "V(e) = e' P e, e = (q_hat - q, v_hat - v): 2n x 2n.")
      .def_property_readonly("velocity_bounds", [](const PyDesign& d) { return d.observer().velocity_bounds; })
      .def_property_readonly("certificate", [](const PyDesign& d) { return std::string(to_string(d.observer().certificate)); },
                             "Which certificate the gains rest on: tight, paper or polytopic.")
      .def_property_readonly("certified", [](const PyDesign& d) { return d.observer().certified; },
                             "A positive rate with a valid P (on the bounds the design used; see proven).");
}

void bind_verdict(py::class_<PyDesign>& c) {
  c.def_property_readonly("proven", [](const PyDesign& d) {
         if (!d.computed) return data(d)["certified"].cast<bool>();
         return d.computed->design.proven() && d.computed->design.unfinished.empty();
       }, "Every number the certificate rests on is proven (certified bounds, or an L given by the user).")
      .def_property_readonly("meets_request", [](const PyDesign& d) -> py::object {
         if (!d.computed) return py::none();
         return py::bool_(unmet_request(*d.computed, *d.options).empty());
       }, "The design certifies what was asked (the command line exits 1 otherwise); None when read from JSON.")
      .def_property_readonly("unmet", [](const PyDesign& d) {
         return d.computed ? unmet_request(*d.computed, *d.options) : std::string();
       }, "Why the design does not meet the request (what would help), or ''.")
      // py::object, not the accessor: an accessor would outlive the document it indexes.
      .def_property_readonly("warnings", [](const PyDesign& d) { return py::list(data(d)["warnings"]); })
      .def_property_readonly("notes", [](const PyDesign& d) { return py::list(data(d)["notes"]); })
      .def_property_readonly("brackets", [](const PyDesign& d) {
         py::dict brackets;
         const py::dict bounds = data(d)["bounds"];
         if (bounds.contains("brackets"))
           for (const auto& [name, bracket] : py::dict(bounds["brackets"]))
             brackets[name] = py::make_tuple(bracket["lower"], bracket["upper"]);
         return brackets;
       }, "The certified brackets {name: (attained, proven upper)} of M0, B, L_joint and, with similarity scaling, L_scaled "
         "(empty for numeric bounds).")
      .def_property_readonly("data", &data, "The design's JSON document as a dict (every number: bounds, brackets, "
                                            "both certificates, the deployment).");
}

void bind_documents(py::class_<PyDesign>& c) {
  c.def("summary", [](const PyDesign& d) { return format_report(computed(d, "summary()")); },
        "The table design-gains prints.")
      .def("to_json", [](const PyDesign& d) { return d.json; }, "The JSON design-gains --json writes.")
      .def_static("from_json", &from_json, py::arg("text"),
                  "A design from design-gains' JSON (the certificate and the robot it was made for), as monte-carlo "
                  "--design reads it. ValueError when the text is not a certified design.")
      .def("export_header", [](const PyDesign& d, const std::string& name) {
         return observer_header(*d.model, computed(d, "export_header()"), name);
       }, py::arg("namespace_name") = "observer_gains", "design-gains --export-header: a C++ header of constexpr values.")
      .def("export_ros2", [](const PyDesign& d, const std::string& node) {
         return ros2_parameters(computed(d, "export_ros2()"), node);
       }, py::arg("node_name") = "velocity_observer", "design-gains --export-ros2: a ROS 2 parameters file.")
      .def("export_observer", [](const PyDesign& d) {
         return exported_observer_text(exported_observer(*d.model, computed(d, "export_observer()")));
       }, "design-gains --export-observer: the model and observer as obsgain::runtime reads them.")
      .def("__repr__", [](const PyDesign& d) {
         const CertifiedObserver& o = d.observer();
         return fmt::format("<obsgain.Design {} theta={:.6g} gamma={:.6g} k={:.6g}{}>", to_string(o.certificate), o.theta,
                            o.gamma, o.k, d.computed ? "" : " (from JSON)");
       });
}

}  // namespace

void bind_design(py::module_& m) {
  py::class_<PyDesign> c(m, "Design",
                         "Observer gains and their certificate (include/obsgain/design/design.hpp), with the deployment "
                         "when one was asked for. Made by design_gains, or read with Design.from_json.");
  bind_gains(c);
  bind_verdict(c);
  bind_documents(c);
  m.def("design_gains", &design, py::arg("robot"), py::kw_only(), py::arg("progress") = py::none(),
        "Observer gains for a target rate, with their certificate: design-gains from Python.\n\n"
        "Keywords, as the command line's options (docs/usage.md):\n"
        "  gamma: target rate [1/s] (theta is then the smallest certifying gain), or theta: the gain to evaluate\n"
        "  alpha, beta (default 1), optimize_shape=False\n"
        "  certificate='tight' | 'paper' | 'polytopic', polytope_cells=32, proof_budget=60 [s]\n"
        "  lipschitz='joint' | 'paper', L: override the Lipschitz constant\n"
        "  bounds='certified' | 'numeric', bound_budget=120 [s], rate_margin=0.01, vmax: velocity bounds\n"
        "  checkpoint=FILE (save the searches every 5 s) or resume=FILE (continue them)\n"
        "  threads=0 (all cores; the numbers do not depend on it)\n"
        "  deployment: sample_period [s], encoder_counts, acceleration_bounds [rad/s^2] (one, or one per joint),\n"
        "    latency [s], velocity_error_tolerance [rad/s], objective='rate' | 'velocity-error'\n"
        "progress: called with one line of text per phase and about four times a second during long searches.\n"
        "The GIL is released while it runs; Ctrl-C interrupts it (KeyboardInterrupt).\n"
        "Bad input raises ValueError with the command line's message; an unmet request is a result: see "
        "Design.meets_request and Design.unmet.");
}

}  // namespace obsgain::python
