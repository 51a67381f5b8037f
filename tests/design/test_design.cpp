#include "json.hpp"
#include "obsgain/certificate/certificate.hpp"
#include "obsgain/design/design.hpp"
#include "obsgain/model/planar_2r.hpp"
#include "obsgain/report/report.hpp"

#include <gtest/gtest.h>

namespace {

obsgain::DesignOptions paper_line() {
  obsgain::DesignOptions o;
  o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  o.gamma = 1.27;
  o.certificate = obsgain::CertificateKind::paper;
  o.lipschitz = obsgain::LipschitzKind::paper;
  return o;
}

TEST(Design, PaperCertificateWithHonestL) {
  const obsgain::Design d = obsgain::design_gains(obsgain::pendubot(), paper_line());
  EXPECT_NEAR(d.L_used, 124.2301, 1e-5 * 124.2301);
  EXPECT_NEAR(d.selected().theta_star, 454.064, 1e-5 * 454.064);
  EXPECT_DOUBLE_EQ(d.selected().observer.theta, d.selected().theta_star);
  EXPECT_DOUBLE_EQ(d.selected().rate, 1.27);
  EXPECT_DOUBLE_EQ(d.selected().observer.k1, d.selected().observer.theta);
  EXPECT_DOUBLE_EQ(d.selected().observer.k2, d.selected().observer.theta * d.selected().observer.theta);
  EXPECT_TRUE(d.selected().observer.certified);
}

TEST(Design, PaperLineWithTheOverride) {
  obsgain::DesignOptions o = paper_line();
  o.L_override = 54.01;
  const obsgain::Design d = obsgain::design_gains(obsgain::pendubot(), o);
  EXPECT_NEAR(d.selected().theta_star, 200.005, 1e-5 * 200.005);
  EXPECT_EQ(d.L_source, "override");
  ASSERT_FALSE(d.warnings.empty());
  EXPECT_NE(d.warnings.front().find("overridden"), std::string::npos);
}

TEST(Design, ThetaEvaluationSaysWhenNothingIsCertified) {
  obsgain::DesignOptions o = paper_line();
  o.gamma.reset();
  o.theta = 200.0;
  const obsgain::Design d = obsgain::design_gains(obsgain::pendubot(), o);
  EXPECT_LT(d.selected().rate, 0.0);
  EXPECT_FALSE(d.selected().observer.certified);
  EXPECT_NE(obsgain::format_report(d).find("NOT CERTIFIED"), std::string::npos);
}

TEST(Design, ShapeOptimisationForThePaperCertificate) {
  obsgain::DesignOptions o = paper_line();
  o.optimize_shape = true;
  const obsgain::Design d = obsgain::design_gains(obsgain::pendubot(), o);
  EXPECT_NEAR(d.alpha, 1.572303, 1e-5 * 1.572303);
  EXPECT_EQ(d.beta, 1.0);
  EXPECT_NEAR(d.lyapunov.S_norm, 1.665095, 1e-5 * 1.665095);
  EXPECT_NEAR(d.shape.alpha_global, d.shape.alpha_polish, 1e-4);
  EXPECT_NEAR(d.shape.objective_global, d.shape.objective_polish, 1e-9);
}

TEST(Design, ShapeOptimisationForTheTightCertificateBeatsAlphaOne) {
  obsgain::DesignOptions o;
  o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  o.gamma = 1.27;
  o.L_override = 54.01;
  const obsgain::Design fixed = obsgain::design_gains(obsgain::pendubot(), o);
  o.optimize_shape = true;
  const obsgain::Design best = obsgain::design_gains(obsgain::pendubot(), o);
  EXPECT_NEAR(fixed.tight.theta_star, 81.2964, 1e-5 * 81.2964);
  EXPECT_LT(best.tight.theta_star, fixed.tight.theta_star);
  EXPECT_NEAR(best.shape.objective_global, best.shape.objective_polish, 1e-6 * best.shape.objective_polish);
  // A second method: no α on a fine grid does better than the optimiser.
  for (double a = 0.2; a < 5.0; a += 0.01)
    EXPECT_GE(obsgain::tight_theta_star(a, 1.0, 1.27, 54.01), best.tight.theta_star * (1 - 1e-9)) << a;
}

TEST(Design, TightCertificateIsTheDefaultAndCertifiesTheTarget) {
  obsgain::DesignOptions o;
  o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  o.gamma = 1.27;
  const obsgain::Design d = obsgain::design_gains(obsgain::pendubot(), o);
  EXPECT_EQ(d.certificate, obsgain::CertificateKind::tight);
  EXPECT_NEAR(d.L_used, 43.3475, 1e-5 * 43.3475);
  EXPECT_TRUE(d.selected().observer.certified);
  EXPECT_DOUBLE_EQ(d.selected().observer.gamma, 1.27);
  EXPECT_GE(d.selected().observer.theta, d.selected().theta_star);
  ASSERT_TRUE(d.selected().lmi_max_eig.has_value());
  EXPECT_LT(*d.selected().lmi_max_eig, 0.0);
  // The tight design needs a far smaller gain than the paper's for the same L.
  EXPECT_LT(d.tight.theta_star, 0.5 * d.paper.theta_star);
}

TEST(Design, JsonCarriesTheContractKeys) {
  obsgain::DesignOptions o;
  o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
  o.theta = 200.0;
  o.L_override = 54.01;
  const nlohmann::json j = obsgain::to_json(obsgain::design_gains(obsgain::pendubot(), o));
  EXPECT_EQ(j["robot"]["name"], "pendubot");
  EXPECT_EQ(j["robot"]["dof"], 2);
  EXPECT_EQ(j["certificate"], "tight");
  EXPECT_NEAR(j["design"]["gamma"].get<double>(), 66.0097, 1e-5 * 66.0097);
  for (const char* key : {"alpha", "beta", "theta_star", "theta", "gamma", "k", "k1", "k2", "P", "lmi_max_eig"})
    EXPECT_TRUE(j["design"].contains(key)) << key;
  for (const char* key : {"M0", "B", "F_norm", "L_paper", "L_joint", "L_used"}) EXPECT_TRUE(j["bounds"].contains(key)) << key;
  EXPECT_EQ(j["lyapunov"]["S"].size(), 4u);
}

TEST(Design, BadOptionsAreRefused) {
  const obsgain::Model model = obsgain::pendubot();
  auto with = [](auto change) {
    obsgain::DesignOptions o;
    o.bound_method = obsgain::BoundMethod::numeric;  // bounds are not under test here
    o.gamma = 1.0;
    change(o);
    return o;
  };
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.gamma = -1.0; })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.gamma = std::nan(""); })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.theta = 3.0; })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.gamma.reset(); })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.alpha = 0.0; })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.beta = -2.0; })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.L_override = 0.0; })), obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.velocity_bounds = Eigen::Vector3d(1, 1, 1); })),
               obsgain::InputError);
  EXPECT_THROW(obsgain::design_gains(model, with([](auto& o) { o.rate_margin = 0.0; })), obsgain::InputError);
}

}  // namespace
