#include "obsgain/urdf_model.hpp"

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <kdl/chain.hpp>
#include <kdl/chaindynparam.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <atomic>
#include <fstream>
#include <memory>
#include <sstream>
#include <unordered_map>

namespace obsgain {

namespace {

// KDL's solvers keep scratch state and so are not re-entrant: each thread gets its own solver and
// argument arrays per chain, built on first use (Monte Carlo evaluates one model on all cores).
struct KdlWorkspace {
  KDL::ChainDynParam solver;
  KDL::JntArray q, v, out;
  KDL::JntSpaceInertiaMatrix M;
  KdlWorkspace(const KDL::Chain& chain, unsigned n)
      : solver(chain, KDL::Vector(0.0, 0.0, -9.81)), q(n), v(n), out(n), M(n) {}
};

class KdlDynamics final : public Dynamics {
 public:
  explicit KdlDynamics(KDL::Chain chain) : chain_(std::move(chain)), n_(static_cast<int>(chain_.getNrOfJoints())) {}

  int dof() const override { return n_; }

  void mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const override {
    KdlWorkspace& w = workspace();
    w.q.data = q;
    check(w.solver.JntToMass(w.q, w.M), "JntToMass");
    M = w.M.data;
  }

  void coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                Eigen::Ref<Eigen::VectorXd> A) const override {
    KdlWorkspace& w = workspace();
    w.q.data = q;
    w.v.data = v;
    check(w.solver.JntToCoriolis(w.q, w.v, w.out), "JntToCoriolis");
    A = w.out.data;
  }

  void gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const override {
    KdlWorkspace& w = workspace();
    w.q.data = q;
    check(w.solver.JntToGravity(w.q, w.out), "JntToGravity");
    g = w.out.data;
  }

  // Rotating or translating the whole chain about its first joint moves no body relative to another, so the
  // kinetic energy, hence M and C, do not depend on q1.
  std::vector<int> configuration_joints() const override {
    std::vector<int> joints;
    for (int i = 1; i < n_; ++i) joints.push_back(i);
    return joints;
  }

 private:
  static void check(int status, const char* call) {
    if (status < 0) throw std::runtime_error(fmt::format("KDL {} failed with status {}", call, status));
  }

  KdlWorkspace& workspace() const {
    thread_local std::unordered_map<std::uint64_t, std::unique_ptr<KdlWorkspace>> workspaces;
    auto& slot = workspaces[id_];
    if (!slot) slot = std::make_unique<KdlWorkspace>(chain_, static_cast<unsigned>(n_));
    return *slot;
  }

  // Workspaces are keyed by a never-reused id, not by address: a later model at the same address must not
  // find this chain's solver.
  static std::uint64_t next_id() {
    static std::atomic<std::uint64_t> counter{0};
    return ++counter;
  }

  KDL::Chain chain_;  // ChainDynParam keeps a reference to it: never moved after construction
  int n_;
  std::uint64_t id_ = next_id();
};

// urdfdom reports why it rejects a file through console_bridge; keep its first error for our one-line message
// instead of letting it print.
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
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && message.empty()) message = text;
  }
  std::string message;

 private:
  console_bridge::LogLevel previous_level_;
};

std::string read_file(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw InputError(fmt::format("cannot read URDF file '{}'", path));
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

// Whether `tip` is `base` or lies below it (a chain must hang from its base, not climb the tree).
bool descends_from(const KDL::Tree& tree, const std::string& tip, const std::string& base) {
  auto it = tree.getSegments().find(tip);
  while (it != tree.getSegments().end()) {
    if (it->first == base) return true;
    if (it == tree.getRootSegment()) return false;
    it = GetTreeElementParent(it->second);
  }
  return false;
}

std::string default_tip(const KDL::Tree& tree, const std::string& base, const std::string& source) {
  std::vector<std::string> leaves;
  for (const auto& [name, element] : tree.getSegments()) {
    if (GetTreeElementChildren(element).empty() && descends_from(tree, name, base)) leaves.push_back(name);
  }
  if (leaves.size() != 1) {
    std::string list;
    for (const auto& leaf : leaves) list += (list.empty() ? "" : ", ") + leaf;
    throw InputError(fmt::format("{}: the tree below '{}' has {} leaves ({}): choose one with --tip-link", source,
                                 base, leaves.size(), list));
  }
  return leaves.front();
}

JointDomain joint_domain(const urdf::Joint& joint, const std::string& source) {
  JointDomain domain;
  switch (joint.type) {
    case urdf::Joint::CONTINUOUS:
      return domain;
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::PRISMATIC:
      domain.type = joint.type == urdf::Joint::REVOLUTE ? JointType::revolute : JointType::prismatic;
      domain.continuous = false;
      if (!joint.limits || !(joint.limits->lower < joint.limits->upper))
        throw InputError(fmt::format("{}: joint '{}' needs <limit lower upper> with lower < upper", source, joint.name));
      domain.lower = joint.limits->lower;
      domain.upper = joint.limits->upper;
      return domain;
    default:
      throw InputError(fmt::format("{}: joint '{}' is neither revolute, continuous nor prismatic", source, joint.name));
  }
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
  model.dynamics->mass_matrix(q, M);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(M);
  const Eigen::VectorXd& lambda = eigen.eigenvalues();
  if (lambda.allFinite() && lambda(0) > 1e-10 * std::max(lambda(n - 1), 1e-300)) return;
  Eigen::Index joint = 0;
  eigen.eigenvectors().col(0).cwiseAbs().maxCoeff(&joint);
  throw InputError(fmt::format("{}: M(q) is singular: joint '{}' moves no mass or inertia (check the <inertial> "
                               "of the links after it)",
                               source, joint_names[joint]));
}

}  // namespace

Model load_urdf(const RobotSource& options) {
  const std::string& path = options.robot;
  const std::string source = "URDF '" + path + "'";
  const std::string xml = read_file(path);
  tinyxml2::XMLDocument document;
  if (document.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
    throw InputError(fmt::format("{}: broken XML at line {}: {}", source, document.ErrorLineNum(), document.ErrorName()));

  urdf::ModelInterfaceSharedPtr robot;
  {
    FirstError error;
    robot = urdf::parseURDF(xml);
    if (!robot) throw InputError(fmt::format("{}: not a valid URDF: {}", source, error.message));
  }
  // The root link is the fixed world: its inertia enters no dynamics, and kdl_parser would warn about it
  // through ROS logging.
  if (robot->root_link_) robot->root_link_->inertial.reset();
  KDL::Tree tree;
  if (!kdl_parser::treeFromUrdfModel(*robot, tree)) throw InputError(fmt::format("{}: kdl_parser rejected it", source));

  const std::string base = options.base_link.empty() ? tree.getRootSegment()->first : options.base_link;
  for (const auto* link : {&base, &options.tip_link}) {
    if (!link->empty() && !tree.getSegments().count(*link))
      throw InputError(fmt::format("{}: there is no link '{}'", source, *link));
  }
  const std::string tip = options.tip_link.empty() ? default_tip(tree, base, source) : options.tip_link;
  KDL::Chain chain;
  if (tip == base || !descends_from(tree, tip, base) || !tree.getChain(base, tip, chain))
    throw InputError(fmt::format("{}: there is no chain from '{}' down to '{}'", source, base, tip));
  const int n = static_cast<int>(chain.getNrOfJoints());
  if (n == 0) throw InputError(fmt::format("{}: the chain from '{}' to '{}' has no moving joint", source, base, tip));

  Model model;
  model.name = robot->getName();
  model.friction = Eigen::MatrixXd::Zero(n, n);
  model.velocity_bounds.resize(n);
  std::vector<std::string> joint_names;
  bool every_velocity_limit = true;
  for (const KDL::Segment& segment : chain.segments) {
    if (segment.getJoint().getType() == KDL::Joint::None) continue;
    const urdf::JointConstSharedPtr joint = robot->getJoint(segment.getJoint().getName());
    const auto i = static_cast<Eigen::Index>(joint_names.size());
    joint_names.push_back(joint->name);
    model.joints.push_back(joint_domain(*joint, source));
    const double velocity = joint->limits ? joint->limits->velocity : 0.0;
    every_velocity_limit = every_velocity_limit && velocity > 0.0;
    model.velocity_bounds(i) = velocity;
    const double damping = joint->dynamics ? joint->dynamics->damping : 0.0;
    if (!(damping >= 0.0) || !std::isfinite(damping))
      throw InputError(fmt::format("{}: joint '{}' has damping {}: must be >= 0", source, joint->name, damping));
    model.friction(i, i) = damping;
  }
  if (!every_velocity_limit) model.velocity_bounds.resize(0);  // then --vmax is required

  if (options.actuated.empty()) {
    model.input_matrix = Eigen::MatrixXd::Identity(n, n);
  } else {
    if (static_cast<int>(options.actuated.size()) != n)
      throw InputError(fmt::format("actuated: the chain has {} joints, got {} flags", n, options.actuated.size()));
    std::vector<int> columns;
    for (int i = 0; i < n; ++i) {
      if (options.actuated[i] != 0 && options.actuated[i] != 1)
        throw InputError(fmt::format("actuated: flag {} = {} must be 0 or 1", i + 1, options.actuated[i]));
      if (options.actuated[i] == 1) columns.push_back(i);
    }
    if (columns.empty()) throw InputError("actuated: at least one joint must be actuated");
    model.input_matrix = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(columns.size()));
    for (std::size_t c = 0; c < columns.size(); ++c) model.input_matrix(columns[c], static_cast<Eigen::Index>(c)) = 1.0;
  }

  model.dynamics = std::make_shared<const KdlDynamics>(std::move(chain));
  validate_model(model);
  check_inertia(model, joint_names, source);
  return model;
}

}  // namespace obsgain
