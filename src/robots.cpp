#include "obsgain/robots.hpp"

#include "obsgain/model_file.hpp"
#include "obsgain/planar_2r.hpp"


namespace obsgain {

std::vector<std::string> builtin_robots() { return {"pendubot"}; }

Model load_robot(const std::string& name_or_file) {
  if (name_or_file == "pendubot") return pendubot();
  if (name_or_file.ends_with(".json")) return load_model_file(name_or_file);
  std::string known;
  for (const auto& name : builtin_robots()) known += (known.empty() ? "" : ", ") + name;
  throw InputError("unknown robot '" + name_or_file + "' (built in: " + known + "; or a model file *.json)");
}

}  // namespace obsgain
