#include "obsgain/bounds/box_forms.hpp"

#include "obsgain/model/dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

namespace obsgain {

namespace {

using taylor_detail::up;

// The largest distance from a point of the interval to `c` (rounded up): |v - c| for every v in x.
double farther_end(const Interval& x, double c) {
  return std::max((Interval(x.upper()) - Interval(c)).upper(), (Interval(c) - Interval(x.lower())).upper());
}

// A side of the box: centre ± radius (radius rounded up, so that the box's side lies inside), and for a wide revolute
// side the rectangle around its arc (every end point rounded outward). Its symbols are the next ones free.
BoxSide box_side(const Interval& side, int joint, bool revolute, int& next_symbol) {
  BoxSide s;
  s.joint = joint;
  s.centre = centre(side);
  s.radius = std::max(side.upper() - s.centre, s.centre - side.lower()) * (1.0 + 0x1p-50) + kTaylorUnderflow;
  s.symbol = next_symbol++;
  if (!revolute || s.radius <= kArcRadius) return s;
  s.arc_symbol = next_symbol++;
  const Interval x = boost::numeric::cos(Interval(0.0, s.radius)), y = boost::numeric::sin(Interval(-s.radius, s.radius));
  s.x_centre = 0.5 * (x.lower() + x.upper());
  s.x_radius = farther_end(x, s.x_centre);
  s.y_radius = std::max(-y.lower(), y.upper());
  return s;
}

// cos q and sin q over an arc side: R(m) (x, y), with cos m and sin m rounded and their errors in the remainders.
std::pair<Taylor, Taylor> arc_trigonometry(const BoxSide& side) {
  const Taylor x = Taylor::symbol(side.x_centre, side.x_radius, side.arc_symbol);
  const Taylor y = Taylor::symbol(0.0, side.y_radius, side.symbol);
  const Interval cm = boost::numeric::cos(Interval(side.centre)), sm = boost::numeric::sin(Interval(side.centre));
  const double c0 = centre(cm), s0 = centre(sm);
  // |cos m - c0| |x| + |sin m - s0| |y| with |x|, |y| <= 1.
  const double error = up(farther_end(cm, c0) + farther_end(sm, s0));
  Taylor c = c0 * x - s0 * y, s = s0 * x + c0 * y;
  c.r = up(c.r + error);
  s.r = up(s.r + error);
  return {c, s};
}

// The chain's kinematics over the box on S = Taylor or Dual<Taylor> (derivative d along side d): every joint from its
// form of q, then each arc side's cosine and sine replaced by the arc's (d/dq cos = -sin, d/dq sin = cos).
template <class S>
std::unique_ptr<ChainKinematics<S>> box_kinematics(const SerialChain& chain, const std::vector<S>& q, const BoxForms& f,
                                                  const std::vector<int>& joints) {
  // Kilobytes per scalar: not on the stack. Default-initialised (not make_unique's value-initialisation, which would
  // zero the whole object first, hundreds of kilobytes per box): the scalars' own constructors make them zero.
  std::unique_ptr<ChainKinematics<S>> k(new ChainKinematics<S>);
  chain_kinematics(chain, q.data(), *k);
  for (std::size_t side = 0; side < f.sides.size(); ++side) {
    if (f.sides[side].arc_symbol < 0) continue;
    const auto [c, s] = arc_trigonometry(f.sides[side]);
    if constexpr (std::is_same_v<S, Taylor>) {
      set_joint_trigonometry(*k, joints[side], c, s);
    } else {
      S C(c), Sn(s);
      C.directions = Sn.directions = static_cast<int>(f.sides.size());
      C.derivative[side] = -s;
      Sn.derivative[side] = c;
      set_joint_trigonometry(*k, joints[side], C, Sn);
    }
  }
  return k;
}

// Σ over M's entries of |a_k| + Σ_{l} |b_kl| for the planar family's single side.
std::vector<double> planar_sensitivities(const std::vector<Taylor>& M, int sides) {
  std::vector<double> s(static_cast<std::size_t>(sides), 0.0);
  for (const Taylor& x : M)
    for (int k = 0; k < sides; ++k) {
      s[k] += std::abs(x.slope(k));
      for (int l = 0; l < sides; ++l) s[k] += std::abs(x.curvature(kPairs.index[k][l]));
    }
  return s;
}

}  // namespace

std::vector<double> BoxForms::symbols_at(const Eigen::VectorXd& q) const {
  std::vector<double> e(static_cast<std::size_t>(symbols), 0.0);
  for (const BoxSide& s : sides) {
    const double t = q(s.joint) - s.centre;
    if (s.arc_symbol < 0) {
      e[s.symbol] = t / s.radius;
    } else {
      e[s.symbol] = std::sin(t) / s.y_radius;
      e[s.arc_symbol] = (std::cos(t) - s.x_centre) / s.x_radius;
    }
  }
  return e;
}

BoxForms box_forms(const Model& model, const JointSearch& search, const std::vector<Interval>& box, bool tensors) {
  BoxForms f;
  f.n = model.dof();
  const int m = static_cast<int>(box.size());
  const auto* chain = std::get_if<SerialChain>(&model.structure);
  // Symbols from the tip: a form carries only the symbols below its highest, and the composite-rigid-body algorithm
  // starts at the tip, so its early forms carry few (a prefix of the pairs).
  int next_symbol = 0;
  f.sides.resize(static_cast<std::size_t>(m));
  for (int k = m; k-- > 0;) {
    const bool revolute = chain && chain->joints[search.joints[k]].type == JointType::revolute;
    f.sides[k] = box_side(box[k], search.joints[k], revolute, next_symbol);
  }
  f.symbols = next_symbol;
  f.side_of.resize(static_cast<std::size_t>(f.symbols));
  for (int k = 0; k < m; ++k) {
    f.side_of[f.sides[k].symbol] = k;
    if (f.sides[k].arc_symbol >= 0) f.side_of[f.sides[k].arc_symbol] = k;
  }
  std::vector<Taylor> q(static_cast<std::size_t>(f.n));
  for (int i = 0; i < f.n; ++i) q[i] = Taylor(search.fixed_q(i));
  for (int k = 0; k < m; ++k) q[search.joints[k]] = Taylor::symbol(f.sides[k].centre, f.sides[k].radius, f.sides[k].symbol);
  const auto entries = static_cast<std::size_t>(f.n * f.n);
  f.M.resize(entries);
  if (!chain) {  // the planar family: one searched joint, no split to choose
    mass_matrix_of(model, q.data(), f.M.data());
    f.sensitivity = planar_sensitivities(f.M, m);
    if (tensors) {
      f.N.resize(entries * static_cast<std::size_t>(f.n));
      coriolis_tensors_of(model, q.data(), f.N.data());
    }
    return f;
  }
  f.sensitivity.assign(static_cast<std::size_t>(m), 0.0);
  if (!tensors) {  // M alone: the derivatives' enclosures by intervals, cheaper than on forms
    chain_mass_matrix(*chain, *box_kinematics(*chain, q, f, search.joints), f.M.data());
    std::vector<Interval> qi(static_cast<std::size_t>(f.n));
    for (int i = 0; i < f.n; ++i) qi[i] = Interval(search.fixed_q(i));
    for (int k = 0; k < m; ++k) qi[search.joints[k]] = box[k];
    const std::vector<Dual<Interval>> M = mass_matrix_with_derivatives(model, search.joints, qi.data());
    for (std::size_t e = 0; e < entries; ++e)
      for (int k = 0; k < m; ++k) f.sensitivity[k] += f.sides[k].radius * boost::numeric::norm(M[e].derivative[k]);
    return f;
  }
  std::vector<Dual<Taylor>> qd(static_cast<std::size_t>(f.n));
  for (int i = 0; i < f.n; ++i) qd[i] = Dual<Taylor>(q[i]);
  for (int k = 0; k < m; ++k) qd[search.joints[k]] = Dual<Taylor>::variable(q[search.joints[k]], k, m);
  std::vector<Dual<Taylor>> M(entries);
  chain_mass_matrix(*chain, *box_kinematics(*chain, qd, f, search.joints), M.data());
  for (std::size_t e = 0; e < entries; ++e) {
    f.M[e] = M[e].value;
    for (int k = 0; k < m; ++k)
      f.sensitivity[k] += f.sides[k].radius * (std::abs(M[e].derivative[k].c) + M[e].derivative[k].radius());
  }
  f.N.resize(entries * static_cast<std::size_t>(f.n));
  christoffel_tensors_from(f.n, search.joints, M, f.N.data());
  return f;
}

}  // namespace obsgain
