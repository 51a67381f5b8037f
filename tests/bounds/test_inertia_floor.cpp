// The inertia floor (bounds/inertia_floor.hpp): λmin(M(q)) >= floor at every q. Analytic cases, the published arms
// against sampled eigenvalues, and what it buys a URDF without rotor inertia: finite certified brackets.
#include "test_files.hpp"
#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/box_forms.hpp"
#include "obsgain/bounds/certified_bounds.hpp"
#include "obsgain/bounds/inertia_floor.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"
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

// The smallest eigenvalue of M (of S M S for S = diag(s), when given) over random configurations of the searched joints.
double sampled_smallest_eigenvalue(const obsgain::Model& model, int samples, const Eigen::VectorXd& scaling = {}) {
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
    if (scaling.size()) M = scaling.asDiagonal() * M * scaling.asDiagonal();
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
  // the published UR5, Panda and Jaco2 have no rotor inertia; the floor is 8.5, 6.7 and 7.3 times below their sampled
  // minimum.
  // Where the armature and the last body dominate (arm6, the iiwa), it is nearly exact.
  struct Arm {
    const char* file;
    double floor, ratio_at_least, ratio_at_most;
  };
  for (const Arm& arm : {Arm{"ur5.urdf", 1.8616e-3, 8.0, 9.0}, Arm{"panda.urdf", 5.2504e-4, 6.0, 7.5},
                         Arm{"iiwa14.urdf", 1.28073, 1.0, 1.001}, Arm{"arm6.urdf", 0.163297, 1.0, 1.001},
                         Arm{"arm3.urdf", 3.9234e-4, 10.0, 20.0}, Arm{"jaco2.urdf", 2.53429e-5, 6.0, 8.0}}) {
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

// The floor's route, (||J(w)|| + ||F||) / λmin(M) with the cheap bound of J(w) at every velocity vertex, computed here
// from the same forms.
double inertia_route(const obsgain::Model& model, const obsgain::JointSearch& search, const std::vector<obsgain::Interval>& box) {
  const obsgain::BoxForms d = obsgain::box_forms(model, search, box, true);
  const double lambda = std::max(obsgain::smallest_eigenvalue_lower(obsgain::taylor_matrix(d.M.data(), d.n, d.n, d.symbols)),
                                 obsgain::inertia_floor(model));
  const double J = obsgain::largest_combination_frobenius_upper(obsgain::unit_jacobians(d), obsgain::box_vertices(model.velocity_bounds));
  return (J + obsgain::spectral_norm_upper(model.friction)) / lambda;
}

TEST(InertiaFloor, L_jointOverABoxIsNeverAboveTheFloorsRoute) {
  // The route is taken only where a value it cannot go below, from the forms' centres, is under the bound already
  // proven (bounds/box_bounds.cpp, route_at_least); so a box's bound is never above the route's, at every box.
  // On the iiwa around q = 0.3 in every searched joint, ±0.4: M⁻¹'s series holds but is loose, and the route gives the
  // box's bound; ±0.1: the series wins by a factor of 4 (±0.3: 18.27 against 30.43, since the sixteenth round's Gram
  // bound of ||E||).
  const obsgain::Model iiwa = obsgain::load_robot({examples + "/iiwa14.urdf"});
  const obsgain::JointSearch search = obsgain::joint_search(iiwa, obsgain::configuration_joints(iiwa));
  const obsgain::BoxBounds bounds(iiwa, search, iiwa.velocity_bounds);
  const auto around = [&](const Eigen::VectorXd& x, double radius) {
    std::vector<obsgain::Interval> box;
    for (std::size_t k = 0; k < search.domain.size(); ++k) {
      const obsgain::Interval& side = search.domain[k];
      const double c = x(static_cast<Eigen::Index>(k));
      box.emplace_back(std::max(side.lower(), c - radius), std::min(side.upper(), c + radius));
    }
    return box;
  };
  const Eigen::VectorXd middle = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(search.domain.size()), 0.3);
  const std::vector<obsgain::Interval> wide = around(middle, 0.4), narrow = around(middle, 0.1);
  const obsgain::BoxForms d = obsgain::box_forms(iiwa, search, wide, true);
  ASSERT_TRUE(obsgain::inverse(d.M, d.n, d.symbols).proven);  // the series route exists on the wide box too
  const double wide_route = inertia_route(iiwa, search, wide);
  EXPECT_NEAR(bounds.joint_lipschitz(wide, 0.0).upper, wide_route, 1e-12 * wide_route);
  EXPECT_LT(bounds.joint_lipschitz(narrow, 0.0).upper, 0.5 * inertia_route(iiwa, search, narrow));
  // Random boxes of every width, on the iiwa and on the UR5 with armature (where the route wins on half the boxes
  // of a search): the bound is at most the route's.
  obsgain::RobotSource ur5_source{examples + "/ur5.urdf"};
  ur5_source.armature = {0.6, 0.6, 0.6, 0.2, 0.2, 0.2};
  const obsgain::Model ur5 = obsgain::load_robot(ur5_source);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const obsgain::Model* model : {&iiwa, &ur5}) {
    const obsgain::JointSearch s = obsgain::joint_search(*model, obsgain::configuration_joints(*model));
    const obsgain::BoxBounds b(*model, s, model->velocity_bounds);
    for (const double radius : {0.05, 0.15, 0.3, 0.6}) {
      for (int trial = 0; trial < 6; ++trial) {
        std::vector<obsgain::Interval> box;
        for (const obsgain::Interval& side : s.domain) {
          const double c = side.lower() + unit(rng) * (side.upper() - side.lower());
          box.emplace_back(std::max(side.lower(), c - radius), std::min(side.upper(), c + radius));
        }
        const double route = inertia_route(*model, s, box);
        EXPECT_LE(b.joint_lipschitz(box, 0.0).upper, route * (1.0 + 1e-12)) << model->name << " radius " << radius;
      }
    }
  }
}

// The diagonal scaling the numeric search keeps on the UR5 with armature 0.6/0.2 (design-gains prints it), and the
// boxes of half-width `radius` in its five searched joints around L_T's numeric maximiser.
const Eigen::VectorXd ur5_scaling = (Eigen::VectorXd(6) << 1.0, 1.41517, 1.48913, 0.694743, 0.673392, 0.518903).finished();
std::vector<obsgain::Interval> around_ur5_maximiser(double radius) {
  const double centre[5] = {-1.86317, -0.347491, 0.305476, -2.33335, 0.152026};
  std::vector<obsgain::Interval> box;
  for (const double c : centre) box.emplace_back(c - radius, c + radius);
  return box;
}

TEST(InertiaFloor, TheSimilarFloorIsTheArmaturesWhereThatLeads) {
  // λmin(S M S) >= min_k a_k s_k² (M ≽ diag(a)) and >= floor min_k s_k²: with S = T⁻¹ on the UR5 with armature the
  // first leads, 0.6 / 1.48913² = 0.2706 against 0.092, on the published file (a = 0) the second. Both hold at
  // random configurations.
  obsgain::RobotSource source{examples + "/ur5.urdf"};
  source.armature = {0.6, 0.6, 0.6, 0.2, 0.2, 0.2};
  const obsgain::Model ur5 = obsgain::load_robot(source), published = obsgain::load_robot({examples + "/ur5.urdf"});
  const Eigen::VectorXd s = ur5_scaling.cwiseInverse();
  const double armatures = 0.6 * s(2) * s(2), floors = obsgain::inertia_floor(published) * s(2) * s(2);
  const double similar = obsgain::similar_inertia_floor(ur5, obsgain::inertia_floor(ur5), s);
  EXPECT_NEAR(similar, armatures, 1e-12 * armatures);
  EXPECT_NEAR(armatures, 0.27057, 1e-5);
  EXPECT_GT(similar, 2.5 * obsgain::inertia_floor(ur5) * s(2) * s(2));
  EXPECT_GE(sampled_smallest_eigenvalue(ur5, 2000, s), similar);
  const double bare = obsgain::similar_inertia_floor(published, obsgain::inertia_floor(published), s);
  EXPECT_NEAR(bare, floors, 1e-12 * floors);
  EXPECT_GE(sampled_smallest_eigenvalue(published, 2000, s), bare);
}

TEST(InertiaFloor, L_TOnWideBoxesPaysNoStretch) {
  // Before, ||T Φ T⁻¹|| over a box was bounded through ||Φ||'s M⁻¹ tail and floor route times the stretch cond(T) =
  // 2.87: on the UR5 with armature, 2.02 and 2.87 times L_joint's bound at half-widths 0.2 and 0.4 (133.7 and 998.3).
  // With T kept inside the tail (||T U T⁻¹|| ||T X T⁻¹||) and the route through T⁻¹ (bounds/box_bounds.hpp,
  // FloorRoute), measured: 66.79 against L_joint's 66.28, and 237 against 348. Every bound holds at sampled points.
  obsgain::RobotSource source{examples + "/ur5.urdf"};
  source.armature = {0.6, 0.6, 0.6, 0.2, 0.2, 0.2};
  const obsgain::Model ur5 = obsgain::load_robot(source);
  const obsgain::JointSearch s = obsgain::joint_search(ur5, obsgain::configuration_joints(ur5));
  const Eigen::MatrixXd T = ur5_scaling.asDiagonal();
  const obsgain::BoxBounds plain(ur5, s, ur5.velocity_bounds), scaled(ur5, s, ur5.velocity_bounds, T);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const double radius : {0.2, 0.4}) {
    const std::vector<obsgain::Interval> box = around_ur5_maximiser(radius);
    const double L_T = scaled.joint_lipschitz(box, 0.0).upper, L_joint = plain.joint_lipschitz(box, 0.0).upper;
    EXPECT_LT(L_T, (radius < 0.3 ? 1.05 : 0.75) * L_joint) << radius;
    for (int point = 0; point < 40; ++point) {
      Eigen::VectorXd x(5);
      for (int k = 0; k < 5; ++k) x(k) = box[k].lower() + unit(rng) * (box[k].upper() - box[k].lower());
      EXPECT_GE(L_T, obsgain::max_joint_lipschitz_norm(ur5, s.configuration(x), ur5.velocity_bounds, T)) << radius;
    }
  }
}

}  // namespace
