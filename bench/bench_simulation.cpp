// One paper-scenario trajectory (θ = 200, α = β = 1, horizon 1 s, rtol 1e-8, atol 1e-10) on one thread, and
// a 200-trial Monte Carlo on 1 and 2 threads. bench/compare_scipy.sh prints the ratios against SciPy.
#include "obsgain/validation/montecarlo.hpp"

#include <benchmark/benchmark.h>

namespace {

obsgain::ObserverCertificate paper_gains(const obsgain::Model& model) {
  obsgain::DesignOptions options;
  options.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  options.theta = 200.0;
  return obsgain::observer_certificate({obsgain::design_gains(model, options), std::nullopt});
}

void PaperTrajectory(benchmark::State& state) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::ObserverCertificate c = paper_gains(model);
  obsgain::MonteCarloOptions options;
  options.scenario = obsgain::Scenario::paper;
  const obsgain::TrialSetup trial = obsgain::make_trial(model, model.velocity_bounds, options, 0, 1.0);
  int steps = 0;
  for (auto _ : state) {
    const auto result = obsgain::simulate_trial(model, c, trial.initial, trial.input,
                                                options.simulation);
    steps = result.steps;
    benchmark::DoNotOptimize(result);
  }
  state.counters["steps"] = steps;
}

void MonteCarlo200(benchmark::State& state) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::ObserverCertificate c = paper_gains(model);
  obsgain::MonteCarloOptions options;
  options.trials = 200;
  options.threads = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(obsgain::run_monte_carlo(model, c, options));
}

BENCHMARK(PaperTrajectory)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(MonteCarlo200)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
