// The Observer class as deployed: it converges to the continuous observer as the sample period shrinks (at
// the order of its measurement interpolation), integrates its own equations at RK4's order, refuses bad input
// without touching its state, and allocates nothing once built. Its own executable: it replaces the global
// malloc to count allocations.
#include "obsgain/runtime/observer.hpp"
#include "obsgain/parsers/robots.hpp"
#include "obsgain/runtime/exported_observer.hpp"

#include <boost/numeric/odeint.hpp>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>

namespace {
std::atomic<long> allocations{0};
}

#ifdef OBSGAIN_COUNT_ALLOCATIONS
// Every heap allocation goes through malloc: operator new in libstdc++, and Eigen's aligned allocator. The
// executable's definitions interpose on the C library's for the whole process, libobsgain included.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* malloc(std::size_t size) {
  ++allocations;
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  ++allocations;
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t size) {
  ++allocations;
  return __libc_realloc(p, size);
}
}
#endif

namespace obsgain {
namespace {

using State = std::vector<double>;
namespace odeint = boost::numeric::odeint;

// Gains of the Pendubot's velocity-error design at 1 kHz (docs/usage.md): θ ≈ 138, α = β = 1, L_joint.
CertifiedObserver gains(double k1, double k2, double L, const Eigen::VectorXd& V) {
  CertifiedObserver o;
  o.k1 = k1;
  o.k2 = k2;
  o.L = L;
  o.velocity_bounds = V;
  return o;
}
CertifiedObserver pendubot_gains() { return gains(138.0, 138.0 * 138.0, 43.3475, Eigen::Vector2d(10.0, 10.0)); }

const Eigen::Vector2d kInput(0.4, 0.0);

// Plant and observer driven by the plant's exact q(t), written out here independently of the library's
// simulation: x = (q, v, q̂, v̂). With `held` set, the observer sees y(t) interpolated between the samples instead.
struct Reference {
  const Model& model;
  const CertifiedObserver& g;
  std::function<Eigen::VectorXd(double)> held;  // y(t); empty: the plant's own q(t)
  std::function<Eigen::VectorXd(double)> input = [](double) { return Eigen::VectorXd(kInput); };
  void operator()(const State& x, State& dx, double t) const {
    const Eigen::VectorXd u = input(t);
    const int n = model.dof();
    const Eigen::Map<const Eigen::VectorXd> q(x.data(), n), v(x.data() + n, n), qh(x.data() + 2 * n, n),
        vh(x.data() + 3 * n, n);
    const auto acceleration = [&](const Eigen::VectorXd& at, const Eigen::VectorXd& w, const Eigen::VectorXd& vf) {
      Eigen::MatrixXd M(n, n);
      Eigen::VectorXd A(n), gr(n);
      obsgain::mass_matrix(model, at, M);
      obsgain::coriolis(model, at, w, A);
      obsgain::gravity(model, at, gr);
      return Eigen::VectorXd(M.llt().solve(model.input_matrix * u - A - model.friction * vf - gr));
    };
    const Eigen::VectorXd y = held ? held(t) : Eigen::VectorXd(q);
    const Eigen::VectorXd sat = vh.cwiseMax(-g.velocity_bounds).cwiseMin(g.velocity_bounds);
    Eigen::Map<Eigen::VectorXd>(dx.data(), n) = v;
    Eigen::Map<Eigen::VectorXd>(dx.data() + n, n) = acceleration(q, v, v);
    Eigen::Map<Eigen::VectorXd>(dx.data() + 2 * n, n) = vh - g.k1 * (qh - y);
    Eigen::Map<Eigen::VectorXd>(dx.data() + 3 * n, n) = acceleration(y, sat, vh) - g.k2 * (qh - y);
  }
};

State initial_state() { return {-1.2, 0.3, 1.0, -1.5, -1.2 + 0.05, 0.3 - 0.02, 0.0, 0.0}; }

// The plant's positions at t = 0, T, 2T, ... (exact, no quantisation), and the reference state at the end.
// The input held over sample interval k: constant, or (varying) changed at every sample as a controller would.
Eigen::VectorXd held_input(bool varying, int k) {
  return varying ? Eigen::VectorXd(kInput * (1.0 + 0.5 * std::sin(0.7 * k))) : Eigen::VectorXd(kInput);
}

std::vector<Eigen::VectorXd> plant_samples(const Model& model, const CertifiedObserver& g, double T, int count,
                                           bool varying = false) {
  int interval = 0;  // integrated interval by interval: the input never changes inside a step
  Reference system{model, g, {}, [&](double) { return held_input(varying, interval); }};
  State x = initial_state();
  std::vector<Eigen::VectorXd> samples{Eigen::Vector2d(x[0], x[1])};
  for (int k = 0; k < count; ++k) {
    interval = k;
    odeint::integrate_adaptive(odeint::make_controlled(1e-13, 1e-13, odeint::runge_kutta_dopri5<State>()), system, x,
                               k * T, (k + 1) * T, T / 8);
    samples.emplace_back(Eigen::Vector2d(x[0], x[1]));
  }
  return samples;
}

Eigen::VectorXd run_class(const Model& model, const CertifiedObserver& g, double T, const std::vector<Eigen::VectorXd>& y,
                          bool varying = false, int substeps = 0) {
  Observer observer(model, g, substeps);
  const State x0 = initial_state();
  observer.reset(y[0], Eigen::Vector2d(x0[4], x0[5]), Eigen::Vector2d(x0[6], x0[7]));
  for (std::size_t k = 1; k < y.size(); ++k)
    EXPECT_TRUE(observer.update(y[k], held_input(varying, static_cast<int>(k) - 1), T).accepted);
  Eigen::VectorXd out(4);
  out << observer.position(), observer.velocity();
  return out;
}

TEST(Observer, ConvergesToTheContinuousObserverAtTheInterpolationOrder) {
  const Model model = pendubot();
  const CertifiedObserver g = pendubot_gains();
  const double horizon = 0.2;
  Reference continuous{model, g, {}};
  State x = initial_state();
  odeint::integrate_adaptive(odeint::make_controlled(1e-13, 1e-13, odeint::runge_kutta_dopri5<State>()), continuous, x,
                             0.0, horizon, 1e-4);
  const Eigen::Vector4d truth(x[4], x[5], x[6], x[7]);
  std::vector<double> errors;
  for (const int count : {50, 100, 200, 400}) {
    const double T = horizon / count;
    errors.push_back((run_class(model, g, T, plant_samples(model, g, T, count)) - truth).norm());
  }
  // Linear interpolation of the samples misses q(t) by O(T²): each halving of T divides the gap by about 4.
  for (std::size_t i = 1; i < errors.size(); ++i) {
    const double ratio = errors[i - 1] / errors[i];
    EXPECT_GT(ratio, 3.5) << "T = " << horizon / (50 << i);
    EXPECT_LT(ratio, 4.5) << "T = " << horizon / (50 << i);
  }
  EXPECT_LT(errors.back(), 1e-4);
}

// With the input changed at every sample, as a controller does (the class reuses the model at the last
// measurement across updates, with the new input).
TEST(Observer, IntegratesItsOwnEquationsAtFourthOrder) {
  const Model model = pendubot();
  const double T = 4e-3, horizon = 0.2;
  const int count = static_cast<int>(horizon / T + 0.5);
  const bool varying = true;
  int interval = 0;
  const std::vector<Eigen::VectorXd> y = plant_samples(model, pendubot_gains(), T, count, varying);
  // The exact flow of the sampled observer: the same equations with y(t) interpolated between the samples.
  Reference sampled{model, pendubot_gains(), [&](double t) {
                      const auto k = std::min<std::size_t>(static_cast<std::size_t>(t / T), y.size() - 2);
                      const double s = (t - static_cast<double>(k) * T) / T;
                      return Eigen::VectorXd(y[k] + s * (y[k + 1] - y[k]));
                    },
                    [&](double) { return held_input(varying, interval); }};
  State x = initial_state();
  for (int k = 0; k < count; ++k) {  // piecewise, so that the integrator never steps across a kink of y(t) or u
    interval = k;
    odeint::integrate_adaptive(odeint::make_controlled(1e-14, 1e-14, odeint::runge_kutta_dopri5<State>()), sampled, x,
                               k * T, (k + 1) * T, T / 16);
  }
  const Eigen::Vector4d flow(x[4], x[5], x[6], x[7]);
  std::vector<double> errors;
  for (const int substeps : {1, 2, 4, 8})
    errors.push_back((run_class(model, pendubot_gains(), T, y, varying, substeps) - flow).norm());
  // Fourth order: each halving of the step divides the error by about 16 (between 12 and 24 per halving, a
  // local constant that still moves a little at these steps; 3.7 to 4.3 over the three halvings together).
  for (std::size_t i = 1; i < errors.size(); ++i) {
    const double ratio = errors[i - 1] / errors[i];
    EXPECT_GT(ratio, 12.0) << "substeps " << (1 << i);
    EXPECT_LT(ratio, 24.0) << "substeps " << (1 << i);
  }
  const double order = std::log2(errors.front() / errors.back()) / 3.0;
  EXPECT_GT(order, 3.7);
  EXPECT_LT(order, 4.3);
  // With the automatic sub-step count (3 here) the integration error is far below half a count of a 4096-count
  // encoder (7.7e-4 rad), the floor the deployment certificate is made of.
  EXPECT_LT((run_class(model, pendubot_gains(), T, y, varying) - flow).norm(), 1e-5);
}

// The documented scheme, written out independently: classical RK4 steps of length h = T / substeps on
// q̂' = v̂ - k1 (q̂ - y(t)), v̂' = M(y_c)⁻¹ (H u - A(y_c, σ(v̂)) - F v̂ - g(y_c)) - k2 (q̂ - y(t)), with y(t) the line
// between the last two samples and y_c it clamped into the joint limits, the model evaluated afresh at every stage.
// An input that changes at every sample, one value per input channel.
Eigen::VectorXd sample_input(const Model& model, int k) {
  return Eigen::VectorXd::LinSpaced(model.input_matrix.cols(), 0.4, -0.2) * (1.0 + 0.5 * std::sin(0.7 * k));
}

Eigen::VectorXd documented_scheme(const Model& model, const CertifiedObserver& g, double T, int substeps,
                                  const std::vector<Eigen::VectorXd>& y, const Eigen::VectorXd& q0,
                                  const Eigen::VectorXd& v0, std::size_t samples) {
  const int n = model.dof();
  Eigen::VectorXd lower(n), upper(n);
  for (int i = 0; i < n; ++i) {
    lower(i) = model.joints[i].continuous ? -1e300 : model.joints[i].lower;
    upper(i) = model.joints[i].continuous ? 1e300 : model.joints[i].upper;
  }
  Eigen::VectorXd q = q0, v = v0;
  for (std::size_t k = 1; k <= samples; ++k) {
    const Eigen::VectorXd u = sample_input(model, static_cast<int>(k) - 1);
    const auto f = [&](double s, const Eigen::VectorXd& qh, const Eigen::VectorXd& vh, Eigen::VectorXd& dq,
                       Eigen::VectorXd& dv) {
      const Eigen::VectorXd yt = y[k - 1] + s * (y[k] - y[k - 1]), yc = yt.cwiseMax(lower).cwiseMin(upper);
      Eigen::MatrixXd M(n, n);
      Eigen::VectorXd A(n), gr(n);
      mass_matrix(model, yc, M);
      coriolis(model, yc, vh.cwiseMax(-g.velocity_bounds).cwiseMin(g.velocity_bounds), A);
      gravity(model, yc, gr);
      dv = M.llt().solve(model.input_matrix * u - A - model.friction * vh - gr) - g.k2 * (qh - yt);
      dq = vh - g.k1 * (qh - yt);
    };
    const double h = T / substeps;
    for (int step = 0; step < substeps; ++step) {
      const double s0 = static_cast<double>(step) / substeps, ds = 1.0 / substeps;
      Eigen::VectorXd a1(n), b1(n), a2(n), b2(n), a3(n), b3(n), a4(n), b4(n);
      f(s0, q, v, a1, b1);
      f(s0 + 0.5 * ds, q + 0.5 * h * a1, v + 0.5 * h * b1, a2, b2);
      f(s0 + 0.5 * ds, q + 0.5 * h * a2, v + 0.5 * h * b2, a3, b3);
      f(s0 + ds, q + h * a3, v + h * b3, a4, b4);
      q += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
      v += h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4);
    }
  }
  Eigen::VectorXd out(2 * n);
  out << q, v;
  return out;
}

// From the first sample on (the first update after reset() once read the end of its interval where the start
// belongs), on the Pendubot and on a 7-joint arm with joint limits.
TEST(Observer, FollowsItsDocumentedSchemeFromTheFirstSample) {
  const Model arm7 = load_robot(RobotSource{OBSGAIN_EXAMPLES_DIR "/arm7.urdf"});
  const Model two_link = pendubot();
  for (const Model* model : {&two_link, &arm7}) {
    const int n = model->dof();
    const CertifiedObserver g = n == 2 ? pendubot_gains() : gains(60.0, 3600.0, 3.0, Eigen::VectorXd::Constant(n, 1.5));
    const double T = 2e-3;
    std::vector<Eigen::VectorXd> y;
    for (int k = 0; k <= 50; ++k) {  // a fast motion: 9.9 rad/s on the first joint
      Eigen::VectorXd sample = Eigen::VectorXd::LinSpaced(n, -0.5, 0.6);
      sample(0) += 9.9 * k * T;
      y.push_back(sample);
    }
    const Eigen::VectorXd q0 = y[0] + Eigen::VectorXd::Constant(n, 0.03), v0 = Eigen::VectorXd::Constant(n, -0.4);
    for (const int substeps : {1, 3}) {
      Observer observer(*model, g, substeps);
      ASSERT_TRUE(observer.reset(y[0], q0, v0));
      for (std::size_t k = 1; k < y.size(); ++k) {
        ASSERT_TRUE(observer.update(y[k], sample_input(*model, static_cast<int>(k) - 1), T).accepted);
        if (k != 1 && k != y.size() - 1) continue;
        Eigen::VectorXd state(2 * n);
        state << observer.position(), observer.velocity();
        const Eigen::VectorXd scheme = documented_scheme(*model, g, T, substeps, y, q0, v0, k);
        EXPECT_LE((state - scheme).norm(), 1e-11 * (1.0 + scheme.norm())) << model->name << ", sample " << k;
      }
    }
  }
}

TEST(Observer, RefusesBadInputAndKeepsItsState) {
  const Model model = pendubot();
  Observer observer(model, pendubot_gains());
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), kInput, 1e-3).accepted);  // no first sample yet
  EXPECT_FALSE(observer.reset(Eigen::Vector2d(std::nan(""), 0.2)));
  ASSERT_TRUE(observer.reset(Eigen::Vector2d(0.1, 0.2)));
  const Eigen::Vector2d q = observer.position(), v = observer.velocity();
  const double nan = std::nan("");
  EXPECT_FALSE(observer.update(Eigen::Vector2d(nan, 0.0), kInput, 1e-3).accepted);
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d(nan, 0.0), 1e-3).accepted);
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), kInput, 0.0).accepted);
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), kInput, -1e-3).accepted);
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), kInput, -1e18).accepted);
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), kInput, 1e9).accepted);  // beyond max_substeps
  EXPECT_FALSE(observer.update(Eigen::Vector3d(0.1, 0.2, 0.3), kInput, 1e-3).accepted);
  // Finite samples whose integration leaves double's range: the state was NaN from there on, and every later sample
  // answered with NaNs.
  EXPECT_FALSE(observer.update(Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d(1e308, 0.0), 1e-3).accepted);
  EXPECT_FALSE(observer.update(Eigen::Vector2d(1e308, 0.2), kInput, 1e-3).accepted);
  EXPECT_EQ(observer.position(), q);
  EXPECT_EQ(observer.velocity(), v);
  // The next sample is answered as by an observer that never saw the refused ones, to the bit.
  Observer fresh(model, pendubot_gains());
  ASSERT_TRUE(fresh.reset(Eigen::Vector2d(0.1, 0.2)));
  ASSERT_TRUE(fresh.update(Eigen::Vector2d(0.11, 0.19), kInput, 1e-3).accepted);
  EXPECT_TRUE(observer.update(Eigen::Vector2d(0.11, 0.19), kInput, 1e-3).accepted);
  EXPECT_EQ(observer.position(), fresh.position());
  EXPECT_EQ(observer.velocity(), fresh.velocity());
  EXPECT_THROW(Observer(model, gains(-1.0, 1.0, 0.0, Eigen::Vector2d(1, 1))), InputError);
  EXPECT_THROW(Observer(model, gains(1.0, 1.0, 0.0, Eigen::Vector3d(1, 1, 1))), InputError);
  EXPECT_THROW(Observer(model, pendubot_gains(), -1), InputError);
}

// The exported text reads back bit for bit, certificate included; a certificate name obsgain does not write is
// refused, not read as another certificate.
TEST(ExportedObserver, ReadsBackWhatItWroteAndRefusesAnUnknownCertificate) {
  ExportedObserver e{pendubot(), pendubot_gains(), 1, 1e-3};
  e.observer.certificate = CertificateKind::polytopic;
  e.observer.P = Eigen::Matrix4d::Identity();
  const std::string text = exported_observer_text(e);
  const ExportedObserver back = read_exported_observer(text);
  EXPECT_EQ(back.observer.certificate, CertificateKind::polytopic);
  EXPECT_EQ(back.observer.k2, 138.0 * 138.0);
  EXPECT_EQ(back.observer.P, e.observer.P);
  std::string renamed = text;
  const auto at = renamed.find("polytopic");
  ASSERT_NE(at, std::string::npos);
  renamed.replace(at, 9, "quadratic");
  try {
    read_exported_observer(renamed);
    ADD_FAILURE() << "an unknown certificate was read";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("certificate 'quadratic'"), std::string::npos) << error.what();
  }
}

void expect_no_allocation(const Model& model, const CertifiedObserver& gains) {
  const long at_start = allocations.load();
  Observer observer(model, gains);
  EXPECT_GT(allocations.load(), at_start) << "the counter counts: construction sizes the buffers";
  const int n = model.dof();
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(model.input_matrix.cols(), 0.1);
  Eigen::VectorXd y = Eigen::VectorXd::Constant(n, 0.2);
  observer.reset(y);
  const long before = allocations.load();
  for (int k = 0; k < 200; ++k) {
    y(0) += 1e-4;
    observer.update(y, u, 1e-3);
  }
  EXPECT_EQ(allocations.load() - before, 0) << model.name;
}

TEST(Observer, AllocatesNothingAfterConstruction) {
#ifndef OBSGAIN_COUNT_ALLOCATIONS
  GTEST_SKIP() << "sanitizer build: AddressSanitizer owns malloc, the plain build counts";
#endif
  expect_no_allocation(pendubot(), pendubot_gains());
  const Model arm7 = load_robot(RobotSource{OBSGAIN_EXAMPLES_DIR "/arm7.urdf"});
  expect_no_allocation(arm7, gains(20.0, 400.0, 3.0, Eigen::VectorXd::Constant(7, 1.5)));
}

}  // namespace
}  // namespace obsgain
