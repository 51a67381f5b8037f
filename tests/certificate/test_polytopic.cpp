#include "obsgain/certificate/certificate.hpp"
#include "obsgain/certificate/polytopic.hpp"
#include "obsgain/model/model.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

// A one-joint polytope: Φ = centre + δ, |δ| <= radius, in one cell with one vertex.
obsgain::PerturbationPolytope scalar_polytope(double centre, double radius) {
  obsgain::PerturbationPolytope polytope;
  polytope.dof = 1;
  polytope.grid = 1;
  obsgain::PolytopeCell cell;
  cell.constant = Eigen::MatrixXd::Constant(1, 1, centre);
  cell.vertices = {cell.constant};
  cell.radius = Eigen::MatrixXd::Constant(1, 1, radius);
  cell.proven = true;
  polytope.cells = {cell};
  return polytope;
}

// Φ = 0 exactly: the error dynamics are linear, s² + θ s + θ² for α = β = 1, and the best quadratic rate is the
// spectral abscissa θ / 2 (a supremum).
TEST(PolytopicCertificate, LinearErrorDynamicsReachTheSpectralAbscissa) {
  const double theta = 40.0;
  const double rate = obsgain::polytopic_rate(scalar_polytope(0.0, 0.0), theta, theta * theta);
  EXPECT_LT(rate, theta / 2);
  EXPECT_GT(rate, 0.99 * theta / 2);
}

// A polytope that is not proven holds P to nothing: no rate and no θ*, not the solver's answer to an empty problem
// (which found a P at every γ up to 512 k1, and was plotted as the polytopic curve above two joints).
TEST(PolytopicCertificate, AnUnprovenPolytopeGivesNoEstimate) {
  const double theta = 40.0;
  obsgain::PerturbationPolytope unproven = scalar_polytope(0.0, 0.0);
  unproven.unproven = "M is not proven invertible over a cell";
  EXPECT_TRUE(std::isinf(obsgain::polytopic_slack(unproven, theta, theta * theta, 1.0)));
  EXPECT_EQ(obsgain::polytopic_rate(unproven, theta, theta * theta), 0.0);
  EXPECT_TRUE(std::isinf(obsgain::polytopic_theta_star(unproven, 1.0, 1.0, 5.0)));
  unproven.unproven.clear();
  unproven.cells.clear();
  EXPECT_EQ(obsgain::polytopic_rate(unproven, theta, theta * theta), 0.0);
}

// One scalar uncertainty |Φ| <= L: the S-procedure is lossless, so the SDP's rate is the bounded-real lemma's,
// computed independently in closed form (certificate.hpp).
TEST(PolytopicCertificate, ScalarUncertaintyEqualsTheBoundedRealLemma) {
  for (const double theta : {65.67, 100.0, 150.0}) {
    const double L = 43.3474784;
    const double sdp = obsgain::polytopic_rate(scalar_polytope(0.0, L), theta, theta * theta);
    const double closed_form = obsgain::tight_rate(theta, theta * theta, L);
    EXPECT_NEAR(sdp, closed_form, 2e-3 * closed_form) << "theta = " << theta;
  }
}

// Certify, then check: the proof accepts the solver's P and rejects it where it cannot hold.
TEST(PolytopicCertificate, IntervalCheckAcceptsTheCertificateAndRejectsPerturbations) {
  const obsgain::PerturbationPolytope polytope = scalar_polytope(-5.0, 20.0);
  const double k1 = 50.0, k2 = 2500.0, gamma = 10.0;
  const obsgain::PolytopicCertificate cert = obsgain::polytopic_certificate(polytope, k1, k2, gamma);
  ASSERT_TRUE(cert.exists) << cert.status;
  EXPECT_TRUE(obsgain::polytopic_check(polytope, k1, k2, gamma, cert.P, cert.multipliers));
  // The same P at a rate no quadratic certificate reaches for this uncertainty.
  const double ceiling = obsgain::polytopic_rate(polytope, k1, k2);
  EXPECT_FALSE(obsgain::polytopic_check(polytope, k1, k2, 1.05 * ceiling, cert.P, cert.multipliers));
  // The coupling between position and velocity errors flipped: V is still positive, the LMI fails.
  Eigen::MatrixXd flipped = cert.P;
  flipped(0, 1) = flipped(1, 0) = -cert.P(0, 1);
  EXPECT_FALSE(obsgain::polytopic_check(polytope, k1, k2, gamma, flipped, cert.multipliers));
  // A wider polytope than the one certified.
  EXPECT_FALSE(obsgain::polytopic_check(scalar_polytope(-5.0, 60.0), k1, k2, gamma, cert.P, cert.multipliers));
  // k is the envelope constant of the P returned, from proven eigenvalue bounds.
  const double k = std::sqrt(obsgain::largest_eigenvalue_upper(cert.P) / obsgain::smallest_eigenvalue_lower(cert.P));
  EXPECT_NEAR(cert.k, k, 1e-9 * k);
}

// The targets on the Pendubot (docs/theory.md, "The polytopic certificate"): at the tight certificate's
// design gain θ = 65.67 the norm bound proves 1.28 1/s; over the proven polytope one full P proves 15.
TEST(PolytopicCertificate, PendubotProvesFifteenAtTheTightDesignGain) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::PerturbationPolytope polytope = obsgain::perturbation_polytope(model, model.velocity_bounds);
  const double theta = 65.67;
  const obsgain::PolytopicCertificate cert = obsgain::polytopic_certificate(polytope, theta, theta * theta, 15.0);
  ASSERT_TRUE(cert.exists) << cert.status;
  // A full P: it couples the two joints' errors, which P₂ ⊗ I cannot do.
  EXPECT_GT(std::abs(cert.P(0, 1)) + std::abs(cert.P(2, 3)) + std::abs(cert.P(0, 3)),
            1e-3 * std::sqrt(cert.P(0, 0) * cert.P(3, 3)));
  // The worst frozen Φ caps any quadratic certificate at 24.4: past it the check must fail.
  EXPECT_FALSE(obsgain::polytopic_check(polytope, theta, theta * theta, 24.5, cert.P, cert.multipliers));
}

// The floor objective's own measure, sqrt(λmax(Kᵀ P K) λmax((P⁻¹)_vv)) / γ with K = [[k1, 0], [k2, g]]: scale-free.
double floor_measure(const Eigen::MatrixXd& P, double k1, double k2, double g, double gamma) {
  Eigen::Matrix2d K;
  K << k1, 0.0, k2, g;
  const double weight = obsgain::symmetric_eigenvalues(K.transpose() * P * K).maxCoeff();
  return std::sqrt(weight * P.inverse()(1, 1)) / gamma;
}

// One joint, |Φ| <= L: the P chosen for the floor is proven, at a rate inside the range asked, and its floor is no
// larger than that of the P chosen for k at the same rate (the two SDPs share the LMIs and differ in the objective).
// Measured: γ 29.9, floor measures 648.5 and 663.9, k 159.7 and 154.6 (one joint leaves P little freedom).
TEST(PolytopicCertificate, TheFloorObjectiveChoosesAProvenPWithTheSmallerFloor) {
  const double theta = 135.86, k1 = theta, k2 = theta * theta, g = 2254.19;
  const obsgain::PerturbationPolytope polytope = scalar_polytope(0.0, 43.3474784);
  const obsgain::PolytopicCertificate floor = obsgain::polytopic_floor_certificate(polytope, k1, k2, 10.0, 30.0, g);
  ASSERT_TRUE(floor.exists) << floor.status;
  EXPECT_GE(floor.gamma, 10.0);
  EXPECT_LE(floor.gamma, 30.0);
  const obsgain::PolytopicCertificate condition = obsgain::polytopic_certificate(polytope, k1, k2, floor.gamma);
  ASSERT_TRUE(condition.exists) << condition.status;
  EXPECT_LE(floor_measure(floor.P, k1, k2, g, floor.gamma), floor_measure(condition.P, k1, k2, g, floor.gamma)) << floor.gamma;
  EXPECT_LE(condition.k, floor.k * (1.0 + 1e-6));  // and the other way round for k
}

TEST(IntervalCholesky, ProvesDefinitenessOfEveryMatrixInside) {
  obsgain::IntervalMatrix X(2, 2);
  X << obsgain::Interval(1.0), obsgain::Interval(0.9, 0.99), obsgain::Interval(0.9, 0.99), obsgain::Interval(1.0);
  EXPECT_TRUE(obsgain::positive_definite_proven(X));
  X(1, 0) = X(0, 1) = obsgain::Interval(0.9, 1.0);  // contains [[1, 1], [1, 1]], singular
  EXPECT_FALSE(obsgain::positive_definite_proven(X));
  // Scales far apart (the observer's P spans θ²): the diagonal scaling keeps the check exact.
  X << obsgain::Interval(1e8), obsgain::Interval(9.9e3), obsgain::Interval(9.9e3), obsgain::Interval(1.0);
  EXPECT_TRUE(obsgain::positive_definite_proven(X));
  X(1, 0) = X(0, 1) = obsgain::Interval(1.0001e4);
  EXPECT_FALSE(obsgain::positive_definite_proven(X));
}

// Every symmetric member of [[2 ± 0.1, 1 ± 0.1], [1 ± 0.1, 2]] has λmax <= (4.1 + sqrt(0.01 + 4 (1.1)²)) / 2 = 3.1511,
// attained at the corner; Weyl's bound is 3 + ||radius||_F = 3 + sqrt(0.03) = 3.1732.
TEST(IntervalEigenvalue, LargestEigenvalueBoundsEveryMatrixInside) {
  obsgain::IntervalMatrix X(2, 2);
  X << obsgain::Interval(1.9, 2.1), obsgain::Interval(0.9, 1.1), obsgain::Interval(0.9, 1.1), obsgain::Interval(2.0);
  const double bound = obsgain::largest_eigenvalue_upper_over(X);
  EXPECT_GE(bound, (4.1 + std::sqrt(0.01 + 4 * 1.21)) / 2);
  EXPECT_NEAR(bound, 3.0 + std::sqrt(0.03), 1e-10);
  // Terms of 1e8 that cancel to about 1 (the measurement gain of a correlated P): the rounding is counted, so the
  // bound stays above the exact value 1 by the rounding of the terms only.
  X << obsgain::Interval(1e8) - obsgain::Interval(1e8 - 1.0), obsgain::Interval(0.0), obsgain::Interval(0.0),
      obsgain::Interval(0.5);
  EXPECT_GE(obsgain::largest_eigenvalue_upper_over(X), 1.0);
  EXPECT_LE(obsgain::largest_eigenvalue_upper_over(X), 1.0 + 1e-6);
}

}  // namespace
