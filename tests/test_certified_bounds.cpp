#include "obsgain/certified_bounds.hpp"
#include "obsgain/design.hpp"
#include "obsgain/planar_2r.hpp"

#include <gtest/gtest.h>

#include <numbers>
#include <random>

namespace {

const obsgain::Model& pendubot_model() {
  static const obsgain::Model model = obsgain::pendubot();
  return model;
}

// Computed once per test process (about two seconds of branch and bound).
const obsgain::CertifiedBounds& pendubot_brackets() {
  static const obsgain::CertifiedBounds brackets =
      *obsgain::certify_bounds(pendubot_model(), obsgain::compute_bounds(pendubot_model(), Eigen::Vector2d(10, 10)));
  return brackets;
}

void expect_brackets(const obsgain::Bracket& b, double reference) {
  // The design notes' values are rounded to 7 digits: the bracket contains them to that rounding.
  EXPECT_LE(b.lower, reference * (1 + 1e-6));
  EXPECT_GE(b.upper, reference * (1 - 1e-6));
  EXPECT_LE(b.upper - b.lower, 1e-6 * b.upper);
  EXPECT_LE(b.lower, b.upper);
  EXPECT_GT(b.boxes, 1);
}

TEST(PendubotBrackets, ContainTheDesignNotesValuesWithGap1e6) {
  expect_brackets(pendubot_brackets().M0, 285.7398);
  expect_brackets(pendubot_brackets().B, 0.4347667);
  expect_brackets(pendubot_brackets().L_joint, 43.3475);
  // Closed forms: M0 = 1/λmin(M(q2 = 0)), B = 2 π3 · 10 · sqrt(3 + √5).
  const Eigen::Matrix2d M = obsgain::planar_2r_mass_matrix<double>({{0.0308, 0.0106, 0.0095, 0.2086, 0.0630}}, 0.0);
  const double M0 = 1.0 / Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(M).eigenvalues()(0);
  EXPECT_LE(pendubot_brackets().M0.lower, M0 * (1 + 1e-14));
  EXPECT_GE(pendubot_brackets().M0.upper, M0);
  const double B = 2.0 * 0.0095 * 10.0 * std::sqrt(3.0 + std::sqrt(5.0));
  EXPECT_LE(pendubot_brackets().B.lower, B * (1 + 1e-14));
  EXPECT_GE(pendubot_brackets().B.upper, B);
}

// Dense random sampling of q, of v anywhere in the box (not only vertices) and of D in [0, 1]ⁿ never
// exceeds a certified upper bound.
TEST(PendubotBrackets, RandomSamplingNeverExceedsTheUpperBounds) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), unit(0.0, 1.0), box(-10.0, 10.0);
  for (int i = 0; i < 50000; ++i) {
    const Eigen::Vector2d q(angle(rng), angle(rng)), v(box(rng), box(rng)), D(unit(rng), unit(rng));
    EXPECT_LE(obsgain::inverse_inertia_norm(pendubot_model(), q), pendubot_brackets().M0.upper);
    EXPECT_LE(obsgain::coriolis_jacobian_norm(pendubot_model(), q, v), pendubot_brackets().B.upper);
    EXPECT_LE(obsgain::joint_lipschitz_norm(pendubot_model(), q, v, D), pendubot_brackets().L_joint.upper);
  }
}

TEST(IntervalEnclosures, NormAndEigenvalueBoundsHoldForEveryMember) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> entry(-3.0, 3.0), width(0.0, 0.5), unit(0.0, 1.0);
  for (int trial = 0; trial < 500; ++trial) {
    obsgain::IntervalMatrix X(2, 2), S(2, 2);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) {
        const double c = entry(rng), w = width(rng);
        X(i, j) = obsgain::Interval(c - w, c + w);
      }
    const double a = 5.0 + entry(rng), b = entry(rng), c = 5.0 + entry(rng), w = width(rng);
    S(0, 0) = obsgain::Interval(a - w, a + w);
    S(0, 1) = S(1, 0) = obsgain::Interval(b - w, b + w);
    S(1, 1) = obsgain::Interval(c - w, c + w);
    const double norm_bound = obsgain::norm_upper_bound(X);
    const double eigen_bound = obsgain::smallest_eigenvalue_lower_bound(S);
    for (int k = 0; k < 200; ++k) {
      Eigen::Matrix2d x, s;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) x(i, j) = X(i, j).lower() + unit(rng) * (X(i, j).upper() - X(i, j).lower());
      const double off = S(0, 1).lower() + unit(rng) * (S(0, 1).upper() - S(0, 1).lower());
      s << S(0, 0).lower() + unit(rng) * 2 * w, off, off, S(1, 1).lower() + unit(rng) * 2 * w;
      EXPECT_LE(x.operatorNorm(), norm_bound);
      EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(s).eigenvalues()(0), eigen_bound);
    }
  }
}

// A model that only offers C(q, v) v on doubles (like a KDL chain) cannot be certified: numeric bounds, with
// a warning saying so.
class DoubleOnlyDynamics final : public obsgain::Dynamics {
 public:
  explicit DoubleOnlyDynamics(std::shared_ptr<const obsgain::Dynamics> inner) : inner_(std::move(inner)) {}
  int dof() const override { return 2; }
  void mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const override {
    inner_->mass_matrix(q, M);
  }
  void coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                Eigen::Ref<Eigen::VectorXd> A) const override {
    inner_->coriolis(q, v, A);
  }
  void gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const override {
    inner_->gravity(q, g);
  }

 private:
  std::shared_ptr<const obsgain::Dynamics> inner_;
};

TEST(CertifiedDesign, FallsBackToNumericWithAWarning) {
  obsgain::Model model = obsgain::pendubot();
  model.dynamics = std::make_shared<DoubleOnlyDynamics>(model.dynamics);
  EXPECT_FALSE(obsgain::certify_bounds(model, obsgain::compute_bounds(model, model.velocity_bounds)).has_value());
  obsgain::DesignOptions options;
  options.gamma = 1.27;
  const obsgain::Design design = obsgain::design_gains(model, options);
  EXPECT_STREQ(design.bounds.method(), "numeric");
  EXPECT_FALSE(design.bounds.certified);
  ASSERT_FALSE(design.warnings.empty());
  EXPECT_NE(design.warnings.front().find("cannot be evaluated on intervals"), std::string::npos);
  EXPECT_NEAR(design.bounds.L_joint.value, 43.3475, 1e-5 * 43.3475);
}

}  // namespace
