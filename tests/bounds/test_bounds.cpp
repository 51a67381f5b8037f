#include "obsgain/bounds/bounds.hpp"
#include "obsgain/model/planar_2r.hpp"
#include "obsgain/numerics/spectrum.hpp"
#include "obsgain/parsers/robots.hpp"

#include <gtest/gtest.h>

#include <numbers>
#include <random>
#include <utility>

namespace {

const obsgain::Model& pendubot_model() {
  static const obsgain::Model model = obsgain::pendubot();
  return model;
}

// Computed once per test process.
const obsgain::BoundReport& pendubot_bounds() {
  static const obsgain::BoundReport report = obsgain::compute_bounds(pendubot_model(), Eigen::Vector2d(10, 10));
  return report;
}

// Design notes §2 and §4, to half a unit of their last printed digit.
TEST(PendubotBounds, ReproduceTheDesignNotes) {
  EXPECT_NEAR(pendubot_bounds().M0.value, 285.7398, 5e-5);
  EXPECT_NEAR(pendubot_bounds().B.value, 0.4347667, 5e-8);
  EXPECT_NEAR(pendubot_bounds().L_paper, 124.2301, 5e-5);
  EXPECT_NEAR(pendubot_bounds().L_joint.value, 43.3475, 5e-5);
  EXPECT_EQ(pendubot_bounds().F_norm, 0.0);
}

TEST(PendubotBounds, MatchClosedForms) {
  // M0 = 1/λmin(M(q2 = 0)); B = 2 π3 ||[[-V2, -(V1 + V2)], [V1, 0]]|| at |sin q2| = 1, V = (10, 10).
  const Eigen::Matrix2d M = obsgain::planar_2r_mass_matrix<double>({{0.0308, 0.0106, 0.0095, 0.2086, 0.0630}}, 1.0);
  const double M0 = 1.0 / obsgain::symmetric_eigenvalues(M)(0);
  EXPECT_NEAR(pendubot_bounds().M0.value, M0, 1e-10 * M0);
  const double B = 2.0 * 0.0095 * 10.0 * std::sqrt(3.0 + std::sqrt(5.0));
  EXPECT_NEAR(pendubot_bounds().B.value, B, 1e-10 * B);
  EXPECT_NEAR(std::abs(std::sin(pendubot_bounds().B.q(1))), 1.0, 1e-8);
  EXPECT_NEAR(pendubot_bounds().M0.q(1), 0.0, 1e-4);
}

TEST(PendubotBounds, BothOptimisersAgree) {
  for (const auto* m : {&pendubot_bounds().M0, &pendubot_bounds().B, &pendubot_bounds().L_joint}) {
    EXPECT_NEAR(m->global_value, m->polish_value, 1e-8 * m->value);
    EXPECT_GT(m->global_evaluations, 0);
    EXPECT_GT(m->polish_evaluations, 0);
  }
}

TEST(PendubotBounds, JointConstantNeverExceedsThePapers) { EXPECT_LE(pendubot_bounds().L_joint.value, pendubot_bounds().L_paper); }

// The vertex reduction: a dense grid over q2 and the whole velocity box (not only vertices) never beats
// the reported maxima, and comes within the grid's resolution of them.
TEST(PendubotBounds, VertexReductionAgainstDenseGrid) {
  const Eigen::Vector2d V(10, 10);
  double best_B = 0.0, best_L = 0.0, best_M0 = 0.0;
  const int nq = 721, nv = 21;
  for (int a = 0; a < nq; ++a) {
    const Eigen::Vector2d q(0.3, -std::numbers::pi + 2.0 * std::numbers::pi * a / (nq - 1));
    best_M0 = std::max(best_M0, obsgain::inverse_inertia_norm(pendubot_model(), q));
    for (int i = 0; i < nv; ++i) {
      for (int j = 0; j < nv; ++j) {
        const Eigen::Vector2d w(-V(0) + 2.0 * V(0) * i / (nv - 1), -V(1) + 2.0 * V(1) * j / (nv - 1));
        best_B = std::max(best_B, obsgain::coriolis_jacobian_norm(pendubot_model(), q, w));
        for (const Eigen::Vector2d D : {Eigen::Vector2d(1, 1), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)})
          best_L = std::max(best_L, obsgain::joint_lipschitz_norm(pendubot_model(), q, w, D));
      }
    }
  }
  EXPECT_LE(best_M0, pendubot_bounds().M0.value * (1 + 1e-12));
  EXPECT_LE(best_B, pendubot_bounds().B.value * (1 + 1e-12));
  EXPECT_LE(best_L, pendubot_bounds().L_joint.value * (1 + 1e-12));
  EXPECT_GT(best_M0, pendubot_bounds().M0.value * (1 - 1e-4));
  EXPECT_GT(best_B, pendubot_bounds().B.value * (1 - 1e-4));
  EXPECT_GT(best_L, pendubot_bounds().L_joint.value * (1 - 1e-4));
}

TEST(Bounds, FrictionEntersBothLipschitzConstants) {
  const obsgain::Planar2RParameters p{{0.0308, 0.0106, 0.0095, 0.2086, 0.0630}, 9.81};
  const obsgain::Model model =
      obsgain::make_planar_2r("damped", p, Eigen::Vector2d(0.02, 0.01), Eigen::Matrix2d::Identity(), Eigen::Vector2d(10, 10));
  const obsgain::BoundReport r = obsgain::compute_bounds(model, model.velocity_bounds);
  EXPECT_DOUBLE_EQ(r.F_norm, 0.02);
  EXPECT_NEAR(r.L_paper, r.M0.value * (r.B.value + 0.02), 1e-12 * r.L_paper);
  EXPECT_LE(r.L_joint.value, r.L_paper);
  // D = 0 leaves M⁻¹F, so L_joint is at least sup ||M⁻¹ F||.
  EXPECT_GE(r.L_joint.value, obsgain::joint_lipschitz_norm(model, r.M0.q, Eigen::Vector2d(10, 10), Eigen::Vector2d::Zero()));
}

}  // namespace

namespace {

// The numeric search polishes its starts in child processes on several cores (numerics/processes.hpp): the same
// numbers, bit for bit, as one after the other, on arm3 (whose L_T rounds search a similarity too).
TEST(Bounds, TheNumericSearchIsTheSameOnOneCoreAndOnTwo) {
  const obsgain::Model arm3 = obsgain::load_robot({std::string(OBSGAIN_EXAMPLES_DIR) + "/arm3.urdf"});
  obsgain::BoundOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const obsgain::BoundReport a = obsgain::compute_bounds(arm3, arm3.velocity_bounds, one);
  const obsgain::BoundReport b = obsgain::compute_bounds(arm3, arm3.velocity_bounds, two);
  const std::pair<const obsgain::BoundMaximum*, const obsgain::BoundMaximum*> pairs[] = {
      {&a.M0, &b.M0}, {&a.B, &b.B}, {&a.L_joint, &b.L_joint}, {&a.L_scaled, &b.L_scaled}};
  for (const auto& [x, y] : pairs) {
    EXPECT_EQ(x->value, y->value);
    EXPECT_EQ(x->polish_value, y->polish_value);
    EXPECT_EQ(x->polish_evaluations, y->polish_evaluations);
    EXPECT_EQ(x->q, y->q);
  }
  ASSERT_TRUE(a.scaled());
  EXPECT_EQ(a.scaling, b.scaling);
}

// ||B||₂ proven from the smaller Gram matrix: never below the largest singular value (Jacobi SVD; a rank-one u vᵀ, whose
// norm is |u| |v|), and above it by the eigenvalue pad and the Gram matrix's rounding only, for square, tall and wide
// matrices. On entries of 1e-162, whose squares underflow to 0, the bound rests on the underflow term alone and still
// holds; the zero matrix's is 0.
TEST(Spectrum, SpectralNormUpperHoldsAndIsTight) {
  std::srand(7);
  const auto check = [](const Eigen::MatrixXd& B, double sigma, double slack) {
    const double bound = obsgain::spectral_norm_upper(B);
    EXPECT_GE(bound, sigma) << B.rows() << " x " << B.cols();
    EXPECT_LE(bound, sigma * (1.0 + slack)) << B.rows() << " x " << B.cols();
  };
  for (const auto& [rows, cols] : {std::pair{7, 7}, std::pair{14, 7}, std::pair{7, 14}, std::pair{3, 1}}) {
    const Eigen::MatrixXd B = Eigen::MatrixXd::Random(rows, cols) * 40.0;
    check(B, Eigen::JacobiSVD<Eigen::MatrixXd>(B).singularValues()(0) * (1.0 - 1e-14), 1e-11);
  }
  const Eigen::VectorXd u = Eigen::VectorXd::LinSpaced(6, 1.0, 6.0), v = Eigen::VectorXd::LinSpaced(6, -2.0, 3.0);
  check(u * v.transpose(), u.norm() * v.norm() * (1.0 - 1e-15), 1e-11);
  check(Eigen::MatrixXd::Constant(7, 7, 1e-162), 7e-162, 10.0);
  EXPECT_EQ(obsgain::spectral_norm_upper(Eigen::MatrixXd::Zero(4, 4)), 0.0);
}

// The Perron root's bound (weighted Gershgorin): a path 0 - 1 - 10, whose spectral radius is √101 = 10.05 and whose
// row sums reach 11; a matrix with a zero row; an empty one. On random non-negative B, never below ρ(B) and never above
// the largest row sum, and never below λmax of a symmetric G with |G| <= B (B with random signs).
TEST(Spectrum, PerronRootBoundHoldsAndBeatsTheRowSums) {
  Eigen::Matrix3d path;
  path << 0, 1, 0, 1, 0, 10, 0, 10, 0;
  EXPECT_GE(obsgain::perron_upper(path), std::sqrt(101.0));
  EXPECT_LE(obsgain::perron_upper(path), std::sqrt(101.0) * (1.0 + 1e-3));
  Eigen::Matrix3d zero_row;
  zero_row << 2, 1, 0, 1, 2, 0, 0, 0, 0;
  EXPECT_GE(obsgain::perron_upper(zero_row), 3.0);
  EXPECT_LE(obsgain::perron_upper(zero_row), 3.0 * (1.0 + 1e-12));
  EXPECT_EQ(obsgain::perron_upper(Eigen::MatrixXd(0, 0)), 0.0);
  std::srand(9);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 1 + trial % 8;
    const Eigen::MatrixXd A = Eigen::MatrixXd::Random(n, n).cwiseAbs();
    const Eigen::MatrixXd B = A + A.transpose();
    const double bound = obsgain::perron_upper(B);
    EXPECT_GE(bound, obsgain::symmetric_eigenvalues(B).maxCoeff() * (1.0 - 1e-14)) << n;
    EXPECT_LE(bound, B.rowwise().sum().maxCoeff() * (1.0 + 1e-14)) << n;
    const Eigen::MatrixXd signs = Eigen::MatrixXd::Random(n, n);
    Eigen::MatrixXd G = B.cwiseProduct(signs.cwiseSign());
    G = (G + G.transpose()).eval() / 2.0;
    EXPECT_LE(obsgain::symmetric_eigenvalues(G).maxCoeff(), bound) << n;
  }
}

// λmin from diagonal lower bounds and off-diagonal moduli (weighted Gershgorin): on the path 0 - 1 - 10 with the
// diagonal 5, λmin = 5 - √101 exactly where Gershgorin's rows give 5 - 11. On random bounds, with unequal diagonals,
// never above λmin of any symmetric S inside them (the diagonals at their bounds or above, random signs), and never
// below Gershgorin's.
TEST(Spectrum, WeightedGershgorinBoundsEveryMemberFromBelow) {
  Eigen::Matrix3d path;
  path << 0, 1, 0, 1, 0, 10, 0, 10, 0;
  const double exact = 5.0 - std::sqrt(101.0);
  EXPECT_LE(obsgain::weighted_gershgorin_lower(Eigen::Vector3d::Constant(5.0), path), exact);
  EXPECT_GE(obsgain::weighted_gershgorin_lower(Eigen::Vector3d::Constant(5.0), path), exact - 1e-2);
  EXPECT_EQ(obsgain::weighted_gershgorin_lower(Eigen::VectorXd(0), Eigen::MatrixXd(0, 0)), obsgain::kInfinity);
  std::srand(11);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 1 + trial % 7;
    const Eigen::VectorXd d = 3.0 * Eigen::VectorXd::Random(n);
    const Eigen::MatrixXd A = Eigen::MatrixXd::Random(n, n).cwiseAbs(), B = A + A.transpose();
    const double bound = obsgain::weighted_gershgorin_lower(d, B);
    double gershgorin = obsgain::kInfinity;
    for (int i = 0; i < n; ++i) gershgorin = std::min(gershgorin, d(i) - (B.row(i).sum() - B(i, i)));
    EXPECT_GE(bound, gershgorin - 1e-12) << n;
    for (int member = 0; member < 5; ++member) {
      Eigen::MatrixXd S = B.cwiseProduct(Eigen::MatrixXd::Random(n, n).cwiseSign());
      S = (S + S.transpose()).eval() / 2.0;
      S.diagonal() = d + Eigen::VectorXd::Random(n).cwiseAbs() * (member % 2);
      EXPECT_LE(bound, obsgain::symmetric_eigenvalues(S)(0)) << n;
    }
  }
}

// Where the minimum is flat (two joints that no Φ couples), the slack picks the smallest cond(T) within it: Φ's
// coupled block [[0, 4], [1, 0]] has ||T Φ T⁻¹|| = max(4 / t₂, t₂), 2 at t₂ = 2, and within 2 (1 + s) the
// smallest spread of (1, t₂, t₃, t₄) is cond 2 / (1 + s), with t₃ and t₄ anywhere between. The minimum is found to
// the bisection's resolution (a relative 1e-6 above it, never below) and the slack taken from there.
TEST(SimilarityScaling, TheSlackTakesTheSmallestConditionNumberWhereTheMinimumIsFlat) {
  Eigen::MatrixXd Phi = Eigen::MatrixXd::Zero(4, 4);
  Phi(0, 1) = 4.0;
  Phi(1, 0) = 1.0;
  Phi(2, 2) = Phi(3, 3) = 0.1;
  const auto norm = [&](const Eigen::VectorXd& t) {
    return obsgain::spectral_norm(t.asDiagonal() * Phi * t.cwiseInverse().asDiagonal());
  };
  const double minimum = norm(obsgain::best_diagonal_scaling({Phi}));
  EXPECT_GE(minimum, 2.0 * (1.0 - 1e-12));
  EXPECT_LE(minimum, 2.0 * (1.0 + 2e-6));
  const double slack = obsgain::BoundOptions{}.scaling_slack;
  const Eigen::VectorXd t = obsgain::best_diagonal_scaling({Phi}, slack);
  EXPECT_LE(norm(t), 2.0 * (1.0 + slack) * (1.0 + 2e-6));
  EXPECT_NEAR(t.maxCoeff() / t.minCoeff(), 2.0 / (1.0 + slack), 1e-3);
}

// Three random 3 x 3 matrices, rows of different sizes so that scaling matters. The SDP's minimum is cross-checked
// against a grid in (log t₂, log t₃), coarse then fine about its best point: no grid point is below it by more than
// the bisection's resolution, and the fine grid comes within 1e-3. Turned by a relative 1e-12 in every entry (the last
// bits a change elsewhere would move), the minimum and the T of smallest cond within the slack move by less than 1e-5.
TEST(SimilarityScaling, TheDiagonalMinimumIsGlobalAndMovesContinuouslyWithTheMatrices) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  std::vector<Eigen::MatrixXd> matrices;
  for (int k = 0; k < 3; ++k)
    matrices.push_back(Eigen::Vector3d(1.0, 4.0, 0.3).asDiagonal() *
                       Eigen::MatrixXd::NullaryExpr(3, 3, [&] { return normal(rng); }));
  const auto worst = [&](const Eigen::VectorXd& t) {
    double value = 0.0;
    for (const Eigen::MatrixXd& Phi : matrices)
      value = std::max(value, obsgain::spectral_norm(t.asDiagonal() * Phi * t.cwiseInverse().asDiagonal()));
    return value;
  };
  const Eigen::VectorXd t = obsgain::best_diagonal_scaling(matrices);
  const double minimum = worst(t);
  // The lowest point of a 121 x 121 grid of the given step about a centre in (log t₂, log t₃).
  const auto lowest = [&](const Eigen::Vector2d& centre, double step) {
    std::pair<double, Eigen::Vector2d> low{1e300, centre};
    for (int i = -60; i <= 60; ++i)
      for (int j = -60; j <= 60; ++j) {
        const Eigen::Vector2d x = centre + step * Eigen::Vector2d(i, j);
        const double value = worst(Eigen::Vector3d(1.0, std::exp(x(0)), std::exp(x(1))));
        if (value < low.first) low = {value, x};
      }
    return low;
  };
  const double grid = lowest(lowest(Eigen::Vector2d::Zero(), 0.05).second, 1e-3).first;
  EXPECT_GE(grid, minimum * (1.0 - 2e-6));
  EXPECT_LE(grid, minimum * (1.0 + 1e-3));
  EXPECT_LT(minimum, 0.9 * worst(Eigen::Vector3d::Ones()));  // scaling matters here
  const double slack = obsgain::BoundOptions{}.scaling_slack;
  const Eigen::VectorXd narrow = obsgain::best_diagonal_scaling(matrices, slack);
  std::uniform_real_distribution<double> bits(-1e-12, 1e-12);
  for (Eigen::MatrixXd& Phi : matrices) Phi = Phi.unaryExpr([&](double x) { return x * (1.0 + bits(rng)); });
  EXPECT_NEAR(worst(obsgain::best_diagonal_scaling(matrices)), minimum, 1e-5 * minimum);
  const Eigen::VectorXd moved = obsgain::best_diagonal_scaling(matrices, slack);
  EXPECT_LT((moved - narrow).cwiseQuotient(narrow).cwiseAbs().maxCoeff(), 1e-5);
}

// A rotated nilpotent Φ = a u vᵀ (u ⊥ v): ||T Φ T⁻¹|| = a ||T u|| ||T⁻ᵀ v|| >= a / cond(T), attained by T = D Rᵀ. No
// diagonal T helps here (its minimum is a, at T = I); the best full T with cond(T) <= κ reaches a / κ exactly.
TEST(SimilarityScaling, ReachesTheAnalyticMinimumWhereNoDiagonalScalingHelps) {
  const double a = 4.0, kappa = 30.0;
  const Eigen::Vector2d u(std::sqrt(0.5), std::sqrt(0.5)), v(-std::sqrt(0.5), std::sqrt(0.5));
  const Eigen::MatrixXd Phi = a * u * v.transpose();
  const Eigen::VectorXd t = obsgain::best_diagonal_scaling({Phi});
  EXPECT_NEAR(obsgain::spectral_norm(t.asDiagonal() * Phi * t.cwiseInverse().asDiagonal()), a, 1e-3 * a);
  const Eigen::MatrixXd T = obsgain::best_similarity({Phi}, kappa);
  EXPECT_EQ(T(0, 0), 1.0);
  EXPECT_EQ(T(1, 0), 0.0);  // upper triangular
  EXPECT_LE(obsgain::condition_number(T), kappa * (1.0 + 1e-6));
  EXPECT_NEAR(obsgain::spectral_norm(T * Phi * T.inverse()), a / kappa, 1e-3 * a);
  // A normal matrix is not improved by any similarity: ||T Φ T⁻¹|| >= ρ(Φ) = ||Φ||.
  const Eigen::MatrixXd symmetric = (Eigen::Matrix2d() << 2.0, 1.0, 1.0, -1.0).finished();
  const Eigen::MatrixXd S = obsgain::best_similarity({symmetric}, kappa);
  EXPECT_NEAR(obsgain::spectral_norm(S * symmetric * S.inverse()), obsgain::spectral_norm(symmetric), 1e-3);
}

}  // namespace
