// Robots from URDF: the Pendubot written as a URDF against the built-in model, the physics of a spatial
// arm against an identity it must satisfy, the bounds against a brute-force grid, and malformed files.
// (KDL cross-checks and the quirks of real arms' files: test_serial_chain.cpp.)
#include "test_files.hpp"
#include "obsgain/bounds/bounds.hpp"
#include "obsgain/validation/montecarlo.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"
#include "obsgain/runtime/exported_observer.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

namespace {

using obsgain_test::read_text;
using obsgain_test::write_temp_file;

using obsgain_test::examples;

TEST(Urdf, PendubotUrdfHasThePendubotsDynamics) {
  const obsgain::Model urdf = obsgain::load_robot({examples + "/pendubot.urdf"});
  const obsgain::Model builtin = obsgain::pendubot();
  ASSERT_EQ(urdf.dof(), 2);
  EXPECT_EQ(urdf.velocity_bounds, builtin.velocity_bounds);
  EXPECT_TRUE(urdf.joints[0].continuous && urdf.joints[1].continuous);
  EXPECT_EQ(obsgain::configuration_joints(urdf), std::vector<int>{1});
  for (const Eigen::Vector2d q : {Eigen::Vector2d(0.3, -2.0), Eigen::Vector2d(-1.2, 0.9), Eigen::Vector2d(2.5, 3.1)}) {
    const Eigen::Vector2d v(4.0, -7.0);
    Eigen::MatrixXd M_urdf(2, 2), M_builtin(2, 2);
    Eigen::VectorXd A_urdf(2), A_builtin(2), g_urdf(2), g_builtin(2);
    obsgain::mass_matrix(urdf, q, M_urdf);
    obsgain::mass_matrix(builtin, q, M_builtin);
    obsgain::coriolis(urdf, q, v, A_urdf);
    obsgain::coriolis(builtin, q, v, A_builtin);
    obsgain::gravity(urdf, q, g_urdf);
    obsgain::gravity(builtin, q, g_builtin);
    EXPECT_LE((M_urdf - M_builtin).norm(), 1e-14 * M_builtin.norm()) << q.transpose();
    EXPECT_LE((A_urdf - A_builtin).norm(), 1e-13 * A_builtin.norm()) << q.transpose();
    EXPECT_LE((g_urdf - g_builtin).norm(), 1e-13 * g_builtin.norm()) << q.transpose();
    // The chain's tensors come from polarisation of Newton–Euler passes.
    std::vector<Eigen::MatrixXd> N_urdf, N_builtin;
    obsgain::coriolis_tensors(urdf, q, N_urdf);
    obsgain::coriolis_tensors(builtin, q, N_builtin);
    for (int i = 0; i < 2; ++i) EXPECT_LE((N_urdf[i] - N_builtin[i]).norm(), 1e-15) << q.transpose();
  }
}

TEST(Urdf, PendubotUrdfGivesThePendubotsBounds) {
  const obsgain::Model urdf = obsgain::load_robot({examples + "/pendubot.urdf"});
  const obsgain::BoundReport r = obsgain::compute_bounds(urdf, urdf.velocity_bounds);
  // The built-in Pendubot's values (docs/reproduction.md; certified brackets in test_certified_bounds).
  EXPECT_NEAR(r.M0.value, 285.7397981, 1e-6 * 285.74);
  EXPECT_NEAR(r.B.value, 0.4347667, 1e-6 * 0.4348);
  EXPECT_NEAR(r.L_joint.value, 43.3474691, 1e-6 * 43.35);
  EXPECT_NEAR(r.L_paper, 124.2301394, 1e-6 * 124.23);
}

// vᵀ A(q, v) = ½ vᵀ Ṁ(q) v (Ṁ - 2C is skew-symmetric): the Coriolis term against the derivative of the
// mass matrix, by central differences along v (with the arms' rotor inertia, which KDL does not model).
TEST(Urdf, CoriolisIsConsistentWithTheMassMatrix) {
  for (const char* file : {"arm3.urdf", "arm6.urdf"}) {
    const obsgain::Model model = obsgain::load_robot({examples + "/" + file});
    const int n = model.dof();
    const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(n, -0.8, 1.3);
    const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(n, 1.5, -2.0);
    Eigen::MatrixXd M_plus(n, n), M_minus(n, n);
    const double h = 1e-5;
    obsgain::mass_matrix(model, q + h * v, M_plus);
    obsgain::mass_matrix(model, q - h * v, M_minus);
    const Eigen::MatrixXd M_dot = (M_plus - M_minus) / (2.0 * h);
    Eigen::VectorXd A(n);
    obsgain::coriolis(model, q, v, A);
    const double power = v.dot(A), expected = 0.5 * v.dot(M_dot * v);
    EXPECT_NEAR(power, expected, 1e-7 * (std::abs(expected) + 1.0)) << file;
    EXPECT_GT(std::abs(expected), 1e-3) << file;  // the identity is not trivially 0 = 0 here
  }
}

TEST(Urdf, JointDomainsVelocityLimitsDampingAndActuationComeFromTheFile) {
  const obsgain::Model arm = obsgain::load_robot({examples + "/arm3.urdf"});
  ASSERT_EQ(arm.dof(), 3);
  EXPECT_TRUE(arm.joints[0].continuous);
  EXPECT_FALSE(arm.joints[1].continuous);
  EXPECT_DOUBLE_EQ(arm.joints[1].lower, -2.0);
  EXPECT_DOUBLE_EQ(arm.joints[2].upper, 2.6);
  EXPECT_EQ(arm.velocity_bounds, Eigen::Vector3d(3.0, 3.0, 4.0));
  EXPECT_EQ(arm.friction, Eigen::MatrixXd(Eigen::Vector3d(0.2, 0.1, 0.05).asDiagonal()));
  EXPECT_EQ(arm.input_matrix, Eigen::MatrixXd::Identity(3, 3));
  EXPECT_EQ(obsgain::configuration_joints(arm), (std::vector<int>{1, 2}));
  const auto coulomb_notes = [](const obsgain::Model& m) {
    return std::count_if(m.notes.begin(), m.notes.end(),
                         [](const std::string& note) { return note.find("Coulomb friction") != std::string::npos; });
  };
  EXPECT_EQ(coulomb_notes(arm), 0);  // friction="0" on every joint
  // Coulomb friction is not modelled: a file that declares it (the xArm's published URDF does, on every joint) is told.
  std::string rubbing = read_text(examples + "/arm3.urdf");
  rubbing.replace(rubbing.find(R"(friction="0")"), 12, R"(friction="0.3")");
  const obsgain::Model rubbed = obsgain::load_robot({write_temp_file("coulomb.urdf", rubbing)});
  ASSERT_EQ(coulomb_notes(rubbed), 1);
  const std::string note = *std::find_if(rubbed.notes.begin(), rubbed.notes.end(), [](const std::string& n) {
    return n.find("Coulomb friction") != std::string::npos;
  });
  EXPECT_EQ(note, "Coulomb friction (<dynamics friction>) of 'yaw' is not modelled: the observer and its "
                  "certificate take the viscous damping only");
  EXPECT_EQ(rubbed.friction, arm.friction);

  const obsgain::Model pendubot = obsgain::load_robot({examples + "/pendubot.urdf", "", "", {1, 0}});
  EXPECT_EQ(pendubot.input_matrix, Eigen::MatrixXd(Eigen::Vector2d(1.0, 0.0)));
  // A sub-chain: base to the upper arm only.
  const obsgain::Model shoulder = obsgain::load_robot({examples + "/arm3.urdf", "base_link", "upper_arm", {}});
  EXPECT_EQ(shoulder.dof(), 2);
}

// The numeric suprema against the largest value on a grid over (q2, q3), all vertices and patterns: never
// below it, and not above it by more than the grid's resolution can hide.
TEST(Urdf, BoundsOfTheThreeJointArmAgainstAGrid) {
  const obsgain::Model arm = obsgain::load_robot({examples + "/arm3.urdf"});
  const obsgain::BoundReport r = obsgain::compute_bounds(arm, arm.velocity_bounds);
  const Eigen::MatrixXd vertices = obsgain::box_vertices(arm.velocity_bounds);
  double M0 = 0.0, B = 0.0, L = 0.0;
  const int steps = 24;
  for (int a = 0; a <= steps; ++a) {
    for (int b = 0; b <= steps; ++b) {
      const Eigen::Vector3d q(0.0, -2.0 + 4.0 * a / steps, -2.6 + 5.2 * b / steps);
      M0 = std::max(M0, obsgain::inverse_inertia_norm(arm, q));
      for (Eigen::Index c = 0; c < vertices.cols(); ++c) {
        B = std::max(B, obsgain::coriolis_jacobian_norm(arm, q, vertices.col(c)));
        for (Eigen::Index s = 0; s < vertices.cols(); ++s) {
          const Eigen::Vector3d pattern = (vertices.col(s).array() > 0.0).cast<double>();
          L = std::max(L, obsgain::joint_lipschitz_norm(arm, q, vertices.col(c), pattern));
        }
      }
    }
  }
  for (const auto& [name, search, grid] : {std::tuple{"M0", r.M0.value, M0}, std::tuple{"B", r.B.value, B},
                                           std::tuple{"L_joint", r.L_joint.value, L}}) {
    EXPECT_GE(search, grid * (1.0 - 1e-12)) << name;
    EXPECT_LE(search, grid * 1.05) << name;
  }
  EXPECT_LE(r.L_joint.value, r.L_paper);
}

// Fully actuated: the computed-torque law makes the plant follow its reference exactly (it starts on it).
TEST(Urdf, MonteCarloTracksReferencesWithComputedTorque) {
  const obsgain::Model arm = obsgain::load_robot({examples + "/arm3.urdf"});
  obsgain::MonteCarloOptions options;
  options.simulation.horizon = 0.5;
  const obsgain::TrialSetup trial = obsgain::make_trial(arm, arm.velocity_bounds, options, 3, 1.0);
  ASSERT_TRUE(trial.input.reference.active());
  obsgain::CertifiedObserver observer;
  observer.k1 = 60.0;
  observer.k2 = 3600.0;
  observer.gamma = 1.0;
  observer.k = 100.0;
  observer.P = Eigen::MatrixXd::Identity(6, 6);
  observer.velocity_bounds = arm.velocity_bounds;
  const obsgain::ObserverCertificate certificate{observer, std::nullopt};
  obsgain::TrialRecord record;
  record.index = 3;
  const auto samples = obsgain::trial_trajectory(arm, certificate, options, record);
  ASSERT_GT(samples.size(), 400u);
  double tracking_error = 0.0, speed = 0.0;
  Eigen::VectorXd q_r(3), v_r(3), a_r(3);
  for (const auto& s : samples) {
    trial.input.reference.evaluate(s.t, q_r, v_r, a_r);
    tracking_error = std::max(tracking_error, (s.q - q_r).norm());
    speed = std::max(speed, (s.v.array().abs() / arm.velocity_bounds.array()).maxCoeff());
  }
  EXPECT_LT(tracking_error, 1e-6);
  EXPECT_LT(speed, 0.6 + 1e-9);  // the reference's speed budget
  EXPECT_GT(speed, 0.05);
}

const std::string two_links = R"(<?xml version="1.0"?>
<robot name="r">
  <link name="base"/>
  <joint name="j1" type="continuous"><parent link="base"/><child link="l1"/><axis xyz="0 -1 0"/></joint>
  <link name="l1"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 -1 0"/></joint>
  <link name="l2">L2_INERTIAL</link>
</robot>)";

std::string with_second_link(const std::string& inertial) {
  std::string text = two_links;
  text.replace(text.find("L2_INERTIAL"), 11, inertial);
  return text;
}

void expect_urdf_refused(const obsgain::RobotSource& source, const std::string& names) {
  try {
    obsgain::load_robot(source);
    ADD_FAILURE() << source.robot << " should be refused";
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(names), std::string::npos) << "'" << e.what() << "' should name " << names;
  }
}

TEST(Urdf, MalformedFilesAreRefusedNamingTheProblem) {
  const std::string good = write_temp_file("good.urdf", with_second_link(
      R"(<inertial><origin xyz="0.1 0 0"/><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)"));
  EXPECT_EQ(obsgain::load_robot({good}).dof(), 2);

  expect_urdf_refused({"/nonexistent/arm.urdf"}, "cannot read URDF file '/nonexistent/arm.urdf'");
  expect_urdf_refused({write_temp_file("broken.urdf", "<robot name='r'><link name='a'></robot>")}, "broken XML at line 1");
  expect_urdf_refused({write_temp_file("not_urdf.urdf", "<robot name='r'><joint name='j' type='revolute'/></robot>")},
                 "not a valid URDF");
  expect_urdf_refused({good, "base", "forearm", {}}, "no link 'forearm'");
  expect_urdf_refused({good, "l2", "base", {}}, "no chain from 'l2' down to 'base'");
  expect_urdf_refused({good, "", "", {1}}, "the chain has 2 joints; give one flag per joint, not 1");
  expect_urdf_refused({good, "", "", {1, 2}}, "flag 2 = 2 must be 0 or 1");
  // The last link carries nothing: joint j2 moves no inertia and M(q) is singular.
  expect_urdf_refused({write_temp_file("massless.urdf", with_second_link(""))}, "joint 'j2' moves no mass or inertia");
  // A mass of 1e308 beside one of 0.5: M's smallest eigenvalue is positive, and far below double's resolution of the
  // largest (said so, not that the joint moves nothing).
  std::string heavy = with_second_link(
      R"(<inertial><origin xyz="0.1 0 0"/><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)");
  heavy.replace(heavy.find(R"(<mass value="1"/>)"), 17, R"(<mass value="1e308"/>)");
  expect_urdf_refused({write_temp_file("heavy.urdf", heavy)}, "M(q) is numerically singular: its smallest eigenvalue");
  expect_urdf_refused({write_temp_file("zero_mass.urdf", with_second_link(
                     R"(<inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>)"))},
                 "joint 'j2' moves no mass or inertia");
  // A massless link with rotational inertia (a rotor's, say) keeps it when lumped into a massless body: it was dropped,
  // and j2 refused as moving nothing. M's j2 diagonal is then its moment about the axis, whatever q.
  const obsgain::Model rotor = obsgain::load_robot({write_temp_file("massless_rotor.urdf", with_second_link(
      R"(<inertial><mass value="0"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.003"/></inertial>)"))});
  Eigen::MatrixXd M(2, 2);
  obsgain::mass_matrix(rotor, Eigen::Vector2d(0.4, 1.1), M);
  EXPECT_NEAR(M(1, 1), 0.002, 1e-15);
  EXPECT_NEAR(M(0, 1), 0.002, 1e-15);
  // A link's own inertial is checked before it is lumped: a negative mass made j2's body massless (l2 vanished, and
  // the Kinova Gen3's forearm at -0.93 kg gave a design), an inertia that is not positive semidefinite could hide in
  // a heavier body.
  expect_urdf_refused({write_temp_file("negative_mass.urdf", with_second_link(
                     R"(<inertial><mass value="-0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)"))},
                 "link 'l2' has mass -0.5 (must be finite and >= 0)");
  expect_urdf_refused({write_temp_file("indefinite.urdf", with_second_link(
                     R"(<inertial><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="-0.001"/></inertial>)"))},
                 "link 'l2' has an inertia that is not positive semidefinite");
  // urdfdom logs a number it cannot read in an <inertial> and goes on with that inertial partly zero (l2 read as
  // moving nothing, or lighter than the file says): its error is the file's refusal, naming the element and the link.
  for (const char* value : {"nan", "1e999", "abc"})
    expect_urdf_refused({write_temp_file("unreadable_inertia.urdf", with_second_link(fmt::format(
                           R"(<inertial><mass value="0.5"/><inertia ixx="{}" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)",
                           value)))},
                        "not a valid URDF: Inertial: inertia element ixx is not a valid double; Could not parse inertial "
                        "element for Link [l2]");
  expect_urdf_refused({write_temp_file("unreadable_origin.urdf", with_second_link(
                     R"(<inertial><origin xyz="nan 0 0"/><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)"))},
                 "Unable to parse component [nan] to a double");
  std::string unlimited = two_links;
  unlimited.replace(unlimited.find(R"(name="j2" type="continuous")"), 27, R"(name="j2" type="revolute")");
  expect_urdf_refused({write_temp_file("unlimited.urdf", unlimited)}, "not a valid URDF: Joint [j2] is of type REVOLUTE but it does not specify limits");
  expect_urdf_refused({examples + "/pendubot.json", "", "", {1, 0}}, "apply to URDF robots only");
}

// A newline in a URDF's robot name (&#10;) ended the exported header's comment line, so that the header did not
// compile, and split the runtime's observer file. Names and notes are one-line labels.
TEST(Urdf, NamesWithControlCharactersBecomeOneLine) {
  std::string text = with_second_link(
      R"(<inertial><origin xyz="0.1 0 0"/><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)");
  text.replace(text.find(R"(<robot name="r">)"), 16, R"(<robot name="arm &quot;x&quot;&#10;two&#9;three">)");
  const obsgain::Model model = obsgain::load_robot({write_temp_file("named.urdf", text)});
  EXPECT_EQ(model.name, "arm \"x\" two three");
  obsgain::CertifiedObserver gains;
  gains.k1 = 10.0;
  gains.k2 = 100.0;
  gains.velocity_bounds = Eigen::Vector2d(1.0, 1.0);  // the file gives none
  gains.P = Eigen::Matrix4d::Identity();
  const obsgain::ExportedObserver back =
      obsgain::read_exported_observer(obsgain::exported_observer_text({model, gains, 1, 1e-3}));
  EXPECT_EQ(back.model.name, model.name);
  EXPECT_EQ(back.observer.k2, 100.0);
}

// A floating or planar joint between the arm's joints was held fixed without a word: the links below it were lumped
// into the arm as if bolted on, and the design was for another robot. Above the arm (a mobile base) it is held fixed
// and said so; anywhere below the first joint the file is refused.
TEST(Urdf, FreeJointsHoldTheBaseFixedAndAreRefusedWithinTheArm) {
  const std::string inertial =
      R"(<inertial><origin xyz="0.1 0 0"/><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>)";
  const obsgain::Model fixed_base = obsgain::load_robot({write_temp_file("fixed_base.urdf", with_second_link(inertial))});
  // Nothing in the file gives a rotor inertia: said so, with what to do (and nothing said once --armature gives it).
  const auto armature_note = [](const obsgain::Model& m) {
    return std::count_if(m.notes.begin(), m.notes.end(), [](const std::string& n) {
      return n.find("no rotor inertia in the file for any joint (armature 0)") != std::string::npos &&
             n.find("give it with --armature") != std::string::npos;
    });
  };
  EXPECT_EQ(armature_note(fixed_base), 1);
  obsgain::RobotSource with_armature{write_temp_file("fixed_base.urdf", with_second_link(inertial))};
  with_armature.armature = {0.1, 0.1};
  EXPECT_EQ(armature_note(obsgain::load_robot(with_armature)), 0);
  for (const char* type : {"floating", "planar"}) {
    std::string mobile = with_second_link(inertial);
    mobile.replace(mobile.find(R"(<link name="base"/>)"), 19,
                   fmt::format(R"(<link name="world"/><joint name="mount" type="{}"><parent link="world"/>)"
                               R"(<child link="base"/></joint><link name="base"/>)", type));
    const obsgain::Model model = obsgain::load_robot({write_temp_file("mobile_base.urdf", mobile)});
    ASSERT_EQ(model.dof(), 2);
    const auto note = std::find_if(model.notes.begin(), model.notes.end(),
                                   [](const std::string& n) { return n.find("held fixed") != std::string::npos; });
    ASSERT_NE(note, model.notes.end());
    EXPECT_NE(note->find(fmt::format("'mount' ({})", type)), std::string::npos) << *note;
    Eigen::MatrixXd M(2, 2), M_fixed(2, 2);
    obsgain::mass_matrix(model, Eigen::Vector2d(0.4, 1.1), M);
    obsgain::mass_matrix(fixed_base, Eigen::Vector2d(0.4, 1.1), M_fixed);
    EXPECT_LT((M - M_fixed).norm(), 1e-15);

    std::string within = with_second_link(inertial);
    within.replace(within.find(R"(name="j2" type="continuous")"), 27, fmt::format(R"(name="j2" type="{}")", type));
    expect_urdf_refused({write_temp_file("free_within.urdf", within)},
                        fmt::format("joint 'j2' is {}: the links below it are not attached to the arm", type));
    std::string below = with_second_link(inertial);
    below.replace(below.find("</robot>"), 8, fmt::format(R"(<joint name="held" type="{}"><parent link="l2"/>)"
                                                          R"(<child link="object"/></joint><link name="object">{}</link></robot>)",
                                                          type, inertial));
    expect_urdf_refused({write_temp_file("free_below.urdf", below)}, fmt::format("joint 'held' is {}", type));
  }
}

}  // namespace
