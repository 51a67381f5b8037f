// The module: its docstring, the error translation, the progress hooks, and the layers' bindings.
#include "bindings.hpp"

#include "obsgain/report/report.hpp"

#include <fmt/format.h>

namespace obsgain::python {

void ProgressHooks::report(const std::string& line) const {
  py::gil_scoped_acquire acquire;
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // KeyboardInterrupt, through the library
  if (!callback_->is_none()) (*callback_)(line);
}

std::function<void(const std::string&)> ProgressHooks::phase() const {
  return [this](const std::string& phase) { report(phase); };
}

std::function<void(const SearchProgress&)> ProgressHooks::search() const {
  return [this](const SearchProgress& p) {
    report(fmt::format("{}: {} boxes, [{:.8g}, {:.8g}], gap {:.1e} (target {:.0e}), {:.0f} s", p.bound, p.boxes,
                       p.lower, p.upper, p.relative_gap, p.target_gap, p.seconds));
  };
}

std::function<void(int, int, double)> ProgressHooks::trials() const {
  return [this](int done, int total, double seconds) {
    report(fmt::format("monte-carlo: {} / {} trials, {:.0f} s", done, total, seconds));
  };
}

}  // namespace obsgain::python

PYBIND11_MODULE(obsgain, m) {
  using namespace obsgain::python;
  m.doc() =
      "obsgain: certified velocity-observer gains for robot manipulators.\n\n"
      "The C++ library's algorithms with NumPy arrays in and out (docs/python.md):\n"
      "  robot = obsgain.load_robot('pendubot')\n"
      "  design = obsgain.design_gains(robot, gamma=1.27)\n"
      "  print(design.summary())\n"
      "  report = obsgain.monte_carlo(design, trials=200, seed=1)\n"
      "  observer = obsgain.Observer(design, robot)\n"
      "Bad input raises ValueError with the command line's one-line message; a request that cannot be met is a\n"
      "result (design.meets_request), not an exception.";
  m.attr("__version__") = obsgain::version();
  // The library's InputError is what the command line reports with exit 2: here a ValueError, same message.
  py::register_exception_translator([](std::exception_ptr error) {
    try {
      if (error) std::rethrow_exception(error);
    } catch (const obsgain::InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  bind_model(m);
  bind_certificates(m);
  bind_design(m);
  bind_validation(m);
  bind_runtime(m);
}
