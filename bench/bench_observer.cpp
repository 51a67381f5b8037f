// The real-time observer's cost per sample: one update() at 1 kHz with the sub-steps its gains need, on the
// Pendubot (target < 1 µs) and on the 7-joint example arm (target < 20 µs). Counters: the RK4 sub-steps per sample.
#include "obsgain/runtime/observer.hpp"
#include "obsgain/parsers/robots.hpp"

#include <benchmark/benchmark.h>

namespace {

obsgain::CertifiedObserver gains(double theta, double L, const Eigen::VectorXd& V) {
  obsgain::CertifiedObserver o;
  o.theta = theta;
  o.k1 = theta;
  o.k2 = theta * theta;
  o.L = L;
  o.velocity_bounds = V;
  return o;
}

void run(benchmark::State& state, const obsgain::Model& model, const obsgain::CertifiedObserver& gains) {
  obsgain::Observer observer(model, gains);
  const int n = model.dof();
  Eigen::VectorXd y = Eigen::VectorXd::Constant(n, 0.3);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(model.input_matrix.cols(), 0.1);
  observer.reset(y);
  const double T = 1e-3;
  double phase = 0.0;
  for (auto _ : state) {
    phase += T;
    y(0) = 0.3 + 0.1 * std::sin(phase);  // a moving measurement, so that nothing is cached by accident
    benchmark::DoNotOptimize(observer.update(y, u, T).velocity.data());
  }
  state.counters["substeps"] = observer.substeps(T);
}

// The Pendubot's velocity-error design at 1 kHz (docs/usage.md): θ ≈ 138, α = β = 1, L_joint = 43.35.
void PendubotUpdate(benchmark::State& state) {
  const obsgain::Model model = obsgain::pendubot();
  run(state, model, gains(138.0, 43.35, Eigen::Vector2d(10.0, 10.0)));
}

// arm7 (iiwa-class, examples/arm7.urdf) with the gains of its velocity-error design at 1 kHz: θ ≈ 170.
void Arm7Update(benchmark::State& state) {
  const obsgain::Model model = obsgain::load_robot(obsgain::RobotSource{OBSGAIN_EXAMPLES_DIR "/arm7.urdf"});
  run(state, model, gains(170.0, 2.24, model.velocity_bounds));
}

}  // namespace

BENCHMARK(PendubotUpdate);
BENCHMARK(Arm7Update);
BENCHMARK_MAIN();
