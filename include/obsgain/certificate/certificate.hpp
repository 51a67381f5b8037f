// Two ways to certify an exponential rate for the error e = (ê_q, ê_v) of the saturated observer, given
// the gains k1 = θα, k2 = θ²β and a Lipschitz constant L with ||φ|| <= L ||e_v||:
//  * paper: the Lyapunov function of the paper's proof, θ* = 2||S||(γ + L);
//  * tight: the best quadratic certificate for the same uncertainty description (bounded-real lemma,
//    docs/theory.md): the largest γ with A2 + γI Hurwitz and ||t(· - γ)||∞ < 1/L.
// Both are per joint: the error dynamics are (2 x 2 block) ⊗ I_n, and so are the certificates.
#pragma once

#include <Eigen/Dense>

namespace obsgain {

// ---- paper certificate (Theorem 1) ----
double paper_theta_star(double S_norm, double gamma, double L);  // 2||S||(γ + L)
double paper_rate(double S_norm, double theta, double L);         // (θ - 2||S||L) / (2||S||)
// V = eᵀ P e in original error coordinates: P = D S2 D, D = diag(1/θ, 1/θ²) (per joint).
Eigen::Matrix2d paper_certificate_matrix(const Eigen::Matrix2d& S2, double theta);

// ---- tight certificate (bounded-real lemma) ----
// sup_ω |t(jω - γ)| for t(s) = (s + k1) / (s² + k1 s + k2), in closed form; +∞ when A2 + γI is not Hurwitz.
double shifted_transfer_peak(double k1, double k2, double gamma);
// The largest certifiable rate (a supremum, found by bisection to ~1e-13 relative). May be negative.
double tight_rate(double k1, double k2, double L);
// The smallest θ with tight_rate(θα, θ²β, L) >= γ (bisection in θ).
double tight_theta_star(double alpha, double beta, double gamma, double L);

struct RiccatiCertificate {
  bool exists = false;           // a stabilising solution was found and P > 0
  Eigen::Matrix2d P = Eigen::Matrix2d::Zero();
  double gamma = 0.0;            // the rate this P certifies
  double riccati_residual = 0.0;  // residual of the Riccati solve, relative to the size of its terms
  double lmi_max_eig = 0.0;      // largest eigenvalue of the LMI at the true L; <= 0 certifies
  double k = 0.0;                // envelope constant sqrt(λmax(P) / λmin(P)) of the returned P
  double riccati_k = 0.0;        // the same for the Riccati solution, before minimising k over the LMI set
};

// P from the stabilising solution of Ãᵀ P + P Ã + P E Eᵀ P + L'² E Eᵀ + ε I = 0 (Ã = A2 + γI, E = (0, 1)ᵀ),
// computed from the ordered (complex) Schur form of the Hamiltonian. L' > L and ε > 0 make the LMI strict.
// From there, the admissible P with the smallest envelope constant k is returned (NLopt COBYLA).
RiccatiCertificate tight_certificate(double k1, double k2, double L, double gamma);

// The 3 x 3 LMI [[ÃᵀP + PÃ + L² E Eᵀ, P E], [Eᵀ P, -1]]: its largest eigenvalue (<= 0 iff P certifies γ).
double certificate_lmi_max_eig(const Eigen::Matrix2d& P, double k1, double k2, double L, double gamma);

// sqrt(λmax(P) / λmin(P)): ||e(t)|| <= k ||e(0)|| e^{-γt} follows from V(e) = eᵀPe decaying at 2γ.
double envelope_constant(const Eigen::Matrix2d& P);

}  // namespace obsgain
