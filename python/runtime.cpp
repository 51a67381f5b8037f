// The runtime layer: the real-time Observer class itself, with arrays in and out.
#include "bindings.hpp"

#include "obsgain/runtime/observer.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

namespace obsgain::python {

namespace {

// The C++ Observer with the model it references kept alive.
struct PyObserver {
  std::shared_ptr<const Model> model;
  std::unique_ptr<Observer> observer;
};

PyObserver make_observer(const PyDesign& design, const std::optional<Robot>& robot, std::optional<int> requested) {
  // The deployment's count by default: the observer then runs what its certificate covers, as the exports do.
  const bool deployed = design.computed && design.computed->deployment;
  const int substeps = requested.value_or(deployed ? design.computed->deployment->certificate.substeps : 0);
  std::shared_ptr<const Model> model = robot ? robot->model : design.robot_model();
  const CertifiedObserver& gains = design.observer();
  if (gains.dof() != model->dof())
    throw InputError(fmt::format("the design is for {} joints, the robot '{}' has {}", gains.dof(), model->name, model->dof()));
  if (substeps < 0 || substeps > Observer::max_substeps)
    throw InputError(fmt::format("substeps = {} must lie in [0, {}] (0: the observer chooses)", substeps, Observer::max_substeps));
  auto observer = std::make_unique<Observer>(*model, gains, substeps);
  return {std::move(model), std::move(observer)};
}

void require_size(const Eigen::VectorXd& x, Eigen::Index size, const char* name) {
  if (x.size() != size) throw InputError(fmt::format("{} has {} values, the observer needs {}", name, x.size(), size));
}

py::tuple update(PyObserver& o, const Eigen::VectorXd& q, const Eigen::VectorXd& u, double dt) {
  require_size(q, o.model->dof(), "q");
  require_size(u, o.model->input_matrix.cols(), "u");
  const Observer::Estimate e = o.observer->update(q, u, dt);
  if (!e.accepted)
    throw InputError(fmt::format("Observer.update refused the sample: reset() first, finite q and u whose integration "
                                 "stays finite, dt = {} > 0 and at most {} sub-steps", dt, Observer::max_substeps));
  return py::make_tuple(Eigen::VectorXd(e.position), Eigen::VectorXd(e.velocity));  // copies: the class reuses its buffers
}

void reset(PyObserver& o, const Eigen::VectorXd& q, const std::optional<Eigen::VectorXd>& q_estimate,
           const std::optional<Eigen::VectorXd>& v_estimate) {
  const Eigen::Index n = o.model->dof();
  require_size(q, n, "q_measured");
  const Eigen::VectorXd q_hat = q_estimate.value_or(q), v_hat = v_estimate.value_or(Eigen::VectorXd::Zero(n));
  require_size(q_hat, n, "q_estimate");
  require_size(v_hat, n, "v_estimate");
  if (!o.observer->reset(q, q_hat, v_hat)) throw InputError("Observer.reset refused: the values must be finite");
}

}  // namespace

void bind_runtime(py::module_& m) {
  py::class_<PyObserver>(m, "Observer",
                         "The observer as it runs on the robot: the C++ class obsgain::Observer "
                         "(include/obsgain/runtime/observer.hpp). Between two samples it integrates the observer's "
                         "equations with the measurement interpolated linearly, by RK4 sub-steps short enough for the "
                         "gains: exactly the implementation the deployment certificate covers.")
      .def(py::init(&make_observer), py::arg("design"), py::arg("robot") = py::none(), py::arg("substeps") = py::none(),
           "Runs the design's gains on `robot` (default: the design's own). substeps: RK4 sub-steps per sample "
           "(default: the deployment's certified count; 0 or no deployment: chosen from the gains and dt).")
      .def("reset", &reset, py::arg("q_measured"), py::arg("q_estimate") = py::none(), py::arg("v_estimate") = py::none(),
           "Starts from q_hat = q_estimate (default: the measurement) and v_hat = v_estimate (default: zero); the "
           "measurement is the first sample.")
      .def("update", &update, py::arg("q_measured"), py::arg("u"), py::arg("dt"),
           "One sample: the encoder position now, the input held since the previous sample, the time since it. "
           "Returns (q_hat, v_hat). ValueError when the sample is refused (the state is then unchanged).")
      .def_property_readonly("position", [](const PyObserver& o) { return Eigen::VectorXd(o.observer->position()); }, "q_hat")
      .def_property_readonly("velocity", [](const PyObserver& o) { return Eigen::VectorXd(o.observer->velocity()); }, "v_hat")
      .def("substeps", [](const PyObserver& o, double dt) { return o.observer->substeps(dt); }, py::arg("dt"),
           "RK4 sub-steps per sample of length dt.");
}

}  // namespace obsgain::python
