// The chain dynamics (composite-rigid-body and bilinear Newton–Euler, templated on the scalar) against KDL, an
// independent implementation; and the URDF quirks of real arms (fixed frames, fixed side
// branches, grippers with mimic fingers, a published hand's revolute fingers, Drake transmissions).
#include "test_files.hpp"
#include "obsgain/design/design.hpp"
#include "obsgain/parsers/robots.hpp"
#include "obsgain/model/dynamics.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <kdl/chaindynparam.hpp>
#include <kdl/tree.hpp>
#include <kdl/treeidsolver_recursive_newton_euler.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <urdf_parser/urdf_parser.h>

#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <sstream>

namespace {

using obsgain_test::read_text;
using obsgain_test::write_temp_file;

using obsgain_test::examples;

// KDL's tree of the file.
KDL::Tree kdl_tree(const std::string& path) {
  const urdf::ModelInterfaceSharedPtr robot = urdf::parseURDF(read_text(path));
  robot->root_link_->inertial.reset();  // the fixed world; kdl_parser would only warn about it
  KDL::Tree tree;
  EXPECT_TRUE(kdl_parser::treeFromUrdfModel(*robot, tree));
  return tree;
}

// KDL's chain from the file's root to `tip`, gravity -9.81 z.
struct KdlReference {
  KDL::Tree tree;
  KDL::Chain chain;
  std::unique_ptr<KDL::ChainDynParam> solver;
  KdlReference(const std::string& path, const std::string& tip) : tree(kdl_tree(path)) {
    EXPECT_TRUE(tree.getChain(tree.getRootSegment()->first, tip, chain));
    solver = std::make_unique<KDL::ChainDynParam>(chain, KDL::Vector(0.0, 0.0, -9.81));
  }
};

// M, the Coriolis forces and gravity at (q, v) against KDL's, to 1e-12 of their size; `context` names the case.
void expect_agrees_with_kdl(const obsgain::Model& model, KdlReference& kdl, const KDL::JntArray& q,
                            const KDL::JntArray& v, const std::string& context) {
  const int n = model.dof();
  KDL::JntArray out(n);
  KDL::JntSpaceInertiaMatrix M_kdl(n);
  kdl.solver->JntToMass(q, M_kdl);
  Eigen::MatrixXd M(n, n);
  obsgain::mass_matrix(model, q.data, M);
  EXPECT_LE((M - M_kdl.data).norm(), 1e-12 * M_kdl.data.norm()) << context;
  kdl.solver->JntToCoriolis(q, v, out);
  Eigen::VectorXd A(n);
  obsgain::coriolis(model, q.data, v.data, A);
  EXPECT_LE((A - out.data).norm(), 1e-12 * (out.data.norm() + M.norm())) << context;
  kdl.solver->JntToGravity(q, out);
  Eigen::VectorXd g(n);
  obsgain::gravity(model, q.data, g);
  EXPECT_LE((g - out.data).norm(), 1e-12 * (out.data.norm() + 1.0)) << context;
}

// A shipped file, KDL's tip, and where to cut the file's text (empty: nowhere): KDL's chain has no side branches,
// so an arm whose hand carries fingers is compared without them (their lumping: UrdfQuirks below).
struct KdlCase {
  const char* file;
  const char* tip;
  const char* branches_from = "";
};

// Named by its file in the test's output.
void PrintTo(const KdlCase& c, std::ostream* out) { *out << c.file; }

// The file, or its text up to `branches_from` closed as a robot, written apart.
std::string kdl_case_path(const KdlCase& c) {
  const std::string path = examples + "/" + c.file;
  if (std::string(c.branches_from).empty()) return path;
  const std::string text = read_text(path);
  const std::size_t cut = text.find(c.branches_from);
  EXPECT_NE(cut, std::string::npos) << c.branches_from;
  return write_temp_file(std::string("without_branches_") + c.file, text.substr(0, cut) + "</robot>\n");
}

class ChainAgainstKdl : public ::testing::TestWithParam<KdlCase> {};

TEST_P(ChainAgainstKdl, MassCoriolisAndGravityAgreeTo1e12) {
  const char* file = GetParam().file;
  const char* tip = GetParam().tip;
  const std::string path = kdl_case_path(GetParam());
  // KDL knows no rotor inertia: compare the rigid bodies alone.
  const int dof = obsgain::load_robot({path}).dof();
  const obsgain::Model model = obsgain::load_robot({path, "", "", {}, std::vector<double>(dof, 0.0)});
  KdlReference kdl(path, tip);
  const int n = model.dof();
  ASSERT_EQ(static_cast<int>(kdl.chain.getNrOfJoints()), n);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), speed(-3.0, 3.0);
  for (int trial = 0; trial < 20; ++trial) {
    KDL::JntArray q(n), v(n);
    for (int i = 0; i < n; ++i) {
      q(i) = angle(rng);
      v(i) = speed(rng);
    }
    expect_agrees_with_kdl(model, kdl, q, v, file);
  }
}

INSTANTIATE_TEST_SUITE_P(ShippedArms, ChainAgainstKdl,
                         ::testing::Values(KdlCase{"pendubot.urdf", "link2"}, KdlCase{"arm3.urdf", "forearm"},
                                           KdlCase{"arm6.urdf", "wrist_3_link"}, KdlCase{"arm7.urdf", "link7"},
                                           // Kinova's description: its wrist's 60° joints, rotations of 3.1415 rad
                                           KdlCase{"jaco2.urdf", "j2n6s300_link_6",
                                                   "<joint name=\"j2n6s300_joint_finger_1\""}),
                         [](const auto& info) {
                           const std::string file = info.param.file;
                           return file.substr(0, file.find('.'));
                         });

// Random chains of 1-7 joints, as a reviewer would write them: revolute, continuous and prismatic joints with origins
// turned by any roll, pitch and yaw, axes of any direction and length (URDF normalises them), and bodies whose inertial
// frames are turned too (the inertia tensor is given in the turned frame) and whose centres lie off every axis.
std::string random_chain_urdf(std::mt19937_64& rng, int joints) {
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), offset(-0.4, 0.4),
      unit(0.0, 1.0);
  const auto triple = [&](auto& distribution) {
    return fmt::format("{:.17g} {:.17g} {:.17g}", distribution(rng), distribution(rng), distribution(rng));
  };
  std::string text = "<?xml version=\"1.0\"?>\n<robot name=\"random\">\n  <link name=\"l0\"/>\n";
  const char* types[] = {"revolute", "continuous", "prismatic"};
  for (int j = 1; j <= joints; ++j) {
    const double m = 0.2 + 3.0 * unit(rng);
    // A positive definite tensor that satisfies the triangle inequality: principal moments a + b >= c.
    const double a = 0.01 + 0.05 * unit(rng), b = 0.01 + 0.05 * unit(rng);
    const double c = std::abs(a - b) + (a + b - std::abs(a - b)) * unit(rng);
    text += fmt::format("  <link name=\"l{}\"><inertial><origin xyz=\"{}\" rpy=\"{}\"/><mass value=\"{:.17g}\"/>"
                        "<inertia ixx=\"{:.17g}\" ixy=\"0\" ixz=\"0\" iyy=\"{:.17g}\" iyz=\"0\" izz=\"{:.17g}\"/>"
                        "</inertial></link>\n",
                        j, triple(offset), triple(angle), m, a, b, c);
    const char* type = types[rng() % 3];
    const std::string axis = fmt::format("{:.17g} {:.17g} {:.17g}", offset(rng), offset(rng), 0.05 + unit(rng));
    text += fmt::format("  <joint name=\"j{}\" type=\"{}\"><parent link=\"l{}\"/><child link=\"l{}\"/>"
                        "<origin xyz=\"{}\" rpy=\"{}\"/><axis xyz=\"{}\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
                        "velocity=\"1\"/></joint>\n",
                        j, type, j - 1, j, triple(offset), triple(angle), axis);
  }
  return text + "</robot>\n";
}

TEST(RandomChainsAgainstKdl, TurnedFramesAndPrismaticJointsAgreeTo1e12) {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> position(-1.0, 1.0), speed(-3.0, 3.0);
  for (int chain = 0; chain < 30; ++chain) {
    const int n = 1 + chain % 7;
    const std::string path = write_temp_file("random_chain.urdf", random_chain_urdf(rng, n));
    const obsgain::Model model = obsgain::load_robot({path, "", "", {}, std::vector<double>(n, 0.0)});
    KdlReference kdl(path, fmt::format("l{}", n));
    ASSERT_EQ(model.dof(), n) << read_text(path);
    ASSERT_EQ(static_cast<int>(kdl.chain.getNrOfJoints()), n);
    for (int trial = 0; trial < 5; ++trial) {
      KDL::JntArray q(n), v(n);
      for (int i = 0; i < n; ++i) {
        q(i) = position(rng);
        v(i) = speed(rng);
      }
      expect_agrees_with_kdl(model, kdl, q, v, read_text(path));
    }
  }
}

// A body in pieces — a link, a tool flange on a fixed joint, a fixed side branch (a sensor), and a gripper
// whose two fingers are a prismatic joint and its <mimic> — must have the dynamics of the one body summed
// by hand.
const char* kPiecesUrdf = R"(<?xml version="1.0"?>
<robot name="pieces">
  <link name="world"/>
  <joint name="j1" type="revolute"><parent link="world"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 0.1"/><mass value="2"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.01"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="sensor_mount" type="fixed"><parent link="l2"/><child link="sensor"/><origin xyz="0.1 0.05 0"/></joint>
  <link name="sensor"><inertial><mass value="0.2"/>
    <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial></link>
  <joint name="flange" type="fixed"><parent link="l2"/><child link="hand"/><origin xyz="0.4 0 0"/></joint>
  <link name="hand"><inertial><mass value="0.5"/>
    <inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.0005" iyz="0" izz="0.0005"/></inertial></link>
  <joint name="finger_left" type="prismatic"><parent link="hand"/><child link="left"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="0.2"/></joint>
  <link name="left"><inertial><mass value="0.1"/>
    <inertia ixx="0.00001" ixy="0" ixz="0" iyy="0.00001" iyz="0" izz="0.00001"/></inertial></link>
  <joint name="finger_right" type="prismatic"><parent link="hand"/><child link="right"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="0.2"/><mimic joint="finger_left"/></joint>
  <link name="right"><inertial><mass value="0.1"/>
    <inertia ixx="0.00001" ixy="0" ixz="0" iyy="0.00001" iyz="0" izz="0.00001"/></inertial></link>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="m1"><drake:gear_ratio value="100"/><drake:rotor_inertia value="0.0001"/></actuator></transmission>
  <transmission name="t2"><type>transmission_interface/SimpleTransmission</type>
    <joint name="j2"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="m2"><drake:gear_ratio value="50"/><drake:rotor_inertia value="0.0002"/></actuator></transmission>
</robot>)";

// The same second body summed by hand: point masses and own inertias moved to the common centre of mass
// (the fingers locked at the middle of their range, 0.02 m, one each way).
std::string hand_summed_urdf() {
  struct Part {
    double m;
    Eigen::Vector3d c;
    double I;  // isotropic own inertia, or the l2 link's diagonal below
  };
  const std::vector<Part> parts = {{0.2, {0.1, 0.05, 0}, 0.0001}, {0.5, {0.4, 0, 0}, 0.0005},
                                   {0.1, {0.4, 0.02, 0}, 0.00001}, {0.1, {0.4, -0.02, 0}, 0.00001}};
  double mass = 1.0;
  Eigen::Vector3d moment = Eigen::Vector3d(0.2, 0, 0);
  for (const auto& p : parts) {
    mass += p.m;
    moment += p.m * p.c;
  }
  const Eigen::Vector3d com = moment / mass;
  const auto shift = [](double m, const Eigen::Vector3d& d) {
    return Eigen::Matrix3d(m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose()));
  };
  Eigen::Matrix3d I = Eigen::Vector3d(0.001, 0.01, 0.01).asDiagonal();
  I += shift(1.0, Eigen::Vector3d(0.2, 0, 0) - com);
  for (const auto& p : parts) I += p.I * Eigen::Matrix3d::Identity() + shift(p.m, p.c - com);
  std::string text = kPiecesUrdf;
  const auto begin = text.find("<joint name=\"sensor_mount\"");
  const auto end = text.find("<transmission");
  text.replace(begin, end - begin, "");
  const std::string l2 = fmt::format(
      R"(<link name="l2"><inertial><origin xyz="{:.17g} {:.17g} {:.17g}"/><mass value="{:.17g}"/>
    <inertia ixx="{:.17g}" ixy="{:.17g}" ixz="{:.17g}" iyy="{:.17g}" iyz="{:.17g}" izz="{:.17g}"/></inertial></link>
  )",
      com.x(), com.y(), com.z(), mass, I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2));
  const auto l2_begin = text.find("<link name=\"l2\">");
  const auto l2_end = text.find("</link>", l2_begin) + 7;
  text.replace(l2_begin, l2_end - l2_begin, l2);
  return text;
}

// KDL's inverse dynamics of the whole tree, `locked` joints held at their positions and at rest: the torques at the
// other joints, in `joints` order, for (q, v, a) and gravity `g`.
struct KdlTree {
  KDL::Tree tree;
  std::map<std::string, unsigned> index;  // joint name -> KDL's q number
  explicit KdlTree(const std::string& path) : tree(kdl_tree(path)) {
    for (const auto& [name, element] : tree.getSegments())
      if (GetTreeElementSegment(element).getJoint().getType() != KDL::Joint::None)
        index[GetTreeElementSegment(element).getJoint().getName()] = GetTreeElementQNr(element);
  }
  Eigen::VectorXd torques(const std::vector<std::string>& joints, const std::map<std::string, double>& locked,
                          const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& a, double g) {
    const unsigned all = tree.getNrOfJoints();
    KDL::JntArray Q(all), V(all), A(all), tau(all);
    for (const auto& [name, position] : locked) Q(index.at(name)) = position;
    for (std::size_t j = 0; j < joints.size(); ++j) {
      Q(index.at(joints[j])) = q(static_cast<Eigen::Index>(j));
      V(index.at(joints[j])) = v(static_cast<Eigen::Index>(j));
      A(index.at(joints[j])) = a(static_cast<Eigen::Index>(j));
    }
    KDL::TreeIdSolver_RNE solver(tree, KDL::Vector(0.0, 0.0, -g));
    EXPECT_GE(solver.CartToJnt(Q, V, A, KDL::WrenchMap{}, tau), 0);
    Eigen::VectorXd out(static_cast<Eigen::Index>(joints.size()));
    for (std::size_t j = 0; j < joints.size(); ++j) out(static_cast<Eigen::Index>(j)) = tau(index.at(joints[j]));
    return out;
  }
};

TEST(UrdfQuirks, TheJacosFingersAreLumpedAsKdlsTreeMovesThemLocked) {
  // Kinova's description carries three revolute fingers on the hand, without <mimic>: the loader locks them at the
  // middle of their range (1 rad) and lumps them into the hand. KDL's tree solver, which moves every body of the tree,
  // must give the same M, C(q, v) v and g at the arm's joints with the fingers held there. Without the fingers the
  // hand would differ by 0.1 in M (the ChainAgainstKdl case above compares the arm without them).
  const std::string path = examples + "/jaco2.urdf";
  const obsgain::Model model = obsgain::load_robot({path, "", "", {}, std::vector<double>(6, 0.0)});
  ASSERT_EQ(model.dof(), 6);
  std::vector<std::string> joints;
  for (int j = 1; j <= 6; ++j) joints.push_back(fmt::format("j2n6s300_joint_{}", j));
  std::map<std::string, double> fingers;
  for (int k = 1; k <= 3; ++k) fingers[fmt::format("j2n6s300_joint_finger_{}", k)] = 1.0;
  KdlTree kdl(path);
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), speed(-1.0, 1.0);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(6);
  for (int trial = 0; trial < 10; ++trial) {
    Eigen::VectorXd q(6), v(6);
    for (int i = 0; i < 6; ++i) {
      q(i) = angle(rng);
      v(i) = speed(rng);
    }
    Eigen::MatrixXd M(6, 6), M_kdl(6, 6);
    obsgain::mass_matrix(model, q, M);
    for (int j = 0; j < 6; ++j) M_kdl.col(j) = kdl.torques(joints, fingers, q, zero, Eigen::VectorXd::Unit(6, j), 0.0);
    EXPECT_LE((M - M_kdl).norm(), 1e-12 * M_kdl.norm());
    Eigen::VectorXd A(6), g(6);
    obsgain::coriolis(model, q, v, A);
    const Eigen::VectorXd A_kdl = kdl.torques(joints, fingers, q, v, zero, 0.0);
    EXPECT_LE((A - A_kdl).norm(), 1e-12 * (A_kdl.norm() + M.norm()));
    obsgain::gravity(model, q, g);
    const Eigen::VectorXd g_kdl = kdl.torques(joints, fingers, q, zero, zero, 9.81);
    EXPECT_LE((g - g_kdl).norm(), 1e-12 * (g_kdl.norm() + 1.0));
  }
}

TEST(UrdfQuirks, FixedFramesSideBranchesAndMimicFingersAreLumpedIntoOneBody) {
  const obsgain::Model pieces = obsgain::load_robot({write_temp_file("pieces.urdf", kPiecesUrdf), "", "", {}, {0.0, 0.0}});
  const obsgain::Model summed = obsgain::load_robot({write_temp_file("summed.urdf", hand_summed_urdf()), "", "", {}, {0.0, 0.0}});
  ASSERT_EQ(pieces.dof(), 2);  // the fingers are a gripper: locked, not chain joints
  for (const Eigen::Vector2d q : {Eigen::Vector2d(0.3, -1.0), Eigen::Vector2d(-2.0, 1.7)}) {
    Eigen::MatrixXd Mp(2, 2), Ms(2, 2);
    obsgain::mass_matrix(pieces, q, Mp);
    obsgain::mass_matrix(summed, q, Ms);
    EXPECT_LE((Mp - Ms).norm(), 1e-13 * Ms.norm()) << q.transpose();
    Eigen::VectorXd gp(2), gs(2);
    obsgain::gravity(pieces, q, gp);
    obsgain::gravity(summed, q, gs);
    EXPECT_LE((gp - gs).norm(), 1e-13 * gs.norm()) << q.transpose();
  }
  std::string notes;
  for (const auto& note : pieces.notes) notes += note + "\n";
  EXPECT_NE(notes.find("'finger_left' at 0.02"), std::string::npos) << notes;
  EXPECT_NE(notes.find("'finger_right' at 0.02"), std::string::npos) << notes;
  EXPECT_NE(notes.find("taken as a gripper"), std::string::npos) << notes;
}

TEST(UrdfQuirks, DrakeTransmissionsPutReflectedRotorInertiaOnTheDiagonal) {
  const std::string path = write_temp_file("pieces.urdf", kPiecesUrdf);
  const obsgain::Model with = obsgain::load_robot({path});
  const obsgain::Model without = obsgain::load_robot({path, "", "", {}, {0.0, 0.0}});
  ASSERT_EQ(obsgain::armature(with).size(), 2);
  EXPECT_DOUBLE_EQ(obsgain::armature(with)(0), 100.0 * 100.0 * 0.0001);  // 1 kg m²
  EXPECT_DOUBLE_EQ(obsgain::armature(with)(1), 50.0 * 50.0 * 0.0002);    // 0.5 kg m²
  const Eigen::Vector2d q(0.4, 0.9);
  Eigen::MatrixXd M_with(2, 2), M_without(2, 2);
  obsgain::mass_matrix(with, q, M_with);
  obsgain::mass_matrix(without, q, M_without);
  EXPECT_LE((M_with - M_without - Eigen::Matrix2d(Eigen::Vector2d(1.0, 0.5).asDiagonal())).norm(), 1e-14);
  const obsgain::Model overridden = obsgain::load_robot({path, "", "", {}, {0.25, 0.125}});
  Eigen::MatrixXd M_overridden(2, 2);
  obsgain::mass_matrix(overridden, q, M_overridden);
  EXPECT_LE((M_overridden - M_without - Eigen::Matrix2d(Eigen::Vector2d(0.25, 0.125).asDiagonal())).norm(), 1e-14);
  std::string notes;
  for (const auto& note : with.notes) notes += note;
  EXPECT_NE(notes.find("drake:rotor_inertia"), std::string::npos) << notes;
}

TEST(UrdfQuirks, DefaultChainIgnoresFixedLeavesAndRefusesSeveralArms) {
  // Fixed frames below the tip (UR-style ee_link and tool0) are leaves that change nothing.
  std::string frames = kPiecesUrdf;
  frames.replace(frames.find("</robot>"), 8, R"(<joint name="tool0_joint" type="fixed"><parent link="hand"/><child link="tool0"/>
    <origin xyz="0 0 0.1"/></joint><link name="tool0"/></robot>)");
  EXPECT_EQ(obsgain::load_robot({write_temp_file("frames.urdf", frames)}).dof(), 2);
  // Two long movable branches are two arms: the user must choose, and the error names the candidates.
  std::string two_arms = R"(<?xml version="1.0"?><robot name="dual"><link name="torso"/>)";
  for (const char* side : {"left", "right"}) {
    std::string parent = "torso";
    for (int i = 1; i <= 4; ++i) {
      const std::string link = fmt::format("{}_{}", side, i);
      two_arms += fmt::format(R"(<joint name="{0}_j" type="continuous"><parent link="{1}"/><child link="{0}"/>
        <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/></joint><link name="{0}"><inertial><mass value="1"/>
        <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>)",
                              link, parent);
      parent = link;
    }
  }
  two_arms += "</robot>";
  try {
    obsgain::load_robot({write_temp_file("two_arms.urdf", two_arms)});
    ADD_FAILURE() << "two arms need --tip-link";
  } catch (const obsgain::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--tip-link"), std::string::npos) << what;
    EXPECT_NE(what.find("left_4, right_4"), std::string::npos) << what;
  }
  EXPECT_EQ(obsgain::load_robot({write_temp_file("two_arms.urdf", two_arms), "", "left_4", {}}).dof(), 4);
}

}  // namespace

namespace {

// The one-line refusal load_robot gives for `source` ("" and a failure where it loads).
std::string load_refusal(const obsgain::RobotSource& source) {
  try {
    obsgain::load_robot(source);
  } catch (const obsgain::InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << source.robot << " loaded";
  return "";
}

// A CAD export: limits 0/0 and velocity 0. Refused naming the joint, the attribute and the override; accepted
// with --joint-limits and --vmax.
TEST(UrdfQuirks, CadLimitsAreRefusedNamingTheJointAndTheOverride) {
  std::string cad = kPiecesUrdf;
  const std::string limit = R"(<limit lower="-2" upper="2" effort="10" velocity="3"/>)";
  cad.replace(cad.find(limit), limit.size(), R"(<limit lower="0" upper="0" effort="0" velocity="0"/>)");
  const std::string path = write_temp_file("cad.urdf", cad);
  const std::string refusal = load_refusal({path});
  EXPECT_NE(refusal.find("joint 'j2' has <limit lower=\"0\" upper=\"0\">"), std::string::npos) << refusal;
  EXPECT_NE(refusal.find("--joint-limits"), std::string::npos) << refusal;
  obsgain::RobotSource source{path};
  source.joint_limits = {obsgain::JointDomain{}, obsgain::JointDomain{obsgain::JointType::revolute, false, -1.5, 1.5}};
  const obsgain::Model model = obsgain::load_robot(source);
  EXPECT_TRUE(model.joints[0].continuous);  // "c": the full circle, whatever the file says
  EXPECT_DOUBLE_EQ(model.joints[1].lower, -1.5);
  EXPECT_EQ(model.velocity_bounds.size(), 0);
  EXPECT_NE(model.missing_velocity_bounds.find("joint 'j2' has <limit velocity=\"0\">"), std::string::npos)
      << model.missing_velocity_bounds;
  obsgain::DesignOptions options;
  options.gamma = 2.0;
  options.bound_method = obsgain::BoundMethod::numeric;
  try {
    obsgain::design_gains(model, options);
    ADD_FAILURE() << "no velocity bounds: --vmax is needed";
  } catch (const obsgain::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("joint 'j2' has <limit velocity=\"0\">"), std::string::npos) << what;
    EXPECT_NE(what.find("--vmax"), std::string::npos) << what;
  }
  options.velocity_bounds = Eigen::Vector2d(2.0, 3.0);
  EXPECT_TRUE(obsgain::design_gains(model, options).selected().observer.certified);
}

// A continuous joint without a <limit> element (the RRBot of gazebo_ros_demos): the note says it has none, not that
// it declares a velocity of 0.
TEST(UrdfQuirks, AJointWithoutALimitIsNamedAsHavingNone) {
  std::string urdf = kPiecesUrdf;
  const std::string j1 = R"(<joint name="j1" type="revolute">)", limit = R"(<limit lower="-3" upper="3" effort="10" velocity="2"/>)";
  urdf.replace(urdf.find(j1), j1.size(), R"(<joint name="j1" type="continuous">)");
  urdf.replace(urdf.find(limit), limit.size(), "");
  const obsgain::Model model = obsgain::load_robot({write_temp_file("no_limit.urdf", urdf)});
  EXPECT_TRUE(model.joints[0].continuous);
  EXPECT_EQ(model.velocity_bounds.size(), 0);
  EXPECT_EQ(model.missing_velocity_bounds, "joint 'j1' has no <limit>");
}

// A chain ending at a finger makes the finger's joint a chain joint, and its <mimic> moves with it: locking the mimic
// would leave its motion out of M. Refused, naming both joints and --tip-link; ending at the hand locks both. A mimic
// of a mimic follows its master's master: refused where that is a chain joint, naming the joint between, and locked
// where it is not, through both multipliers and offsets (the left finger at 0.02, the middle one at 0.02, the right
// one at 2 * 0.02 + 0.001). A mimic of a joint the file does not have, or a loop of mimics, has no position: refused.
TEST(UrdfQuirks, AMimicOfAChainJointDirectlyOrThroughAnotherIsRefused) {
  std::string chained = kPiecesUrdf;
  const std::string mimic = R"(<mimic joint="finger_left"/>)";
  chained.replace(chained.find(mimic), mimic.size(), R"(<mimic joint="finger_z_middle" multiplier="2" offset="0.001"/>)");
  chained.insert(chained.find("<transmission"), R"(<joint name="finger_z_middle" type="prismatic"><parent link="hand"/>
    <child link="middle"/><axis xyz="0 0 1"/><limit lower="0" upper="0.04" effort="10" velocity="0.2"/>
    <mimic joint="finger_left"/></joint>
  <link name="middle"><inertial><mass value="0.1"/>
    <inertia ixx="0.00001" ixy="0" ixz="0" iyy="0.00001" iyz="0" izz="0.00001"/></inertial></link>
  )");
  // urdfdom lists a link's child joints by name: finger_right is checked before finger_z_middle.
  const std::pair<std::string, const char*> cases[] = {
      {write_temp_file("pieces.urdf", kPiecesUrdf), "(<mimic>): a joint coupled to the chain is not modelled; end the "
                                                    "chain above 'finger_left' with --tip-link"},
      {write_temp_file("chained_mimic.urdf", chained), "(<mimic>, through 'finger_z_middle'): a joint coupled"}};
  for (const auto& [path, how] : cases) {
    obsgain::RobotSource finger{path};
    finger.tip_link = "left";
    const std::string refusal = load_refusal(finger);
    EXPECT_NE(refusal.find(std::string("joint 'finger_right' follows the chain joint 'finger_left' ") + how),
              std::string::npos)
        << refusal;
    obsgain::RobotSource hand{path};
    hand.tip_link = "hand";
    EXPECT_EQ(obsgain::load_robot(hand).dof(), 2);
  }
  obsgain::RobotSource hand{cases[1].first};
  hand.tip_link = "hand";
  std::string notes;
  for (const auto& note : obsgain::load_robot(hand).notes) notes += note + "\n";
  EXPECT_NE(notes.find("'finger_left' at 0.02, 'finger_right' at 0.041, 'finger_z_middle' at 0.02"), std::string::npos)
      << notes;
  std::string loop = chained, missing = chained;
  loop.replace(loop.find(mimic), mimic.size(), R"(<mimic joint="finger_right"/>)");
  missing.replace(missing.find(mimic), mimic.size(), R"(<mimic joint="finger_nowhere"/>)");
  std::string refusal = load_refusal({write_temp_file("mimic_loop.urdf", loop)});
  EXPECT_NE(refusal.find("joint 'finger_right' follows a loop of <mimic> joints (<mimic>, through 'finger_z_middle'): "
                         "it has no position to be locked at"),
            std::string::npos)
      << refusal;
  refusal = load_refusal({write_temp_file("mimic_missing.urdf", missing)});
  EXPECT_NE(refusal.find("joint 'finger_z_middle' has <mimic joint=\"finger_nowhere\">, which names no joint of the file"),
            std::string::npos)
      << refusal;
}

}  // namespace
