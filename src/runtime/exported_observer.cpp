#include "obsgain/runtime/exported_observer.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace obsgain {

namespace {

std::string number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  return buffer;
}

void write_values(std::ostringstream& out, const char* key, const double* values, Eigen::Index count) {
  out << key;
  for (Eigen::Index i = 0; i < count; ++i) out << ' ' << number(values[i]);
  out << '\n';
}

void write_matrix(std::ostringstream& out, const char* key, const Eigen::MatrixXd& M) {
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = M;
  out << key << ' ' << M.rows() << ' ' << M.cols();
  for (Eigen::Index i = 0; i < rows.size(); ++i) out << ' ' << number(rows.data()[i]);
  out << '\n';
}

void write_structure(std::ostringstream& out, const RobotStructure& structure) {
  if (const auto* p = std::get_if<Planar2RParameters>(&structure)) {
    out << "structure planar_2r\n";
    const double values[] = {p->pi[0], p->pi[1], p->pi[2], p->pi[3], p->pi[4], p->g0, p->armature[0], p->armature[1]};
    write_values(out, "parameters", values, 8);
    return;
  }
  const SerialChain& chain = std::get<SerialChain>(structure);
  out << "structure serial_chain " << chain.dof() << '\n';
  write_values(out, "gravity", chain.gravity.data(), 3);
  for (int i = 0; i < chain.dof(); ++i) {
    const ChainJoint& j = chain.joints[i];
    const RigidBody& b = chain.bodies[i];
    out << (j.type == JointType::revolute ? "revolute" : "prismatic") << '\n';
    write_matrix(out, "rotation", j.rotation);
    write_values(out, "translation", j.translation.data(), 3);
    write_values(out, "axis", j.axis.data(), 3);
    write_values(out, "mass", &b.mass, 1);
    write_values(out, "com", b.com.data(), 3);
    write_matrix(out, "inertia", b.inertia);
  }
  write_values(out, "armature", chain.armature.data(), chain.armature.size());
}

}  // namespace

std::string exported_observer_text(const ExportedObserver& e) {
  std::ostringstream out;
  out << "obsgain-observer 1\n";
  out << "name " << e.model.name << '\n';
  write_structure(out, e.model.structure);
  for (const JointDomain& d : e.model.joints) {
    out << "domain " << (d.type == JointType::revolute ? "revolute" : "prismatic");
    if (d.continuous)
      out << " continuous\n";
    else
      out << ' ' << number(d.lower) << ' ' << number(d.upper) << '\n';
  }
  write_matrix(out, "friction", e.model.friction);
  write_matrix(out, "input_matrix", e.model.input_matrix);
  const CertifiedObserver& o = e.observer;
  out << "certificate " << to_string(o.certificate) << '\n';
  const double gains[] = {o.alpha, o.beta, o.theta, o.k1, o.k2, o.gamma, o.k, o.L, o.certified ? 1.0 : 0.0};
  write_values(out, "observer", gains, 9);
  write_values(out, "velocity_bounds", o.velocity_bounds.data(), o.velocity_bounds.size());
  write_matrix(out, "P", o.P);
  out << "substeps " << e.substeps << '\n';
  write_values(out, "sample_period", &e.sample_period, 1);
  out << "end\n";
  return out.str();
}

namespace {

class Reader {
 public:
  explicit Reader(const std::string& text) : in_(text) {}

  void expect(const std::string& keyword) {
    std::string word;
    if (!(in_ >> word) || word != keyword)
      throw InputError("exported observer: expected '" + keyword + "', got '" + word.substr(0, 40) + "'");
    keyword_ = keyword;
  }
  std::string word() {
    std::string w;
    if (!(in_ >> w)) fail("ends early");
    return w;
  }
  std::string rest_of_line() {
    std::string line;
    std::getline(in_ >> std::ws, line);
    return line;
  }
  double value() { return number(word()); }
  double number(const std::string& w) const {
    char* end = nullptr;
    const double x = std::strtod(w.c_str(), &end);
    if (end == w.c_str() || *end != '\0' || !std::isfinite(x)) fail("has '" + w.substr(0, 40) + "', not a finite number");
    return x;
  }
  int count(int limit) {
    const double x = value();
    if (x != std::floor(x) || x < 0 || x > limit) fail("has a count out of range");
    return static_cast<int>(x);
  }
  Eigen::VectorXd values(const std::string& keyword, int count) {
    expect(keyword);
    Eigen::VectorXd v(count);
    for (int i = 0; i < count; ++i) v(i) = value();
    return v;
  }
  Eigen::MatrixXd matrix(const std::string& keyword, int rows, int cols) {
    expect(keyword);
    if (count(1024) != rows || count(1024) != cols) fail("has the wrong size");
    Eigen::MatrixXd M(rows, cols);
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) M(i, j) = value();
    return M;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError("exported observer: '" + keyword_ + "' " + what);
  }

 private:
  std::istringstream in_;
  std::string keyword_;
};

SerialChain read_chain(Reader& r, int n) {
  SerialChain chain;
  chain.gravity = r.values("gravity", 3);
  for (int i = 0; i < n; ++i) {
    ChainJoint joint;
    const std::string type = r.word();
    if (type != "revolute" && type != "prismatic") r.fail("joint type '" + type.substr(0, 20) + "'");
    joint.type = type == "revolute" ? JointType::revolute : JointType::prismatic;
    joint.rotation = r.matrix("rotation", 3, 3);
    joint.translation = r.values("translation", 3);
    joint.axis = r.values("axis", 3);
    RigidBody body;
    body.mass = r.values("mass", 1)(0);
    body.com = r.values("com", 3);
    body.inertia = r.matrix("inertia", 3, 3);
    chain.joints.push_back(joint);
    chain.bodies.push_back(body);
  }
  chain.armature = r.values("armature", n);
  return chain;
}

void read_model(Reader& r, Model& model) {
  r.expect("name");
  model.name = r.rest_of_line();
  r.expect("structure");
  const std::string kind = r.word();
  if (kind == "planar_2r") {
    const Eigen::VectorXd p = r.values("parameters", 8);
    model.structure = Planar2RParameters{{p(0), p(1), p(2), p(3), p(4)}, p(5), {p(6), p(7)}};
  } else if (kind == "serial_chain") {
    model.structure = read_chain(r, r.count(kMaxChainJoints));
  } else {
    r.fail("kind '" + kind.substr(0, 20) + "'");
  }
  const int n = model.dof();
  for (int i = 0; i < n; ++i) {
    r.expect("domain");
    JointDomain d;
    d.type = r.word() == "prismatic" ? JointType::prismatic : JointType::revolute;
    const std::string first = r.word();
    if (first != "continuous") {
      d.continuous = false;
      d.lower = r.number(first);
      d.upper = r.value();
    }
    model.joints.push_back(d);
  }
  model.friction = r.matrix("friction", n, n);
  r.expect("input_matrix");
  const int rows = r.count(1024), cols = r.count(1024);
  if (rows != n || cols < 1) r.fail("has the wrong size");
  model.input_matrix.resize(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) model.input_matrix(i, j) = r.value();
}

}  // namespace

ExportedObserver read_exported_observer(const std::string& text) {
  Reader r(text);
  r.expect("obsgain-observer");
  if (r.count(1000) != 1) r.fail("version is not 1");
  ExportedObserver e;
  read_model(r, e.model);
  const int n = e.model.dof();
  r.expect("certificate");
  const std::string kind = r.word();
  CertifiedObserver& o = e.observer;
  const std::optional<CertificateKind> certificate = certificate_kind(kind);
  if (!certificate) throw InputError("exported observer: certificate '" + kind.substr(0, 40) + "' is not one obsgain writes");
  o.certificate = *certificate;
  const Eigen::VectorXd g = r.values("observer", 9);
  o.alpha = g(0), o.beta = g(1), o.theta = g(2), o.k1 = g(3), o.k2 = g(4), o.gamma = g(5), o.k = g(6), o.L = g(7);
  o.certified = g(8) != 0.0;
  o.velocity_bounds = r.values("velocity_bounds", n);
  o.P = r.matrix("P", 2 * n, 2 * n);
  r.expect("substeps");
  e.substeps = r.count(100000);
  e.sample_period = r.values("sample_period", 1)(0);
  r.expect("end");
  e.model.velocity_bounds = o.velocity_bounds;
  e.model.fingerprint = "exported";
  validate_model(e.model);
  return e;
}

}  // namespace obsgain
