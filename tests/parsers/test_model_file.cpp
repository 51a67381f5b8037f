#include "json.hpp"
#include "obsgain/bounds/bounds.hpp"
#include "obsgain/design/design.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"
#include "obsgain/parsers/model_file.hpp"
#include "obsgain/parsers/robots.hpp"

#include "test_files.hpp"
#include <gtest/gtest.h>

#include <fstream>
#include <limits>

namespace {

using obsgain_test::examples;

TEST(ModelFile, PendubotFileEqualsTheBuiltIn) {
  const obsgain::Model file = obsgain::load_robot({examples + "/pendubot.json"});
  const obsgain::Model builtin = obsgain::pendubot();
  const obsgain::BoundReport a = obsgain::compute_bounds(file, file.velocity_bounds);
  const obsgain::BoundReport b = obsgain::compute_bounds(builtin, builtin.velocity_bounds);
  EXPECT_EQ(file.name, "pendubot");
  EXPECT_EQ(file.input_matrix, builtin.input_matrix);
  EXPECT_DOUBLE_EQ(a.M0.value, b.M0.value);
  EXPECT_DOUBLE_EQ(a.B.value, b.B.value);
  EXPECT_DOUBLE_EQ(a.L_joint.value, b.L_joint.value);
}

// Hand-derived: for π3 > 0, det M = π1π2 − π3² cos²q2 is smallest and tr M largest at q2 = 0, so
// M0 = 1/λmin(M(0)); B = 2π3 max over the two sign patterns of ||[[−w2, −(w1 + w2)], [w1, 0]]|| at |sin q2| = 1.
void expect_hand_derived(const std::string& file, double pi1, double pi2, double pi3, const Eigen::Vector2d& V,
                         double friction_norm) {
  const obsgain::Model model = obsgain::load_robot({examples + "/" + file});
  const obsgain::BoundReport r = obsgain::compute_bounds(model, model.velocity_bounds);
  const double tr = pi1 + 2 * pi2 + 2 * pi3, det = pi1 * pi2 - pi3 * pi3;
  const double M0 = 2.0 / (tr - std::sqrt(tr * tr - 4 * det)) ;
  double B = 0.0;
  for (const Eigen::Vector2d w : {Eigen::Vector2d(V(0), V(1)), Eigen::Vector2d(V(0), -V(1))}) {
    Eigen::Matrix2d X;
    X << -w(1), -(w(0) + w(1)), w(0), 0.0;
    B = std::max(B, 2 * pi3 * obsgain::spectral_norm(X));
  }
  EXPECT_NEAR(r.M0.value, M0, 1e-9 * M0) << file;
  EXPECT_NEAR(r.B.value, B, 1e-9 * B) << file;
  EXPECT_DOUBLE_EQ(r.F_norm, friction_norm) << file;
  EXPECT_NEAR(r.L_paper, M0 * (B + friction_norm), 1e-8 * r.L_paper) << file;
  EXPECT_LE(r.L_joint.value, r.L_paper) << file;
}

TEST(ModelFile, ExamplesAgainstHandDerivedValues) {
  expect_hand_derived("acrobot.json", 0.3333, 0.3333, 0.25, Eigen::Vector2d(6, 12), 0.0);
  expect_hand_derived("two_link_arm.json", 1.2, 0.25, 0.3, Eigen::Vector2d(3, 4), 0.5);
  const obsgain::Model acrobot = obsgain::load_robot({examples + "/acrobot.json"});
  EXPECT_EQ(acrobot.input_matrix, Eigen::MatrixXd(Eigen::Vector2d(0, 1)));
}

nlohmann::json valid() {
  return nlohmann::json::parse(R"({"name": "arm", "type": "planar_2r", "pi": [1.2, 0.25, 0.3, 8, 1],
                                   "friction": [0.5, 0.2], "velocity_bounds": [3, 4]})");
}

void expect_field_refused(const nlohmann::json& j, const std::string& field) {
  try {
    obsgain::model_from_json_text(j.dump(), "arm.json");
    FAIL() << "accepted " << j.dump();
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("arm.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what() << " should name " << field;
  }
}

TEST(ModelFile, MalformedDescriptionsNameTheField) {
  EXPECT_NO_THROW(obsgain::model_from_json_text(valid().dump(), "arm.json"));
  auto j = valid();
  j.erase("pi");
  expect_field_refused(j, "'pi' is missing");
  j = valid();
  j["mass"] = 3;
  expect_field_refused(j, "'mass' is not a model field");
  j = valid();
  j["pi"] = {1, 2, 3, 4};
  expect_field_refused(j, "'pi' must be an array of 5 numbers");
  j = valid();
  j["pi"][2] = "0.3";
  expect_field_refused(j, "'pi[2]' must be a number");
  j = valid();
  j["pi"] = {0.01, 0.01, 0.01, 0.1, 0.1};  // π1π2 = π3²: singular at q2 = 0
  expect_field_refused(j, "singular or indefinite");
  j = valid();
  j["pi"][1] = -0.25;
  expect_field_refused(j, "not positive definite");
  j = valid();
  j["type"] = "scara";
  expect_field_refused(j, "'type' must be \"planar_2r\"");
  j = valid();
  j["velocity_bounds"] = {3, -4};
  expect_field_refused(j, "'velocity_bounds' must be positive");
  j = valid();
  j["friction"] = {0.5};
  expect_field_refused(j, "'friction' must be an array of 2");
  j = valid();
  j["input_matrix"] = {{1, 0}};
  expect_field_refused(j, "'input_matrix' must be 2 rows");
  // JSON has no infinity: a number beyond double's range is refused as the text it is.
  std::string text = valid().dump();
  text.replace(text.find("\"name\""), 0, "\"g0\": 1e999, ");
  EXPECT_THROW(obsgain::model_from_json_text(text, "arm.json"), obsgain::InputError);
}

TEST(ModelFile, FilesThatCannotBeReadOrParsed) {
  EXPECT_THROW(obsgain::load_robot({"/nonexistent/robot.json"}), obsgain::InputError);
  const std::string broken = ::testing::TempDir() + "/obsgain_broken.json";
  std::ofstream(broken) << "{\"name\": \"arm\", \"type\": ";
  try {
    obsgain::load_robot({broken});
    FAIL();
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos) << e.what();
  }
}

TEST(ModelFile, WithoutVelocityBoundsTheDesignAsksForThem) {
  auto j = valid();
  j.erase("velocity_bounds");
  const obsgain::Model model = obsgain::model_from_json_text(j.dump(), "arm.json");
  obsgain::DesignOptions options;
  options.gamma = 1.0;
  options.bound_method = obsgain::BoundMethod::numeric;
  try {
    obsgain::design_gains(model, options);
    FAIL();
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--vmax"), std::string::npos) << e.what();
  }
  options.velocity_bounds = Eigen::Vector2d(3, 4);
  EXPECT_TRUE(obsgain::design_gains(model, options).selected().observer.certified);
}

// A friction of 1e308 is finite, but M⁻¹F overflows: every value of L_joint was infinite, the optimisers kept no point,
// and the search read an empty one (a segmentation fault). The bound's overflow is now the model's refusal.
TEST(ModelFile, NumbersThatOverflowTheBoundsAreRefusedNamingTheBound) {
  auto j = valid();
  j["friction"] = {0.5, 1e308};
  const obsgain::Model model = obsgain::model_from_json_text(j.dump(), "arm.json");
  try {
    obsgain::compute_bounds(model, Eigen::Vector2d(3, 4));
    FAIL();
  } catch (const obsgain::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("L_joint is not finite at q = ("), std::string::npos) << e.what();
  }
  // Large, and its squares still within double's range: a bound. The friction swamps J (about 10) by 1e99, so
  // L_joint is ||M⁻¹F|| at its own argmax, computed here apart, to the search's precision.
  j["friction"] = {0.5, 1e100};
  const obsgain::Model large = obsgain::model_from_json_text(j.dump(), "arm.json");
  const obsgain::BoundReport r = obsgain::compute_bounds(large, Eigen::Vector2d(3, 4));
  EXPECT_NEAR(r.F_norm, 1e100, 1e86);
  Eigen::MatrixXd M(2, 2);
  obsgain::mass_matrix(large, r.L_joint.q, M);
  const double friction_term = obsgain::spectral_norm(M.inverse() * large.friction);
  EXPECT_NEAR(r.L_joint.value, friction_term, 1e-9 * friction_term);
}

}  // namespace
