#include "obsgain/report/design_file.hpp"

#include "obsgain/deployment/deployment.hpp"
#include "json.hpp"

#include <fmt/format.h>

#include <cmath>

namespace obsgain {

namespace {

RobotSource robot_source(const nlohmann::json& robot) {
  RobotSource source;
  source.robot = robot.at("source").get<std::string>();
  source.base_link = robot.value("base_link", "");
  source.tip_link = robot.value("tip_link", "");
  source.actuated = robot.value("actuated", std::vector<int>{});
  if (robot.contains("joint_limits")) {
    for (const nlohmann::json& range : robot.at("joint_limits")) {
      JointDomain domain;
      if (range != "c") {
        domain.continuous = false;
        domain.lower = range.at(0).get<double>();
        domain.upper = range.at(1).get<double>();
      }
      source.joint_limits.push_back(domain);
    }
  }
  // The armature the design used, given again: a file whose transmissions changed still gets these values.
  if (source.robot.ends_with(".urdf") || source.robot.ends_with(".json"))
    source.armature = robot.value("armature", std::vector<double>{});
  return source;
}

Eigen::VectorXd vector_of(const nlohmann::json& values, Eigen::Index size, const std::string& name) {
  const auto v = values.get<std::vector<double>>();
  if (size >= 0 && static_cast<Eigen::Index>(v.size()) != size) throw InputError(name + " needs one value per joint");
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// A number the observer needs positive (and finite), or the file's refusal naming it.
double positive(const nlohmann::json& design, const char* key) {
  const double x = design.at(key).get<double>();
  if (!(x > 0.0) || !std::isfinite(x)) throw InputError(fmt::format("design.{} = {} must be positive", key, x));
  return x;
}

// What design-gains writes holds together: k1 = θα and k2 = θ²β (to rounding), L >= 0 and P symmetric positive
// definite. An edited file that breaks them is no certificate to validate: a P of −I passed every Lyapunov check.
void check_consistent(const CertifiedObserver& o) {
  const auto close = [](double x, double y) { return std::abs(x - y) <= 1e-12 * std::abs(y); };
  if (!close(o.k1, o.theta * o.alpha) || !close(o.k2, o.theta * o.theta * o.beta))
    throw InputError(fmt::format("design.k1 = {} and k2 = {} must be theta alpha and theta^2 beta (theta = {}, alpha "
                                 "= {}, beta = {})", o.k1, o.k2, o.theta, o.alpha, o.beta));
  if (!(o.L >= 0.0) || !std::isfinite(o.L)) throw InputError(fmt::format("design.L = {} must be >= 0", o.L));
  if (!o.P.allFinite() || !o.P.isApprox(o.P.transpose(), 1e-12) || Eigen::LLT<Eigen::MatrixXd>(o.P).info() != Eigen::Success)
    throw InputError("design.P must be symmetric positive definite");
}

CertifiedObserver certified_observer(const nlohmann::json& j, const Eigen::VectorXd& V) {
  const nlohmann::json& d = j.at("design");
  if (!d.at("certified").get<bool>()) throw InputError("the saved design is not certified: nothing to validate");
  CertifiedObserver o;
  // Designs saved before the certificate was named used the tight one; a name this version does not know is refused.
  const std::string kind = d.value("certificate", j.value("certificate", "tight"));
  const std::optional<CertificateKind> certificate = certificate_kind(kind);
  if (!certificate) throw InputError("design.certificate '" + kind + "' is not one of paper, tight, scaled, polytopic");
  o.certificate = *certificate;
  o.alpha = positive(d, "alpha");
  o.beta = positive(d, "beta");
  o.theta = positive(d, "theta");
  o.k1 = positive(d, "k1");
  o.k2 = positive(d, "k2");
  o.gamma = d.at("envelope_gamma").get<double>();
  o.k = d.at("k").get<double>();
  o.L = d.value("L", j.at("bounds").at("L_used").get<double>());  // designs saved before "L" was written: L_used
  o.velocity_bounds = V;
  o.certified = true;
  const auto P = d.at("P").get<std::vector<std::vector<double>>>();
  const auto size = static_cast<std::size_t>(2 * V.size());
  if (P.size() != size) throw InputError("design.P must be " + std::to_string(size) + " x " + std::to_string(size));
  o.P.resize(static_cast<Eigen::Index>(size), static_cast<Eigen::Index>(size));
  for (std::size_t r = 0; r < size; ++r) {
    if (P[r].size() != size) throw InputError("design.P must be square");
    for (std::size_t c = 0; c < size; ++c) o.P(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = P[r][c];
  }
  check_consistent(o);
  return o;
}

SampledCertificate sampled_certificate(const nlohmann::json& dep, const CertifiedObserver& o) {
  const Eigen::Index n = o.velocity_bounds.size();
  SampledCertificate c;
  c.sample_period = dep.at("sample_period").get<double>();
  c.latency = dep.value("latency", 0.0);
  c.encoder_resolution = vector_of(dep.at("encoder_resolution"), n, "deployment.encoder_resolution");
  c.acceleration_bounds = vector_of(dep.at("acceleration_bounds"), n, "deployment.acceleration_bounds");
  c.level = dep.at("iss_envelope").at("level").get<double>();
  c.offset = dep.at("iss_envelope").at("offset").get<double>();
  c.position_norm = dep.at("ultimate_position_error_norm").get<double>();
  c.velocity_norm = dep.at("ultimate_velocity_error_norm").get<double>();
  for (const double x : {o.L, c.level, c.offset})
    if (!(x > 0.0) || !std::isfinite(x)) throw InputError("deployment: L_used, level and offset must be positive");
  DeploymentOptions ranges;  // the ranges design-gains accepts
  ranges.sample_period = c.sample_period;
  ranges.latency = c.latency;
  ranges.encoder_resolution = c.encoder_resolution;
  ranges.acceleration_bounds = c.acceleration_bounds;
  try {
    validate_deployment_options(ranges, static_cast<int>(n));
  } catch (const InputError& e) {
    throw InputError(std::string("the design file's deployment: ") + e.what());
  }
  return c;
}

}  // namespace

SavedDesign saved_design_from_json(const nlohmann::json& j) {
  try {
    SavedDesign saved;
    saved.robot = robot_source(j.at("robot"));
    saved.fingerprint = j.at("robot").value("fingerprint", "");
    const Eigen::VectorXd V = vector_of(j.at("velocity_bounds"), -1, "velocity_bounds");
    saved.certificate.observer = certified_observer(j, V);
    if (j.contains("deployment")) saved.certificate.sampled = sampled_certificate(j.at("deployment"), saved.certificate.observer);
    return saved;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(std::string("not a design-gains JSON: ") + e.what());
  }
}

SavedDesign saved_design_from_json_text(const std::string& text) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(std::string("not valid JSON: ") + e.what());
  }
  return saved_design_from_json(j);
}

void check_saved_design_model(const SavedDesign& saved, const Model& model, const std::string& label) {
  if (!saved.fingerprint.empty() && saved.fingerprint != model.fingerprint)
    throw InputError(label + " was made for another version of '" + saved.robot.robot + "' (fingerprint " +
                     saved.fingerprint + ", the file now " + model.fingerprint + "): run design-gains again");
  validate_velocity_bounds(model, saved.certificate.observer.velocity_bounds);
}

}  // namespace obsgain
