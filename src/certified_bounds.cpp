#include "obsgain/certified_bounds.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <limits>
#include <mutex>
#include <numbers>
#include <queue>
#include <set>
#include <thread>

namespace obsgain {

namespace {

using boost::numeric::square;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The floating-point eigensolvers are backward stable: their error is a small multiple of n ε ||X||, far
// below this relative pad for the sizes obsgain accepts (n <= 16).
constexpr double kEigenPad = 1e-12;

Interval magnitude_interval(const Interval& x) { return Interval(boost::numeric::norm(x)); }

// max |x - centre| over x, rounded up.
double radius_about(const Interval& x, double centre) {
  return std::max((Interval(x.upper()) - Interval(centre)).upper(), (Interval(centre) - Interval(x.lower())).upper());
}

// ||mid X||₂ computed in floating point, padded, plus ||rad X||_F (rounded up): an upper bound for every X
// in the interval matrix (Weyl).
double weyl_norm_upper_bound(const IntervalMatrix& X) {
  Eigen::MatrixXd mid(X.rows(), X.cols());
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index j = 0; j < X.cols(); ++j) {
      mid(i, j) = centre(X(i, j));
      radius2 += square(Interval(radius_about(X(i, j), mid(i, j))));
    }
  const double m = mid.operatorNorm();
  return (Interval(m) * Interval(1.0 + kEigenPad) + boost::numeric::sqrt(radius2)).upper();
}

// Frobenius norm, rounded up: a cheap upper bound of ||X||₂ used to skip choices before an eigensolve.
double frobenius_upper_bound(const IntervalMatrix& X) {
  Interval sum(0.0);
  for (Eigen::Index i = 0; i < X.size(); ++i) sum += square(magnitude_interval(X(i)));
  return boost::numeric::sqrt(sum).upper();
}

}  // namespace

double norm_upper_bound(const IntervalMatrix& X) {
  if (X.rows() != 2 || X.cols() != 2) return weyl_norm_upper_bound(X);
  // λmax(XᵀX) = (p + r)/2 + sqrt(((p - r)/2)² + s²) with XᵀX = [[p, s], [s, r]].
  const Interval p = square(X(0, 0)) + square(X(1, 0));
  const Interval r = square(X(0, 1)) + square(X(1, 1));
  const Interval s = X(0, 0) * X(0, 1) + X(1, 0) * X(1, 1);
  const Interval lambda = (p + r) / 2.0 + boost::numeric::sqrt(square((p - r) / 2.0) + square(s));
  // Both are valid upper bounds; the closed form wins on wide boxes, Weyl's on narrow ones (no dependency).
  return std::min(boost::numeric::sqrt(lambda).upper(), weyl_norm_upper_bound(X));
}

double smallest_eigenvalue_lower_bound(const IntervalMatrix& M) {
  if (M.rows() == 2) {
    const Interval a = M(0, 0), b = M(0, 1), c = M(1, 1);
    return ((a + c) / 2.0 - boost::numeric::sqrt(square((a - c) / 2.0) + square(b))).lower();
  }
  // Weyl: λmin(M) >= λmin(mid M) - ||rad M||_F, with a pad for the floating-point eigenvalue.
  Eigen::MatrixXd mid(M.rows(), M.cols());
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index j = 0; j < M.cols(); ++j) {
      mid(i, j) = centre(M(i, j));
      radius2 += square(Interval(radius_about(M(i, j), mid(i, j))));
    }
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(mid).eigenvalues();
  const double pad = kEigenPad * lambda.cwiseAbs().maxCoeff();
  return (Interval(lambda(0)) - Interval(pad) - boost::numeric::sqrt(radius2)).lower();
}

namespace {

IntervalMatrix product(const IntervalMatrix& A, const IntervalMatrix& B) {
  IntervalMatrix C(A.rows(), B.cols());
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (Eigen::Index j = 0; j < B.cols(); ++j) {
      Interval sum(0.0);
      for (Eigen::Index k = 0; k < A.cols(); ++k) sum += A(i, k) * B(k, j);
      C(i, j) = sum;
    }
  return C;
}

IntervalMatrix to_interval(const Eigen::MatrixXd& A) { return A.cast<Interval>(); }

// Both contain the true values, so their intersection does too (never empty in exact arithmetic; if rounding
// ever made it so, keep the first).
IntervalMatrix intersection(const IntervalMatrix& A, const IntervalMatrix& B) {
  IntervalMatrix C = A;
  for (Eigen::Index i = 0; i < A.size(); ++i) {
    const double lo = std::max(A(i).lower(), B(i).lower()), hi = std::min(A(i).upper(), B(i).upper());
    if (lo <= hi) C(i) = Interval(lo, hi);
  }
  return C;
}

// A matrix function over a box in centred form: X(q) = X(m) + Σ_k S_k (q_k - m_k) with S_k ∈ slope[k]
// (the mean-value theorem, entry by entry), and the natural enclosure `box` as a safeguard.
struct Centred {
  IntervalMatrix box, mid;
  std::vector<IntervalMatrix> slope;
};

// t_k = q_k - m_k over the box (outward rounded).
using Offsets = std::vector<Interval>;

IntervalMatrix enclosure(const Centred& c, const Offsets& t) {
  IntervalMatrix sum = c.mid;
  for (std::size_t k = 0; k < t.size(); ++k) sum += c.slope[k] * t[k];
  return intersection(c.box, sum);
}

// The second-order refinement: ||X(m) + Σ mid(S_k) t_k|| is convex in t, so its maximum over the box of t
// sits at a corner; the rest, Σ (S_k - mid S_k) t_k, is bounded by ||Σ rad(S_k) |t_k|||_F. Its excess over the
// true supremum shrinks quadratically with the box (the slopes' widths times the box's).
template <class CornerBound>
double centred_corners(const Centred& c, const Offsets& t, CornerBound&& corner_bound, bool maximum) {
  const auto m = static_cast<int>(t.size());
  const Eigen::Index rows = c.mid.rows(), cols = c.mid.cols();
  IntervalMatrix remainder_sum = IntervalMatrix::Constant(rows, cols, Interval(0.0));
  for (int k = 0; k < m; ++k) {
    const double reach = boost::numeric::norm(t[k]);
    for (Eigen::Index i = 0; i < c.mid.size(); ++i)
      remainder_sum(i) += Interval(radius_about(c.slope[k](i), centre(c.slope[k](i)))) * reach;
  }
  const double rest = frobenius_upper_bound(remainder_sum);
  double best = maximum ? -kInfinity : kInfinity;
  for (unsigned corner = 0; corner < (1u << m); ++corner) {
    IntervalMatrix Y = c.mid;
    for (int k = 0; k < m; ++k) {
      const Interval tk((corner >> k) & 1u ? t[k].upper() : t[k].lower());
      for (Eigen::Index i = 0; i < Y.size(); ++i) Y(i) += Interval(centre(c.slope[k](i))) * tk;
    }
    const double value = corner_bound(Y);
    best = maximum ? std::max(best, value) : std::min(best, value);
  }
  return maximum ? (Interval(best) + Interval(rest)).upper() : (Interval(best) - Interval(rest)).lower();
}

// Corners are 2^m eigen-solves: worth it only on boxes narrow enough for the quadratic term to win.
constexpr int kMaxCornerDimensions = 6;

double centred_norm_upper(const Centred& c, const Offsets& t) {
  double bound = norm_upper_bound(enclosure(c, t));
  if (static_cast<int>(t.size()) <= kMaxCornerDimensions)
    bound = std::min(bound, centred_corners(c, t, [](const IntervalMatrix& Y) { return weyl_norm_upper_bound(Y); }, true));
  return bound;
}

double centred_smallest_eigenvalue_lower(const Centred& c, const Offsets& t) {
  double bound = smallest_eigenvalue_lower_bound(enclosure(c, t));
  if (static_cast<int>(t.size()) <= kMaxCornerDimensions)
    bound = std::max(bound, centred_corners(c, t, [](const IntervalMatrix& Y) { return smallest_eigenvalue_lower_bound(Y); },
                                            false));
  return bound;
}

// Encloses M⁻¹ for every M in an interval matrix: with C ≈ mid(M)⁻¹ and E = I - C M, ||E||_∞ = ε < 1,
// M⁻¹ = (I - E)⁻¹ C = C + E C + E² (I - E)⁻¹ C, and every entry of the last term is at most ε² ||C||_∞ / (1 - ε).
std::optional<IntervalMatrix> inverse_enclosure(const IntervalMatrix& M) {
  const Eigen::Index n = M.rows();
  Eigen::MatrixXd mid(n, n);
  for (Eigen::Index i = 0; i < M.size(); ++i) mid(i) = centre(M(i));
  const Eigen::MatrixXd C = mid.inverse();
  if (!C.allFinite()) return std::nullopt;
  const IntervalMatrix Ci = to_interval(C);
  IntervalMatrix E = -product(Ci, M);
  for (Eigen::Index i = 0; i < n; ++i) E(i, i) += 1.0;
  Interval epsilon(0.0), c_norm(0.0);
  for (Eigen::Index i = 0; i < n; ++i) {
    Interval row(0.0), c_row(0.0);
    for (Eigen::Index j = 0; j < n; ++j) {
      row += magnitude_interval(E(i, j));
      c_row += Interval(std::abs(C(i, j)));
    }
    epsilon = Interval(std::max(epsilon.upper(), row.upper()));
    c_norm = Interval(std::max(c_norm.upper(), c_row.upper()));
  }
  if (!(epsilon.upper() < 1.0)) return std::nullopt;
  const double tail = (square(epsilon) * c_norm / (Interval(1.0) - epsilon)).upper();
  IntervalMatrix inverse = Ci + product(E, Ci);
  for (Eigen::Index i = 0; i < inverse.size(); ++i) inverse(i) += Interval(-tail, tail);
  return inverse;
}

// The searched joints' box, the full configuration as duals (the box, and its midpoint without directions),
// and the offsets q - m.
struct BoxPoint {
  std::vector<DualInterval> box, mid;
  Offsets offsets;
  Eigen::VectorXd midpoint;
};

struct SearchDomain {
  std::vector<int> joints;
  Eigen::VectorXd fixed_q;
  std::vector<Interval> domain;
};

BoxPoint box_point(const SearchDomain& s, const std::vector<Interval>& x) {
  const auto m = static_cast<int>(x.size());
  BoxPoint b;
  b.midpoint = s.fixed_q;
  for (Eigen::Index i = 0; i < s.fixed_q.size(); ++i) {
    b.box.emplace_back(Interval(s.fixed_q(i)));
    b.mid.emplace_back(Interval(s.fixed_q(i)));
  }
  for (int k = 0; k < m; ++k) {
    const double c = centre(x[k]);
    b.box[s.joints[k]] = DualInterval::variable(x[k], k, m);
    b.mid[s.joints[k]] = DualInterval(Interval(c));
    b.midpoint(s.joints[k]) = c;
    b.offsets.push_back(x[k] - Interval(c));
  }
  return b;
}

// The vertex/pattern structure of B and L_joint (design notes §3, §4): J(q, w) = 2 [wᵀN_1; …; wᵀN_n] is linear in
// the tensors, so its centred form follows from theirs.
IntervalMatrix jacobian_of(const std::vector<IntervalMatrix>& N, const Eigen::VectorXd& w) {
  const auto n = static_cast<Eigen::Index>(N.size());
  IntervalMatrix J(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 0; k < n; ++k) {
      Interval sum(0.0);
      for (Eigen::Index j = 0; j < n; ++j) sum += N[i](k, j) * w(j);
      J(i, k) = 2.0 * sum;
    }
  return J;
}

struct TensorEnclosure {
  std::vector<IntervalMatrix> box, mid;
  std::vector<std::vector<IntervalMatrix>> slope;  // [direction][i]
};

TensorEnclosure tensors_over(const IntervalDynamics& dynamics, const BoxPoint& b) {
  TensorEnclosure t;
  const std::vector<MatrixEnclosure> over_box = dynamics.coriolis_tensors(b.box);
  const std::vector<MatrixEnclosure> at_mid = dynamics.coriolis_tensors(b.mid);
  t.slope.resize(b.offsets.size());
  for (std::size_t i = 0; i < over_box.size(); ++i) {
    t.box.push_back(over_box[i].value);
    t.mid.push_back(at_mid[i].value);
    for (std::size_t k = 0; k < b.offsets.size(); ++k) t.slope[k].push_back(over_box[i].derivative[k]);
  }
  return t;
}

Centred jacobian_centred(const TensorEnclosure& t, const Eigen::VectorXd& w) {
  Centred c{jacobian_of(t.box, w), jacobian_of(t.mid, w), {}};
  for (const auto& slope : t.slope) c.slope.push_back(jacobian_of(slope, w));
  return c;
}

Centred mass_centred(const IntervalDynamics& dynamics, const BoxPoint& b) {
  const MatrixEnclosure over_box = dynamics.mass_matrix(b.box);
  return {over_box.value, dynamics.mass_matrix(b.mid).value, over_box.derivative};
}

// An upper bound over a box, and the side to split next: the one whose derivative enclosures' widths
// contribute most to the centred form's remainder (sides the function does not depend on are never split).
struct BoxBound {
  double upper = 0.0;
  std::vector<double> smear;  // per searched side: Σ width(∂X/∂q_k) |q_k - m_k|, over the entries that matter
};

void add_smear(const Centred& c, const Offsets& t, double weight, std::vector<double>& smear) {
  smear.resize(t.size(), 0.0);
  for (std::size_t k = 0; k < t.size(); ++k) {
    double sum = 0.0;
    for (Eigen::Index i = 0; i < c.slope[k].size(); ++i) sum += boost::numeric::width(c.slope[k](i));
    smear[k] += weight * sum * boost::numeric::norm(t[k]);
  }
}

struct Box {
  std::vector<Interval> x;
  double upper;
  std::vector<double> smear;
  bool operator<(const Box& other) const { return upper < other.upper; }
};

// Best-first branch and bound on all cores: always split the box with the largest upper bound, so the
// global upper is the top of the queue; stop at the gap, the deadline or the box limit. `upper(box, lower)`
// may stop refining once it is sure the box is below `lower` (the running best attained value).
BoundBracket branch_and_bound(const SearchDomain& s, const std::function<BoxBound(const BoxPoint&, double)>& upper,
                              const std::function<double(const Eigen::VectorXd&)>& point, const Eigen::VectorXd& seed,
                              const CertifiedOptions& options, std::chrono::steady_clock::time_point deadline,
                              const char* name) {
  const auto start = std::chrono::steady_clock::now();
  auto next_report = start + std::chrono::seconds(1);
  BoundBracket bracket;
  bracket.argmax = seed;
  bracket.lower = point(seed);
  std::priority_queue<Box> queue;
  {
    BoxBound first = upper(box_point(s, s.domain), bracket.lower);
    queue.push({s.domain, first.upper, std::move(first.smear)});
  }
  bracket.boxes = 1;

  std::mutex mutex;
  std::condition_variable changed;
  int busy = 0;
  std::multiset<double> in_flight;
  double pruned_upper = 0.0;  // the largest bound of a discarded box: below the attained value, but proven
  bool stop = false;
  const auto worker = [&] {
    const UpwardRounding upward;
    std::unique_lock lock(mutex);
    while (true) {
      while (!stop && queue.empty() && busy > 0) changed.wait(lock);
      if (stop || queue.empty()) break;
      // The global upper bound is the largest of the queued and the in-flight boxes' bounds.
      const double global_upper = std::max(queue.top().upper, in_flight.empty() ? 0.0 : *in_flight.rbegin());
      const bool converged = std::isfinite(global_upper) && global_upper - bracket.lower <= options.relative_gap * global_upper;
      if (converged || bracket.boxes >= options.max_boxes || std::chrono::steady_clock::now() >= deadline) {
        stop = true;
        break;
      }
      const Box box = queue.top();
      queue.pop();
      ++busy;
      const auto flight = in_flight.insert(box.upper);
      const double lower = bracket.lower;
      lock.unlock();

      std::size_t side = 0;
      for (std::size_t k = 1; k < box.x.size(); ++k)
        if (box.smear[k] > box.smear[side]) side = k;
      const double middle = centre(box.x[side]);
      std::array<Box, 2> children{Box{box.x, 0.0, {}}, Box{box.x, 0.0, {}}};
      children[0].x[side] = Interval(box.x[side].lower(), middle);
      children[1].x[side] = Interval(middle, box.x[side].upper());
      double best = lower;
      Eigen::VectorXd best_q;
      for (Box& child : children) {
        const BoxPoint b = box_point(s, child.x);
        const double value = point(b.midpoint);
        if (value > best) {
          best = value;
          best_q = b.midpoint;
        }
        // A child's supremum cannot exceed its parent's bound.
        BoxBound bound = upper(b, best);
        child.upper = std::min(box.upper, bound.upper);
        child.smear = std::move(bound.smear);
      }

      lock.lock();
      --busy;
      in_flight.erase(flight);
      bracket.boxes += 2;
      if (best > bracket.lower) {
        bracket.lower = best;
        bracket.argmax = best_q;
      }
      for (Box& child : children) {
        if (child.upper > bracket.lower)
          queue.push(std::move(child));
        else
          pruned_upper = std::max(pruned_upper, child.upper);
      }
      if (options.progress && std::chrono::steady_clock::now() >= next_report) {
        const auto now = std::chrono::steady_clock::now();
        next_report = now + std::chrono::milliseconds(250);
        SearchProgress p;
        p.bound = name;
        p.boxes = bracket.boxes;
        p.lower = bracket.lower;
        p.upper = std::max({queue.empty() ? 0.0 : queue.top().upper, pruned_upper, in_flight.empty() ? 0.0 : *in_flight.rbegin()});
        // A box not yet shown bounded (M⁻¹ not proven finite on it) leaves the upper end infinite: gap 1.
        p.relative_gap = std::isfinite(p.upper) && p.upper > 0.0 ? (p.upper - p.lower) / p.upper
                         : std::isfinite(p.upper)                ? 0.0
                                                                 : 1.0;
        p.target_gap = options.relative_gap;
        p.seconds = std::chrono::duration<double>(now - start).count();
        if (deadline != std::chrono::steady_clock::time_point::max())
          p.seconds_left = std::max(0.0, std::chrono::duration<double>(deadline - now).count());
        options.progress(p);
      }
      changed.notify_all();
    }
    changed.notify_all();
  };
  const int threads = options.threads > 0 ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
  worker();
  for (auto& thread : pool) thread.join();
  // Every part of the domain is in the queue or was discarded with a proven bound below the attained value.
  bracket.upper = std::max(queue.empty() ? 0.0 : queue.top().upper, pruned_upper);
  bracket.lower = std::min(bracket.lower, bracket.upper);  // the attained value is a float estimate: ulps
  bracket.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return bracket;
}

// A continuous joint's period, widened by an ulp so that the rounded π leaves no sliver of the circle out.
Interval search_interval(const JointDomain& joint) {
  if (!joint.continuous) return Interval(joint.lower, joint.upper);
  const double pi_up = std::nextafter(std::numbers::pi, kInfinity);
  return Interval(-pi_up, pi_up);
}

}  // namespace

std::string certification_unavailable(const Model& model) {
  if (dynamic_cast<const IntervalDynamics*>(model.dynamics.get()) == nullptr)
    return fmt::format("model '{}' cannot be evaluated on intervals", model.name);
  if (static_cast<int>(model.dynamics->configuration_joints().size()) > kMaxDirections)
    return fmt::format("model '{}' depends on {} joint positions; certified bounds search at most {}", model.name,
                       model.dynamics->configuration_joints().size(), kMaxDirections);
  return {};
}

std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options) {
  if (!certification_unavailable(model).empty()) return std::nullopt;
  const auto& dynamics = dynamic_cast<const IntervalDynamics&>(*model.dynamics);
  const Eigen::VectorXd& V = numeric.velocity_bounds;
  const int n = model.dof();
  SearchDomain s;
  s.joints = model.dynamics->configuration_joints();
  s.fixed_q = Eigen::VectorXd::Zero(n);
  for (int j : s.joints) s.domain.push_back(search_interval(model.joints[j]));
  const Eigen::MatrixXd vertices = box_vertices(V);
  const unsigned count = static_cast<unsigned>(vertices.cols());
  // J(q, -w) = -J(q, w): the vertices with w_n < 0 repeat the others for ||J||, and for ||M⁻¹(J D + F)|| too
  // when F = 0 (as in compute_bounds).
  const unsigned half = count / 2;
  const bool frictionless = model.friction.isZero(0.0);
  const IntervalMatrix F = to_interval(model.friction);

  const auto start = std::chrono::steady_clock::now();
  const bool unlimited = options.budget_seconds <= 0.0;
  // Each bound gets an equal share of what is left of the budget when it starts. L_joint goes first: the
  // default design rests on it alone (M0 and B only enter L_paper).
  const auto deadline_for = [&](int remaining_bounds) {
    if (unlimited) return std::chrono::steady_clock::time_point::max();
    const double used = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double share = std::max(0.0, options.budget_seconds - used) / remaining_bounds;
    return std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                  std::chrono::duration<double>(share));
  };

  CertifiedBounds result;
  // X = M⁻¹(J D + F) = A D + R with A = M⁻¹J, R = M⁻¹F. Centred forms: ∂A/∂q_k = M⁻¹(∂J_k - ∂M_k A), likewise R.
  const auto l_upper = [&](const BoxPoint& b, double lower) {
    const Centred M = mass_centred(dynamics, b);
    const auto inverse_box = inverse_enclosure(enclosure(M, b.offsets));
    const auto inverse_mid = inverse_enclosure(M.mid);
    BoxBound bound{kInfinity, {}};
    const TensorEnclosure t = tensors_over(dynamics, b);
    if (!inverse_box || !inverse_mid) {
      // M varies too much over the box for a Neumann enclosure of M⁻¹ (ill-conditioned inertia on a wide box):
      // ||M⁻¹(J D + F)|| <= (||J|| + ||F||) / λmin(M), finite as soon as M is proven positive definite.
      add_smear(M, b.offsets, 1.0, bound.smear);
      const double lambda = std::max(centred_smallest_eigenvalue_lower(M, b.offsets), dynamics.inertia_floor());
      if (!(lambda > 0.0)) return bound;
      double J_norm = 0.0;
      for (unsigned c = half; c < count; ++c)
        J_norm = std::max(J_norm, norm_upper_bound(enclosure(jacobian_centred(t, vertices.col(c)), b.offsets)));
      bound.upper = ((Interval(J_norm) + Interval(norm_upper_bound(F))) / Interval(lambda)).upper();
      return bound;
    }
    const auto m = b.offsets.size();
    const auto left_inverse = [&](const Centred& Y) {
      Centred X{product(*inverse_box, Y.box), product(*inverse_mid, Y.mid), {}};
      for (std::size_t k = 0; k < m; ++k) X.slope.push_back(product(*inverse_box, Y.slope[k] - product(M.slope[k], X.box)));
      return X;
    };
    const Centred R = left_inverse(Centred{F, F, std::vector<IntervalMatrix>(m, IntervalMatrix::Constant(n, n, Interval(0.0)))});
    const unsigned last_pattern = frictionless ? count - 1 : 0u;
    double best = 0.0;
    for (unsigned c = frictionless ? half : 0u; c < count; ++c) {
      const Centred A = left_inverse(jacobian_centred(t, vertices.col(c)));
      add_smear(A, b.offsets, 1.0, bound.smear);
      // Full patterns first: with F = 0 the full pattern is the maximum (||A D|| <= ||A||) and the only one
      // searched; in general it usually wins, so that a high running value lets the cheap bound skip most of the others.
      for (unsigned pattern = count; pattern-- > last_pattern;) {
        const auto select = [&](const IntervalMatrix& a, const IntervalMatrix& r) {
          IntervalMatrix x = r;
          for (int j = 0; j < n; ++j)
            if ((pattern >> j) & 1u) x.col(j) += a.col(j);
          return x;
        };
        Centred X{select(A.box, R.box), select(A.mid, R.mid), {}};
        for (std::size_t k = 0; k < m; ++k) X.slope.push_back(select(A.slope[k], R.slope[k]));
        const IntervalMatrix enclosed = enclosure(X, b.offsets);
        const double floor = std::max(best, lower);
        const double frobenius = frobenius_upper_bound(enclosed);
        if (frobenius <= floor) {
          best = std::max(best, frobenius);
          continue;
        }
        const double cheap = norm_upper_bound(enclosed);
        best = std::max(best, cheap <= floor ? cheap : centred_norm_upper(X, b.offsets));
      }
    }
    bound.upper = best;
    return bound;
  };
  result.L_joint = branch_and_bound(s, l_upper, [&](const Eigen::VectorXd& q) { return max_joint_lipschitz_norm(model, q, V); },
                                    numeric.L_joint.q, options, deadline_for(3), "L_joint");

  // M0 = sup 1/λmin(M): a box whose M cannot be shown positive definite gets +∞ and is split further.
  const auto b_upper = [&](const BoxPoint& b, double lower) {
    const TensorEnclosure t = tensors_over(dynamics, b);
    BoxBound bound;
    double best = 0.0;
    for (unsigned c = half; c < count; ++c) {
      const Centred J = jacobian_centred(t, vertices.col(c));
      // A choice whose cheap bound cannot beat what is already known (this box's best, or the value attained
      // elsewhere) changes neither the box's fate nor the bracket: its refinement is skipped (its cheap bound
      // still counts, so that the box's value stays an upper bound).
      add_smear(J, b.offsets, 1.0, bound.smear);
      const double cheap = norm_upper_bound(enclosure(J, b.offsets));
      best = std::max(best, cheap <= std::max(best, lower) ? cheap : centred_norm_upper(J, b.offsets));
    }
    bound.upper = best;
    return bound;
  };
  result.B = branch_and_bound(s, b_upper, [&](const Eigen::VectorXd& q) { return max_coriolis_jacobian_norm(model, q, V); },
                              numeric.B.q, options, deadline_for(2), "B");

  const auto m0_upper = [&](const BoxPoint& b, double) {
    const Centred M = mass_centred(dynamics, b);
    const double lambda = std::max(centred_smallest_eigenvalue_lower(M, b.offsets), dynamics.inertia_floor());
    BoxBound bound{lambda > 0.0 ? (Interval(1.0) / Interval(lambda)).upper() : kInfinity, {}};
    add_smear(M, b.offsets, 1.0, bound.smear);
    return bound;
  };
  result.M0 = branch_and_bound(s, m0_upper, [&](const Eigen::VectorXd& q) { return inverse_inertia_norm(model, q); },
                               numeric.M0.q, options, deadline_for(1), "M0");

  return result;
}

void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified) {
  report.certified = true;
  report.M0_bracket = certified.M0;
  report.B_bracket = certified.B;
  report.L_joint_bracket = certified.L_joint;
  report.M0.value = certified.M0.upper;
  report.B.value = certified.B.upper;
  report.L_paper = (Interval(report.M0.value) * (Interval(report.B.value) + Interval(report.F_norm))).upper();
  // L_joint <= L_paper holds for every q, w, D (design notes §4): a proven L_paper bounds L_joint too, and is
  // the smaller of the two when the branch and bound of L_joint ran out of budget on a wide domain.
  if (report.L_paper < report.L_joint_bracket.upper) report.L_joint_bracket.upper = report.L_paper;
  report.L_joint.value = report.L_joint_bracket.upper;
  report.wall_seconds += certified.M0.seconds + certified.B.seconds + certified.L_joint.seconds;
}

namespace {

// The derivative enclosures that ∂h/∂q is built from, h(q) = M(q) a + A(q, v) + g(q): computed once per box,
// combined for as many (a, v) as needed.
struct SensitivityTerms {
  MatrixEnclosure M, g;
  std::vector<MatrixEnclosure> N;
};

SensitivityTerms sensitivity_terms(const IntervalDynamics& dynamics, const std::vector<DualInterval>& q) {
  return {dynamics.mass_matrix(q), dynamics.gravity(q), dynamics.coriolis_tensors(q)};
}

// Columns ∂h/∂q_j for every a and v in the interval vectors (v_k v_l in `velocity_products`).
IntervalMatrix sensitivity_enclosure(const SensitivityTerms& t, const std::vector<Interval>& a,
                                     const IntervalMatrix& velocity_products) {
  const auto n = static_cast<Eigen::Index>(a.size());
  IntervalMatrix K(n, n);
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = 0; i < n; ++i) {
      Interval sum = t.g.derivative[j](i, 0);
      for (Eigen::Index k = 0; k < n; ++k) {
        sum += t.M.derivative[j](i, k) * a[k];
        for (Eigen::Index l = 0; l < n; ++l) sum += t.N[i].derivative[j](k, l) * velocity_products(k, l);
      }
      K(i, j) = sum;
    }
  return K;
}

IntervalMatrix products_of(const std::vector<Interval>& v) {
  const auto n = static_cast<Eigen::Index>(v.size());
  IntervalMatrix P(n, n);
  for (Eigen::Index k = 0; k < n; ++k)
    for (Eigen::Index l = 0; l < n; ++l) P(k, l) = k == l ? square(v[k]) : v[k] * v[l];
  return P;
}

}  // namespace

std::string sensitivity_unavailable(const Model& model) {
  if (dynamic_cast<const IntervalDynamics*>(model.dynamics.get()) == nullptr)
    return fmt::format("model '{}' cannot be evaluated on intervals", model.name);
  if (model.dof() > kMaxDirections)
    return fmt::format("model '{}' has {} joints; the position sensitivity is searched over at most {}", model.name,
                       model.dof(), kMaxDirections);
  return {};
}

std::optional<BoundBracket> certify_position_sensitivity(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                                         const Eigen::VectorXd& acceleration_bounds,
                                                         const CertifiedOptions& options) {
  if (!sensitivity_unavailable(model).empty()) return std::nullopt;
  const auto& dynamics = dynamic_cast<const IntervalDynamics&>(*model.dynamics);
  const int n = model.dof();
  // Gravity depends on every joint (the first too, unless its axis is vertical): all of them are searched.
  SearchDomain s;
  s.fixed_q = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    s.joints.push_back(j);
    s.domain.push_back(search_interval(model.joints[j]));
  }
  std::vector<Interval> a_box, v_box;
  for (int j = 0; j < n; ++j) {
    a_box.emplace_back(-acceleration_bounds(j), acceleration_bounds(j));
    v_box.emplace_back(-velocity_bounds(j), velocity_bounds(j));
  }
  const IntervalMatrix v_products = products_of(v_box);

  const auto box_upper = [&](const BoxPoint& b, double) {
    BoxBound bound{norm_upper_bound(sensitivity_enclosure(sensitivity_terms(dynamics, b.box), a_box, v_products)), {}};
    // No second derivatives to weigh the sides by: split the widest (relative to its domain).
    for (int k = 0; k < n; ++k) bound.smear.push_back(boost::numeric::width(b.offsets[k]) / boost::numeric::width(s.domain[k]));
    return bound;
  };
  // Attained values: the norm is convex in a and in v_k v_l jointly only along vertices, so the lower end
  // tries vertex pairs (all of them up to three joints, a fixed pseudo-random 64 beyond).
  const Eigen::MatrixXd a_vertices = box_vertices(acceleration_bounds), v_vertices = box_vertices(velocity_bounds);
  std::vector<std::pair<Eigen::Index, Eigen::Index>> choices;
  if (n <= 3) {
    for (Eigen::Index i = 0; i < a_vertices.cols(); ++i)
      for (Eigen::Index k = 0; k < v_vertices.cols(); ++k) choices.emplace_back(i, k);
  } else {
    std::uint64_t state = 0x9e3779b97f4a7c15ULL;
    for (int c = 0; c < 64; ++c) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      choices.emplace_back(static_cast<Eigen::Index>((state >> 20) % a_vertices.cols()),
                           static_cast<Eigen::Index>((state >> 40) % v_vertices.cols()));
    }
  }
  const auto point = [&](const Eigen::VectorXd& q) {
    const UpwardRounding upward;
    std::vector<DualInterval> x;
    for (int j = 0; j < n; ++j) x.push_back(DualInterval::variable(Interval(q(j)), j, n));
    const SensitivityTerms terms = sensitivity_terms(dynamics, x);
    double best = 0.0;
    for (const auto& [i, k] : choices) {
      std::vector<Interval> a, v;
      for (int j = 0; j < n; ++j) {
        a.emplace_back(a_vertices(j, i));
        v.emplace_back(v_vertices(j, k));
      }
      const IntervalMatrix K = sensitivity_enclosure(terms, a, products_of(v));
      Eigen::MatrixXd mid(n, n);
      for (Eigen::Index e = 0; e < K.size(); ++e) mid(e) = centre(K(e));
      best = std::max(best, mid.operatorNorm());
    }
    return best;
  };
  const bool unlimited = options.budget_seconds <= 0.0;
  const auto deadline = unlimited ? std::chrono::steady_clock::time_point::max()
                                  : std::chrono::steady_clock::now() +
                                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                            std::chrono::duration<double>(options.budget_seconds));
  Eigen::VectorXd seed(n);
  for (int j = 0; j < n; ++j) seed(j) = centre(s.domain[j]);
  return branch_and_bound(s, box_upper, point, seed, options, deadline, "C_q");
}

}  // namespace obsgain
