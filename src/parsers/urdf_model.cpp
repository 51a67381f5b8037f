#include "obsgain/parsers/urdf_model.hpp"

#include "obsgain/model/dynamics.hpp"

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <memory>
#include <set>
#include <sstream>

namespace obsgain {

namespace {

// urdfdom reports why it rejects a file through console_bridge; keep its first two errors (what was wrong, then where)
// for our one-line message instead of letting them print.
class FirstError final : public console_bridge::OutputHandler {
 public:
  FirstError() {
    previous_level_ = console_bridge::getLogLevel();
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_ERROR);
    console_bridge::useOutputHandler(this);
  }
  ~FirstError() override {
    console_bridge::restorePreviousOutputHandler();
    console_bridge::setLogLevel(previous_level_);
  }
  FirstError(const FirstError&) = delete;
  FirstError& operator=(const FirstError&) = delete;
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_ERROR) return;
    if (errors_ < 2) message += (message.empty() ? "" : "; ") + text;
    ++errors_;
  }
  bool any() const { return errors_ > 0; }
  std::string message;

 private:
  console_bridge::LogLevel previous_level_;
  int errors_ = 0;
};

// `part` placed at (rotation, translation) in `body`'s frame, lumped into `body` (parallel-axis theorem).
RigidBody lump(const RigidBody& body, const RigidBody& part, const Eigen::Matrix3d& rotation,
               const Eigen::Vector3d& translation) {
  const double mass = body.mass + part.mass;
  if (mass <= 0.0) {  // both massless: no centre of mass to shift to, but their rotational inertias still add
    RigidBody result = body;
    result.inertia += rotation * part.inertia * rotation.transpose();
    return result;
  }
  const Eigen::Vector3d part_com = rotation * part.com + translation;
  const Eigen::Vector3d com = (body.mass * body.com + part.mass * part_com) / mass;
  // Parallel-axis theorem: I_about_c = I_own + m (|d|² I - d dᵀ) with d the offset of each body's centre from c.
  const auto shifted = [](double m, const Eigen::Vector3d& d) {
    return Eigen::Matrix3d(m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose()));
  };
  RigidBody result;
  result.mass = mass;
  result.com = com;
  result.inertia = body.inertia + shifted(body.mass, body.com - com) + rotation * part.inertia * rotation.transpose() +
                   shifted(part.mass, part_com - com);
  return result;
}

// Why a body cannot be physical (a negative or non-finite mass, non-finite numbers, an inertia that is not positive
// semidefinite), or nothing.
std::string unphysical(const RigidBody& body) {
  if (!std::isfinite(body.mass) || body.mass < 0.0) return fmt::format("has mass {} (must be finite and >= 0)", body.mass);
  if (!body.com.allFinite() || !body.inertia.allFinite()) return "has a centre of mass or inertia that is not finite";
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(body.inertia).eigenvalues()(0);
  if (smallest < -1e-9 * std::max(1.0, body.inertia.norm()))
    return fmt::format("has an inertia that is not positive semidefinite (smallest principal moment {:.6g})", smallest);
  return {};
}

// InputError naming the joint when the data cannot describe a physical chain (sizes, non-unit axes, unphysical
// bodies).
void validate_chain(const SerialChain& chain, const std::string& source) {
  const int n = chain.dof();
  if (n == 0) throw InputError(source + ": the chain has no moving joint");
  if (n > kMaxChainJoints)
    throw InputError(fmt::format("{}: the chain has {} moving joints; obsgain handles at most {}", source, n, kMaxChainJoints));
  if (static_cast<int>(chain.bodies.size()) != n || chain.armature.size() != n)
    throw InputError(fmt::format("{}: {} joints need {} bodies and {} armature values", source, n, n, n));
  for (int i = 0; i < n; ++i) {
    const ChainJoint& joint = chain.joints[i];
    const RigidBody& body = chain.bodies[i];
    if (!joint.rotation.allFinite() || !joint.translation.allFinite() || !joint.axis.allFinite() ||
        std::abs(joint.axis.norm() - 1.0) > 1e-9)
      throw InputError(fmt::format("{}: joint '{}' needs a finite placement and a unit axis", source, joint.name));
    if (const std::string why = unphysical(body); !why.empty())
      throw InputError(fmt::format("{}: the body moved by joint '{}' {}", source, joint.name, why));
    if (!std::isfinite(chain.armature[i]) || chain.armature[i] < 0.0)
      throw InputError(fmt::format("{}: joint '{}' has armature {} (must be >= 0)", source, joint.name, chain.armature[i]));
  }
  if (!chain.gravity.allFinite()) throw InputError(source + ": gravity must be finite");
}

std::string read_file(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(fmt::format("cannot read URDF file '{}' (not a file)", path));
  std::ifstream file(path);
  if (!file) throw InputError(fmt::format("cannot read URDF file '{}'", path));
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

// The joint's domain from the file, or from --joint-limits (its type stays the file's).
JointDomain joint_domain(const urdf::Joint& joint, const JointDomain* override_limits, const std::string& source) {
  const JointType type = joint.type == urdf::Joint::PRISMATIC ? JointType::prismatic : JointType::revolute;
  if (joint.type != urdf::Joint::CONTINUOUS && joint.type != urdf::Joint::REVOLUTE && joint.type != urdf::Joint::PRISMATIC)
    throw InputError(fmt::format("{}: joint '{}' is neither revolute, continuous nor prismatic", source, joint.name));
  JointDomain domain;
  if (override_limits) {
    domain = *override_limits;
    if (domain.continuous && type == JointType::prismatic)
      throw InputError(fmt::format("--joint-limits: joint '{}' is prismatic: it needs lower:upper, not c", joint.name));
  } else if (joint.type == urdf::Joint::CONTINUOUS) {
    return domain;
  } else {
    if (!joint.limits || !(joint.limits->lower < joint.limits->upper))
      throw InputError(fmt::format("{}: joint '{}' has <limit lower=\"{}\" upper=\"{}\">: lower must be below upper "
                                   "(override with --joint-limits lo1:hi1,...; c for a continuous joint)",
                                   source, joint.name, joint.limits ? joint.limits->lower : 0.0,
                                   joint.limits ? joint.limits->upper : 0.0));
    domain.continuous = false;
    domain.lower = joint.limits->lower;
    domain.upper = joint.limits->upper;
  }
  domain.type = type;
  // M and C see a revolute joint through sin/cos only: a range of a full turn or more is the whole circle.
  if (type == JointType::revolute && !domain.continuous && domain.upper - domain.lower >= 2.0 * std::numbers::pi)
    return JointDomain{};
  return domain;
}

Eigen::Isometry3d to_isometry(const urdf::Pose& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  return T;
}

Eigen::Vector3d to_vector(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

bool movable(const urdf::Joint& joint) {
  return joint.type == urdf::Joint::REVOLUTE || joint.type == urdf::Joint::CONTINUOUS || joint.type == urdf::Joint::PRISMATIC;
}

// A floating or planar joint: the links below it are not attached to the ones above.
bool free_joint(const urdf::Joint& joint) {
  return joint.type == urdf::Joint::FLOATING || joint.type == urdf::Joint::PLANAR;
}

// Above the arm's first joint a free joint is a mobile base, held fixed as the observer's model has it; below it, the
// links under it would be lumped into the arm as if bolted on.
void check_free_joint(const urdf::Joint& joint, bool below_arm, const std::string& source, std::vector<std::string>& held) {
  if (!free_joint(joint)) return;
  const char* type = joint.type == urdf::Joint::FLOATING ? "floating" : "planar";
  if (below_arm)
    throw InputError(fmt::format("{}: joint '{}' is {}: the links below it are not attached to the arm, and obsgain "
                                 "models a serial chain of revolute, continuous and prismatic joints (make it fixed, "
                                 "or end the chain above it with --tip-link)", source, joint.name, type));
  held.push_back(fmt::format("'{}' ({})", joint.name, type));
}

// A chain joint moves freely; a mimic joint follows another and is locked with the side branches.
bool chain_candidate(const urdf::Joint& joint) { return movable(joint) && !joint.mimic; }

// The link's own inertia as a RigidBody in the link's frame. Each link is checked before it is lumped: a negative mass
// lumped into a body of none made that body massless (the link vanished), and one lumped into a heavier body hid it.
RigidBody link_body(const urdf::Link& link, const std::string& source) {
  RigidBody body;
  if (!link.inertial) return body;
  const urdf::Inertial& in = *link.inertial;
  const Eigen::Isometry3d T = to_isometry(in.origin);
  Eigen::Matrix3d I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  body.mass = in.mass;
  body.com = T.translation();
  body.inertia = T.linear() * I * T.linear().transpose();
  if (const std::string why = unphysical(body); !why.empty())
    throw InputError(fmt::format("{}: link '{}' {}", source, link.name, why));
  return body;
}

// The joints a <mimic> follows, nearest first: a mimic of a mimic follows its master's master. The list ends at a
// joint that is no mimic, or before a missing joint or a cycle (which check_mimic refuses).
std::vector<const urdf::Joint*> mimic_masters(const urdf::ModelInterface& robot, const urdf::Joint& joint) {
  std::vector<const urdf::Joint*> masters;
  for (const urdf::Joint* follower = &joint; follower->mimic;) {
    const urdf::Joint* master = robot.getJoint(follower->mimic->joint_name).get();
    if (!master || master == &joint || std::find(masters.begin(), masters.end(), master) != masters.end()) break;
    masters.push_back(master);
    follower = master;
  }
  return masters;
}

// How far along its axis a locked joint sits: the middle of its range (0 for continuous joints), or what its
// <mimic> says of the joint it follows, in turn through each mimic between.
double locked_position(const urdf::ModelInterface& robot, const urdf::Joint& joint) {
  std::vector<const urdf::Joint*> followers = mimic_masters(robot, joint);
  followers.insert(followers.begin(), &joint);
  const urdf::Joint& first = *followers.back();  // the first master, which is no mimic (check_mimic)
  double position =
      first.type == urdf::Joint::CONTINUOUS || !first.limits ? 0.0 : 0.5 * (first.limits->lower + first.limits->upper);
  for (auto follower = followers.rbegin() + 1; follower != followers.rend(); ++follower)
    position = (*follower)->mimic->multiplier * position + (*follower)->mimic->offset;
  return position;
}

// The child link's frame in the parent link's frame, the joint at `position`.
Eigen::Isometry3d joint_transform(const urdf::Joint& joint, double position) {
  Eigen::Isometry3d T = to_isometry(joint.parent_to_joint_origin_transform);
  const Eigen::Vector3d axis = to_vector(joint.axis).normalized();
  if (joint.type == urdf::Joint::REVOLUTE || joint.type == urdf::Joint::CONTINUOUS)
    T.rotate(Eigen::AngleAxisd(position, axis));
  else if (joint.type == urdf::Joint::PRISMATIC)
    T.translate(position * axis);
  return T;
}

// Counts the movable joints (mimic ones too: a mimic finger is still a finger) on the longest path below
// (and including) `joint`.
int movable_depth(const urdf::Joint& joint, const urdf::ModelInterface& robot) {
  int deepest = 0;
  const urdf::LinkConstSharedPtr child = robot.getLink(joint.child_link_name);
  for (const auto& next : child->child_joints) deepest = std::max(deepest, movable_depth(*next, robot));
  return deepest + (movable(joint) ? 1 : 0);
}

std::vector<std::string> leaves_below(const urdf::Link& link) {
  if (link.child_links.empty()) return {link.name};
  std::vector<std::string> leaves;
  for (const auto& child : link.child_links) {
    const auto below = leaves_below(*child);
    leaves.insert(leaves.end(), below.begin(), below.end());
  }
  return leaves;
}

// Fingers have at most this many joints in a row; longer movable branches are arms, and the user must choose.
constexpr int kGripperDepth = 3;

// The default chain: from the base, follow the only child branch that holds movable joints; stop at a link
// with none (the arm's end, whatever fixed frames hang below) or with several short ones (a gripper).
std::vector<urdf::JointConstSharedPtr> default_path(const urdf::ModelInterface& robot, const urdf::Link& base,
                                                   const std::string& source, std::vector<std::string>& notes) {
  std::vector<urdf::JointConstSharedPtr> path;
  const urdf::Link* link = &base;
  while (true) {
    std::vector<urdf::JointConstSharedPtr> branches;
    for (const auto& joint : link->child_joints)
      if (movable_depth(*joint, robot) > 0) branches.push_back(joint);
    if (branches.empty()) break;
    if (branches.size() > 1) {
      bool gripper = true;
      std::string names, tips;
      for (const auto& joint : branches) {
        gripper = gripper && movable_depth(*joint, robot) <= kGripperDepth;
        names += (names.empty() ? "'" : ", '") + joint->name + "'";
        for (const auto& leaf : leaves_below(*robot.getLink(joint->child_link_name))) tips += (tips.empty() ? "" : ", ") + leaf;
      }
      if (!gripper)
        throw InputError(fmt::format("{}: the tree branches at '{}' into several arms ({}): choose one with --tip-link "
                                     "(candidates: {})",
                                     source, link->name, names, tips));
      notes.push_back(fmt::format("the chain ends at '{}': its movable branches {} are taken as a gripper, locked and "
                                  "lumped into it (--tip-link chooses another chain)",
                                  link->name, names));
      break;
    }
    path.push_back(branches.front());
    link = robot.getLink(branches.front()->child_link_name).get();
  }
  return path;
}

std::vector<urdf::JointConstSharedPtr> path_to_tip(const urdf::ModelInterface& robot, const std::string& base,
                                                   const std::string& tip, const std::string& source) {
  std::vector<urdf::JointConstSharedPtr> path;
  urdf::LinkConstSharedPtr link = robot.getLink(tip);
  while (link->name != base) {
    const urdf::JointConstSharedPtr joint = link->parent_joint;
    if (!joint) throw InputError(fmt::format("{}: there is no chain from '{}' down to '{}'", source, base, tip));
    path.insert(path.begin(), joint);
    link = robot.getLink(joint->parent_link_name);
  }
  return path;
}

// Reflected rotor inertia from Drake-style transmissions: gear_ratio² × rotor_inertia, per joint name.
std::map<std::string, double> transmission_armature(const tinyxml2::XMLDocument& document, const std::string& source) {
  std::map<std::string, double> armature;
  const tinyxml2::XMLElement* robot = document.FirstChildElement("robot");
  for (const auto* t = robot ? robot->FirstChildElement("transmission") : nullptr; t; t = t->NextSiblingElement("transmission")) {
    const auto* joint = t->FirstChildElement("joint");
    const auto* actuator = t->FirstChildElement("actuator");
    if (!joint || !actuator || !joint->Attribute("name")) continue;
    const auto value = [&](const char* tag, double fallback) {
      const auto* element = actuator->FirstChildElement(tag);
      if (!element) return fallback;
      double x = 0.0;
      if (element->QueryDoubleAttribute("value", &x) != tinyxml2::XML_SUCCESS || !std::isfinite(x) || x < 0.0)
        throw InputError(fmt::format("{}: transmission of joint '{}': <{} value> must be a number >= 0", source,
                                     joint->Attribute("name"), tag));
      return x;
    };
    const double rotor = value("drake:rotor_inertia", 0.0);
    const double gear = value("drake:gear_ratio", 1.0);
    if (rotor > 0.0) armature[joint->Attribute("name")] = gear * gear * rotor;
  }
  return armature;
}

// M(q) singular means some joint moves no inertia; name the joint that the null direction drives most.
void check_inertia(const Model& model, const std::vector<std::string>& joint_names, const std::string& source) {
  const int n = model.dof();
  Eigen::VectorXd q(n);
  for (int i = 0; i < n; ++i) {
    const JointDomain& joint = model.joints[i];
    q(i) = joint.continuous ? 0.3 : joint.lower + 0.37 * (joint.upper - joint.lower);
  }
  Eigen::MatrixXd M(n, n);
  mass_matrix(model, q, M);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(M);
  const Eigen::VectorXd& lambda = eigen.eigenvalues();
  if (lambda.allFinite() && lambda(0) > 1e-10 * std::max(lambda(n - 1), 1e-300)) return;
  Eigen::Index joint = 0;
  eigen.eigenvectors().col(0).cwiseAbs().maxCoeff(&joint);
  // A positive λmin next to a λmax past double's resolution of it (a mass of 1e308 beside one of 1) is no zero.
  if (lambda.allFinite() && lambda(0) > 1e-300)
    throw InputError(fmt::format("{}: M(q) is numerically singular: its smallest eigenvalue {:.3g} (mostly joint "
                                 "'{}') is below 1e-10 of its largest, {:.3g} (check the <inertial> of the links after "
                                 "that joint, and the masses beside them)",
                                 source, lambda(0), joint_names[joint], lambda(n - 1)));
  throw InputError(fmt::format("{}: M(q) is singular: joint '{}' moves no mass or inertia (check the <inertial> "
                               "of the links after it)",
                               source, joint_names[joint]));
}

// The file, parsed: its XML (for the transmissions urdfdom does not read) and urdfdom's model.
struct ParsedUrdf {
  tinyxml2::XMLDocument document;
  urdf::ModelInterfaceSharedPtr robot;
};

void parse(const std::string& path, const std::string& source, ParsedUrdf& parsed) {
  const std::string xml = read_file(path);
  if (parsed.document.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
    throw InputError(fmt::format("{}: broken XML at line {}: {}", source, parsed.document.ErrorLineNum(),
                                 parsed.document.ErrorName()));
  FirstError error;
  parsed.robot = urdf::parseURDF(xml);
  // urdfdom may also log an error and go on: a number it cannot read ("nan", "1e999", "abc") in an <inertial> leaves
  // that inertial partly zero, and the link would be read lighter than the file says.
  if (!parsed.robot || error.any()) throw InputError(fmt::format("{}: not a valid URDF: {}", source, error.message));
}

// A locked joint is lumped at one position; a <mimic> of a chain joint (directly, or through other mimics) moves with
// it, and lumping it would give M without its motion: refused, with the way out. A <mimic> that names no joint of the
// file, or whose masters loop, gives no position: refused.
void check_mimic(const urdf::ModelInterface& robot, const urdf::Joint& joint, const std::set<std::string>& chain_joints,
                 const std::string& source) {
  if (!movable(joint) || !joint.mimic) return;
  const std::vector<const urdf::Joint*> masters = mimic_masters(robot, joint);
  std::string through;
  for (const urdf::Joint* master : masters) {
    if (chain_joints.count(master->name))
      throw InputError(fmt::format("{}: joint '{}' follows the chain joint '{}' (<mimic>{}): a joint coupled to the "
                                   "chain is not modelled; end the chain above '{}' with --tip-link",
                                   source, joint.name, master->name, through, master->name));
    through += fmt::format("{} '{}'", through.empty() ? ", through" : ",", master->name);
  }
  const urdf::Joint& last = masters.empty() ? joint : *masters.back();
  if (!last.mimic) return;
  if (!robot.getJoint(last.mimic->joint_name))
    throw InputError(fmt::format("{}: joint '{}' has <mimic joint=\"{}\">, which names no joint of the file", source,
                                 last.name, last.mimic->joint_name));
  throw InputError(fmt::format("{}: joint '{}' follows a loop of <mimic> joints (<mimic>{}): it has no position to be "
                               "locked at", source, joint.name, through));
}

// The chain's joints and lumped bodies along `path`, with each movable joint's name and domain. Movable joints start
// a new body; everything rigidly attached (fixed joints, locked mimic joints, side branches locked at their stated
// positions) is lumped into the body it hangs from. Whatever is attached to the base itself is the fixed world.
struct BuiltChain {
  SerialChain chain;
  std::vector<std::string> joint_names;
  std::vector<JointDomain> domains;
  std::vector<std::string> locked;
  std::vector<std::string> held_fixed;  // free joints above the arm (a mobile base)
};

BuiltChain build_chain(const urdf::ModelInterface& robot, const std::string& base,
                       const std::vector<urdf::JointConstSharedPtr>& path, const RobotSource& options,
                       const std::string& source) {
  BuiltChain built;
  SerialChain& chain = built.chain;
  std::set<std::string> on_path, chain_joints;
  for (const auto& joint : path) {
    on_path.insert(joint->name);
    if (chain_candidate(*joint)) chain_joints.insert(joint->name);
  }
  Eigen::Isometry3d placement = Eigen::Isometry3d::Identity();  // current link in the current body's frame
  std::function<void(const urdf::Link&, const Eigen::Isometry3d&)> lump_subtree = [&](const urdf::Link& link,
                                                                                        const Eigen::Isometry3d& T) {
    if (!chain.bodies.empty()) chain.bodies.back() = lump(chain.bodies.back(), link_body(link, source), T.linear(), T.translation());
    for (const auto& joint : link.child_joints) {
      if (on_path.count(joint->name)) continue;
      check_free_joint(*joint, !chain.bodies.empty(), source, built.held_fixed);
      check_mimic(robot, *joint, chain_joints, source);
      const double position = movable(*joint) ? locked_position(robot, *joint) : 0.0;
      if (movable(*joint) && !chain.bodies.empty()) built.locked.push_back(fmt::format("'{}' at {:.4g}", joint->name, position));
      lump_subtree(*robot.getLink(joint->child_link_name), T * joint_transform(*joint, position));
    }
  };
  lump_subtree(*robot.getLink(base), placement);
  for (const auto& joint : path) {
    check_free_joint(*joint, !chain.joints.empty(), source, built.held_fixed);
    if (chain_candidate(*joint)) {
      ChainJoint c;
      c.name = joint->name;
      c.type = joint->type == urdf::Joint::PRISMATIC ? JointType::prismatic : JointType::revolute;
      const Eigen::Isometry3d origin = placement * to_isometry(joint->parent_to_joint_origin_transform);
      c.rotation = origin.linear();
      c.translation = origin.translation();
      const Eigen::Vector3d axis = to_vector(joint->axis);
      if (!(axis.norm() > 0.0)) throw InputError(fmt::format("{}: joint '{}' has a zero <axis>", source, joint->name));
      c.axis = axis.normalized();
      chain.joints.push_back(c);
      chain.bodies.emplace_back();
      const std::size_t index = built.joint_names.size();
      built.joint_names.push_back(joint->name);
      built.domains.push_back(
          joint_domain(*joint, index < options.joint_limits.size() ? &options.joint_limits[index] : nullptr, source));
      placement = Eigen::Isometry3d::Identity();
    } else {
      check_mimic(robot, *joint, chain_joints, source);
      const double position = movable(*joint) ? locked_position(robot, *joint) : 0.0;
      if (movable(*joint)) built.locked.push_back(fmt::format("'{}' at {:.4g}", joint->name, position));
      placement = placement * joint_transform(*joint, position);
    }
    lump_subtree(*robot.getLink(joint->child_link_name), placement);
  }
  return built;
}

// The velocity box from <limit velocity> (none when a joint has no positive limit: --vmax is then required), and
// F = diag(<dynamics damping>); a note names the joints whose Coulomb friction is left out.
void velocities_and_friction(const urdf::ModelInterface& robot, const std::vector<std::string>& names,
                             const std::string& source, Model& model) {
  const int n = static_cast<int>(names.size());
  model.friction = Eigen::MatrixXd::Zero(n, n);
  model.velocity_bounds.resize(n);
  bool every_velocity_limit = true;
  std::vector<std::string> coulomb;
  for (int i = 0; i < n; ++i) {
    const urdf::JointConstSharedPtr joint = robot.getJoint(names[i]);
    const double velocity = joint->limits ? joint->limits->velocity : 0.0;
    model.velocity_bounds(i) = velocity;
    if (!(velocity > 0.0)) {
      every_velocity_limit = false;
      // A continuous joint often has no <limit> at all: said so, not as a limit of 0 it does not declare.
      const std::string declared =
          joint->limits ? fmt::format("has <limit velocity=\"{}\">", velocity) : std::string("has no <limit>");
      model.missing_velocity_bounds += fmt::format("{}joint '{}' {}", model.missing_velocity_bounds.empty() ? "" : ", ",
                                                   joint->name, declared);
    }
    const double damping = joint->dynamics ? joint->dynamics->damping : 0.0;
    if (!(damping >= 0.0) || !std::isfinite(damping))
      throw InputError(fmt::format("{}: joint '{}' has damping {}: must be >= 0", source, joint->name, damping));
    model.friction(i, i) = damping;
    if (joint->dynamics && joint->dynamics->friction != 0.0) coulomb.push_back("'" + joint->name + "'");
  }
  if (!every_velocity_limit) model.velocity_bounds.resize(0);
  // Not modelled (docs/robots.md): said, so that a file that declares it does not pass for the plant certified.
  if (!coulomb.empty())
    model.notes.push_back(fmt::format("Coulomb friction (<dynamics friction>) of {} is not modelled: the observer and "
                                      "its certificate take the viscous damping only",
                                      fmt::join(coulomb, ", ")));
}

// Reflected rotor inertia: --armature, or the file's Drake transmissions.
Eigen::VectorXd chain_armature(const tinyxml2::XMLDocument& document, const std::vector<std::string>& names,
                               const RobotSource& options, const std::string& source, std::vector<std::string>& notes) {
  const int n = static_cast<int>(names.size());
  Eigen::VectorXd armature = Eigen::VectorXd::Zero(n);
  if (!options.armature.empty()) {
    if (static_cast<int>(options.armature.size()) != n)
      throw InputError(fmt::format("--armature: the chain has {} joints; give one value per joint, not {}", n, options.armature.size()));
    for (int i = 0; i < n; ++i) {
      if (!(options.armature[i] >= 0.0)) throw InputError(fmt::format("--armature: a{} = {} must be >= 0", i + 1, options.armature[i]));
      armature(i) = options.armature[i];
    }
    return armature;
  }
  const auto from_file = transmission_armature(document, source);
  std::vector<std::string> given, missing;
  for (int i = 0; i < n; ++i) {
    const auto it = from_file.find(names[i]);
    (it != from_file.end() ? given : missing).push_back(names[i]);
    if (it != from_file.end()) armature(i) = it->second;
  }
  if (!given.empty())
    notes.push_back(fmt::format("armature of {} from the file's transmissions (drake:gear_ratio² × drake:rotor_inertia); "
                                "--armature overrides",
                                fmt::join(given, ", ")));
  // Most published URDFs give none (a <mechanicalReduction> is not an inertia), and without it the bounds and θ of a
  // geared arm are those of another robot (docs/robots.md, "Rotor inertia matters").
  if (!missing.empty())
    notes.push_back(fmt::format("no rotor inertia in the file for {} (armature 0): a geared joint's reflected rotor "
                                "inertia, gear ratio² × rotor inertia, dominates M at the wrist; give it with --armature",
                                given.empty() ? std::string("any joint") : fmt::format("{}", fmt::join(missing, ", "))));
  return armature;
}

// H from --actuated (default: every joint).
Eigen::MatrixXd input_matrix(const std::vector<int>& actuated, int n) {
  if (actuated.empty()) return Eigen::MatrixXd::Identity(n, n);
  if (static_cast<int>(actuated.size()) != n)
    throw InputError(fmt::format("--actuated: the chain has {} joints; give one flag per joint, not {}", n, actuated.size()));
  std::vector<int> columns;
  for (int i = 0; i < n; ++i) {
    if (actuated[i] != 0 && actuated[i] != 1)
      throw InputError(fmt::format("--actuated: flag {} = {} must be 0 or 1", i + 1, actuated[i]));
    if (actuated[i] == 1) columns.push_back(i);
  }
  if (columns.empty()) throw InputError("--actuated: at least one joint must be actuated");
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(columns.size()));
  for (std::size_t c = 0; c < columns.size(); ++c) H(columns[c], static_cast<Eigen::Index>(c)) = 1.0;
  return H;
}

}  // namespace

Model load_urdf(const RobotSource& options) {
  const std::string source = "URDF '" + options.robot + "'";
  ParsedUrdf parsed;
  parse(options.robot, source, parsed);
  const urdf::ModelInterface& robot = *parsed.robot;
  const std::string base = options.base_link.empty() ? robot.getRoot()->name : options.base_link;
  for (const auto* link : {&base, &options.tip_link})
    if (!link->empty() && !robot.getLink(*link)) throw InputError(fmt::format("{}: there is no link '{}'", source, *link));
  Model model;
  model.name = robot.getName();
  const auto path = options.tip_link.empty() ? default_path(robot, *robot.getLink(base), source, model.notes)
                                             : path_to_tip(robot, base, options.tip_link, source);
  BuiltChain built = build_chain(robot, base, path, options, source);
  const int n = built.chain.dof();
  if (n == 0) throw InputError(fmt::format("{}: the chain below '{}' has no moving joint", source, base));
  if (!options.joint_limits.empty() && static_cast<int>(options.joint_limits.size()) != n)
    throw InputError(fmt::format("--joint-limits: the chain has {} joints; give one range per joint, not {}", n,
                                 options.joint_limits.size()));
  if (!built.locked.empty()) {
    model.notes.push_back(fmt::format("locked and lumped into the chain's bodies: {} (middle of range, or as <mimic> says)",
                                      fmt::join(built.locked, ", ")));
  }
  if (!built.held_fixed.empty())
    model.notes.push_back(fmt::format("held fixed (the arm's base does not move): {}", fmt::join(built.held_fixed, ", ")));
  model.notes.insert(model.notes.begin(), fmt::format("chain: {} joints from '{}' to '{}'", n, base,
                                                      path.empty() ? base : path.back()->child_link_name));
  model.joints = built.domains;
  velocities_and_friction(robot, built.joint_names, source, model);
  built.chain.armature = chain_armature(parsed.document, built.joint_names, options, source, model.notes);
  model.input_matrix = input_matrix(options.actuated, n);
  validate_chain(built.chain, source);
  model.structure = std::move(built.chain);
  validate_model(model);
  check_inertia(model, built.joint_names, source);
  return model;
}

}  // namespace obsgain
