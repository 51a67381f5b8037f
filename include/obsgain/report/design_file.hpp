// What monte-carlo needs from design-gains' JSON: the robot to load again and the certificate to validate.
#pragma once

#include "obsgain/model/model.hpp"
#include "obsgain/validation/simulation.hpp"

#include <string>

namespace obsgain {

struct SavedDesign {
  RobotSource robot;
  std::string fingerprint;  // of the model file the design was made for (empty in older files)
  ObserverCertificate certificate;
};

// From design-gains' JSON text; InputError when it is not JSON or not a certified design.
SavedDesign saved_design_from_json_text(const std::string& text);

// The robot loaded again for a saved design (load_robot(saved.robot)) is the one it was made for: InputError,
// starting with `label`, when the file changed since (another fingerprint) or the velocity box does not fit it.
void check_saved_design_model(const SavedDesign& saved, const Model& model, const std::string& label);

}  // namespace obsgain
