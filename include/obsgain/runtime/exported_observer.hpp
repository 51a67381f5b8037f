// A design as the controller reads it: the robot's dynamics as data and the certified observer, in a plain text
// format that the runtime library reads with no solver and no parser library (design-gains --export-header embeds
// it in the generated header; --export-observer writes it to a file). Numbers are written with 17 significant
// digits, so a design read back runs bit for bit the gains and the model it was designed for.
#pragma once

#include "obsgain/model/model.hpp"
#include "obsgain/runtime/certified_observer.hpp"

#include <string>

namespace obsgain {

struct ExportedObserver {
  Model model;
  CertifiedObserver observer;
  int substeps = 0;            // RK4 sub-steps per sample the design certified (0: the Observer chooses)
  double sample_period = 0.0;  // T of the deployment (0: none was certified)
};

std::string exported_observer_text(const ExportedObserver& exported);

// InputError naming the line's keyword when the text is not such a design.
ExportedObserver read_exported_observer(const std::string& text);

}  // namespace obsgain
