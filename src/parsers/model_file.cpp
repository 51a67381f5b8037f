#include "obsgain/parsers/model_file.hpp"

#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace obsgain {

namespace {

class FieldReader {
 public:
  FieldReader(const nlohmann::json& j, std::string source) : j_(j), source_(std::move(source)) {}

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(fmt::format("{}: field '{}' {}", source_, field, what));
  }

  // What the user wrote, cut so that one line stays one line (a field may hold a megabyte).
  static std::string echo(const nlohmann::json& value) {
    const std::string text = value.dump();
    return text.size() <= 60 ? text : text.substr(0, 60) + "... (" + std::to_string(text.size()) + " characters)";
  }

  // JSON numbers are finite: the parser refuses any beyond double's range.
  double number(const std::string& field, const nlohmann::json& value) const {
    if (!value.is_number()) fail(field, "must be a number, got " + echo(value));
    return value.get<double>();
  }

  Eigen::VectorXd vector(const std::string& field, std::size_t length) const {
    const nlohmann::json& value = j_.at(field);
    if (!value.is_array() || value.size() != length)
      fail(field, fmt::format("must be an array of {} numbers, got {}", length, echo(value)));
    Eigen::VectorXd v(static_cast<Eigen::Index>(length));
    for (std::size_t i = 0; i < length; ++i) v(static_cast<Eigen::Index>(i)) = number(fmt::format("{}[{}]", field, i), value[i]);
    return v;
  }

  Eigen::MatrixXd matrix(const std::string& field, std::size_t rows) const {
    const nlohmann::json& value = j_.at(field);
    if (!value.is_array() || value.size() != rows || !value[0].is_array() || value[0].empty())
      fail(field, fmt::format("must be {} rows of numbers, got {}", rows, echo(value)));
    const std::size_t cols = value[0].size();
    Eigen::MatrixXd m(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
    for (std::size_t i = 0; i < rows; ++i) {
      if (!value[i].is_array() || value[i].size() != cols) fail(field, "rows must all have the same length");
      for (std::size_t k = 0; k < cols; ++k)
        m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = number(fmt::format("{}[{}][{}]", field, i, k), value[i][k]);
    }
    return m;
  }

 private:
  const nlohmann::json& j_;
  std::string source_;
};

// A JSON model file's object; `source` names the file in error messages.
Model model_from_json(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object()) throw InputError(source + ": a model file is a JSON object");
  const FieldReader read(j, source);
  const std::set<std::string> known = {"name", "type", "pi", "g0", "friction", "input_matrix", "velocity_bounds", "armature"};
  for (const auto& [key, value] : j.items())
    if (!known.count(key)) read.fail(key, "is not a model field (known: name, type, pi, g0, friction, input_matrix, velocity_bounds, armature)");
  for (const char* required : {"name", "type", "pi"})
    if (!j.contains(required)) read.fail(required, "is missing");
  if (!j["name"].is_string() || j["name"].get<std::string>().empty()) read.fail("name", "must be a non-empty string");
  if (j["type"] != "planar_2r") read.fail("type", "must be \"planar_2r\", got " + FieldReader::echo(j["type"]));

  Planar2RParameters parameters;
  const Eigen::VectorXd pi = read.vector("pi", 5);
  for (int i = 0; i < 5; ++i) parameters.pi[i] = pi(i);
  if (j.contains("g0")) parameters.g0 = read.number("g0", j["g0"]);
  // M(q) = [[π1 + π2 + 2π3 c, π2 + π3 c], [π2 + π3 c, π2]] has det = π1π2 − π3² c²: positive definite on the whole
  // circle iff π2 > 0 and π1π2 > π3².
  if (!(pi(1) > 0.0)) read.fail("pi", fmt::format("gives M22 = pi2 = {} <= 0: M(q) is not positive definite", pi(1)));
  if (!(pi(0) * pi(1) > pi(2) * pi(2)))
    read.fail("pi", fmt::format("gives pi1 pi2 - pi3^2 = {:.6g} <= 0: M(q) is singular or indefinite at q2 = 0",
                                pi(0) * pi(1) - pi(2) * pi(2)));
  if (j.contains("armature")) {
    const Eigen::VectorXd armature = read.vector("armature", 2);
    if ((armature.array() < 0.0).any()) read.fail("armature", "must be non-negative (reflected rotor inertia, kg m^2)");
    parameters.armature = {armature(0), armature(1)};
  }
  const Eigen::Vector2d friction = j.contains("friction") ? Eigen::Vector2d(read.vector("friction", 2)) : Eigen::Vector2d::Zero();
  if ((friction.array() < 0.0).any()) read.fail("friction", "must be non-negative (viscous friction)");
  const Eigen::MatrixXd H = j.contains("input_matrix") ? read.matrix("input_matrix", 2) : Eigen::MatrixXd::Identity(2, 2);
  Eigen::VectorXd V;
  if (j.contains("velocity_bounds")) {
    V = read.vector("velocity_bounds", 2);
    if ((V.array() <= 0.0).any()) read.fail("velocity_bounds", "must be positive");
  }
  return make_planar_2r(j["name"].get<std::string>(), parameters, friction, H, V);
}

nlohmann::json parse_model(std::istream& in, const std::string& source) {
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {  // syntax, and numbers such as 1e999 that overflow a double
    throw InputError("model file '" + source + "' is not valid JSON: " + e.what());
  }
}

}  // namespace

Model model_from_json_text(const std::string& text, const std::string& source) {
  std::istringstream in(text);
  return model_from_json(parse_model(in, source), source);
}

Model load_model_file(const std::string& path, const std::vector<double>& armature) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError("cannot read model file '" + path + "' (not a file)");
  std::ifstream file(path);
  if (!file) throw InputError("cannot read model file '" + path + "'");
  nlohmann::json j = parse_model(file, path);
  if (!armature.empty()) {
    if (armature.size() != 2)
      throw InputError(fmt::format("--armature: the model has 2 joints; give one value per joint, not {}", armature.size()));
    j["armature"] = armature;
  }
  return model_from_json(j, path);
}

}  // namespace obsgain
