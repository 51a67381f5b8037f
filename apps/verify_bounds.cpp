// verify-bounds: certified bound brackets, the design, a Monte Carlo verdict and plots, as a report.
#include "cli.hpp"
#include "obsgain/numerics/distributed.hpp"
#include "obsgain/report/report.hpp"
#include "obsgain/parsers/robots.hpp"
#include "obsgain/validation/verification.hpp"

#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"Write a bound-verification report (HTML, JSON, CSV, plots)", "verify-bounds"};
  app.set_version_flag("--version", obsgain::version());
  app.footer("Exit codes: 0 report written and no violation; 1 a Monte Carlo violation, or Monte Carlo past --step-budget\n"
      "(the report is written; the message says what would help); 2 bad input.\n"
      "Examples:\n  build/verify-bounds --robot pendubot --gamma 1.27 --out report/\n"
      "  build/verify-bounds --robot examples/arm3.urdf --gamma 5 --trials 50 --bound-budget 15 --out report3/");
  obsgain::DesignArguments design;
  obsgain::add_design_options(app, design);
  obsgain::MonteCarloArguments monte_carlo;
  monte_carlo.trials = "200";
  obsgain::add_monte_carlo_options(app, monte_carlo);
  std::string out;
  app.add_option("--out", out, "output directory")->required()->type_name("DIRECTORY");
  return obsgain::run_app(app, argc, argv, [&] {
    if (obsgain::distributed::output_rank()) obsgain::require_report_directory("--out", out);  // rank 0 writes it
    const obsgain::Model model = obsgain::load_robot(obsgain::to_robot_source(design));
    const obsgain::DesignRequest request = obsgain::to_design_request(design, model);
    obsgain::VerificationOptions options;
    options.design = request.design;
    options.deployment = request.deployment;
    for (int i = 0; i < argc; ++i) options.command_line += (i ? " " : "") + std::string(argv[i]);
    options.monte_carlo = obsgain::to_monte_carlo_options(monte_carlo, design);
    const obsgain::VerificationReport report = obsgain::verify_design(model, options);
    if (!obsgain::distributed::output_rank()) {  // rank 0 writes the report
      if (!report.design.design.unfinished.empty()) throw obsgain::UnmetRequest(report.design.design.unfinished);
      return report.monte_carlo.certificate_held() ? 0 : 1;
    }
    if (options.design.progress) options.design.progress("writing the report and its plots");
    const obsgain::WrittenReport written = obsgain::write_verification_report(report, out);
    obsgain::close_progress_line();
    std::cerr << obsgain::format_warnings(report.design.design);
    std::cout << obsgain::format_report(report.design) << "\n" << obsgain::format_report(report.monte_carlo) << "\n";
    std::cout << "report: " << written.html << "\n       " << written.json << "\n";
    if (!written.plots) std::cout << "plots missing: " << written.plots_note << "\n";
    if (!report.design.design.unfinished.empty()) throw obsgain::UnmetRequest(report.design.design.unfinished);
    if (!report.monte_carlo.not_run.empty()) throw obsgain::UnmetRequest("Monte Carlo " + report.monte_carlo.not_run);
    return report.monte_carlo.certificate_held() ? 0 : 1;
  });
}
