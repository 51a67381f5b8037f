#include "obsgain/bounds/bounds.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"

#include "test_files.hpp"
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace {

using obsgain_test::examples;

// Polarisation of the quadratic form A(q, ·): (A(e_j + e_k) - A(e_j) - A(e_k)) / 2, an independent way to the
// tensors that the chain computes entry by entry with its bilinear Newton–Euler pass.
double polarised(const obsgain::Model& model, const Eigen::VectorXd& q, int i, int j, int k) {
  const int n = model.dof();
  const auto A = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd out(n);
    obsgain::coriolis(model, q, v, out);
    return out(i);
  };
  const Eigen::VectorXd ej = Eigen::VectorXd::Unit(n, j), ek = Eigen::VectorXd::Unit(n, k);
  return j == k ? A(ej) : 0.5 * (A(ej + ek) - A(ej) - A(ek));
}

TEST(Model, ChainTensorsEqualThePolarisedCoriolisForce) {
  const obsgain::Model model = obsgain::load_robot({examples + "/arm6.urdf"});
  const int n = model.dof();
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(n, -1.0 + trial, 2.0 - 0.7 * trial);
    std::vector<Eigen::MatrixXd> N;
    obsgain::coriolis_tensors(model, q, N);
    double scale = 0.0;
    for (const auto& Ni : N) scale = std::max(scale, Ni.cwiseAbs().maxCoeff());
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) EXPECT_NEAR(N[i](j, k), polarised(model, q, i, j, k), 1e-13 * scale);
  }
}

TEST(Model, ChainBilinearFormEqualsThePolarisedOne) {
  const obsgain::Model model = obsgain::load_robot({examples + "/arm7.urdf"});
  const int n = model.dof();
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(n, -2.0, 1.3);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, 1.0, -1.5), y = Eigen::VectorXd::LinSpaced(n, 0.3, 2.0);
  Eigen::VectorXd bilinear(n), plus(n), minus(n);
  obsgain::coriolis_bilinear(model, q, x, y, bilinear);
  obsgain::coriolis(model, q, x + y, plus);
  obsgain::coriolis(model, q, x - y, minus);
  // Polarisation subtracts terms of size ||A(x ± y)||: its error is rounding at that scale.
  EXPECT_LE((bilinear - 0.25 * (plus - minus)).norm(), 1e-13 * plus.norm());
  EXPECT_GT(bilinear.norm(), 1e-3);
}

TEST(Model, CoriolisTensorsReproduceCTimesV) {
  const obsgain::Model model = obsgain::pendubot();
  const Eigen::Vector2d q(0.1, 0.9), v(3.0, -7.0);
  std::vector<Eigen::MatrixXd> N;
  obsgain::coriolis_tensors(model, q, N);
  // C(q, v) v of the paper, written out.
  const double p3 = 0.0095, s2 = std::sin(q(1));
  const Eigen::Vector2d Cv(-p3 * s2 * v(1) * v(0) + (-p3 * s2 * v(1) - p3 * s2 * v(0)) * v(1), p3 * s2 * v(0) * v(0));
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(v.dot(N[i] * v), Cv(i), 1e-15);
}

TEST(Model, UnknownRobotAndBadBoundsAreRefused) {
  EXPECT_THROW(obsgain::load_robot({"nope"}), obsgain::InputError);
  const obsgain::Model model = obsgain::pendubot();
  EXPECT_THROW(obsgain::validate_velocity_bounds(model, Eigen::Vector3d(1, 1, 1)), obsgain::InputError);
  EXPECT_THROW(obsgain::validate_velocity_bounds(model, Eigen::Vector2d(0, 1)), obsgain::InputError);
  EXPECT_THROW(obsgain::validate_velocity_bounds(model, Eigen::Vector2d(std::nan(""), 1)), obsgain::InputError);
  EXPECT_NO_THROW(obsgain::validate_velocity_bounds(model, Eigen::Vector2d(1, 2)));
}

TEST(Model, SingularInertiaIsReportedWithItsConfiguration) {
  // π1 π2 = π3² makes M(q) singular at q2 = 0.
  const obsgain::Planar2RParameters singular{{0.01, 0.01, 0.01, 0.1, 0.1}, 9.81};
  const obsgain::Model model =
      obsgain::make_planar_2r("singular", singular, Eigen::Vector2d::Zero(), Eigen::Matrix2d::Identity(),
                              Eigen::Vector2d(1, 1));
  try {
    obsgain::compute_bounds(model, Eigen::Vector2d(1, 1));
    FAIL() << "a singular inertia matrix must be refused";
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
}

// M and the Coriolis tensors at q and at q with its last joint turned to `last`, their largest difference relative to
// the largest entry.
double last_joint_effect(const obsgain::Model& model, Eigen::VectorXd q, double last) {
  const int n = model.dof();
  Eigen::MatrixXd M(n, n), M_turned(n, n);
  std::vector<Eigen::MatrixXd> N, N_turned;
  obsgain::mass_matrix(model, q, M);
  obsgain::coriolis_tensors(model, q, N);
  q(n - 1) = last;
  obsgain::mass_matrix(model, q, M_turned);
  obsgain::coriolis_tensors(model, q, N_turned);
  double difference = (M - M_turned).cwiseAbs().maxCoeff(), scale = M.cwiseAbs().maxCoeff();
  for (int i = 0; i < n; ++i) {
    difference = std::max(difference, (N[i] - N_turned[i]).cwiseAbs().maxCoeff());
    scale = std::max(scale, N[i].cwiseAbs().maxCoeff());
  }
  return difference / scale;
}

// A last body symmetric about its joint's axis (arm7's and the iiwa's flange: centre of mass on the axis, isotropic
// inertia) leaves M and C independent of that joint: the searches drop it. A body that is not (arm6's wrist, the
// Panda's hand), or one moved off the axis by a millimetre, keeps it; the dynamics agree either way.
TEST(Model, ALastBodySymmetricAboutItsAxisTakesItsJointOutOfTheSearch) {
  const Eigen::VectorXd q7 = Eigen::VectorXd::LinSpaced(7, -2.0, 1.3);
  for (const char* file : {"arm7.urdf", "iiwa14.urdf"}) {
    const obsgain::Model arm = obsgain::load_robot({examples + "/" + file});
    EXPECT_EQ(obsgain::configuration_joints(arm), (std::vector<int>{1, 2, 3, 4, 5})) << file;
    EXPECT_LT(last_joint_effect(arm, q7, 2.9), 1e-14) << file;
  }
  obsgain::Model moved = obsgain::load_robot({examples + "/arm7.urdf"});
  std::get<obsgain::SerialChain>(moved.structure).bodies.back().com.x() = 1e-3;
  EXPECT_EQ(obsgain::configuration_joints(moved), (std::vector<int>{1, 2, 3, 4, 5, 6}));
  EXPECT_GT(last_joint_effect(moved, q7, 2.9), 1e-6);
  // About a tilted axis the test is not exact in floating point: the joint is kept, though the body is symmetric.
  obsgain::Model tilted = obsgain::load_robot({examples + "/arm7.urdf"});
  auto& flange = std::get<obsgain::SerialChain>(tilted.structure);
  flange.joints.back().axis = Eigen::Vector3d(0.0, 0.6, 0.8);
  flange.bodies.back().com = 0.02 * flange.joints.back().axis;
  EXPECT_EQ(obsgain::configuration_joints(tilted).size(), 6u);
  EXPECT_LT(last_joint_effect(tilted, q7, 2.9), 1e-14);
  const obsgain::Model panda = obsgain::load_robot({examples + "/panda.urdf"});
  EXPECT_EQ(obsgain::configuration_joints(panda).size(), 6u);
  EXPECT_GT(last_joint_effect(panda, q7, 2.9), 1e-6);
  const obsgain::Model arm6 = obsgain::load_robot({examples + "/arm6.urdf"});
  EXPECT_EQ(obsgain::configuration_joints(arm6), (std::vector<int>{1, 2, 3, 4, 5}));
  EXPECT_GT(last_joint_effect(arm6, Eigen::VectorXd::LinSpaced(6, -2.0, 1.3), 2.9), 1e-6);
}

// How far M and the Coriolis tensors at g q (q + π e_joint with the `flipped` joints' positions negated) are from
// S M'(q) S and s_i s_j s_l N'_i(q)_jl (S flipping `flipped`; M' and N' the `image` model's), relative to their
// largest entries, at `count` random configurations.
double half_turn_asymmetry(const obsgain::Model& model, const obsgain::Model& image, int joint,
                           const std::vector<int>& flipped, int count) {
  const int n = model.dof();
  Eigen::VectorXd s = Eigen::VectorXd::Ones(n);
  for (int j : flipped) s(j) = -1.0;
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  double worst = 0.0;
  for (int t = 0; t < count; ++t) {
    Eigen::VectorXd q(n);
    for (int k = 0; k < n; ++k) q(k) = angle(rng);
    Eigen::VectorXd turned = s.asDiagonal() * q;
    turned(joint) += std::numbers::pi;
    Eigen::MatrixXd M(n, n), M_turned(n, n);
    std::vector<Eigen::MatrixXd> N, N_turned;
    obsgain::mass_matrix(image, q, M);
    obsgain::mass_matrix(model, turned, M_turned);
    obsgain::coriolis_tensors(image, q, N);
    obsgain::coriolis_tensors(model, turned, N_turned);
    const auto relative = [](const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y) {
      return (X - Y).cwiseAbs().maxCoeff() / std::max(1e-300, Y.cwiseAbs().maxCoeff());
    };
    worst = std::max(worst, relative(M_turned, s.asDiagonal() * M * s.asDiagonal()));
    for (int i = 0; i < n; ++i)
      worst = std::max(worst, relative(N_turned[i], s(i) * (s.asDiagonal() * N[i] * s.asDiagonal())));
  }
  return worst;
}
double half_turn_asymmetry(const obsgain::Model& model, int joint, const std::vector<int>& flipped, int count) {
  return half_turn_asymmetry(model, model, joint, flipped, count);
}

// The model whose shoulder at q is `model`'s at q + π e_2: the second joint's placement R becomes H R D, H and D the
// half-turns about the coordinate axes R carries the joint's axis onto and the axis itself.
obsgain::Model shoulder_turned(obsgain::Model model) {
  obsgain::ChainJoint& joint = std::get<obsgain::SerialChain>(model.structure).joints[1];
  Eigen::Index own = 0, second = 0;
  joint.axis.cwiseAbs().maxCoeff(&own);
  joint.rotation.col(own).cwiseAbs().maxCoeff(&second);
  Eigen::Vector3d h = -Eigen::Vector3d::Ones(), d = -Eigen::Vector3d::Ones();
  h(second) = d(own) = 1.0;
  joint.rotation = h.asDiagonal() * joint.rotation * d.asDiagonal();
  return model;
}

// The UR5's and arm6's shoulder-lift axis meets the base axis at a right angle, and their last two bodies are half-turn
// symmetric about the fifth joint's axis, on which the last joint sits: a half-turn of the shoulder lift, of the fifth
// joint with the last one reflected, or of the last joint changes M and the Coriolis tensors by signs only (the first
// joint's, the last joint's, none), to the last bits, and the searched constants are invariant. The iiwa's, arm7's and
// Panda's shoulders are the same up to 4e-16 to 5e-12 in their placements' rotations: a half-turn gives the model with
// those entries' signs flipped, for any data, and not the model itself (the Panda's by more than 1e-13). Moving the
// shoulder off the base axis, tilting its axis out of the plane across the base axis by 1e-6, or coupling the first
// joint by friction loses the shoulder's symmetry; moving the last joint off the fifth's axis or coupling the two by
// friction loses the fifth's, and moving the last body's centre of mass loses both of the wrist's.
TEST(Model, HalfTurnSymmetriesAreTakenWhereTheyHoldUpToNegligibleEntries) {
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(6, -2.0, 1.3);
  for (const char* file : {"ur5.urdf", "arm6.urdf"}) {
    const obsgain::Model arm = obsgain::load_robot({examples + "/" + file});
    const std::vector<obsgain::HalfTurn> turns = obsgain::half_turn_symmetries(arm);
    ASSERT_EQ(turns.size(), 3u) << file;
    EXPECT_EQ(turns[0].joint, 1);
    EXPECT_EQ(turns[0].flipped, (std::vector<int>{0}));
    EXPECT_EQ(turns[1].joint, 4);
    EXPECT_EQ(turns[1].flipped, (std::vector<int>{5}));
    EXPECT_EQ(turns[2].joint, 5);
    EXPECT_TRUE(turns[2].flipped.empty());
    for (const obsgain::HalfTurn& turn : turns) {
      EXPECT_LT(half_turn_asymmetry(arm, turn.joint, turn.flipped, 20), 1e-13) << file << " joint " << turn.joint;
      Eigen::VectorXd turned = q;
      for (int j : turn.flipped) turned(j) = -turned(j);
      turned(turn.joint) += std::numbers::pi;
      const double L = obsgain::max_joint_lipschitz_norm(arm, q, arm.velocity_bounds, {});
      EXPECT_NEAR(obsgain::max_joint_lipschitz_norm(arm, turned, arm.velocity_bounds, {}), L, 1e-12 * L) << file;
      const double M0 = obsgain::inverse_inertia_norm(arm, q);
      EXPECT_NEAR(obsgain::inverse_inertia_norm(arm, turned), M0, 1e-12 * M0) << file;
    }
  }
  for (const char* file : {"iiwa14.urdf", "arm7.urdf", "panda.urdf"}) {
    const obsgain::Model arm = obsgain::load_robot({examples + "/" + file});
    const std::vector<obsgain::HalfTurn> turns = obsgain::half_turn_symmetries(arm);
    ASSERT_EQ(turns.size(), 1u) << file;
    EXPECT_EQ(turns[0].joint, 1);
    EXPECT_EQ(turns[0].flipped, (std::vector<int>{0}));
    EXPECT_LT(half_turn_asymmetry(arm, shoulder_turned(arm), 1, {0}, 20), 1e-13) << file;
  }
  EXPECT_GT(half_turn_asymmetry(obsgain::load_robot({examples + "/panda.urdf"}), 1, {0}, 5), 1e-13);
  obsgain::Model tilted = obsgain::load_robot({examples + "/iiwa14.urdf"});
  std::get<obsgain::SerialChain>(tilted.structure).joints[1].rotation(2, 2) = 1e-6;
  EXPECT_TRUE(obsgain::half_turn_symmetries(tilted).empty());
  EXPECT_LT(half_turn_asymmetry(tilted, shoulder_turned(tilted), 1, {0}, 5), 1e-13);  // an identity for any data
  EXPECT_GT(half_turn_asymmetry(tilted, 1, {0}, 5), 1e-8);
  EXPECT_TRUE(obsgain::half_turn_symmetries(obsgain::pendubot()).empty());
  obsgain::Model off_axis = obsgain::load_robot({examples + "/ur5.urdf"});
  std::get<obsgain::SerialChain>(off_axis.structure).joints[1].translation.x() = 1e-3;
  ASSERT_EQ(obsgain::half_turn_symmetries(off_axis).size(), 2u);
  EXPECT_EQ(obsgain::half_turn_symmetries(off_axis)[0].joint, 4);
  EXPECT_GT(half_turn_asymmetry(off_axis, 1, {0}, 5), 1e-6);
  obsgain::Model coupled = obsgain::load_robot({examples + "/ur5.urdf"});
  coupled.friction(0, 1) = coupled.friction(1, 0) = 0.1;
  ASSERT_EQ(obsgain::half_turn_symmetries(coupled).size(), 2u);
  EXPECT_EQ(obsgain::half_turn_symmetries(coupled)[0].joint, 4);
  obsgain::Model wrist_coupled = obsgain::load_robot({examples + "/ur5.urdf"});
  wrist_coupled.friction(4, 5) = wrist_coupled.friction(5, 4) = 0.1;
  ASSERT_EQ(obsgain::half_turn_symmetries(wrist_coupled).size(), 2u);
  EXPECT_EQ(obsgain::half_turn_symmetries(wrist_coupled)[1].joint, 5);
  obsgain::Model wrist_off_axis = obsgain::load_robot({examples + "/ur5.urdf"});
  std::get<obsgain::SerialChain>(wrist_off_axis.structure).joints[5].translation.x() = 1e-3;
  ASSERT_EQ(obsgain::half_turn_symmetries(wrist_off_axis).size(), 2u);
  EXPECT_EQ(obsgain::half_turn_symmetries(wrist_off_axis)[1].joint, 5);
  EXPECT_GT(half_turn_asymmetry(wrist_off_axis, 4, {5}, 5), 1e-6);
  obsgain::Model unbalanced = obsgain::load_robot({examples + "/ur5.urdf"});
  std::get<obsgain::SerialChain>(unbalanced.structure).bodies.back().com.x() = 1e-3;
  ASSERT_EQ(obsgain::half_turn_symmetries(unbalanced).size(), 1u);
  EXPECT_EQ(obsgain::half_turn_symmetries(unbalanced)[0].joint, 1);
  EXPECT_GT(half_turn_asymmetry(unbalanced, 5, {}, 5), 1e-6);
  EXPECT_GT(half_turn_asymmetry(unbalanced, 4, {5}, 5), 1e-6);
}

}  // namespace
