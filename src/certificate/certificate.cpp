#include "obsgain/certificate/certificate.hpp"

#include "obsgain/model/model.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <fmt/format.h>
#include <nlopt.hpp>

#include <cmath>
#include <complex>
#include <limits>

namespace obsgain {

double paper_theta_star(double S_norm, double gamma, double L) { return 2.0 * S_norm * (gamma + L); }

double paper_rate(double S_norm, double theta, double L) { return (theta - 2.0 * S_norm * L) / (2.0 * S_norm); }

Eigen::Matrix2d paper_certificate_matrix(const Eigen::Matrix2d& S2, double theta) {
  const Eigen::Vector2d d(1.0 / theta, 1.0 / (theta * theta));
  return d.asDiagonal() * S2 * d.asDiagonal();
}

double shifted_transfer_peak(double k1, double k2, double gamma) {
  // t(s - γ) = (s + c) / (s² + a s + b)
  const double a = k1 - 2.0 * gamma;
  const double b = gamma * gamma - k1 * gamma + k2;
  const double c = k1 - gamma;
  if (!(a > 0.0) || !(b > 0.0)) return std::numeric_limits<double>::infinity();
  // |t(jω)|² = (x + c²) / (x² + p x + b²) with x = ω²; its stationary point solves x² + 2c² x - (b² - c² p) = 0.
  const double p = a * a - 2.0 * b;
  const auto squared = [&](double x) { return (x + c * c) / (x * x + p * x + b * b); };
  double peak = squared(0.0);
  const double c2 = c * c;
  const double discriminant = c2 * c2 + b * b - c2 * p;
  if (discriminant >= 0.0) {
    // x = -c² + sqrt(c⁴ + q) written without cancellation: q / (c² + sqrt(c⁴ + q)).
    const double q = b * b - c2 * p;
    const double x = q / (c2 + std::sqrt(discriminant));
    if (x > 0.0) peak = std::max(peak, squared(x));
  }
  return std::sqrt(peak);
}

double tight_rate(double k1, double k2, double L) {
  // L = 0 (a single joint: nothing couples the error to the velocity) is the linear observer alone: L times an
  // infinite peak is NaN, not feasible, so the rate is where A2 + γI stops being Hurwitz, as it should be.
  if (!(k1 > 0.0) || !(k2 > 0.0) || !(L >= 0.0) || !std::isfinite(k1) || !std::isfinite(k2) || !std::isfinite(L))
    throw InputError(fmt::format("tight certificate needs finite k1, k2 > 0 and L >= 0 (k1 = {}, k2 = {}, L = {})", k1, k2, L));
  const auto feasible = [&](double gamma) { return L * shifted_transfer_peak(k1, k2, gamma) < 1.0; };
  // The feasible rates form an interval (-∞, γ_tight): a certificate for γ certifies every smaller rate.
  double lo = -1.0;
  while (!feasible(lo)) {
    lo *= 2.0;
    if (lo < -1e300) return -std::numeric_limits<double>::infinity();
  }
  double hi = 0.5 * k1;  // A2 + γI stops being Hurwitz here
  for (int i = 0; i < 200 && hi - lo > 1e-14 * std::max(1.0, std::abs(hi)); ++i) {
    const double mid = 0.5 * (lo + hi);
    (feasible(mid) ? lo : hi) = mid;
  }
  return lo;
}

double tight_theta_star(double alpha, double beta, double gamma, double L) {
  const auto rate = [&](double theta) { return tight_rate(theta * alpha, theta * theta * beta, L); };
  double hi = 1.0;
  while (rate(hi) < gamma) {
    hi *= 2.0;
    // The peak's closed form squares k2: past k1, k2 = 1e150 it overflows, and the bisection ended on a θ* of 1e77
    // that nothing had certified (an L of 1e101, from a friction of 1e100).
    if (hi * alpha > 1e150 || hi * hi * beta > 1e150)
      throw InputError(fmt::format("no gain theta with k1, k2 up to 1e150 certifies gamma = {} with L = {:.6g}", gamma, L));
  }
  double lo = hi / 2.0;
  while (lo > 1e-12 && rate(lo) >= gamma) lo /= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-14 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (rate(mid) >= gamma ? hi : lo) = mid;
  }
  return hi;
}

double certificate_lmi_max_eig(const Eigen::Matrix2d& P, double k1, double k2, double L, double gamma) {
  Eigen::Matrix2d A;
  A << -k1 + gamma, 1.0, -k2, gamma;
  const Eigen::Vector2d E(0.0, 1.0);
  Eigen::Matrix3d lmi;
  lmi.topLeftCorner<2, 2>() = A.transpose() * P + P * A + L * L * E * E.transpose();
  lmi.topRightCorner<2, 1>() = P * E;
  lmi.bottomLeftCorner<1, 2>() = (P * E).transpose();
  lmi(2, 2) = -1.0;
  // A congruence by the diagonal's scales keeps the sign and makes the number comparable to rounding (1e-16).
  Eigen::Vector3d scale;
  for (int i = 0; i < 3; ++i) scale(i) = 1.0 / std::sqrt(std::max(std::abs(lmi(i, i)), 1e-300));
  const Eigen::Matrix3d scaled = scale.asDiagonal() * lmi * scale.asDiagonal();
  return symmetric_eigenvalues(0.5 * (scaled + scaled.transpose()))(2);
}

double envelope_constant(const Eigen::Matrix2d& P) {
  const Eigen::Vector2d lambda = symmetric_eigenvalues(P);
  return std::sqrt(lambda(1) / lambda(0));
}

namespace {

// Reorders a complex Schur form H = Z T Zᴴ so that eigenvalues with negative real part come first
// (adjacent swaps by unitary rotations built from the eigenvector of the 2 x 2 block).
void order_stable_first(Eigen::Matrix4cd& T, Eigen::Matrix4cd& Z) {
  for (int pass = 0; pass < 4; ++pass) {
    for (int k = 0; k + 1 < 4; ++k) {
      if (!(T(k, k).real() >= 0.0 && T(k + 1, k + 1).real() < 0.0)) continue;
      const std::complex<double> t12 = T(k, k + 1);
      const std::complex<double> shift = T(k + 1, k + 1) - T(k, k);
      const double norm = std::sqrt(std::norm(t12) + std::norm(shift));
      const std::complex<double> a = t12 / norm, b = shift / norm;
      Eigen::Matrix2cd Q;
      Q << a, -std::conj(b), b, std::conj(a);
      T.middleRows(k, 2) = Q.adjoint() * T.middleRows(k, 2);
      T.middleCols(k, 2) = T.middleCols(k, 2) * Q;
      Z.middleCols(k, 2) = Z.middleCols(k, 2) * Q;
      T(k + 1, k) = 0.0;
    }
  }
}

}  // namespace

namespace {

// The stabilising solution of Aᵀ P + P A + P R P + Q = 0 from the stable invariant subspace of the
// Hamiltonian [[A, R], [-Q, -Aᵀ]]; false when it has eigenvalues on the imaginary axis.
// Solved in balanced coordinates: with x = T z, T = diag(1, t), P = T⁻¹ P_z T⁻¹ / c solves the equation with
// A_z = T⁻¹ A T, R_z = T⁻¹ R T⁻¹ / c, Q_z = c T Q T. t equalises A's off-diagonal entries (1 and -k2) and
// c the sizes of R_z and Q_z; unbalanced, the Hamiltonian spans k2² : 1 and for θ ~ 10³ the solution
// loses every digit the LMI test needs.
bool stabilising_riccati(const Eigen::Matrix2d& A, const Eigen::Matrix2d& R, const Eigen::Matrix2d& Q,
                         Eigen::Matrix2d& P) {
  const double t = std::sqrt(std::sqrt(std::abs(A(1, 0)) / std::max(std::abs(A(0, 1)), 1e-300)));
  const Eigen::Vector2d T(1.0, t > 0.0 && std::isfinite(t) ? t : 1.0);
  const Eigen::Matrix2d A_z = T.cwiseInverse().asDiagonal() * A * T.asDiagonal();
  Eigen::Matrix2d R_z = T.cwiseInverse().asDiagonal() * R * T.cwiseInverse().asDiagonal();
  Eigen::Matrix2d Q_z = T.asDiagonal() * Q * T.asDiagonal();
  const double c = R_z.norm() > 0.0 && Q_z.norm() > 0.0 ? std::sqrt(R_z.norm() / Q_z.norm()) : 1.0;
  R_z /= c;
  Q_z *= c;

  Eigen::Matrix4d H;
  H << A_z, R_z, -Q_z, -A_z.transpose();
  const ComplexSchurForm schur = complex_schur(H.cast<std::complex<double>>());
  Eigen::Matrix4cd U = schur.T;
  Eigen::Matrix4cd Z = schur.U;
  order_stable_first(U, Z);
  const double scale = H.norm();
  for (int k = 0; k < 4; ++k) {
    const bool stable = U(k, k).real() < -1e-10 * scale;
    const bool anti_stable = U(k, k).real() > 1e-10 * scale;
    if ((k < 2 && !stable) || (k >= 2 && !anti_stable)) return false;
  }
  const Eigen::Matrix2d P_z = (Z.bottomLeftCorner<2, 2>() * Z.topLeftCorner<2, 2>().inverse()).real();
  const Eigen::Matrix2d P_raw = T.cwiseInverse().asDiagonal() * P_z * T.cwiseInverse().asDiagonal() / c;
  P = 0.5 * (P_raw + P_raw.transpose());
  return P.allFinite();
}

// P = C Cᵀ with C = [[e^x0, 0], [x1, e^x2]]: every parameter vector is a positive definite P.
Eigen::Matrix2d from_cholesky(const double* x) {
  Eigen::Matrix2d C;
  C << std::exp(x[0]), 0.0, x[1], std::exp(x[2]);
  return C * C.transpose();
}

struct EnvelopeProblem {
  double k1, k2, L, gamma;
};

// Among the P that satisfy the LMI (with a small strict margin), the one with the smallest condition
// number: the LMI set is convex and κ quasi-convex on it, so a local method from a feasible start suffices.
Eigen::Matrix2d smallest_envelope_matrix(const Eigen::Matrix2d& P0, double k1, double k2, double L, double gamma) {
  const Eigen::LLT<Eigen::Matrix2d> llt(P0);
  const Eigen::Matrix2d C = llt.matrixL();
  std::vector<double> x = {std::log(C(0, 0)), C(1, 0), std::log(C(1, 1))};
  EnvelopeProblem problem{k1, k2, L, gamma};
  nlopt::opt opt(nlopt::LN_COBYLA, 3);
  opt.set_min_objective(
      [](unsigned, const double* x, double*, void*) { return std::log(envelope_constant(from_cholesky(x))); },
      nullptr);
  opt.add_inequality_constraint(
      [](unsigned, const double* x, double*, void* data) {
        const auto* p = static_cast<const EnvelopeProblem*>(data);
        return certificate_lmi_max_eig(from_cholesky(x), p->k1, p->k2, p->L, p->gamma) + 1e-7;
      },
      &problem, 0.0);
  opt.set_xtol_rel(1e-10);
  opt.set_maxeval(3000);
  const double start_k = envelope_constant(P0);
  double value = 0.0;
  try {
    opt.optimize(x, value);
  } catch (const std::exception&) {
    return P0;  // COBYLA gave up: the Riccati solution is still a valid certificate
  }
  const Eigen::Matrix2d P = from_cholesky(x.data());
  const bool better = certificate_lmi_max_eig(P, k1, k2, L, gamma) < 0.0 && envelope_constant(P) < start_k;
  return better ? P : P0;
}

}  // namespace

RiccatiCertificate tight_certificate(double k1, double k2, double L, double gamma) {
  RiccatiCertificate cert;
  cert.gamma = gamma;
  const double peak = shifted_transfer_peak(k1, k2, gamma);
  if (!(L * peak < 1.0)) return cert;  // no quadratic certificate exists at this rate
  // Inflate L halfway to where the frequency condition would fail (1 / peak), so that the LMI at L is strict; written
  // without dividing by L, which may be 0 (a single joint).
  const double L_inflated = 0.5 * (L + 1.0 / peak);

  Eigen::Matrix2d A;
  A << -k1 + gamma, 1.0, -k2, gamma;
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();
  R(1, 1) = 1.0;
  Eigen::Matrix2d Q = L_inflated * L_inflated * R;
  Eigen::Matrix2d P;
  if (!stabilising_riccati(A, R, Q, P)) return cert;
  // L' > L makes the LMI strict only along E; a term ε e1 e1ᵀ, small against the e1 diagonal of
  // ÃᵀP + PÃ, makes it strict in every direction.
  Q(0, 0) += 1e-6 * std::abs(2.0 * A(0, 0) * P(0, 0));
  if (!stabilising_riccati(A, R, Q, P)) return cert;
  cert.P = P;
  // Relative to the size of the terms (ÃᵀP is ~1e11 near the supremum while Q is ~1e3).
  const Eigen::Matrix2d AtP = A.transpose() * P;
  cert.riccati_residual = (AtP + AtP.transpose() + P * R * P + Q).norm() /
                          (2.0 * AtP.norm() + (P * R * P).norm() + Q.norm());
  const Eigen::Vector2d lambda = symmetric_eigenvalues(P);
  if (!(lambda(0) > 0.0)) return cert;
  cert.riccati_k = envelope_constant(P);
  cert.P = smallest_envelope_matrix(P, k1, k2, L, gamma);
  cert.lmi_max_eig = certificate_lmi_max_eig(cert.P, k1, k2, L, gamma);
  cert.k = envelope_constant(cert.P);
  cert.exists = cert.lmi_max_eig < 0.0;
  return cert;
}

}  // namespace obsgain
