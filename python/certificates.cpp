// The certificate layer: the paper's and the tight certificate as functions of the gains (per joint).
#include "bindings.hpp"

#include "obsgain/certificate/certificate.hpp"
#include "obsgain/certificate/lyapunov.hpp"

#include <pybind11/eigen.h>

#include <fmt/format.h>

#include <cmath>

namespace obsgain::python {

namespace {

// The closed forms and bisections assume positive, finite gains and a finite L >= 0.
double positive(const char* name, double value) {
  if (!std::isfinite(value) || value <= 0.0) throw InputError(fmt::format("{} = {} must be positive and finite", name, value));
  return value;
}

double lipschitz(double L) {
  if (!std::isfinite(L) || L < 0.0) throw InputError(fmt::format("L = {} must be finite and >= 0", L));
  return L;
}

py::dict riccati_certificate(double k1, double k2, double L, double gamma) {
  const RiccatiCertificate c = tight_certificate(positive("k1", k1), positive("k2", k2), lipschitz(L), positive("gamma", gamma));
  py::dict d;
  d["exists"] = c.exists;
  d["P"] = Eigen::Matrix2d(c.P);
  d["gamma"] = c.gamma;
  d["k"] = c.k;
  d["lmi_max_eig"] = c.lmi_max_eig;
  d["riccati_residual"] = c.riccati_residual;
  return d;
}

py::dict lyapunov(double alpha, double beta, int dof) {
  if (dof < 1 || dof > 64) throw InputError(fmt::format("dof = {} must lie in [1, 64]", dof));
  const LyapunovSolution s = observer_lyapunov(positive("alpha", alpha), positive("beta", beta), dof);
  py::dict d;
  d["S2"] = Eigen::Matrix2d(s.S2);
  d["S"] = s.S;
  d["S_norm"] = s.S_norm;
  d["residual"] = s.residual;
  return d;
}

}  // namespace

void bind_certificates(py::module_& m) {
  m.def("paper_theta_star", [](double S_norm, double gamma, double L) {
    return paper_theta_star(positive("S_norm", S_norm), positive("gamma", gamma), lipschitz(L));
  }, py::arg("S_norm"), py::arg("gamma"), py::arg("L"), "The paper's Theorem 1: theta* = 2 ||S|| (gamma + L).");
  m.def("paper_rate", [](double S_norm, double theta, double L) {
    return paper_rate(positive("S_norm", S_norm), positive("theta", theta), lipschitz(L));
  }, py::arg("S_norm"), py::arg("theta"), py::arg("L"), "The rate Theorem 1 certifies at theta: (theta - 2||S||L) / (2||S||).");
  m.def("tight_rate", [](double k1, double k2, double L) {
    return tight_rate(positive("k1", k1), positive("k2", k2), lipschitz(L));
  }, py::arg("k1"), py::arg("k2"), py::arg("L"),
        "The largest rate the bounded-real lemma certifies for gains k1, k2 and ||phi|| <= L ||e_v|| (a supremum; "
        "may be negative).");
  m.def("tight_theta_star", [](double alpha, double beta, double gamma, double L) {
    return tight_theta_star(positive("alpha", alpha), positive("beta", beta), positive("gamma", gamma), lipschitz(L));
  }, py::arg("alpha"), py::arg("beta"), py::arg("gamma"), py::arg("L"),
        "The smallest theta with tight_rate(theta alpha, theta^2 beta, L) >= gamma.");
  m.def("shifted_transfer_peak", [](double k1, double k2, double gamma) {
    return shifted_transfer_peak(positive("k1", k1), positive("k2", k2), gamma);
  }, py::arg("k1"), py::arg("k2"), py::arg("gamma"),
        "sup_w |t(jw - gamma)| for t(s) = (s + k1) / (s^2 + k1 s + k2); inf when A2 + gamma I is not Hurwitz.");
  m.def("tight_certificate", &riccati_certificate, py::arg("k1"), py::arg("k2"), py::arg("L"), py::arg("gamma"),
        "The per-joint P certifying gamma (Riccati, then the smallest envelope constant k): a dict with exists, P, "
        "gamma, k, lmi_max_eig (<= 0 certifies) and riccati_residual.");
  m.def("observer_lyapunov", &lyapunov, py::arg("alpha"), py::arg("beta"), py::arg("dof"),
        "S solving the observer's Lyapunov equation for the shape (alpha, beta): a dict with S2, S, S_norm, residual.");
}

}  // namespace obsgain::python
