// The model layer: robots by name, model file or URDF, and their dynamics in double as arrays.
#include "bindings.hpp"

#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <cmath>
#include <limits>

namespace obsgain::python {

namespace {

// One finite value per joint, or ValueError naming the argument.
const Eigen::VectorXd& joint_values(const Model& model, const Eigen::VectorXd& values, const char* name) {
  if (values.size() != model.dof())
    throw InputError(fmt::format("{} has {} values for a robot of {} joints", name, values.size(), model.dof()));
  if (!values.allFinite()) throw InputError(fmt::format("{} must be finite", name));
  return values;
}

// What the dynamics return, or ValueError when it left double's range (a tau of 1e308): NaNs are no answer.
template <class Result>
Result finite_result(Result x, const char* what) {
  if (!x.allFinite()) throw InputError(fmt::format("{} overflows double precision at these arguments", what));
  return x;
}

// joint_limits: one entry per joint, (lower, upper) or "c" for the full circle.
std::vector<JointDomain> joint_domains(const py::list& limits) {
  std::vector<JointDomain> domains;
  for (const py::handle item : limits) {
    const auto i = domains.size() + 1;
    JointDomain domain;
    if (!(py::isinstance<py::str>(item) && item.cast<std::string>() == "c")) {
      const auto range = item.cast<std::pair<double, double>>();
      domain.continuous = false;
      domain.lower = range.first;
      domain.upper = range.second;
      if (!std::isfinite(domain.lower) || !std::isfinite(domain.upper) || !(domain.lower < domain.upper))
        throw InputError(fmt::format("joint-limits: range {} = ({}, {}) needs finite lower < upper", i, domain.lower,
                                     domain.upper));
    }
    domains.push_back(domain);
  }
  return domains;
}

Robot load(const std::string& source, const std::optional<std::vector<double>>& armature,
           const std::optional<Eigen::VectorXd>& vmax, const std::string& base_link, const std::string& tip_link,
           const std::optional<std::vector<int>>& actuated, const std::optional<py::list>& joint_limits) {
  RobotSource s{source, base_link, tip_link, actuated.value_or(std::vector<int>{}), armature.value_or(std::vector<double>{}),
                joint_limits ? joint_domains(*joint_limits) : std::vector<JointDomain>{}};
  Model model = load_robot(s);
  if (vmax) {
    validate_velocity_bounds(model, *vmax);
    model.velocity_bounds = *vmax;
  }
  return {std::make_shared<const Model>(std::move(model))};
}

py::list limits_of(const Model& model) {
  py::list limits;
  constexpr double infinity = std::numeric_limits<double>::infinity();
  for (const JointDomain& d : model.joints)
    limits.append(d.continuous ? py::make_tuple(-infinity, infinity) : py::make_tuple(d.lower, d.upper));
  return limits;
}

void bind_dynamics(py::class_<Robot>& robot) {
  robot
      .def(
          "mass_matrix",
          [](const Robot& r, const Eigen::VectorXd& q) {
            Eigen::MatrixXd M(r.model->dof(), r.model->dof());
            mass_matrix(*r.model, joint_values(*r.model, q, "q"), M);
            return finite_result(M, "M(q)");
          },
          py::arg("q"), "M(q), the n x n inertia matrix (with the armature on its diagonal).")
      .def(
          "coriolis",
          [](const Robot& r, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
            Eigen::VectorXd A(r.model->dof());
            coriolis(*r.model, joint_values(*r.model, q, "q"), joint_values(*r.model, v, "v"), A);
            return finite_result(A, "A(q, v)");
          },
          py::arg("q"), py::arg("v"), "A(q, v) = C(q, v) v, the Coriolis and centrifugal forces.")
      .def(
          "gravity",
          [](const Robot& r, const Eigen::VectorXd& q) {
            Eigen::VectorXd g(r.model->dof());
            gravity(*r.model, joint_values(*r.model, q, "q"), g);
            return finite_result(g, "g(q)");
          },
          py::arg("q"), "g(q), the gravity forces.")
      .def(
          "forward_dynamics",
          [](const Robot& r, const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
            DynamicsWorkspace work(r.model->dof());
            Eigen::VectorXd qdd(r.model->dof());
            forward_dynamics(*r.model, joint_values(*r.model, q, "q"), joint_values(*r.model, v, "v"),
                             joint_values(*r.model, tau, "tau"), qdd, work);
            return finite_result(qdd, "q''");
          },
          py::arg("q"), py::arg("v"), py::arg("tau"), "q'' = M(q)⁻¹ (tau - A(q, v) - F v - g(q)), tau = H u.");
}

}  // namespace

void bind_model(py::module_& m) {
  py::class_<Robot> robot(m, "Robot",
                          "A robot as data: M(q) q'' + A(q, q') + F q' + g(q) = H u, its joint domains and velocity "
                          "box (include/obsgain/model/model.hpp). Made by load_robot.");
  robot.def_property_readonly("name", [](const Robot& r) { return r.model->name; })
      .def_property_readonly("dof", [](const Robot& r) { return r.model->dof(); })
      .def_property_readonly("velocity_bounds", [](const Robot& r) { return r.model->velocity_bounds; },
                             "V: the box |v_i| <= V_i the certificates assume (empty when the model gives none).")
      .def_property_readonly("joint_limits", [](const Robot& r) { return limits_of(*r.model); },
                             "(lower, upper) per joint; (-inf, inf) for a continuous joint.")
      .def_property_readonly("friction", [](const Robot& r) { return r.model->friction; }, "F (viscous), n x n.")
      .def_property_readonly("input_matrix", [](const Robot& r) { return r.model->input_matrix; }, "H, n x m.")
      .def_property_readonly("armature", [](const Robot& r) { return armature(*r.model); },
                             "Reflected rotor inertia per joint (zeros: none).")
      .def_property_readonly("notes", [](const Robot& r) { return r.model->notes; },
                             "What loading decided for you (chain chosen, bodies lumped, armature).")
      .def_property_readonly("fingerprint", [](const Robot& r) { return r.model->fingerprint; })
      .def("__repr__", [](const Robot& r) {
        return fmt::format("<obsgain.Robot '{}', {} joints>", r.model->name, r.model->dof());
      });
  bind_dynamics(robot);
  m.def("load_robot", &load, py::arg("source") = "pendubot", py::kw_only(), py::arg("armature") = py::none(),
        py::arg("vmax") = py::none(), py::arg("base_link") = "", py::arg("tip_link") = "",
        py::arg("actuated") = py::none(), py::arg("joint_limits") = py::none(),
        "Loads a robot: 'pendubot' (built in), a model file (*.json) or a URDF (*.urdf).\n\n"
        "armature: reflected rotor inertia per joint [kg m^2] (URDF and model files; default: the file's).\n"
        "vmax: velocity bounds per joint [rad/s] (default: the model's).\n"
        "base_link, tip_link: URDF only, the chain (default: the root, the arm's movable path).\n"
        "actuated: URDF only, 0/1 per joint (default: all).\n"
        "joint_limits: URDF only, (lower, upper) or 'c' per joint (default: the file's <limit>).\n"
        "Raises ValueError naming what cannot be loaded.");
}

}  // namespace obsgain::python
