// The dynamics of any Model, computed from its structure: as templates on the scalar (what the certified bounds
// evaluate on intervals and Taylor forms), and in double for design, simulation and the real-time observer.
// The double functions write into caller-owned storage and allocate nothing (the observer's update relies on it).
#pragma once

#include "obsgain/model/chain_dynamics.hpp"
#include "obsgain/model/model.hpp"
#include "obsgain/numerics/dual.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <vector>

namespace obsgain {

// ---- any scalar: q holds every joint; matrices row-major, M[i * n + j], N[(i * n + j) * n + k], g[i] ----

template <class S>
void mass_matrix_of(const Model& model, const S* q, S* M) {
  if (const auto* p = std::get_if<Planar2RParameters>(&model.structure)) {
    using std::cos;
    const auto m = planar_2r_mass_matrix(*p, S(cos(q[1])));
    for (int i = 0; i < 4; ++i) M[i] = m(i / 2, i % 2);
    return;
  }
  const SerialChain& chain = std::get<SerialChain>(model.structure);
  ChainKinematics<S> k;
  chain_kinematics(chain, q, k);
  chain_mass_matrix(chain, k, M);
}

template <class S>
void coriolis_tensors_of(const Model& model, const S* q, S* N) {
  if (const auto* p = std::get_if<Planar2RParameters>(&model.structure)) {
    using std::sin;
    const auto tensors = planar_2r_coriolis_tensors(*p, S(sin(q[1])));
    for (int i = 0; i < 8; ++i) N[i] = tensors[i / 4]((i / 2) % 2, i % 2);
    return;
  }
  const SerialChain& chain = std::get<SerialChain>(model.structure);
  ChainKinematics<S> k;
  chain_kinematics(chain, q, k);
  chain_coriolis_tensors(chain, k, N);
}

// M(q) of a serial chain on forward-mode duals along `joints` (at most kMaxDirections): row-major values with their
// partial derivatives, derivative d along joints[d].
template <class S>
std::vector<Dual<S>> mass_matrix_with_derivatives(const Model& model, const std::vector<int>& joints, const S* q) {
  const int n = model.dof(), directions = static_cast<int>(joints.size());
  std::vector<Dual<S>> qd(static_cast<std::size_t>(n)), M(static_cast<std::size_t>(n * n));
  for (int i = 0; i < n; ++i) qd[i] = Dual<S>(q[i]);
  for (int d = 0; d < directions; ++d) qd[joints[d]] = Dual<S>::variable(q[joints[d]], d, directions);
  mass_matrix_of(model, qd.data(), M.data());
  return M;
}

// N_i[j][k] = ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j - ∂M_jk/∂q_i), the Christoffel symbols of the first kind, from M's
// derivatives along `joints` (every joint M depends on: the other derivatives vanish). On Taylor forms the three
// derivatives share their noise symbols, so their first- and second-order parts combine exactly and only third-order
// remainders add: no enclosure is subtracted from another (docs/theory.md, "Taylor forms").
// `emit(i, j, k, N_i[j][k])` for every k >= j (N_i[k][j] is the same): each symbol is formed once, where the caller
// takes it, and no tensor of forms (kilobytes each) is allocated on the way.
template <class S, class Emit>
void for_each_christoffel_symbol(int n, const std::vector<int>& joints, const std::vector<Dual<S>>& M, Emit&& emit) {
  std::vector<int> direction(static_cast<std::size_t>(n), -1);
  for (std::size_t d = 0; d < joints.size(); ++d) direction[joints[d]] = static_cast<int>(d);
  const S zero(0.0);
  const auto dM = [&](int i, int j, int k) -> const S& {
    return direction[k] < 0 ? zero : M[i * n + j].derivative[direction[k]];
  };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = j; k < n; ++k) emit(i, j, k, S(0.5 * (dM(i, j, k) + dM(i, k, j) - dM(j, k, i))));
}
template <class S>
void christoffel_tensors_from(int n, const std::vector<int>& joints, const std::vector<Dual<S>>& M, S* N) {
  for_each_christoffel_symbol(n, joints, M, [&](int i, int j, int k, const S& symbol) {
    N[(i * n + j) * n + k] = symbol;
    N[(i * n + k) * n + j] = symbol;
  });
}

template <class S>
void christoffel_tensors_of(const Model& model, const std::vector<int>& joints, const S* q, S* N) {
  if (std::holds_alternative<Planar2RParameters>(model.structure)) return coriolis_tensors_of(model, q, N);
  christoffel_tensors_from(model.dof(), joints, mass_matrix_with_derivatives(model, joints, q), N);
}

template <class S>
void gravity_of(const Model& model, const S* q, S* g) {
  if (const auto* p = std::get_if<Planar2RParameters>(&model.structure)) {
    using std::cos;
    const auto v = planar_2r_gravity(*p, S(cos(q[0])), S(cos(q[0] + q[1])));
    g[0] = v(0);
    g[1] = v(1);
    return;
  }
  const SerialChain& chain = std::get<SerialChain>(model.structure);
  ChainKinematics<S> k;
  chain_kinematics(chain, q, k);
  chain_gravity(chain, k, g);
}

// ---- double ----

// The dynamics at one configuration, evaluated repeatedly: the real-time observer needs M once and A + g at
// four velocities per instant. What depends on q alone is computed once, in set(): a chain's kinematics (every
// joint's sine, cosine and rotation), the planar family's M, N_i and g.
class ConfigurationDynamics {
 public:
  explicit ConfigurationDynamics(const Model& model)
      : model_(model), planar_parameters_(std::get_if<Planar2RParameters>(&model.structure)),
        chain_(std::get_if<SerialChain>(&model.structure)) {}
  void set(const Eigen::Ref<const Eigen::VectorXd>& q) noexcept;
  void mass_matrix(Eigen::Ref<Eigen::MatrixXd> M) const noexcept;
  void gravity(Eigen::Ref<Eigen::VectorXd> g) const noexcept;
  // A(q, v) = C(q, v) v.
  void coriolis(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> A) const noexcept;
  // A(q, v) + g(q).
  void bias_forces(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> out) const noexcept;
  // out_i = xᵀ N_i(q) y.
  void coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y,
                         Eigen::Ref<Eigen::VectorXd> out) const noexcept;

 private:
  struct Planar {
    Eigen::Matrix2d M;
    std::array<Eigen::Matrix2d, 2> N;
    Eigen::Vector2d g;
  };
  const Model& model_;
  const Planar2RParameters* planar_parameters_;  // one of the two is set
  const SerialChain* chain_;
  Planar planar_{};
  ChainKinematics<double> kinematics_{};
};

void mass_matrix(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M);
// A(q, v) = C(q, v) v.
void coriolis(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
              Eigen::Ref<Eigen::VectorXd> A);
// out_i = xᵀ N_i(q) y, the symmetric bilinear form of A, which the simulation's error equation needs at every step.
void coriolis_bilinear(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                       const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y,
                       Eigen::Ref<Eigen::VectorXd> out);
void gravity(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g);
// N_i(q) (symmetric) with A_i(q, v) = vᵀ N_i(q) v.
void coriolis_tensors(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, std::vector<Eigen::MatrixXd>& N);

// ∂A/∂v at (q, w) from the Coriolis tensors: J = 2 [wᵀN_1; …; wᵀN_n]. Linear in w (docs/theory.md, "The constants").
Eigen::MatrixXd coriolis_jacobian(const std::vector<Eigen::MatrixXd>& N, const Eigen::Ref<const Eigen::VectorXd>& w);

// Joints whose positions M and C depend on; the bound searches run over these only. Rotating or translating a
// whole serial chain about its first joint moves no body relative to another: its M and C do not depend on q1. Nor on
// the last joint where the last body is symmetric about its axis, nor on a prismatic joint that slides along the axis
// of every revolute joint before it (docs/theory.md, "The constants").
std::vector<int> configuration_joints(const Model& model);

// A symmetry of a serial chain: g q negates the positions of `negated`, then turns those of `turned` by π, and
// M(g q) = P M'(q) P, P = diag(±1) with -1 at `negated` (the velocities map as the positions), with P F P = F. It
// maps the first joint's frame by a diagonal of ±1 (a half-turn, a mirror or -I; `frames[j]` is what joint j's frame
// is mapped by, before its rotation) and everything beyond it onto itself: the shoulder's half-turn, a half-turn of a
// joint beyond which the chain is symmetric, the mirror image of the whole arm. M' is the model's own where the
// placements carry those maps exactly; where they do only up to negligible entries (a URDF's rounded π/2), it is the
// model with those entries' signs flipped, and every box's bound of the one is, bit for bit, one of the other. The
// certified constants (sup ||M⁻¹||, ||J||, ||Φ||) take the same values at q and g q, so the searches may cover part
// of the domain (bounds/joint_search.hpp, folded; docs/theory.md, "Chain symmetries"). Found from exact zeros and
// negligible entries only: a chain that is merely close to symmetric has none.
struct ChainSymmetry {
  std::vector<int> negated;
  std::vector<int> turned;
  std::vector<Eigen::Vector3d> frames;

  bool negates(int joint) const { return std::find(negated.begin(), negated.end(), joint) != negated.end(); }
  bool turns(int joint) const { return std::find(turned.begin(), turned.end(), joint) != turned.end(); }
  bool moves(int joint) const { return negates(joint) || turns(joint); }
};
// Per searched joint in order, the symmetry that turns it and the one that negates it, each moving no searched joint
// before it and the fewest after it.
std::vector<ChainSymmetry> chain_symmetries(const Model& model);
// S X S = X for S = diag(±1) with -1 at `flipped` (X square): no entry couples a flipped joint with an unflipped one.
bool commutes_with_flips(const Eigen::MatrixXd& X, const std::vector<int>& flipped);


// Scratch for the functions below, sized once: loops that reuse it allocate nothing.
struct DynamicsWorkspace {
  Eigen::MatrixXd M;
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::VectorXd A, g, rhs;
  explicit DynamicsWorkspace(int n) : M(n, n), llt(n), A(n), g(n), rhs(n) {}
};

// The plant's acceleration where M(q) is already factorised (`llt`, at the configuration `at` holds):
// q'' = M(q)⁻¹ (τ - A(q, v) - F v - g(q)).
void plant_acceleration(const Model& model, const ConfigurationDynamics& at, const Eigen::LLT<Eigen::MatrixXd>& llt,
                        const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& tau,
                        Eigen::Ref<Eigen::VectorXd> qdd, DynamicsWorkspace& work);

// q'' = M(q)⁻¹ (τ - A(q, v) - F v - g(q)) for the generalised force τ = H u.
void forward_dynamics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& tau,
                      Eigen::Ref<Eigen::VectorXd> qdd, DynamicsWorkspace& work);

// τ = M(q) a + A(q, v) + F v + g(q): the generalised force that gives acceleration a (computed torque).
void inverse_dynamics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& a,
                      Eigen::Ref<Eigen::VectorXd> tau, DynamicsWorkspace& work);

}  // namespace obsgain
