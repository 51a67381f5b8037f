#include "obsgain/parsers/robots.hpp"

#include "obsgain/parsers/model_file.hpp"
#include "obsgain/parsers/urdf_model.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <filesystem>
#include <fstream>

namespace obsgain {

std::vector<std::string> builtin_robots() { return {"pendubot"}; }

namespace {

Model load(const RobotSource& source) {
  const std::string& robot = source.robot;
  if (robot.ends_with(".urdf")) return load_urdf(source);
  if (!source.base_link.empty() || !source.tip_link.empty() || !source.actuated.empty() || !source.joint_limits.empty())
    throw InputError("--base-link, --tip-link, --actuated and --joint-limits apply to URDF robots only, not to '" + robot + "'");
  if (!source.armature.empty() && !robot.ends_with(".json"))
    throw InputError("--armature applies to URDF robots and model files only, not to '" + robot + "'");
  if (robot == "pendubot") return pendubot();
  if (robot.ends_with(".json")) return load_model_file(robot, source.armature);
  std::string known;
  for (const auto& name : builtin_robots()) known += (known.empty() ? "" : ", ") + name;
  throw InputError("unknown robot '" + robot + "' (built in: " + known + "; or a model file *.json or *.urdf)");
}

// FNV-1a, 64 bits, of the file's bytes: a design file records it, and monte-carlo refuses a changed file.
std::string file_fingerprint(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::uint64_t hash = 1469598103934665603ull;
  char c;
  while (file.get(c)) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ull;
  }
  return fmt::format("fnv1a64:{:016x}", hash);
}

// Names and notes are one-line labels: the exported header's comments, the ROS 2 file and the runtime's observer file
// are written line by line, and a newline in a URDF's robot name (`&#10;`) broke them. Control characters become
// spaces.
std::string one_line(std::string text) {
  for (char& c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return text;
}

}  // namespace

Model load_robot(const RobotSource& source) {
  Model model = load(source);
  model.name = one_line(model.name);
  for (std::string& note : model.notes) note = one_line(note);
  model.source = source;
  model.fingerprint = source.robot.ends_with(".json") || source.robot.ends_with(".urdf") ? file_fingerprint(source.robot)
                                                                                          : "built-in";
  if (source.robot.ends_with(".json") || source.robot.ends_with(".urdf")) {
    std::error_code error;
    const std::filesystem::path absolute = std::filesystem::absolute(source.robot, error);
    if (!error) model.source.robot = absolute.lexically_normal().string();
  }
  return model;
}

}  // namespace obsgain
