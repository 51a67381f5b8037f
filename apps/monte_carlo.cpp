// monte-carlo: simulate plant and observer from randomised initial errors against the certified envelope.
#include "cli.hpp"
#include "obsgain/numerics/distributed.hpp"
#include "obsgain/report/report.hpp"

#include <fstream>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"Validate a certified observer design by Monte Carlo simulation", "monte-carlo"};
  app.set_version_flag("--version", obsgain::version());
  app.footer("Exit codes: 0 no trajectory left the certified envelope; 1 a violation was found, or the run would exceed\n"
      "--step-budget (a gain too stiff to simulate in minutes: the message says what would help); 2 bad input.\n"
      "Examples:\n  build/monte-carlo --robot pendubot --gamma 1.27 --trials 1000\n"
      "  build/monte-carlo --design design.json --trials 200 --seed 2");
  obsgain::DesignArguments design;
  obsgain::add_design_options(app, design);
  obsgain::MonteCarloArguments arguments;
  obsgain::add_monte_carlo_options(app, arguments);
  std::string design_file;
  app.add_option("--design", design_file, "validate the design saved by design-gains --json FILE")->type_name("FILE");
  std::string json_path, csv_path, trajectory_path;
  auto* json = app.add_option("--json", json_path, "write JSON to stdout (no FILE, or -), or to FILE")
                   ->expected(0, 1)
                   ->type_name("[FILE]");
  app.add_option("--csv", csv_path, "write one row per trial to FILE")->type_name("FILE");
  app.add_option("--trajectory", trajectory_path, "write the time series of trial 0 to FILE")->type_name("FILE");
  return obsgain::run_app(app, argc, argv, [&] {
    obsgain::require_writable({{"--json", json_path}, {"--csv", csv_path}, {"--trajectory", trajectory_path}});
    const obsgain::MonteCarloOptions options = obsgain::to_monte_carlo_options(arguments, design);
    const obsgain::ValidationTarget target = obsgain::load_validation_target(design, design_file);
    const obsgain::MonteCarloReport report = obsgain::run_monte_carlo(target.model, target.certificate, options);
    obsgain::close_progress_line();
    if (!report.not_run.empty()) throw obsgain::UnmetRequest(report.not_run);
    const int code = report.certificate_held() ? 0 : 1;
    if (!obsgain::distributed::output_rank()) return code;  // rank 0 prints and writes the files
    if (json->count() > 0 && (json_path.empty() || json_path == "-")) {  // "-": stdout, as usual
      std::cout << obsgain::to_json_text(report);
    } else {
      std::cout << obsgain::format_report(report);
      if (json->count() > 0) {
        std::ofstream file(json_path);
        if (!(file << obsgain::to_json_text(report)))
          throw obsgain::InputError("cannot write JSON to '" + json_path + "'");
      }
    }
    if (!csv_path.empty()) {
      std::ofstream csv(csv_path);
      if (!csv) throw obsgain::InputError("cannot write '" + csv_path + "'");
      obsgain::write_trials_csv(report, csv);
    }
    if (!trajectory_path.empty()) {
      std::ofstream out(trajectory_path);
      if (!out) throw obsgain::InputError("cannot write '" + trajectory_path + "'");
      // Trial 0 as the statistics count it (the attempt that was kept).
      obsgain::write_trajectory_csv(obsgain::trial_trajectory(target.model, target.certificate, options, report.records[0]),
                                    out);
    }
    return code;
  });
}
