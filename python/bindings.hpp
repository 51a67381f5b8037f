// The Python module `obsgain` (docs/python.md): bindings only. Each file binds one layer (docs/architecture.md);
// this header holds the Python-side value types they share and the two helpers every long call uses.
#pragma once

#include "obsgain/deployment/deployment.hpp"
#include "obsgain/report/design_file.hpp"
#include "obsgain/validation/montecarlo.hpp"

#include <pybind11/pybind11.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace obsgain::python {

namespace py = pybind11;

// A loaded robot. Shared: designs, reports and observers made from it keep it alive (the Observer class holds a
// reference to its model).
struct Robot {
  std::shared_ptr<const Model> model;
};

// A design: computed by design_gains (with the request it answers), or read back from design-gains' JSON (then
// it carries the certificate and the document only, as monte-carlo --design reads them).
struct PyDesign {
  std::shared_ptr<const Model> model;  // empty for a design read from JSON until a validation loads its robot
  std::optional<DeployedDesign> computed;
  std::optional<DesignOptions> options;  // the request (without its progress callback)
  std::optional<ObserverCertificate> certificate;  // empty when the design certifies no rate
  SavedDesign saved;                               // the robot source and fingerprint (read from JSON: all of it)
  std::string json;

  const CertifiedObserver& observer() const;  // the selected observer (ValueError when there is none)
  std::shared_ptr<const Model> robot_model() const;  // its model, loaded again for a design read from JSON
};

// Calls `body` with the GIL released. Ctrl-C is honoured at every progress report of the library (about five
// times a second in the long searches and in Monte Carlo): the report raises KeyboardInterrupt there.
template <class Body>
auto without_gil(Body&& body) {
  py::gil_scoped_release release;
  return body();
}

// The library's progress hooks for one call: each takes the GIL back, raises on a pending Ctrl-C (an exception
// the library lets through: docs/python.md), then hands one line of text to `callback` (None: no callback).
// The callback object must outlive the call.
class ProgressHooks {
 public:
  explicit ProgressHooks(const py::object& callback) : callback_(&callback) {}
  std::function<void(const std::string&)> phase() const;
  std::function<void(const SearchProgress&)> search() const;
  std::function<void(int, int, double)> trials() const;

 private:
  void report(const std::string& line) const;
  const py::object* callback_;
};

void bind_model(py::module_& m);
void bind_certificates(py::module_& m);
void bind_design(py::module_& m);
void bind_validation(py::module_& m);
void bind_runtime(py::module_& m);

// Keyword arguments (docs/python.md) to the library's options, with the command line's names, defaults and
// checks. Each takes what it reads out of `arguments`; refuse_unknown then names any keyword left (TypeError), before
// the values are checked (validate_design_options, validate_monte_carlo_options).
int thread_count(py::dict& arguments);  // "threads": the design's search and the Monte Carlo trials share it
struct DesignRequest {
  DesignOptions design;
  std::optional<DeploymentOptions> deployment;
};
DesignRequest design_request(py::dict& arguments, const ProgressHooks& hooks, int threads);
MonteCarloOptions monte_carlo_options(py::dict& arguments, const ProgressHooks& hooks, int default_trials, int threads);
void refuse_unknown(const py::dict& remaining, const char* function);

// A design computed for `robot` by the request.
PyDesign computed_design(const Robot& robot, DeployedDesign design, DesignOptions options);

}  // namespace obsgain::python
