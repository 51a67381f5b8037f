// The library's JSON in one place, on nlohmann_json: every result type's object, and the reader of design files.
// Internal: the public headers expose JSON as text (report.hpp), so that nlohmann_json is not a dependency of the
// library's users. The tests include it to read values back.
#pragma once

#include "obsgain/report/design_file.hpp"
#include "obsgain/report/report.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace obsgain {

nlohmann::json to_json(const Eigen::MatrixXd& matrix);  // rows of numbers
nlohmann::json to_json(const Eigen::VectorXd& vector);
nlohmann::json to_json(const BoundReport& bounds);
nlohmann::json certified_json(const BoundReport& bounds);  // {M0, B, L_joint}: {lower, upper, argmax_q, boxes, seconds}
nlohmann::json to_json(const CertificateSummary& summary);
nlohmann::json to_json(const Design& design);
nlohmann::json to_json(const Deployment& deployment);
nlohmann::json to_json(const DeployedDesign& design);  // the design, with "deployment" when it has one
nlohmann::json to_json(const MonteCarloReport& report);
nlohmann::json to_json(const VerificationReport& report);

SavedDesign saved_design_from_json(const nlohmann::json& design_json);

}  // namespace obsgain
