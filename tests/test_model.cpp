#include "obsgain/planar_2r.hpp"
#include "obsgain/bounds.hpp"
#include "obsgain/robots.hpp"

#include <gtest/gtest.h>

namespace {

// A model that only provides A(q, v), like a KDL chain: N_i must come from polarisation.
class BlackBoxCoriolis final : public obsgain::Dynamics {
 public:
  explicit BlackBoxCoriolis(const obsgain::Planar2RDynamics& inner) : inner_(inner) {}
  int dof() const override { return 2; }
  void mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const override {
    inner_.mass_matrix(q, M);
  }
  void coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                Eigen::Ref<Eigen::VectorXd> A) const override {
    inner_.coriolis(q, v, A);
  }
  void gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const override {
    inner_.gravity(q, g);
  }

 private:
  const obsgain::Planar2RDynamics& inner_;
};

TEST(Model, PolarisationRecoversThePendubotCoriolisTensors) {
  const obsgain::Model model = obsgain::pendubot();
  const auto& analytic = dynamic_cast<const obsgain::Planar2RDynamics&>(*model.dynamics);
  const BlackBoxCoriolis black_box(analytic);
  for (double q2 : {-2.5, -0.3, 0.0, 0.7, 1.5707963267948966, 3.0}) {
    const Eigen::Vector2d q(0.4, q2);
    std::vector<Eigen::MatrixXd> expected, recovered;
    analytic.coriolis_tensors(q, expected);
    black_box.coriolis_tensors(q, recovered);
    for (int i = 0; i < 2; ++i) EXPECT_LE((expected[i] - recovered[i]).norm(), 1e-15) << "q2 = " << q2;
  }
}

TEST(Model, PolarisedBilinearFormEqualsTheAnalyticOne) {
  const obsgain::Model model = obsgain::pendubot();
  const auto& analytic = dynamic_cast<const obsgain::Planar2RDynamics&>(*model.dynamics);
  const BlackBoxCoriolis black_box(analytic);
  const Eigen::Vector2d q(0.4, 1.1);
  for (const auto& [x, y] : {std::pair{Eigen::Vector2d(1.0, -2.0), Eigen::Vector2d(10.0, 3.0)},
                             std::pair{Eigen::Vector2d(1e-3, 0.5), Eigen::Vector2d(-10.0, 10.0)}}) {
    Eigen::VectorXd expected(2), polarised(2);
    analytic.coriolis_bilinear(q, x, y, expected);
    black_box.coriolis_bilinear(q, x, y, polarised);
    // Polarisation subtracts terms of size π3 (|x| + |y|)²: its error is rounding at that scale.
    const double scale = 0.0095 * std::pow(x.norm() + y.norm(), 2);
    EXPECT_LE((expected - polarised).norm(), 1e-14 * scale) << x.transpose();
    EXPECT_GT(expected.norm(), 1e-4);
  }
}

TEST(Model, CoriolisTensorsReproduceCTimesV) {
  const obsgain::Model model = obsgain::pendubot();
  const Eigen::Vector2d q(0.1, 0.9), v(3.0, -7.0);
  std::vector<Eigen::MatrixXd> N;
  model.dynamics->coriolis_tensors(q, N);
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

}  // namespace
