// The observer as it runs on the robot: called once per sample with the encoder position and the input that
// was applied since the previous sample. Between two samples it integrates the observer's own equations
//   q̂' = v̂ - k1 (q̂ - y(t)),   v̂' = M(y_c)⁻¹ (H u - A(y_c, σ(v̂)) - F v̂ - g(y_c)) - k2 (q̂ - y(t)),
// with y(t) the straight line between the last two measurements and y_c the same clamped into the joint
// limits, by classical Runge–Kutta sub-steps short enough for the gains (observer_substeps). This is exactly
// the implementation the deployment certificate covers (deployment.hpp, docs/theory.md).
//
// Real-time use: every buffer is sized at construction; update() and reset() allocate nothing, throw nothing,
// and take a bounded time (at most max_substeps sub-steps). Invalid input (an update before the first reset(),
// a size mismatch, NaN, dt <= 0 or a dt needing more than max_substeps sub-steps) is refused: the state is left
// unchanged and `accepted` is false. So is a sample whose integration leaves double's range (finite inputs such as a
// u of 1e308): a state of NaNs would answer every later sample with NaNs.
#pragma once

#include "obsgain/model/dynamics.hpp"
#include "obsgain/runtime/certified_observer.hpp"

#include <Eigen/Dense>

#include <array>

namespace obsgain {

// Sub-steps per sample of length dt: h (k1 + sqrt(k2) + L) <= 1/2. The error dynamics' eigenvalues are at most
// about k1 + sqrt(k2) in modulus (θ for α = β = 1, where this sum is 2θ) plus what the model's Lipschitz part
// adds, so h |λ| <= 1/2: deep inside RK4's stability region, local relative error below (1/2)^5 / 120 = 3e-4,
// and the tests measure the sampled observer's flow to 1e-5 at 250 Hz.
int observer_substeps(double k1, double k2, double L, double dt);

class Observer {
 public:
  static constexpr int max_substeps = 100000;

  struct Estimate {
    const Eigen::VectorXd& position;  // q̂
    const Eigen::VectorXd& velocity;  // v̂
    bool accepted;
  };

  // Runs the gains k1, k2 with the saturation at the velocity box of `observer`; its L sets the sub-step length.
  // `substeps`: RK4 sub-steps per sample, 0 for observer_substeps (a fixed count caps the cost). Keeps a
  // reference to the model: it must outlive the observer.
  Observer(const Model& model, const CertifiedObserver& observer, int substeps = 0);

  // Starts from q̂ = the measurement (or any estimate), v̂ = v_estimate; the measurement is the first sample.
  bool reset(const Eigen::Ref<const Eigen::VectorXd>& q_measured, const Eigen::Ref<const Eigen::VectorXd>& q_estimate,
             const Eigen::Ref<const Eigen::VectorXd>& v_estimate) noexcept;
  bool reset(const Eigen::Ref<const Eigen::VectorXd>& q_measured) noexcept;

  // One sample: q_measured at the current time, u the input held since the previous sample, dt the time since
  // it. Returns the estimate at the current time.
  Estimate update(const Eigen::Ref<const Eigen::VectorXd>& q_measured, const Eigen::Ref<const Eigen::VectorXd>& u,
                  double dt) noexcept;

  const Eigen::VectorXd& position() const { return q_hat_; }
  const Eigen::VectorXd& velocity() const { return v_hat_; }
  int substeps(double dt) const { return substeps_ > 0 ? substeps_ : observer_substeps(gains_.k1, gains_.k2, gains_.L, dt); }
  const CertifiedObserver& gains() const { return gains_; }

 private:
  // The stage arithmetic works on fixed-capacity arrays with plain loops: at the sizes of robot arms a general
  // vector expression's dispatch costs more than its arithmetic.
  using Joints = std::array<double, kMaxChainJoints>;
  using Joints2 = std::array<double, kMaxChainJoints * kMaxChainJoints>;

  // What stays fixed at one instant of a sample interval: the interpolated measurement and the model there.
  struct Instant {
    Joints y{}, y_model{};  // measurement, and the same clamped into the joint limits
    ConfigurationDynamics dynamics;  // at y_model
    Eigen::MatrixXd M;
    Joints2 inverse{};  // M(y_model)⁻¹, row-major: computed once per instant, used by its stages

    explicit Instant(const Model& model) : dynamics(model), M(model.dof(), model.dof()) {}
  };

  // N: the joint count when it is compiled in (the loops then unroll), 0 for any.
  template <int N>
  void integrate(double dt, int steps) noexcept;
  template <int N>
  void freeze(double fraction, Instant& instant) noexcept;
  template <int N>
  void invert(Instant& instant) noexcept;
  template <int N>
  void derivative(const Instant& instant, const Joints& q, const Joints& v, Joints& dq, Joints& dv) noexcept;
  template <int N>
  void step(Instant& start, Instant& end, double h) noexcept;  // one RK4 sub-step from start to end

  const Model& model_;
  CertifiedObserver gains_;
  int substeps_;
  int n_;
  Joints lower_{}, upper_{};  // joint limits (±∞ for continuous joints)
  Eigen::VectorXd q_hat_, v_hat_;
  Joints q_before_{}, v_before_{};  // the state before an update, restored when it is refused
  Joints y_previous_{}, y_current_{}, Hu_{};
  Instant start_, middle_, end_;
  // Which of start_ (0) and end_ (1) holds the model at the last measurement (-1: none since reset): the next
  // update starts there: M(y) and its factorisation are reused, the input enters each stage afresh.
  int last_instant_ = -1;
  bool started_ = false;  // reset() has given the first sample
  Eigen::VectorXd saturated_, bias_;
  std::array<Joints, 4> kq_{}, kv_{};
  Joints q_stage_{}, v_stage_{};
};

}  // namespace obsgain
