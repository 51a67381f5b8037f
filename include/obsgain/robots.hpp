// Where models come from: the built-in robots by name, or a model file.
#pragma once

#include "obsgain/model.hpp"

#include <string>
#include <vector>

namespace obsgain {

std::vector<std::string> builtin_robots();

// "pendubot", or a path to a JSON model file (model_file.hpp). Throws InputError naming the robot when it cannot be loaded.
Model load_robot(const std::string& name_or_file);

}  // namespace obsgain
