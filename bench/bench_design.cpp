// design-gains on the Pendubot end to end (bounds, Lyapunov, both certificates), as the app runs it.
// Target: median under 0.2 s. Run: build/bench/bench_design --benchmark_repetitions=10
#include "obsgain/design.hpp"
#include "obsgain/planar_2r.hpp"

#include <benchmark/benchmark.h>

namespace {

void DesignGainsPendubot(benchmark::State& state, bool optimize_shape) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions options;
  options.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  options.gamma = 1.27;
  options.optimize_shape = optimize_shape;
  for (auto _ : state) benchmark::DoNotOptimize(obsgain::design_gains(model, options));
}

BENCHMARK_CAPTURE(DesignGainsPendubot, alpha_beta_1, false)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(DesignGainsPendubot, optimize_shape, true)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
