// The inertia floor (bounds/inertia_floor.hpp): λmin(M(q)) >= floor at every q. Analytic cases, the published arms
// against sampled eigenvalues, and what it buys a URDF without rotor inertia: finite certified brackets.
#include "test_files.hpp"
#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/certified_bounds.hpp"
#include "obsgain/bounds/inertia_floor.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using obsgain_test::examples;
using obsgain_test::write_temp_file;

// One joint of `type` moving one body: inertia diag(i, i, i) (a sphere) about a centre of mass on the joint's axis.
std::string one_body_urdf(const char* type, double inertia) {
  return fmt::format(R"(<robot name="one">
  <link name="base"/>
  <link name="body">
    <inertial><origin xyz="0 0 0.3"/><mass value="2.0"/>
      <inertia ixx="{0}" iyy="{0}" izz="{0}" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="j" type="{1}"><parent link="base"/><child link="body"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="2"/></joint>
</robot>)",
                     inertia, type);
}

// The smallest eigenvalue of M over random configurations of the searched joints.
double sampled_smallest_eigenvalue(const obsgain::Model& model, int samples) {
  const obsgain::JointSearch s = obsgain::joint_search(model, obsgain::configuration_joints(model));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = model.dof();
  Eigen::MatrixXd M(n, n);
  double smallest = INFINITY;
  for (int k = 0; k < samples; ++k) {
    Eigen::VectorXd x(static_cast<Eigen::Index>(s.joints.size()));
    for (std::size_t j = 0; j < s.joints.size(); ++j)
      x(static_cast<Eigen::Index>(j)) = s.domain[j].lower() + unit(rng) * (s.domain[j].upper() - s.domain[j].lower());
    obsgain::mass_matrix(model, s.configuration(x), M);
    smallest = std::min(smallest, Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues()(0));
  }
  return smallest;
}

TEST(InertiaFloor, ASphereTurningAboutItsCentreGivesItsMomentExactly) {
  // M = i: the body turns about an axis through its centre of mass, and every principal moment is i.
  const obsgain::Model model = obsgain::load_robot({write_temp_file("sphere.urdf", one_body_urdf("revolute", 0.02))});
  EXPECT_NEAR(obsgain::inertia_floor(model), 0.02, 1e-9 * 0.02);
  // With armature a, M = i + a and the floor is i + a.
  const obsgain::Model geared =
      obsgain::load_robot({write_temp_file("sphere.urdf", one_body_urdf("revolute", 0.02)), "", "", {}, {0.5}});
  EXPECT_NEAR(obsgain::inertia_floor(geared), 0.52, 1e-9 * 0.52);
}

TEST(InertiaFloor, APrismaticJointKeepsTheArmatureAlone) {
  // A slider's velocity is no angular velocity: the bodies' moments prove nothing, the armature still does.
  const std::string path = write_temp_file("slider.urdf", one_body_urdf("prismatic", 0.02));
  EXPECT_EQ(obsgain::inertia_floor(obsgain::load_robot({path})), 0.0);
  EXPECT_EQ(obsgain::inertia_floor(obsgain::load_robot({path, "", "", {}, {0.25}})), 0.25);
}

TEST(InertiaFloor, EveryArmsFloorIsBelowItsSampledSmallestEigenvalue) {
  // (file, floor computed by a bisection in double, the sampled smallest eigenvalue over floor at least):
  // the published UR5 and Panda have no rotor inertia; the floor is 8.5 and 6.7 times below their sampled minimum.
  // Where the armature and the last body dominate (arm6, the iiwa), it is nearly exact.
  struct Arm {
    const char* file;
    double floor, ratio_at_least, ratio_at_most;
  };
  for (const Arm& arm : {Arm{"ur5.urdf", 1.8616e-3, 8.0, 9.0}, Arm{"panda.urdf", 5.2504e-4, 6.0, 7.5},
                         Arm{"iiwa14.urdf", 1.28073, 1.0, 1.001}, Arm{"arm6.urdf", 0.163297, 1.0, 1.001},
                         Arm{"arm3.urdf", 3.9234e-4, 10.0, 20.0}}) {
    SCOPED_TRACE(arm.file);
    const obsgain::Model model = obsgain::load_robot({examples + "/" + arm.file});
    const double floor = obsgain::inertia_floor(model);
    EXPECT_NEAR(floor, arm.floor, 1e-4 * arm.floor);
    const double smallest = sampled_smallest_eigenvalue(model, 3000);
    EXPECT_GE(smallest / floor, arm.ratio_at_least);
    EXPECT_LE(smallest / floor, arm.ratio_at_most);
  }
}

TEST(InertiaFloor, APublishedUrdfWithoutRotorInertiaGetsFiniteCertifiedBrackets) {
  // Without the floor, M⁻¹ over the wide boxes near an upright upper arm could not be enclosed, and the UR5 as
  // published had no finite upper bound of M0 or L_joint even after 600 s. Now every box has one at once.
  const obsgain::Model ur5 = obsgain::load_robot({examples + "/ur5.urdf"});
  obsgain::BoundOptions light;
  light.global_evaluations_per_dimension = 100;
  light.polish_starts = 1;
  light.samples_per_dimension = 4;
  light.diagonal_scaling = false;
  const obsgain::BoundReport numeric = obsgain::compute_bounds(ur5, ur5.velocity_bounds, light);
  obsgain::CertifiedOptions options;
  options.budget_seconds = 0.5;
  const obsgain::CertifiedBounds brackets = *obsgain::certify_bounds(ur5, numeric, options);
  const double floor = obsgain::inertia_floor(ur5);
  EXPECT_GE(brackets.M0.upper, brackets.M0.lower);
  EXPECT_LE(brackets.M0.upper, 1.0 / floor * (1.0 + 1e-12));  // ||M⁻¹|| <= 1/λmin
  EXPECT_GE(brackets.L_joint.upper, brackets.L_joint.lower);
  EXPECT_TRUE(std::isfinite(brackets.L_joint.upper));
}

}  // namespace
