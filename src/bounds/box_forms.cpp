#include "obsgain/bounds/box_forms.hpp"

#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/taylor3.hpp"

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

// cos q and sin q over an arc side of centre m: R(m) (x, y) for the forms x, y of its symbols (Taylor or Taylor3), with
// cos m and sin m rounded and their errors in the remainders.
template <class Form>
std::pair<Form, Form> rotated_arc(double m, const Form& x, const Form& y) {
  const Interval cm = boost::numeric::cos(Interval(m)), sm = boost::numeric::sin(Interval(m));
  const double c0 = centre(cm), s0 = centre(sm);
  // |cos m - c0| |x| + |sin m - s0| |y| with |x|, |y| <= 1.
  const double error = up(farther_end(cm, c0) + farther_end(sm, s0));
  Form c = c0 * x - s0 * y, s = s0 * x + c0 * y;
  c.r = up(c.r + error);
  s.r = up(s.r + error);
  return {c, s};
}

// The chain's kinematics over the box on second-order forms: every joint from its form of q, then each arc side's
// cosine and sine replaced by the arc's.
std::unique_ptr<ChainKinematics<Taylor>> box_kinematics(const SerialChain& chain, const std::vector<Taylor>& q,
                                                       const BoxForms& f, const std::vector<int>& joints) {
  // Kilobytes per scalar: not on the stack. Default-initialised (not make_unique's value-initialisation, which would
  // zero the whole object first, hundreds of kilobytes per box): the scalars' own constructors make them zero.
  std::unique_ptr<ChainKinematics<Taylor>> k(new ChainKinematics<Taylor>);
  chain_kinematics(chain, q.data(), *k);
  for (std::size_t side = 0; side < f.sides.size(); ++side) {
    if (f.sides[side].arc_symbol < 0) continue;
    const BoxSide& a = f.sides[side];
    const auto [c, s] = rotated_arc(a.centre, Taylor::symbol(a.x_centre, a.x_radius, a.arc_symbol),
                                    Taylor::symbol(0.0, a.y_radius, a.symbol));
    set_joint_trigonometry(*k, joints[side], c, s);
  }
  return k;
}

// M, its derivatives and the Christoffel tensors on third-order forms (numerics/taylor3.hpp), turned into the box's
// second-order forms at the end. Inside, the sides' angles (or arcs' y) are the first symbols, numbered from the tip
// as the box's, and the arcs' x follow: third-order forms keep cubic terms among the first kCubicSymbols only
// (docs/theory.md, "Third-order forms for M and the tensors").
class ThirdOrderForms {
 public:
  ThirdOrderForms(const SerialChain& chain, const JointSearch& search, BoxForms& f)
      : chain_(chain), search_(search), f_(f), m_(static_cast<int>(f.sides.size())),
        inner_(static_cast<std::size_t>(f.symbols)), arc_(static_cast<std::size_t>(m_), -1) {
    for (int k = m_ - 1, next = m_; k >= 0; --k) {
      inner_[f.sides[k].symbol] = angle(k);
      if (f.sides[k].arc_symbol >= 0) inner_[f.sides[k].arc_symbol] = arc_[k] = next++;
    }
  }
  void compute() {
    const auto entries = static_cast<std::size_t>(f_.n * f_.n);
    std::vector<Dual<Taylor3>> M(entries);
    chain_mass_matrix(chain_, *kinematics(), M.data());
    f_.sensitivity.assign(static_cast<std::size_t>(m_), 0.0);
    for (std::size_t e = 0; e < entries; ++e) {
      f_.M[e] = second_order(M[e].value);
      for (int k = 0; k < m_; ++k) f_.sensitivity[k] += f_.sides[k].radius * deviation(M[e].derivative[k]);
    }
    christoffel_tensors(M);
  }

 private:
  int angle(int side) const { return m_ - 1 - side; }
  // sup |x| over the box's symbols (its centre's modulus and radius).
  static double deviation(const Taylor3& x) {
    const Taylor3::Sizes s = x.sizes();
    return std::abs(x.c) + up(s.linear() + s.quadratic() + up(x.r + s.cubic));
  }
  std::unique_ptr<ChainKinematics<Dual<Taylor3>>> kinematics() const {
    std::vector<Dual<Taylor3>> q(static_cast<std::size_t>(f_.n));
    for (int i = 0; i < f_.n; ++i) q[i] = Dual<Taylor3>(Taylor3(search_.fixed_q(i)));
    for (int k = 0; k < m_; ++k)
      q[search_.joints[k]] =
          Dual<Taylor3>::variable(Taylor3::symbol(f_.sides[k].centre, f_.sides[k].radius, angle(k)), k, m_);
    std::unique_ptr<ChainKinematics<Dual<Taylor3>>> kinematics(new ChainKinematics<Dual<Taylor3>>);
    chain_kinematics(chain_, q.data(), *kinematics);
    for (int k = 0; k < m_; ++k) {
      if (arc_[k] < 0) continue;
      const BoxSide& side = f_.sides[k];
      const Taylor3 x = Taylor3::symbol(side.x_centre, side.x_radius, arc_[k]);
      const Taylor3 y = Taylor3::symbol(0.0, side.y_radius, angle(k));
      const auto [c, s] = rotated_arc(side.centre, x, y);
      Dual<Taylor3> cosine(c), sine(s);
      cosine.directions = sine.directions = m_;
      cosine.derivative[k] = -s;  // d/dq cos = -sin
      sine.derivative[k] = c;
      set_joint_trigonometry(*kinematics, search_.joints[k], cosine, sine);
    }
    return kinematics;
  }
  // The second-order form in the box's numbering, the cubic part bounded monomial by monomial.
  Taylor second_order(const Taylor3& x) const {
    const int symbols = f_.symbols;
    Taylor y(x.c);
    y.symbols = symbols;
    for (int i = 0; i < symbols; ++i) y.a[i] = inner_[i] < x.s1 ? x.a[inner_[i]] : 0.0;
    for (int p = 0; p < pair_count(symbols); ++p) {
      const int q = kPairs.index[inner_[kPairs.first[p]]][inner_[kPairs.second[p]]];
      y.b[p] = q < x.pairs() ? x.b[q] : 0.0;
    }
    y.r = up(x.r + x.sizes().cubic);
    return y;
  }
  // The Christoffel symbols on the third-order forms (their three derivatives' cubic terms cancel there too), each
  // converted once and copied to its mirror.
  void christoffel_tensors(const std::vector<Dual<Taylor3>>& M) const {
    const int n = f_.n;
    f_.N.resize(static_cast<std::size_t>(n * n * n));
    for_each_christoffel_symbol(n, search_.joints, M, [&](int i, int j, int k, const Taylor3& symbol) {
      f_.N[(i * n + j) * n + k] = second_order(symbol);
      f_.N[(i * n + k) * n + j] = f_.N[(i * n + j) * n + k];
    });
  }

  const SerialChain& chain_;
  const JointSearch& search_;
  BoxForms& f_;
  int m_;
  std::vector<int> inner_;  // the box's symbol i is inner_[i] inside
  std::vector<int> arc_;    // side k's arc's x inside (-1: a narrow side)
};

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
  const auto entries = static_cast<std::size_t>(f.n * f.n);
  f.M.resize(entries);
  if (chain && tensors) {
    ThirdOrderForms(*chain, search, f).compute();
    return f;
  }
  std::vector<Taylor> q(static_cast<std::size_t>(f.n));
  for (int i = 0; i < f.n; ++i) q[i] = Taylor(search.fixed_q(i));
  for (int k = 0; k < m; ++k) q[search.joints[k]] = Taylor::symbol(f.sides[k].centre, f.sides[k].radius, f.sides[k].symbol);
  if (!chain) {  // the planar family: one searched joint, no split to choose
    mass_matrix_of(model, q.data(), f.M.data());
    f.sensitivity = planar_sensitivities(f.M, m);
    if (tensors) {
      f.N.resize(entries * static_cast<std::size_t>(f.n));
      coriolis_tensors_of(model, q.data(), f.N.data());
    }
    return f;
  }
  // M alone: the derivatives' enclosures by intervals, cheaper than on forms.
  f.sensitivity.assign(static_cast<std::size_t>(m), 0.0);
  chain_mass_matrix(*chain, *box_kinematics(*chain, q, f, search.joints), f.M.data());
  std::vector<Interval> qi(static_cast<std::size_t>(f.n));
  for (int i = 0; i < f.n; ++i) qi[i] = Interval(search.fixed_q(i));
  for (int k = 0; k < m; ++k) qi[search.joints[k]] = box[k];
  const std::vector<Dual<Interval>> M = mass_matrix_with_derivatives(model, search.joints, qi.data());
  for (std::size_t e = 0; e < entries; ++e)
    for (int k = 0; k < m; ++k) f.sensitivity[k] += f.sides[k].radius * boost::numeric::norm(M[e].derivative[k]);
  return f;
}

}  // namespace obsgain
