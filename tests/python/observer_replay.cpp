// The C++ Observer on a recorded trajectory, for the Python tests' bit-for-bit comparison with obsgain.Observer.
// Usage: observer_replay OBSERVER_FILE SAMPLES_FILE. SAMPLES_FILE: a first line with the n positions the observer
// is reset at, then one line per sample: dt, n positions, m inputs. Prints q̂ and v̂ after each sample, 17 digits.
#include "obsgain/runtime/exported_observer.hpp"
#include "obsgain/runtime/observer.hpp"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: observer_replay OBSERVER_FILE SAMPLES_FILE\n";
    return 2;
  }
  std::ifstream observer_file(argv[1]), samples(argv[2]);
  const std::string text{std::istreambuf_iterator<char>(observer_file), std::istreambuf_iterator<char>()};
  const obsgain::ExportedObserver exported = obsgain::read_exported_observer(text);
  obsgain::Observer observer(exported.model, exported.observer, exported.substeps);
  const int n = exported.model.dof();
  const auto m = exported.model.input_matrix.cols();
  Eigen::VectorXd q(n), u(m);
  std::string line;
  std::getline(samples, line);
  std::istringstream first(line);
  for (int i = 0; i < n; ++i) first >> q(i);
  if (!observer.reset(q)) return 1;
  while (std::getline(samples, line)) {
    std::istringstream row(line);
    double dt = 0.0;
    row >> dt;
    for (int i = 0; i < n; ++i) row >> q(i);
    for (Eigen::Index i = 0; i < m; ++i) row >> u(i);
    const auto estimate = observer.update(q, u, dt);
    if (!estimate.accepted) return 1;
    for (int i = 0; i < n; ++i) std::printf("%.17g ", estimate.position(i));
    for (int i = 0; i < n; ++i) std::printf("%.17g ", estimate.velocity(i));
    std::printf("\n");
  }
  return 0;
}
