// Every result type's JSON (for tools and for the next command) and its human report, in one place.
#pragma once

#include "obsgain/design.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace obsgain {

nlohmann::json to_json(const Eigen::MatrixXd& matrix);  // rows of numbers
nlohmann::json to_json(const Eigen::VectorXd& vector);
nlohmann::json to_json(const BoundReport& bounds);
nlohmann::json to_json(const CertificateSummary& summary);
nlohmann::json to_json(const Design& design);

// The design as a table a control engineer reads: bounds and where they sit, S, both certificates side by
// side, the chosen gains, and warnings.
std::string format_report(const Design& design);

}  // namespace obsgain
