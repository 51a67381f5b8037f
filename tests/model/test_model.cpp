#include "obsgain/bounds/bounds.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"

#include "test_files.hpp"
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>

namespace {

using obsgain_test::examples;
using obsgain_test::write_temp_file;

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

// M and the Coriolis tensors at q and at q with joint `joint` moved to `value`, their largest difference relative to
// the largest entry.
double joint_effect(const obsgain::Model& model, Eigen::VectorXd q, int joint, double value) {
  const int n = model.dof();
  Eigen::MatrixXd M(n, n), M_moved(n, n);
  std::vector<Eigen::MatrixXd> N, N_moved;
  obsgain::mass_matrix(model, q, M);
  obsgain::coriolis_tensors(model, q, N);
  q(joint) = value;
  obsgain::mass_matrix(model, q, M_moved);
  obsgain::coriolis_tensors(model, q, N_moved);
  double difference = (M - M_moved).cwiseAbs().maxCoeff(), scale = M.cwiseAbs().maxCoeff();
  for (int i = 0; i < n; ++i) {
    difference = std::max(difference, (N[i] - N_moved[i]).cwiseAbs().maxCoeff());
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
    EXPECT_LT(joint_effect(arm, q7, 6, 2.9), 1e-14) << file;
  }
  obsgain::Model moved = obsgain::load_robot({examples + "/arm7.urdf"});
  std::get<obsgain::SerialChain>(moved.structure).bodies.back().com.x() = 1e-3;
  EXPECT_EQ(obsgain::configuration_joints(moved), (std::vector<int>{1, 2, 3, 4, 5, 6}));
  EXPECT_GT(joint_effect(moved, q7, 6, 2.9), 1e-6);
  // About a tilted axis the test is not exact in floating point: the joint is kept, though the body is symmetric.
  obsgain::Model tilted = obsgain::load_robot({examples + "/arm7.urdf"});
  auto& flange = std::get<obsgain::SerialChain>(tilted.structure);
  flange.joints.back().axis = Eigen::Vector3d(0.0, 0.6, 0.8);
  flange.bodies.back().com = 0.02 * flange.joints.back().axis;
  EXPECT_EQ(obsgain::configuration_joints(tilted).size(), 6u);
  EXPECT_LT(joint_effect(tilted, q7, 6, 2.9), 1e-14);
  const obsgain::Model panda = obsgain::load_robot({examples + "/panda.urdf"});
  EXPECT_EQ(obsgain::configuration_joints(panda).size(), 6u);
  EXPECT_GT(joint_effect(panda, q7, 6, 2.9), 1e-6);
  const obsgain::Model arm6 = obsgain::load_robot({examples + "/arm6.urdf"});
  EXPECT_EQ(obsgain::configuration_joints(arm6), (std::vector<int>{1, 2, 3, 4, 5}));
  EXPECT_GT(joint_effect(arm6, Eigen::VectorXd::LinSpaced(6, -2.0, 1.3), 5, 2.9), 1e-6);
}

// A SCARA as URDF: two turns about z, a quill sliding along `quill_axis`, a tool turning about z.
std::string scara_urdf(const std::string& quill_axis) {
  const auto link = [](const char* name, const char* com, const char* mass, const char* inertia) {
    return std::string("<link name=\"") + name + "\"><inertial><origin xyz=\"" + com + "\"/><mass value=\"" + mass +
           "\"/><inertia " + inertia + "/></inertial></link>";
  };
  const auto joint = [](const char* name, const char* type, const char* parent, const char* child, const char* at,
                        const std::string& axis, const char* limits) {
    return std::string("<joint name=\"") + name + "\" type=\"" + type + "\"><parent link=\"" + parent +
           "\"/><child link=\"" + child + "\"/><origin xyz=\"" + at + "\"/><axis xyz=\"" + axis +
           "\"/><limit " + limits + " effort=\"1\"/></joint>";
  };
  return "<robot name=\"scara\"><link name=\"base\"/>" +
         link("arm1", "0.2 0 0", "4", R"(ixx="0.01" iyy="0.06" izz="0.06" ixy="0" ixz="0" iyz="0")") +
         link("arm2", "0.15 0.01 0", "2.5", R"(ixx="0.005" iyy="0.03" izz="0.03" ixy="0.001" ixz="0" iyz="0")") +
         link("quill", "0 0 -0.1", "1", R"(ixx="0.004" iyy="0.004" izz="0.0005" ixy="0" ixz="0" iyz="0")") +
         link("tool", "0.01 0 -0.02", "0.5", R"(ixx="0.0005" iyy="0.0005" izz="0.0003" ixy="0" ixz="0" iyz="0")") +
         joint("j1", "revolute", "base", "arm1", "0 0 0.4", "0 0 1", R"(lower="-2.5" upper="2.5" velocity="3")") +
         joint("j2", "revolute", "arm1", "arm2", "0.4 0 0", "0 0 1", R"(lower="-2.6" upper="2.6" velocity="4")") +
         joint("j3", "prismatic", "arm2", "quill", "0.3 0 0", quill_axis, R"(lower="-0.2" upper="0" velocity="1")") +
         joint("j4", "revolute", "quill", "tool", "0 0 -0.2", "0 0 1", R"(lower="-6" upper="6" velocity="6")") +
         "</robot>";
}

// A joint that slides along the direction every turn before it is about moves the bodies after it where no turn sees
// them: M and C do not depend on it, and the searches drop it. Sliding along another direction, it is kept.
TEST(Model, AJointSlidingAlongEveryTurnBeforeItTakesItOutOfTheSearch) {
  const Eigen::VectorXd q = Eigen::Vector4d(0.3, -1.1, -0.05, 0.7);
  const obsgain::Model scara = obsgain::load_robot({write_temp_file("scara.urdf", scara_urdf("0 0 1"))});
  EXPECT_EQ(obsgain::configuration_joints(scara), (std::vector<int>{1, 3}));
  EXPECT_LT(joint_effect(scara, q, 2, -0.17), 1e-14);
  for (const char* axis : {"1 0 0", "0 0.6 0.8"}) {
    const obsgain::Model other = obsgain::load_robot({write_temp_file("scara_other.urdf", scara_urdf(axis))});
    EXPECT_EQ(obsgain::configuration_joints(other), (std::vector<int>{1, 2, 3})) << axis;
    EXPECT_GT(joint_effect(other, q, 2, -0.17), 1e-6) << axis;
  }
  // A gantry: every slide after the first is along a direction no turn sees; M is constant and nothing is searched.
  obsgain::Model gantry = scara;
  auto& chain = std::get<obsgain::SerialChain>(gantry.structure);
  for (int j = 0; j < 4; ++j) {
    chain.joints[static_cast<std::size_t>(j)].type = obsgain::JointType::prismatic;
    chain.joints[static_cast<std::size_t>(j)].axis = Eigen::Vector3d::Unit(j % 3);
  }
  EXPECT_TRUE(obsgain::configuration_joints(gantry).empty());
  for (int j = 0; j < 4; ++j) EXPECT_LT(joint_effect(gantry, q, j, 0.4), 1e-14) << j;
}

// g q: the `negated` joints' positions negated, then the `turned` ones' turned by π.
Eigen::VectorXd mapped(const obsgain::ChainSymmetry& g, Eigen::VectorXd q) {
  for (int j : g.negated) q(j) = -q(j);
  for (int j : g.turned) q(j) += std::numbers::pi;
  return q;
}

// The model whose M at q is `model`'s at g q up to P: each placement R_j becomes B R_j E, E what joint j's frame is
// mapped by and B what the body before it is (its joint's E, times the half-turn about that joint's axis where it is
// turned). That is R_j where the chain carries the maps exactly, and R_j with some negligible entries' signs flipped
// where it carries them only up to those.
obsgain::Model image_of(obsgain::Model model, const obsgain::ChainSymmetry& g) {
  auto& chain = std::get<obsgain::SerialChain>(model.structure);
  for (int j = 1; j < chain.dof(); ++j) {
    Eigen::Vector3d body = g.frames[static_cast<std::size_t>(j - 1)];
    if (g.turns(j - 1)) {
      Eigen::Index axis = 0;
      chain.joints[static_cast<std::size_t>(j - 1)].axis.cwiseAbs().maxCoeff(&axis);
      body = -body;
      body(axis) = -body(axis);
    }
    obsgain::ChainJoint& joint = chain.joints[static_cast<std::size_t>(j)];
    joint.rotation = body.asDiagonal() * joint.rotation * g.frames[static_cast<std::size_t>(j)].asDiagonal();
  }
  return model;
}

// How far M and the Coriolis tensors at g q are from P M'(q) P and p_i P N'_i(q) P (P = diag(±1) with -1 at the
// negated joints; M' and N' the `image` model's), relative to their largest entries, at `count` random configurations.
double asymmetry(const obsgain::Model& model, const obsgain::Model& image, const obsgain::ChainSymmetry& g, int count) {
  const int n = model.dof();
  Eigen::VectorXd p = Eigen::VectorXd::Ones(n);
  for (int j : g.negated) p(j) = -1.0;
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  double worst = 0.0;
  for (int t = 0; t < count; ++t) {
    Eigen::VectorXd q(n);
    for (int k = 0; k < n; ++k) q(k) = angle(rng);
    Eigen::MatrixXd M(n, n), M_mapped(n, n);
    std::vector<Eigen::MatrixXd> N, N_mapped;
    obsgain::mass_matrix(image, q, M);
    obsgain::mass_matrix(model, mapped(g, q), M_mapped);
    obsgain::coriolis_tensors(image, q, N);
    obsgain::coriolis_tensors(model, mapped(g, q), N_mapped);
    const auto relative = [](const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y) {
      return (X - Y).cwiseAbs().maxCoeff() / std::max(1e-300, Y.cwiseAbs().maxCoeff());
    };
    worst = std::max(worst, relative(M_mapped, p.asDiagonal() * M * p.asDiagonal()));
    for (int i = 0; i < n; ++i)
      worst = std::max(worst, relative(N_mapped[i], p(i) * (p.asDiagonal() * N[i] * p.asDiagonal())));
  }
  return worst;
}
double asymmetry(const obsgain::Model& model, const obsgain::ChainSymmetry& g, int count) {
  return asymmetry(model, model, g, count);
}

// A symmetry's joints: its negated ones, then -1, then its turned ones.
std::vector<int> joints_of(const obsgain::ChainSymmetry& g) {
  std::vector<int> joints = g.negated;
  joints.push_back(-1);
  joints.insert(joints.end(), g.turned.begin(), g.turned.end());
  return joints;
}
std::vector<std::vector<int>> joints_of(const std::vector<obsgain::ChainSymmetry>& symmetries) {
  std::vector<std::vector<int>> all;
  for (const obsgain::ChainSymmetry& g : symmetries) all.push_back(joints_of(g));
  return all;
}

// The UR5's and arm6's chains have four symmetries: the shoulder lift's half-turn (the first joint negated, which M
// does not see), the mirror image of the arm (the shoulder lift, elbow and first two wrist joints negated, the wrist's
// turned), a half-turn of the fifth joint (the last negated) and of the last. M, the Coriolis tensors and the searched
// constants keep their values up to P, to the last bits, for the UR5's mirror with M' (its file rounds π/2: its own M
// is off by more than 1e-13). The iiwa's, arm7's and Panda's shoulders are the same up to 4e-16 to 5e-12 in their
// placements' rotations: the shoulder's half-turn gives the model with those entries' signs flipped, for any data,
// and not the model itself (the Panda's by more than 1e-13).
TEST(Model, ChainSymmetriesHoldUpToNegligibleEntries) {
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(6, -2.0, 1.3);
  const std::vector<std::vector<int>> expected{{0, -1, 1}, {1, 2, 3, 4, -1, 3, 4}, {5, -1, 4}, {-1, 5}};
  for (const char* file : {"ur5.urdf", "arm6.urdf"}) {
    const obsgain::Model arm = obsgain::load_robot({examples + "/" + file});
    const std::vector<obsgain::ChainSymmetry> symmetries = obsgain::chain_symmetries(arm);
    ASSERT_EQ(joints_of(symmetries), expected) << file;
    for (const obsgain::ChainSymmetry& g : symmetries) {
      const obsgain::Model image = image_of(arm, g);
      EXPECT_LT(asymmetry(arm, image, g, 20), 1e-13) << file;
      const double L = obsgain::max_joint_lipschitz_norm(image, q, arm.velocity_bounds, {});
      EXPECT_NEAR(obsgain::max_joint_lipschitz_norm(arm, mapped(g, q), arm.velocity_bounds, {}), L, 1e-12 * L) << file;
      const double M0 = obsgain::inverse_inertia_norm(image, q);
      EXPECT_NEAR(obsgain::inverse_inertia_norm(arm, mapped(g, q)), M0, 1e-12 * M0) << file;
    }
    EXPECT_LT(asymmetry(arm, symmetries[0], 20), 1e-13) << file;
    EXPECT_LT(asymmetry(arm, symmetries[2], 20), 1e-13) << file;
  }
  const obsgain::Model ur5 = obsgain::load_robot({examples + "/ur5.urdf"});
  EXPECT_GT(asymmetry(ur5, obsgain::chain_symmetries(ur5)[1], 5), 1e-13);
  for (const char* file : {"iiwa14.urdf", "arm7.urdf", "panda.urdf"}) {
    const obsgain::Model arm = obsgain::load_robot({examples + "/" + file});
    const std::vector<obsgain::ChainSymmetry> symmetries = obsgain::chain_symmetries(arm);
    ASSERT_EQ(joints_of(symmetries), (std::vector<std::vector<int>>{{0, -1, 1}})) << file;
    EXPECT_LT(asymmetry(arm, image_of(arm, symmetries[0]), symmetries[0], 20), 1e-13) << file;
  }
  const obsgain::Model panda = obsgain::load_robot({examples + "/panda.urdf"});
  EXPECT_GT(asymmetry(panda, obsgain::chain_symmetries(panda)[0], 5), 1e-13);
  // arm3: the shoulder lift's turn with P = I (its M has no first row off the diagonal), and its mirror.
  const obsgain::Model arm3 = obsgain::load_robot({examples + "/arm3.urdf"});
  ASSERT_EQ(joints_of(obsgain::chain_symmetries(arm3)), (std::vector<std::vector<int>>{{-1, 1}, {1, 2, -1}}));
  for (const obsgain::ChainSymmetry& g : obsgain::chain_symmetries(arm3)) EXPECT_LT(asymmetry(arm3, g, 20), 1e-13);
  EXPECT_TRUE(obsgain::chain_symmetries(obsgain::pendubot()).empty());
}

// Breaking the data breaks the symmetries that rest on them, and only those: tilting the iiwa's shoulder axis by 1e-6
// out of the plane across the base axis (its image is still an identity for any data, but not its own), moving the
// UR5's shoulder or last joint, or its last body's centre of mass, by a millimetre, or coupling joints by friction.
// Where another map still holds it is taken instead: the last body off its axis keeps a half-turn of the fifth joint
// with the last turned too, and friction between the first two joints or the last two a mirror that negates both.
TEST(Model, ChainSymmetriesAreNotTakenWhereTheDataBreakThem) {
  const obsgain::Model iiwa = obsgain::load_robot({examples + "/iiwa14.urdf"});
  obsgain::Model tilted = iiwa;
  std::get<obsgain::SerialChain>(tilted.structure).joints[1].rotation(2, 2) = 1e-6;
  EXPECT_TRUE(obsgain::chain_symmetries(tilted).empty());
  const obsgain::ChainSymmetry shoulder = obsgain::chain_symmetries(iiwa)[0];
  EXPECT_LT(asymmetry(tilted, image_of(tilted, shoulder), shoulder, 5), 1e-13);
  EXPECT_GT(asymmetry(tilted, shoulder, 5), 1e-8);
  const obsgain::Model ur5 = obsgain::load_robot({examples + "/ur5.urdf"});
  const std::vector<obsgain::ChainSymmetry> all = obsgain::chain_symmetries(ur5);
  const std::vector<int> turn_2{0, -1, 1}, mirror{1, 2, 3, 4, -1, 3, 4}, turn_5{5, -1, 4}, turn_6{-1, 5};
  const auto expect_left = [](const obsgain::Model& broken, const std::vector<std::vector<int>>& left) {
    const std::vector<obsgain::ChainSymmetry> symmetries = obsgain::chain_symmetries(broken);
    EXPECT_EQ(joints_of(symmetries), left);
    for (const obsgain::ChainSymmetry& g : symmetries) EXPECT_LT(asymmetry(broken, image_of(broken, g), g, 5), 1e-13);
  };
  obsgain::Model off_axis = ur5;
  std::get<obsgain::SerialChain>(off_axis.structure).joints[1].translation.x() = 1e-3;
  expect_left(off_axis, {mirror, turn_5, turn_6});
  EXPECT_GT(asymmetry(off_axis, all[0], 5), 1e-6);
  obsgain::Model wrist_off_axis = ur5;
  std::get<obsgain::SerialChain>(wrist_off_axis.structure).joints[5].translation.x() = 1e-3;
  expect_left(wrist_off_axis, {turn_2, mirror, turn_6});
  EXPECT_GT(asymmetry(wrist_off_axis, all[2], 5), 1e-6);
  obsgain::Model unbalanced = ur5;
  std::get<obsgain::SerialChain>(unbalanced.structure).bodies.back().com.x() = 1e-3;
  expect_left(unbalanced, {turn_2, mirror, {5, -1, 4, 5}});
  for (int k : {2, 3}) EXPECT_GT(asymmetry(unbalanced, all[static_cast<std::size_t>(k)], 5), 1e-6);
  obsgain::Model coupled = ur5;
  coupled.friction(0, 1) = coupled.friction(1, 0) = 0.1;
  expect_left(coupled, {{0, 1, 2, 3, 4, -1, 1, 3, 4}, turn_5, turn_6});
  obsgain::Model wrist_coupled = ur5;
  wrist_coupled.friction(4, 5) = wrist_coupled.friction(5, 4) = 0.1;
  expect_left(wrist_coupled, {turn_2, {1, 2, 3, 4, 5, -1, 3}, turn_6});
}

}  // namespace
