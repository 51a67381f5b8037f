// Robots from model files: JSON for the lumped planar two-link family of the paper.
//   { "name": "my-arm", "type": "planar_2r", "pi": [p1, p2, p3, p4, p5], "g0": 9.81,
//     "friction": [f1, f2], "input_matrix": [[1, 0], [0, 1]], "velocity_bounds": [3, 4] }
// name, type, pi required; g0 (9.81), friction (0), input_matrix (identity), velocity_bounds (none: then
// --vmax is required) optional. Every error names the file and the field.
#pragma once

#include "obsgain/model/model.hpp"

#include <string>
#include <vector>

namespace obsgain {

// `armature`, when given, overrides the file's (one value per joint).
Model load_model_file(const std::string& path, const std::vector<double>& armature = {});

// The same from the file's text; `source` names the file in error messages.
Model model_from_json_text(const std::string& text, const std::string& source);

}  // namespace obsgain
