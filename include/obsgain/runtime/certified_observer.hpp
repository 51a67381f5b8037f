// One value type for an observer and what is certified about it: the gains, the shape, the rate and envelope,
// the Lyapunov matrix, the Lipschitz constant and the velocity box it rests on, and which certificate gave them.
// Every stage carries it: the certificates produce it, the design chooses one, the deployment certifies it
// sampled, the exports write it, the simulations check it, and the real-time Observer runs it.
#pragma once

#include <Eigen/Dense>

#include <optional>
#include <string>

namespace obsgain {

// paper: Theorem 1's Lyapunov function; tight: the best quadratic certificate for ||φ|| <= L ||e_v|| (bounded-real
// lemma), per joint; scaled: the same in the coordinates T e, T diagonal, for ||T φ|| <= L_T ||T e_v||; polytopic:
// one full P over a proven polytope of the perturbation (docs/theory.md).
enum class CertificateKind { paper, tight, scaled, polytopic };

const char* to_string(CertificateKind kind);
// The kind to_string names ("paper", "tight", "scaled", "polytopic"); none for any other name.
std::optional<CertificateKind> certificate_kind(const std::string& name);

struct CertifiedObserver {
  CertificateKind certificate = CertificateKind::tight;
  double alpha = 1.0, beta = 1.0, theta = 0.0;  // shape and gain
  double k1 = 0.0, k2 = 0.0;                    // injection gains θα (positions) and θ²β (velocities)
  double gamma = 0.0;  // the certified rate: ||e(t)|| <= k ||e(0)|| e^{-γt} and V(e(t)) <= V(e(0)) e^{-2γt}
  double k = 0.0;      // the envelope constant sqrt(λmax(P) / λmin(P))
  // V(e) = eᵀ P e with e = (q̂ - q, v̂ - v), positions first: 2n x 2n (P₂ ⊗ I_n for the per-joint certificates).
  Eigen::MatrixXd P;
  double L = 0.0;                   // the Lipschitz constant of the perturbation (||φ|| <= L ||e_v||; scaled: L_T)
  Eigen::VectorXd velocity_bounds;  // V: the assumption |v_i| <= V_i, and the observer's saturation σ_V
  bool certified = false;           // a positive rate with a valid P (on the bounds the design used)

  int dof() const { return static_cast<int>(velocity_bounds.size()); }
};

// P₂ ⊗ I_n in the (positions, velocities) ordering: [[p11 I, p12 I], [p21 I, p22 I]].
Eigen::MatrixXd per_joint_matrix(const Eigen::Matrix2d& P2, int dof);
// P₂ ⊗ TᵀT: the per-joint certificate in the coordinates (T e_q, T e_v), in original coordinates.
Eigen::MatrixXd scaled_per_joint_matrix(const Eigen::Matrix2d& P2, const Eigen::MatrixXd& scaling);

}  // namespace obsgain
