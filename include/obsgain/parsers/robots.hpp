// Where models come from: the built-in robots by name, or a model file.
#pragma once

#include "obsgain/model/model.hpp"

#include <string>
#include <vector>

namespace obsgain {

std::vector<std::string> builtin_robots();

// "pendubot", or the path of a JSON model file (model_file.hpp) or a URDF (urdf_model.hpp). The model
// records its source with file paths made absolute. Throws InputError naming the robot when it cannot be
// loaded, or when URDF-only options are given for another robot.
Model load_robot(const RobotSource& source);

}  // namespace obsgain
