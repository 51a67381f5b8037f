// Every result type's JSON (for tools and for the next command) and its human report, in one place.
#pragma once

#include "obsgain/deployment/deployment.hpp"
#include "obsgain/validation/montecarlo.hpp"
#include "obsgain/validation/verification.hpp"

#include <ostream>
#include <optional>
#include <string>

namespace obsgain {

// The JSON of each result (indent 2): the one serialisation tools and the next command read. Built in one
// place (src/json.hpp, report.cpp) with nlohmann_json, which stays a private dependency of the library.
std::string to_json_text(const Design& design);
std::string to_json_text(const DeployedDesign& design);
std::string to_json_text(const MonteCarloReport& report);
std::string to_json_text(const VerificationReport& report);

// What ended a certified bracket's search: its name in the JSON and the HTML table ("gap", "budget", "race", ...),
// and for a person why it stopped short ("stopped by the budget, --bound-budget", ...; "" when the gap was reached).
struct StopText {
  const char* name;
  const char* reason;
};
StopText stop_text(SearchStop stop);
// A stopped search's pace for the human reports ("excess x 0.55 per doubling of the work", excess_per_doubling); ""
// when it has none.
std::string pace_text(const BoundBracket& bracket);

// "(1, 2.5)": vectors in the human reports.
std::string format_vector(const Eigen::VectorXd& v);
// A similarity scaling T as printed: diag(t1, ..., tn) when diagonal, else its rows [[...], ...].
std::string format_scaling(const Eigen::MatrixXd& T);

// The paper and tight certificates side by side, row by row, the scaled one when the bounds kept a similarity scaling,
// and the polytopic one when it was asked for (the text and HTML reports both show these).
struct ComparisonRow {
  std::string label;
  double paper, tight;
  std::optional<double> scaled = std::nullopt, polytopic = std::nullopt;
};
std::vector<ComparisonRow> certificate_comparison(const Design& design);

// With --optimize-shape: how α was chosen, in one line (the text and HTML reports both show it); empty otherwise.
std::string shape_summary(const Design& design);

// "obsgain X.Y.Z" (--version, and the report's verdict box).
std::string version();

// The design as a table a control engineer reads: bounds and where they sit, S, both certificates side by
// side, the chosen gains, and the deployment when there is one.
std::string format_report(const Design& design);
std::string format_report(const DeployedDesign& design);
// The design's warnings, one "warning: ..." line each (the apps print them on stderr).
std::string format_warnings(const Design& design);

std::string format_report(const MonteCarloReport& report);
void write_trials_csv(const MonteCarloReport& report, std::ostream& out);          // one row per trial
void write_trajectory_csv(const std::vector<TrajectorySample>& samples, std::ostream& out);


struct WrittenReport {
  std::string html, json;   // paths
  bool plots = false;       // gnuplot drew the plots
  std::string plots_note;   // why not, when it did not
};
// Writes DIR/report.json, DIR/report.html (self-contained: plots inline as SVG) and the CSV behind every
// plot. Plots are drawn by gnuplot from the CSVs; without gnuplot the report still builds and says so.
WrittenReport write_verification_report(const VerificationReport& report, const std::string& directory);
// InputError unless write_verification_report can write to `directory`: it is a writable directory, or the nearest
// part of its path that exists is one (the writer creates the rest). `option` names it in the message (--out, out).
// Asked before the work, so that a bad directory is not found after minutes of search.
void require_report_directory(const std::string& option, const std::string& directory);

}  // namespace obsgain
