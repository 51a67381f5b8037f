// A controller that runs the observer design-gains exported: the generated header holds the model and the certified
// observer as data, obsgain::runtime reads them and runs the Observer. It links the runtime alone.
#include "observer_gains.hpp"

#include <obsgain/runtime/exported_observer.hpp>
#include <obsgain/runtime/observer.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const obsgain::ExportedObserver exported = obsgain::read_exported_observer(observer_gains::runtime_description);
  if (exported.observer.k1 != observer_gains::k1 || exported.observer.k2 != observer_gains::k2) return 1;
  obsgain::Observer observer(exported.model, exported.observer, exported.substeps);
  // The Pendubot at rest at the lower equilibrium, measured exactly; the observer starts 0.1 rad and 2 rad/s off.
  Eigen::Vector2d q(-1.5707963267948966, 0.0), u = Eigen::Vector2d::Zero();
  if (!observer.reset(q, q + Eigen::Vector2d(0.1, -0.1), Eigen::Vector2d(2.0, 2.0))) return 1;
  for (int k = 0; k < 1000; ++k)
    if (!observer.update(q, u, observer_gains::sample_period).accepted) return 1;
  const double error = (observer.velocity()).norm() + (observer.position() - q).norm();
  std::printf("error after 1 s: %.3g\n", error);
  return error < 1e-6 ? 0 : 1;
}
