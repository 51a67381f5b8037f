// Second-order Taylor forms (numerics/taylor.hpp), the matrices built on them, and the dynamics evaluated on them over
// boxes of configurations (the certified bounds' enclosures): they contain the double values at random points of
// random boxes, their remainder shrinks as the cube of the box's width, and the norm bound keeps the sign of the
// second-order term.
#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/bounds/taylor_matrix.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"
#include "obsgain/numerics/taylor.hpp"
#include "obsgain/parsers/robots.hpp"

#include "test_files.hpp"
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>

namespace {

using obsgain_test::examples;

// x(ε) without its remainder, and whether a value lies within the remainder of it (plus `slack` for the double
// evaluation the value comes from).
double polynomial_part(const obsgain::Taylor& x, const std::vector<double>& epsilon) {
  double v = x.c;
  for (std::size_t k = 0; k < epsilon.size(); ++k) v += x.a[k] * epsilon[k];
  for (std::size_t k = 0; k < epsilon.size(); ++k)
    for (std::size_t l = k; l < epsilon.size(); ++l) v += x.b[obsgain::kPairs.index[k][l]] * epsilon[k] * epsilon[l];
  return v;
}
bool encloses(const obsgain::Taylor& x, const std::vector<double>& epsilon, double value, double slack) {
  return std::abs(value - polynomial_part(x, epsilon)) <= x.r + slack;
}

TEST(TaylorForms, EncloseCosineSineAndProductsAtRandomPoints) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), centre(-4.0, 4.0), radius(0.0, 4.0);
  for (int trial = 0; trial < 2000; ++trial) {
    // Two symbols, narrow and wide arguments (wide ones take the constant form).
    const obsgain::Taylor x = obsgain::Taylor::symbol(centre(rng), radius(rng), 0) +
                              obsgain::Taylor::symbol(0.0, 0.1 * radius(rng), 1);
    const obsgain::Taylor y = obsgain::Taylor::symbol(centre(rng), radius(rng), 1);
    const obsgain::Taylor c = cos(x), s = sin(x), p = x * y, q = cos(x) * sin(y), t = (x * y) * (x - y);
    for (int point = 0; point < 20; ++point) {
      const std::vector<double> e{unit(rng), unit(rng)};
      const double xv = polynomial_part(x, e), yv = polynomial_part(y, e);
      EXPECT_TRUE(encloses(c, e, std::cos(xv), 1e-15)) << x.c << " " << x.a[0];
      EXPECT_TRUE(encloses(s, e, std::sin(xv), 1e-15)) << x.c << " " << x.a[0];
      EXPECT_TRUE(encloses(p, e, xv * yv, 1e-14));
      EXPECT_TRUE(encloses(q, e, std::cos(xv) * std::sin(yv), 1e-15));
      EXPECT_TRUE(encloses(t, e, xv * yv * (xv - yv), 1e-12));
    }
  }
}

// A product of first-order forms is exact (no remainder), and sin near its maximum keeps the negative curvature:
// sin(π/2 + 0.1 ε) = 1 - 0.005 ε² + R, |R| <= 0.1³/6 · sin(0.1), so its upper end is 1 + 1.7e-5.
TEST(TaylorForms, SecondOrderTermsAreExact) {
  const obsgain::Taylor x = obsgain::Taylor::symbol(2.0, 0.5, 0), y = obsgain::Taylor::symbol(-1.0, 0.25, 1);
  const obsgain::Taylor p = x * y;
  EXPECT_EQ(p.c, -2.0);
  EXPECT_EQ(p.b[obsgain::kPairs.index[0][1]], 0.125);
  EXPECT_LT(p.r, 1e-14);
  const obsgain::Taylor s = sin(obsgain::Taylor::symbol(M_PI / 2, 0.1, 0));
  EXPECT_NEAR(s.b[obsgain::kPairs.index[0][0]], -0.005, 1e-15);
  EXPECT_LT(s.upper(), 1.0 + 1.7e-5);
  EXPECT_GE(s.upper(), 1.0);
}

// λmin of a Taylor matrix sees where the remainder sits: a remainder of 5 on the large diagonal entry of
// diag(10, 1) leaves λmin = 1 (a norm-only remainder would give 1 - 5), and the bound holds for every member.
TEST(TaylorMatrices, SmallestEigenvalueUsesTheRemainderEntryByEntry) {
  obsgain::TaylorMatrix X;
  X.centre = Eigen::Vector2d(10.0, 1.0).asDiagonal();
  X.slopes.push_back((Eigen::Matrix2d() << 0.0, 0.01, 0.01, 0.0).finished());
  X.curvatures.push_back(Eigen::Matrix2d::Zero());
  X.entry_remainder = (Eigen::Matrix2d() << 5.0, 0.0, 0.0, 0.0).finished();
  X.remainder = 5.0;
  const double lower = obsgain::smallest_eigenvalue_lower(X);
  EXPECT_GT(lower, 0.99);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Matrix2d member = X.centre + unit(rng) * X.slopes[0] + (Eigen::Matrix2d() << 5.0 * unit(rng), 0, 0, 0).finished();
    EXPECT_LE(lower, obsgain::symmetric_eigenvalues(member)(0));
  }
  X.entry_remainder.resize(0, 0);  // known as a norm only
  EXPECT_LT(obsgain::smallest_eigenvalue_lower(X), -3.9);
}

// X(ε) = diag(10 - 0.2ε₀², 1) + ε₁ [[0, 0.1], [0.1, 0]]: its norm is at most 10.0011 (at ε₀ = 0 the coupling adds
// about 0.1²/9), and the bound keeps the negative ε₀² term instead of adding its size (which gives >= 10.2): it is
// 10.0052 (the cubic and quartic terms, and the coupling through the 2 x 2 lemma). The bound holds at random members
// of random matrices of this shape.
TEST(TaylorMatrices, NormBoundKeepsTheSignOfTheCurvature) {
  obsgain::TaylorMatrix X;
  X.centre = Eigen::Vector2d(10.0, 1.0).asDiagonal();
  X.slopes = {Eigen::Matrix2d::Zero(), (Eigen::Matrix2d() << 0.0, 0.1, 0.1, 0.0).finished()};
  X.curvatures = {(Eigen::Matrix2d() << -0.2, 0.0, 0.0, 0.0).finished(), Eigen::Matrix2d::Zero(), Eigen::Matrix2d::Zero()};
  const double bound = obsgain::norm_upper(X, 0.0);
  EXPECT_GE(bound, 10.0011);
  EXPECT_LT(bound, 10.0053);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    obsgain::TaylorMatrix Y;
    Y.centre = Eigen::Matrix3d::NullaryExpr([&] { return 3.0 * unit(rng); });
    for (int k = 0; k < 2; ++k) Y.slopes.push_back(Eigen::Matrix3d::NullaryExpr([&] { return 0.3 * unit(rng); }));
    for (int p = 0; p < 3; ++p) Y.curvatures.push_back(Eigen::Matrix3d::NullaryExpr([&] { return 0.2 * unit(rng); }));
    const double upper = obsgain::norm_upper(Y, 0.0);
    for (int point = 0; point < 50; ++point) {
      const double e0 = unit(rng), e1 = unit(rng);
      const Eigen::Matrix3d member = Y.centre + e0 * Y.slopes[0] + e1 * Y.slopes[1] + e0 * e0 * Y.curvatures[0] +
                                     e0 * e1 * Y.curvatures[1] + e1 * e1 * Y.curvatures[2];
      EXPECT_LE(obsgain::spectral_norm(member), upper);
    }
  }
}

// M and the Christoffel tensors of a model over a box of its searched joints (symbol k: side k).
struct BoxForms {
  std::vector<obsgain::Taylor> M, N;
};

BoxForms box_forms(const obsgain::Model& model, const obsgain::JointSearch& s, const Eigen::VectorXd& centre,
                   const std::vector<double>& radius) {
  const int n = model.dof();
  std::vector<obsgain::Taylor> q(n);
  for (int i = 0; i < n; ++i) q[i] = obsgain::Taylor(centre(i));
  for (std::size_t k = 0; k < s.joints.size(); ++k)
    q[s.joints[k]] = obsgain::Taylor::symbol(centre(s.joints[k]), radius[k], static_cast<int>(k));
  BoxForms f{std::vector<obsgain::Taylor>(n * n), std::vector<obsgain::Taylor>(n * n * n)};
  obsgain::mass_matrix_of(model, q.data(), f.M.data());
  obsgain::christoffel_tensors_of(model, s.joints, q.data(), f.N.data());
  return f;
}

// A random box of the searched joints (centre in (-3, 3), half-widths up to `scale`) and random points in it:
// their symbols ε and configurations q.
struct RandomBox {
  Eigen::VectorXd centre;
  std::vector<double> radius;
};
RandomBox random_box(const obsgain::JointSearch& s, int n, double scale, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> angle(-3.0, 3.0), width(0.0, 1.0);
  RandomBox box{Eigen::VectorXd(n), std::vector<double>(s.joints.size())};
  for (int i = 0; i < n; ++i) box.centre(i) = angle(rng);
  for (auto& r : box.radius) r = scale * width(rng);
  return box;
}
struct RandomPoint {
  std::vector<double> epsilon;
  Eigen::VectorXd q;
};
RandomPoint random_point(const obsgain::JointSearch& s, const RandomBox& box, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  RandomPoint point{std::vector<double>(s.joints.size()), box.centre};
  for (std::size_t k = 0; k < s.joints.size(); ++k) {
    point.epsilon[k] = unit(rng);
    point.q(s.joints[k]) += point.epsilon[k] * box.radius[k];
  }
  return point;
}

class TaylorDynamics : public ::testing::TestWithParam<const char*> {};

// Random boxes (narrow and wide), random points inside: M(q) and N_i(q) in double (N by the Newton–Euler pass, an
// independent computation; M by the rotation in double, where the forms rotate inertias in the double-angle form)
// lie within the forms.
TEST_P(TaylorDynamics, EncloseMAndTheCoriolisTensorsAtRandomPointsOfRandomBoxes) {
  const obsgain::Model model = obsgain::load_robot({examples + "/" + GetParam()});
  const int n = model.dof();
  const obsgain::JointSearch s = obsgain::joint_search(model, obsgain::configuration_joints(model));
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    const RandomBox box = random_box(s, n, trial < 4 ? 0.05 : trial < 7 ? 1.0 : 3.2, rng);
    const BoxForms f = box_forms(model, s, box.centre, box.radius);
    for (int point = 0; point < 10; ++point) {
      const auto [e, q] = random_point(s, box, rng);
      Eigen::MatrixXd M(n, n);
      obsgain::mass_matrix(model, q, M);
      std::vector<Eigen::MatrixXd> N;
      obsgain::coriolis_tensors(model, q, N);
      const double slack = 1e-12 * (1.0 + M.norm());  // the double evaluations' rounding
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) {
          EXPECT_TRUE(encloses(f.M[r * n + c], e, M(r, c), slack)) << GetParam() << " M(" << r << "," << c << ")";
          for (int i = 0; i < n; ++i)
            EXPECT_TRUE(encloses(f.N[(i * n + r) * n + c], e, N[i](r, c), slack)) << GetParam() << " N" << i;
        }
    }
  }
}

// M(q)⁻¹ at random points of random boxes lies within the inverse's forms plus its tail: ||M⁻¹ - P(ε)||₂ <=
// ||entry remainders||_F + tail (the tail's factor is ||E K|| = ||Kᵀ E||, K triangular).
TEST_P(TaylorDynamics, InverseEnclosesTheInverseAtRandomPoints) {
  const obsgain::Model model = obsgain::load_robot({examples + "/" + GetParam()});
  const int n = model.dof();
  const obsgain::JointSearch s = obsgain::joint_search(model, obsgain::configuration_joints(model));
  const auto m = s.joints.size();
  std::mt19937_64 rng(8);
  int proven = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const RandomBox box = random_box(s, n, 0.15, rng);
    const BoxForms f = box_forms(model, s, box.centre, box.radius);
    const obsgain::UpwardRounding upward;
    const obsgain::TaylorInverse inverse = obsgain::inverse(f.M, n, static_cast<int>(m));
    if (!inverse.proven) continue;
    ++proven;
    double remainders = 0.0;
    for (const obsgain::Taylor& x : inverse.entries) remainders += x.r * x.r;
    const double allowed = std::sqrt(remainders) + inverse.tail;
    for (int point = 0; point < 20; ++point) {
      const auto [e, q] = random_point(s, box, rng);
      Eigen::MatrixXd M(n, n), P(n, n);
      obsgain::mass_matrix(model, q, M);
      for (int i = 0; i < n * n; ++i) P(i / n, i % n) = polynomial_part(inverse.entries[i], e);
      const Eigen::MatrixXd inverse_M = M.inverse();
      EXPECT_LE(obsgain::spectral_norm(inverse_M - P), allowed + 1e-10 * inverse_M.norm()) << GetParam();
    }
  }
  EXPECT_GT(proven, 10) << GetParam();
}

// The forms' remainder is third order: halving the box divides it by eight. The exponent is fitted over four widths
// at a fixed centre (about 3 for every model; a first-order form, affine arithmetic, gives 2).
TEST_P(TaylorDynamics, RemaindersShrinkAsTheCubeOfTheWidth) {
  const obsgain::Model model = obsgain::load_robot({examples + "/" + GetParam()});
  const obsgain::JointSearch s = obsgain::joint_search(model, obsgain::configuration_joints(model));
  const Eigen::VectorXd centre = Eigen::VectorXd::LinSpaced(model.dof(), 0.3, 1.7);
  std::vector<double> log_w, log_M, log_N;
  for (double w : {0.2, 0.1, 0.05, 0.025}) {
    const BoxForms f = box_forms(model, s, centre, std::vector<double>(s.joints.size(), w / 2));
    const auto total = [](const std::vector<obsgain::Taylor>& X) {
      return std::accumulate(X.begin(), X.end(), 0.0, [](double t, const obsgain::Taylor& x) { return t + x.r; });
    };
    log_w.push_back(std::log(w));
    log_M.push_back(std::log(total(f.M)));
    log_N.push_back(std::log(total(f.N)));
  }
  const auto slope = [&](const std::vector<double>& y) {
    const double mx = std::accumulate(log_w.begin(), log_w.end(), 0.0) / 4, my = std::accumulate(y.begin(), y.end(), 0.0) / 4;
    double sxy = 0.0, sxx = 0.0;
    for (int i = 0; i < 4; ++i) {
      sxy += (log_w[i] - mx) * (y[i] - my);
      sxx += (log_w[i] - mx) * (log_w[i] - mx);
    }
    return sxy / sxx;
  };
  for (const auto* remainders : {&log_M, &log_N}) {
    EXPECT_GT(slope(*remainders), 2.8) << GetParam();
    EXPECT_LT(slope(*remainders), 3.4) << GetParam();
  }
}

// The bound of L_joint over a small box is never below the values attained in it (its corners and random points),
// and within 3 % of them (it was 5 % with first-order forms).
TEST_P(TaylorDynamics, JointLipschitzBoxBoundsHoldAndAreTightOnSmallBoxes) {
  const obsgain::Model model = obsgain::load_robot({examples + "/" + GetParam()});
  const obsgain::JointSearch s = obsgain::joint_search(model, obsgain::configuration_joints(model));
  const obsgain::BoxBounds boxes(model, s, model.velocity_bounds);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0), angle(-3.0, 3.0);
  for (int trial = 0; trial < 6; ++trial) {
    std::vector<obsgain::Interval> box;
    for (std::size_t k = 0; k < s.joints.size(); ++k) {
      const double lo = angle(rng);
      box.emplace_back(lo, lo + 0.02);
    }
    const obsgain::UpwardRounding upward;
    const double bound = boxes.joint_lipschitz(box, 0.0).upper;
    double attained = 0.0;
    for (int point = 0; point < 40; ++point) {
      Eigen::VectorXd x(static_cast<Eigen::Index>(box.size()));
      for (std::size_t k = 0; k < box.size(); ++k)
        x(k) = box[k].lower() + (point < 8 ? ((point >> (k % 3)) & 1) : unit(rng)) * 0.02;
      attained = std::max(attained, obsgain::max_joint_lipschitz_norm(model, s.configuration(x), model.velocity_bounds));
    }
    EXPECT_GE(bound, attained) << GetParam();
    EXPECT_LE(bound, 1.03 * attained) << GetParam();
  }
}

// The same for L_T = sup ||T Φ T⁻¹|| with a random diagonal T: the scaled forms' bound holds and is as tight; with
// T = I it equals the unscaled bound to the rounding of the scaling (a factor 1 + 1e-15).
TEST_P(TaylorDynamics, ScaledJointLipschitzBoxBoundsHoldAndAreTightOnSmallBoxes) {
  const obsgain::Model model = obsgain::load_robot({examples + "/" + GetParam()});
  const obsgain::JointSearch s = obsgain::joint_search(model, obsgain::configuration_joints(model));
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> unit(0.0, 1.0), angle(-3.0, 3.0), logarithm(-1.2, 1.2);
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(model.dof());
  const obsgain::BoxBounds plain(model, s, model.velocity_bounds), unit_scaled(model, s, model.velocity_bounds, ones);
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::VectorXd t = Eigen::VectorXd::Ones(model.dof());
    for (int i = 1; i < model.dof(); ++i) t(i) = std::exp(logarithm(rng));
    const obsgain::BoxBounds scaled(model, s, model.velocity_bounds, t);
    std::vector<obsgain::Interval> box;
    for (std::size_t k = 0; k < s.joints.size(); ++k) {
      const double lo = angle(rng);
      box.emplace_back(lo, lo + 0.02);
    }
    const obsgain::UpwardRounding upward;
    const double bound = scaled.joint_lipschitz(box, 0.0).upper, unscaled = plain.joint_lipschitz(box, 0.0).upper;
    EXPECT_GE(unit_scaled.joint_lipschitz(box, 0.0).upper, unscaled) << GetParam();
    EXPECT_LE(unit_scaled.joint_lipschitz(box, 0.0).upper, unscaled * (1.0 + 1e-12)) << GetParam();
    double attained = 0.0;
    for (int point = 0; point < 40; ++point) {
      Eigen::VectorXd x(static_cast<Eigen::Index>(box.size()));
      for (std::size_t k = 0; k < box.size(); ++k)
        x(k) = box[k].lower() + (point < 8 ? ((point >> (k % 3)) & 1) : unit(rng)) * 0.02;
      attained = std::max(attained, obsgain::max_joint_lipschitz_norm(model, s.configuration(x), model.velocity_bounds, t));
    }
    EXPECT_GE(bound, attained) << GetParam();
    EXPECT_LE(bound, 1.03 * attained) << GetParam();
  }
}

INSTANTIATE_TEST_SUITE_P(TwoThreeSixAndSevenJoints, TaylorDynamics,
                         ::testing::Values("pendubot.urdf", "arm3.urdf", "arm6.urdf", "arm7.urdf"));

}  // namespace
