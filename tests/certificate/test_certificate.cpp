#include "obsgain/certificate/certificate.hpp"
#include "obsgain/certificate/lyapunov.hpp"
#include "obsgain/model/input_error.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <gtest/gtest.h>

#include <random>

namespace {

constexpr double kPaperL = 54.01;
constexpr double kHonestL = 124.2301394;  // L_paper of the stated model (docs/reproduction.md)

TEST(PaperCertificate, ThetaStarWithBothLipschitzConstants) {
  const double S = obsgain::observer_lyapunov(1.0, 1.0, 2).S_norm;
  EXPECT_NEAR(obsgain::paper_theta_star(S, 1.27, kHonestL), 454.064, 1e-5 * 454.064);
  EXPECT_NEAR(obsgain::paper_theta_star(S, 1.27, kPaperL), 200.005, 1e-5 * 200.005);
  // At θ = 200 the honest L certifies nothing: the paper's claim rests on its L.
  EXPECT_LT(obsgain::paper_rate(S, 200.0, kHonestL), 0.0);
  EXPECT_NEAR(obsgain::paper_rate(S, 200.0, kPaperL), 1.2686, 1e-4);
}

TEST(TightCertificate, PaperGainsAndPaperL) {
  EXPECT_NEAR(obsgain::tight_rate(200.0, 40000.0, kPaperL), 66.0097, 1e-5 * 66.0097);
  EXPECT_NEAR(obsgain::tight_theta_star(1.0, 1.0, 1.27, kPaperL), 81.2964, 1e-5 * 81.2964);
}

// For γ far below L, θ* grows as L (1.46789 L at γ = 2, α = β = 1), until k2 = θ² passes 1e150: there the peak's
// closed form overflowed and the bisection ended on a θ* of 1e77 for an L of 1e101, certified by nothing. Refused.
TEST(TightCertificate, ExtremeLipschitzConstantsScaleOrAreRefused) {
  for (const double L : {1e10, 1e30, 1e60}) {
    const double theta = obsgain::tight_theta_star(1.0, 1.0, 2.0, L);
    EXPECT_NEAR(theta / L, 1.46789, 1e-5) << L;
    EXPECT_GE(obsgain::tight_rate(theta, theta * theta, L), 2.0);
    EXPECT_LT(obsgain::tight_rate(0.99 * theta, 0.99 * 0.99 * theta * theta, L), 2.0);
  }
  try {
    obsgain::tight_theta_star(1.0, 1.0, 2.0, 1e101);
    ADD_FAILURE() << "a theta* was returned for L = 1e101";
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("up to 1e150 certifies gamma = 2 with L = 1e+101"), std::string::npos) << e.what();
  }
}

// Closed-form peak against a dense frequency sweep refined locally (a sweep can only be below the true peak).
TEST(TightCertificate, ClosedFormPeakAgainstFrequencySweep) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const double k1 = std::exp(std::log(0.1) + unit(rng) * std::log(1e4));
    const double k2 = std::exp(std::log(0.01) + unit(rng) * std::log(1e8));
    const double gamma = (unit(rng) - 0.5) * k1;
    const double peak = obsgain::shifted_transfer_peak(k1, k2, gamma);
    if (!std::isfinite(peak)) continue;
    const auto magnitude = [&](double log_w) {
      const std::complex<double> s(-gamma, std::exp(log_w));
      return std::abs((s + k1) / (s * s + k1 * s + k2));
    };
    // Sweep log ω, then refine the best cell by golden section: sharp resonances fall between grid points.
    const int points = 20000;
    const double lo = std::log(1e-4), step = std::log(1e10) / points;
    int best = 0;
    for (int i = 1; i <= points; ++i)
      if (magnitude(lo + i * step) > magnitude(lo + best * step)) best = i;
    double a = lo + (best - 1) * step, b = lo + (best + 1) * step;
    const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
    for (int it = 0; it < 100; ++it) {
      const double c = b - golden * (b - a), d = a + golden * (b - a);
      (magnitude(c) > magnitude(d) ? b : a) = magnitude(c) > magnitude(d) ? d : c;
    }
    const std::complex<double> s0(-gamma, 0.0);
    const double sweep = std::max(magnitude(0.5 * (a + b)), std::abs((s0 + k1) / (s0 * s0 + k1 * s0 + k2)));
    EXPECT_GE(peak, sweep * (1 - 1e-8)) << k1 << " " << k2 << " " << gamma;
    EXPECT_LE(peak, sweep * (1 + 1e-8)) << k1 << " " << k2 << " " << gamma;
  }
}

TEST(TightCertificate, RiccatiCertificateExistsJustBelowTheSupremumOnly) {
  const double k1 = 200.0, k2 = 40000.0;
  const double sup = obsgain::tight_rate(k1, k2, kPaperL);
  const obsgain::RiccatiCertificate below = obsgain::tight_certificate(k1, k2, kPaperL, 0.999 * sup);
  ASSERT_TRUE(below.exists);
  EXPECT_LT(below.lmi_max_eig, 0.0);
  EXPECT_EQ(obsgain::certificate_lmi_max_eig(below.P, k1, k2, kPaperL, 0.999 * sup), below.lmi_max_eig);
  EXPECT_GT(obsgain::symmetric_eigenvalues(below.P)(0), 0.0);
  EXPECT_LE(below.k, below.riccati_k);
  EXPECT_LT(below.riccati_residual, 1e-10);
  const obsgain::RiccatiCertificate above = obsgain::tight_certificate(k1, k2, kPaperL, 1.001 * sup);
  EXPECT_FALSE(above.exists);
  // Nor does the P certified below the supremum work above it.
  EXPECT_GT(obsgain::certificate_lmi_max_eig(below.P, k1, k2, kPaperL, 1.001 * sup), 0.0);
}

// The tight certificate is the best quadratic one, so it never needs a larger θ than the paper's.
// Large gains (a six-joint arm's L ≈ 600 needs θ ≈ 900, k2 ≈ 8e5): the Hamiltonian spans k2² : 1 unless
// balanced, and the LMI check then fails for a certificate that exists.
TEST(TightCertificate, LargeGainsStillCertify) {
  for (const double L : {598.7153109, 5987.153109}) {
    const double gamma = 5.0;
    const double theta = obsgain::tight_theta_star(1.0, 1.0, gamma / 0.99, L);
    const obsgain::RiccatiCertificate c = obsgain::tight_certificate(theta, theta * theta, L, gamma);
    EXPECT_TRUE(c.exists) << "L = " << L;
    EXPECT_LT(c.riccati_residual, 1e-12) << "L = " << L;
    EXPECT_LT(c.lmi_max_eig, 0.0) << "L = " << L;
    EXPECT_GT(c.k, 1.0) << "L = " << L;
  }
}

TEST(TightCertificate, NeverWorseThanThePaper) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    const double alpha = std::exp(std::log(0.05) + unit(rng) * std::log(400.0));
    const double beta = std::exp(std::log(0.05) + unit(rng) * std::log(400.0));
    const double L = std::exp(std::log(0.1) + unit(rng) * std::log(1e4));
    const double gamma = std::exp(std::log(0.01) + unit(rng) * std::log(1e4));
    const double S = obsgain::observer_lyapunov(alpha, beta, 1).S_norm;
    EXPECT_LE(obsgain::tight_theta_star(alpha, beta, gamma, L),
              obsgain::paper_theta_star(S, gamma, L) * (1 + 1e-12))
        << "alpha " << alpha << " beta " << beta << " L " << L << " gamma " << gamma;
  }
}

TEST(PaperCertificate, EnvelopeConstantInOriginalCoordinates) {
  // P = D S D with D = diag(1/θ, 1/θ²): for α = β = 1 and θ = 200, k = sqrt(λmax/λmin) of that P.
  const Eigen::Matrix2d S = obsgain::observer_lyapunov(1.0, 1.0, 1).S2;
  const Eigen::Matrix2d P = obsgain::paper_certificate_matrix(S, 200.0);
  EXPECT_DOUBLE_EQ(P(0, 0), 1.0 / (200.0 * 200.0));
  EXPECT_DOUBLE_EQ(P(1, 1), 1.5 / std::pow(200.0, 4));
  const Eigen::Vector2d lambda = obsgain::symmetric_eigenvalues(P);
  EXPECT_DOUBLE_EQ(obsgain::envelope_constant(P), std::sqrt(lambda(1) / lambda(0)));
}

}  // namespace
