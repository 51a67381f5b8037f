// Every result type's JSON (for tools and for the next command) and its human report, in one place.
#pragma once

#include "obsgain/design.hpp"
#include "obsgain/montecarlo.hpp"
#include "obsgain/verification.hpp"

#include <nlohmann/json.hpp>

#include <ostream>
#include <string>

namespace obsgain {

nlohmann::json to_json(const Eigen::MatrixXd& matrix);  // rows of numbers
nlohmann::json to_json(const Eigen::VectorXd& vector);
nlohmann::json to_json(const BoundReport& bounds);
nlohmann::json certified_json(const BoundReport& bounds);  // {M0, B, L_joint}: {lower, upper, argmax_q, boxes, seconds}
nlohmann::json to_json(const CertificateSummary& summary);
nlohmann::json to_json(const Design& design);
nlohmann::json to_json(const DeploymentCertificate& deployment, const std::vector<TradeoffPoint>& tradeoff,
                       DesignObjective objective);
// The deployment section of the design table (rate_proven: the design's own certificate is a proof).
std::string format_deployment(const DeploymentCertificate& deployment, const std::vector<TradeoffPoint>& tradeoff,
                              bool rate_proven);

// "(1, 2.5)": vectors in the human reports.
std::string format_vector(const Eigen::VectorXd& v);

// The paper and tight certificates side by side, row by row (the text and HTML reports both show these).
struct ComparisonRow {
  std::string label;
  double paper, tight;
};
std::vector<ComparisonRow> certificate_comparison(const Design& design);

// The design as a table a control engineer reads: bounds and where they sit, S, both certificates side by
// side, the chosen gains, and warnings.
// "obsgain X.Y.Z" (--version, and the report's verdict box).
std::string version();

std::string format_report(const Design& design);
// The design's warnings, one "warning: ..." line each (the apps print them on stderr).
std::string format_warnings(const Design& design);

nlohmann::json to_json(const MonteCarloReport& report);
std::string format_report(const MonteCarloReport& report);
void write_trials_csv(const MonteCarloReport& report, std::ostream& out);          // one row per trial
void write_trajectory_csv(const std::vector<TrajectorySample>& samples, std::ostream& out);

nlohmann::json to_json(const VerificationReport& report);

struct WrittenReport {
  std::string html, json;   // paths
  bool plots = false;       // gnuplot drew the plots
  std::string plots_note;   // why not, when it did not
};
// Writes DIR/report.json, DIR/report.html (self-contained: plots inline as SVG) and the CSV behind every
// plot. Plots are drawn by gnuplot from the CSVs; without gnuplot the report still builds and says so.
WrittenReport write_verification_report(const VerificationReport& report, const std::string& directory);

// What monte-carlo needs from design-gains' JSON: the robot, the velocity box and the certificate.
struct SavedDesign {
  RobotSource robot;
  std::string fingerprint;  // of the model file the design was made for (empty in older files)
  Eigen::VectorXd velocity_bounds;
  ObserverCertificate certificate;
};
SavedDesign saved_design_from_json(const nlohmann::json& design_json);

}  // namespace obsgain
