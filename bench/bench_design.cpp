// design-gains on the Pendubot end to end (bounds, Lyapunov, both certificates), as the app runs it, with
// numeric bounds (target: median under 0.2 s) and with certified bounds, and with the polytopic certificate; and verify-bounds' computation
// (certified bounds, 200 Monte Carlo trials, plot data; target under 60 s on 2 cores); and design-gains on
// the 6-joint URDF arm of examples/ (5-dimensional bound search, 64 x 64 vertex/pattern choices for L_joint;
// target under 30 s on 2 cores); and the three-joint URDF arm with the polytopic certificate by search.
// Run: build/bench/bench_design --benchmark_repetitions=5
#include "obsgain/design/design.hpp"
#include "obsgain/parsers/robots.hpp"
#include "obsgain/validation/verification.hpp"

#include <benchmark/benchmark.h>

#include <optional>

namespace {

void DesignGainsPendubot(benchmark::State& state, bool optimize_shape, obsgain::BoundMethod method) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions options;
  options.gamma = 1.27;
  options.optimize_shape = optimize_shape;
  options.bound_method = method;
  for (auto _ : state) benchmark::DoNotOptimize(obsgain::design_gains(model, options));
}

// --certificate polytopic: the polytope, about 20 SDPs (bisection in θ) and the interval check.
void DesignGainsPendubotPolytopic(benchmark::State& state) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::DesignOptions options;
  options.gamma = 1.27;
  options.certificate = obsgain::CertificateKind::polytopic;
  for (auto _ : state) benchmark::DoNotOptimize(obsgain::design_gains(model, options));
}

void VerifyPendubot(benchmark::State& state) {
  const obsgain::Model model = obsgain::pendubot();
  obsgain::VerificationOptions options;
  options.design.gamma = 1.27;
  for (auto _ : state) benchmark::DoNotOptimize(obsgain::verify_design(model, options));
}

// An arm from its URDF: `design-gains --robot examples/armN.urdf --gamma 5 [--bounds numeric] [--bound-budget s]
// [--certificate polytopic]`.
void DesignGainsArm(benchmark::State& state, const char* file, obsgain::BoundMethod method, double budget,
                    std::optional<obsgain::CertificateKind> certificate = std::nullopt) {
  const obsgain::Model model = obsgain::load_robot({std::string(OBSGAIN_EXAMPLES_DIR) + "/" + file});
  obsgain::DesignOptions options;
  options.gamma = 5.0;
  options.bound_method = method;
  options.certified_bounds.budget_seconds = budget;
  if (certificate) options.certificate = *certificate;
  for (auto _ : state) benchmark::DoNotOptimize(obsgain::design_gains(model, options));
}

using obsgain::BoundMethod;
BENCHMARK_CAPTURE(DesignGainsPendubot, numeric, false, BoundMethod::numeric)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(DesignGainsPendubot, numeric_optimize_shape, true, BoundMethod::numeric)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(DesignGainsPendubot, certified, false, BoundMethod::certified)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(DesignGainsPendubotPolytopic)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(VerifyPendubot)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK_CAPTURE(DesignGainsArm, arm3_certified_30s, "arm3.urdf", BoundMethod::certified, 30.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
// The polytopic certificate by search (docs/theory.md): P on samples, the smallest k, the branch and bound proof.
BENCHMARK_CAPTURE(DesignGainsArm, arm3_polytopic, "arm3.urdf", BoundMethod::certified, 30.0,
                  obsgain::CertificateKind::polytopic)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK_CAPTURE(DesignGainsArm, arm6_numeric, "arm6.urdf", BoundMethod::numeric, 0.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK_CAPTURE(DesignGainsArm, arm7_numeric, "arm7.urdf", BoundMethod::numeric, 0.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
