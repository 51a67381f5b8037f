// One box of the certified bounds' branch and bound (bounds/box_bounds.hpp), per arm: the time of L_joint's bound on
// a box of the searched joints with every choice enumerated (no value attained to beat), single-threaded, beside what
// the search counts for it (`counted_ms`, the budget's reference seconds for two cores: bounds/box_bounds.cpp,
// box_costs). The count is fitted to run an eighth above half the time of a search's boxes on one core, each step of
// a box alike (docs/theory.md, "The budget"). `width`: the box's share of every searched side; `symbols`: its forms'
// symbols.
// The loop bounds one box again and again, so the heap is empty between iterations: glibc would return its top to the
// system every time and the next box fault its pages in again, which a search, whose queue keeps the heap in use, does
// not pay (25-30 % of this loop's time on arm6, arm7 and the iiwa; the same counted search took the same wall time
// with and without it). main() therefore fixes glibc's thresholds, so that the loop times what a search pays.
// FormsByKind: what a box's forms cost with its sides as angles, as arcs and both, against what the count says.
// Run: build/bench/bench_box (one kind: --benchmark_filter=FormsByKind)
#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/box_forms.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <string>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace {

void JointLipschitzBox(benchmark::State& state, const char* file, double width, std::vector<double> armature = {}) {
  obsgain::RobotSource source{std::string(OBSGAIN_EXAMPLES_DIR) + "/" + file};
  source.armature = std::move(armature);
  const obsgain::Model model = obsgain::load_robot(source);
  const obsgain::JointSearch search = obsgain::joint_search(model, obsgain::configuration_joints(model));
  const obsgain::BoxBounds boxes(model, search, model.velocity_bounds);
  std::vector<obsgain::Interval> box;
  for (const obsgain::Interval& side : search.domain) {
    const double low = side.lower() + 0.3 * (side.upper() - side.lower());
    box.emplace_back(low, low + width * (side.upper() - side.lower()));
  }
  double work = 0.0;
  for (auto _ : state) {
    const obsgain::BoxBound bound = boxes.joint_lipschitz(box, 0.0);
    work = bound.work;
    benchmark::DoNotOptimize(bound);
  }
  state.counters["counted_ms"] = 1e3 * work;
  state.counters["symbols"] = obsgain::box_forms(model, search, box, true).symbols;
}

BENCHMARK_CAPTURE(JointLipschitzBox, arm3_narrow, "arm3.urdf", 0.02)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(JointLipschitzBox, arm6_narrow, "arm6.urdf", 0.02)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(JointLipschitzBox, arm6_wide, "arm6.urdf", 0.1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(JointLipschitzBox, arm7_narrow, "arm7.urdf", 0.02)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(JointLipschitzBox, arm7_wide, "arm7.urdf", 0.1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(JointLipschitzBox, iiwa14_narrow, "iiwa14.urdf", 0.02)->Unit(benchmark::kMillisecond);
// Two published arms with an assumed rotor inertia, as bench_certified_arms takes them: without friction, which the
// count takes to halve the velocity vertices, their boxes count less than arm6's of the same joints and symbols.
BENCHMARK_CAPTURE(JointLipschitzBox, ur5_armature_narrow, "ur5.urdf", 0.02,
                  std::vector<double>{0.6, 0.6, 0.6, 0.2, 0.2, 0.2})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(JointLipschitzBox, jaco2_armature_narrow, "jaco2.urdf", 0.02, std::vector<double>(6, 0.1))
    ->Unit(benchmark::kMillisecond);

// The forms of three boxes of one arm (M, its derivatives and the tensors on third-order forms), timed in turn many
// times: every searched side narrow (one symbol, its angle), every side wide (an arc, two symbols), and the two
// alternately. The machine's pace drifts 10 % and more within minutes and moves the three alike, so the ratios of the
// medians are what this compares (they held to 0.03 across runs while the times drifted 40 %; docs/history.md, the
// thirty-ninth round), beside the ratios the count gives the forms (bounds/box_bounds.cpp, box_costs).
void FormsByKind(benchmark::State& state, const char* file, std::vector<double> armature = {}) {
  obsgain::RobotSource source{std::string(OBSGAIN_EXAMPLES_DIR) + "/" + file};
  source.armature = std::move(armature);
  const obsgain::Model model = obsgain::load_robot(source);
  const obsgain::JointSearch search = obsgain::joint_search(model, obsgain::configuration_joints(model));
  const auto box = [&](double narrow, double wide) {
    std::vector<obsgain::Interval> b;
    for (const obsgain::Interval& side : search.domain) {  // inside the side: centred at 0.37 of it
      const double width = side.upper() - side.lower();
      const double radius = std::min(b.size() % 2 ? wide : narrow, 0.37 * width), centre = side.lower() + 0.37 * width;
      b.emplace_back(centre - radius, centre + radius);
    }
    return b;
  };
  constexpr double angle = 0.8 * obsgain::kArcRadius, arc = 0.4;
  const std::array<std::vector<obsgain::Interval>, 3> boxes{box(angle, angle), box(arc, arc), box(angle, arc)};
  std::array<std::vector<double>, 3> seconds;
  for (auto _ : state)
    for (std::size_t kind = 0; kind < boxes.size(); ++kind) {
      const auto start = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(obsgain::box_forms(model, search, boxes[kind], true));
      seconds[kind].push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
  const obsgain::CountedModel counted = obsgain::counted_model(model);
  std::array<double, 3> median{}, count{};
  for (std::size_t kind = 0; kind < boxes.size(); ++kind) {
    std::vector<double>& t = seconds[kind];
    std::nth_element(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(t.size() / 2), t.end());
    median[kind] = t[t.size() / 2];
    const obsgain::BoxForms f = obsgain::box_forms(model, search, boxes[kind], true);
    count[kind] = obsgain::box_costs(f.n, f.symbols, counted).forms;
  }
  state.counters["angles_ms"] = 1e3 * median[0];
  state.counters["arcs_ms"] = 1e3 * median[1];
  state.counters["mixed_ms"] = 1e3 * median[2];
  state.counters["angles/arcs"] = median[0] / median[1];
  state.counters["mixed/arcs"] = median[2] / median[1];
  state.counters["counted_angles/arcs"] = count[0] / count[1];
  state.counters["counted_mixed/arcs"] = count[2] / count[1];
}

BENCHMARK_CAPTURE(FormsByKind, arm6, "arm6.urdf")->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(FormsByKind, iiwa14, "iiwa14.urdf")->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(FormsByKind, ur5_armature, "ur5.urdf", std::vector<double>{0.6, 0.6, 0.6, 0.2, 0.2, 0.2})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

}  // namespace

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 16 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
