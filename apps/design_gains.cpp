// design-gains: observer gains for a target convergence rate (or the rate a given gain certifies).
#include "cli.hpp"
#include "obsgain/numerics/distributed.hpp"
#include "obsgain/report/export.hpp"
#include "obsgain/report/report.hpp"
#include "obsgain/parsers/robots.hpp"

#include <fstream>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"Design certified velocity-observer gains (saturated Luenberger observer)", "design-gains"};
  app.set_version_flag("--version", obsgain::version());
  app.footer("Exit codes: 0 success; 1 the design does not certify the requested rate (or rests on bounds that are not\n"
      "proven while --bounds certified was asked); 2 bad input (one line on stderr naming it).\n"
      "Examples:\n  build/design-gains --robot pendubot --gamma 1.27\n"
      "  build/design-gains --robot examples/arm3.urdf --gamma 5 --json design.json\n"
      "  build/design-gains --robot pendubot --gamma 1.27 --sample-period 0.001 --encoder-counts 4096 \\\n"
      "      --acceleration-bounds 200 --objective velocity-error --export-header observer_gains.hpp");
  obsgain::DesignArguments arguments;
  obsgain::add_design_options(app, arguments);
  std::string json_path;
  auto* json = app.add_option("--json", json_path, "write JSON to stdout (no FILE, or -), or to FILE")
                   ->expected(0, 1)
                   ->type_name("[FILE]");
  std::string header_path, ros2_path, observer_path;
  app.add_option("--export-header", header_path,
                 "write the gains and the certificate as a C++ header of constexpr values (with the model and observer "
                 "for obsgain::runtime)")
      ->type_name("FILE.hpp");
  app.add_option("--export-ros2", ros2_path, "write the gains and the certificate as a ROS 2 parameters file")
      ->type_name("FILE.yaml");
  app.add_option("--export-observer", observer_path,
                 "write the model and the observer as obsgain::runtime reads them (read_exported_observer)")
      ->type_name("FILE");
  return obsgain::run_app(app, argc, argv, [&] {
    obsgain::require_writable({{"--json", json_path},
                               {"--export-header", header_path},
                               {"--export-ros2", ros2_path},
                               {"--export-observer", observer_path}});
    const obsgain::Model model = obsgain::load_robot(obsgain::to_robot_source(arguments));
    const obsgain::DesignRequest request = obsgain::to_design_request(arguments, model);
    const obsgain::DeployedDesign design = obsgain::design_observer(model, request.design, request.deployment);
    obsgain::close_progress_line();
    std::cerr << obsgain::format_warnings(design.design);
    const std::string text = obsgain::to_json_text(design);
    if (json->count() > 0 && (json_path.empty() || json_path == "-")) {  // "-": stdout, as usual
      std::cout << text;
    } else {
      std::cout << obsgain::format_report(design);
      if (json->count() > 0 && obsgain::distributed::output_rank()) {
        std::ofstream file(json_path);
        if (!(file << text)) throw obsgain::InputError("cannot write JSON to '" + json_path + "'");
      }
    }
    // Gains that do not meet the request never reach a controller's files: the report says why, exit 1.
    if (const std::string unmet = obsgain::unmet_request(design, request.design); !unmet.empty()) {
      const bool exports = !header_path.empty() || !ros2_path.empty() || !observer_path.empty();
      std::cerr << "design-gains: error: " << unmet << (exports ? " (nothing exported)" : "") << "\n";
      return 1;
    }
    for (const auto& [path, content] :
         {std::pair{header_path, obsgain::observer_header(model, design)},
          std::pair{ros2_path, obsgain::ros2_parameters(design)},
          std::pair{observer_path, obsgain::exported_observer_text(obsgain::exported_observer(model, design))}}) {
      if (path.empty() || !obsgain::distributed::output_rank()) continue;
      std::ofstream file(path);
      if (!(file << content)) throw obsgain::InputError("cannot write '" + path + "'");
    }
    return 0;
  });
}
