#include "obsgain/certificate/polytopic.hpp"

#include "obsgain/model/model.hpp"
#include "obsgain/numerics/interval.hpp"
#include "obsgain/numerics/optimize.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace obsgain {

namespace {

using Entry = std::pair<int, int>;

constexpr double kNotFound = std::numeric_limits<double>::infinity();

// Where each unknown sits in the solver's y: P's lower triangle (balanced coordinates), one multiplier per entry
// (i, j) that has a radius in some cell (shared by all cells: the solver's work then grows with the vertices,
// not with the cells; docs/theory.md), then one last scalar (the slack t, the condition number κ, or the floor's λmax m).
struct Layout {
  int n = 0, N = 0;
  std::vector<Entry> p_entries;                 // (a, b), a >= b
  std::vector<Entry> uncertain;                 // (i, j) with a radius in some cell
  std::vector<std::vector<int>> cell_entries;   // per cell: which of them have a radius there
  int tau_offset = 0;                           // index of the first multiplier
  int last = 0;                                 // index of t or κ
  int size() const { return last + 1; }
};

Layout layout_of(const PerturbationPolytope& polytope) {
  Layout l;
  l.n = polytope.dof;
  l.N = 2 * l.n;
  for (int a = 0; a < l.N; ++a)
    for (int b = 0; b <= a; ++b) l.p_entries.emplace_back(a, b);
  l.tau_offset = static_cast<int>(l.p_entries.size());
  for (int i = 0; i < l.n; ++i)
    for (int j = 0; j < l.n; ++j) {
      bool any = false;
      for (const PolytopeCell& cell : polytope.cells) any = any || cell.radius(i, j) > 0.0;
      if (any) l.uncertain.emplace_back(i, j);
    }
  for (const PolytopeCell& cell : polytope.cells) {
    std::vector<int> used;
    for (std::size_t u = 0; u < l.uncertain.size(); ++u)
      if (cell.radius(l.uncertain[u].first, l.uncertain[u].second) > 0.0) used.push_back(static_cast<int>(u));
    l.cell_entries.push_back(std::move(used));
  }
  l.last = l.tau_offset + static_cast<int>(l.uncertain.size());
  return l;
}

Eigen::MatrixXd basis(int N, const Entry& e) {
  Eigen::MatrixXd E = Eigen::MatrixXd::Zero(N, N);
  E(e.first, e.second) = E(e.second, e.first) = 1.0;
  return E;
}

// x = (s e_q, e_v) with s = sqrt(k2): A_x = [[-k1 I, s I], [-s I, Φ]] has entries of one size, P_x = S⁻¹ P S⁻¹.
Eigen::MatrixXd balanced_matrix(double k1, double s, const Eigen::MatrixXd& Phi) {
  const auto n = Phi.rows();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  A.topLeftCorner(n, n).diagonal().setConstant(-k1);
  A.topRightCorner(n, n).diagonal().setConstant(s);
  A.bottomLeftCorner(n, n).diagonal().setConstant(-s);
  A.bottomRightCorner(n, n) = Phi;
  return A;
}

// [[AᵀP + PA + 2γP + Σ_u τ_u ρ_u² c_j c_jᵀ, P E_u], [E_uᵀ P, -diag(τ)]] (- t I when `slack`) ≼ 0, as a block.
LinearMatrixInequality vertex_lmi(const Layout& l, int cell, const Eigen::MatrixXd& A, const Eigen::MatrixXd& radius,
                                  double gamma, bool slack) {
  const std::vector<int>& used = l.cell_entries[cell];
  const int size = l.N + static_cast<int>(used.size());
  LinearMatrixInequality lmi;
  lmi.size = size;
  for (std::size_t v = 0; v < l.p_entries.size(); ++v) {
    const Eigen::MatrixXd E = basis(l.N, l.p_entries[v]);
    Eigen::MatrixXd F = Eigen::MatrixXd::Zero(size, size);
    F.topLeftCorner(l.N, l.N) = A.transpose() * E + E * A + 2.0 * gamma * E;
    for (std::size_t u = 0; u < used.size(); ++u) {
      const int row = l.n + l.uncertain[used[u]].first;
      F.block(0, l.N + u, l.N, 1) = E.col(row);
      F.block(l.N + u, 0, 1, l.N) = E.col(row).transpose();
    }
    lmi.terms.emplace_back(static_cast<int>(v), packed(F));
  }
  for (std::size_t u = 0; u < used.size(); ++u) {
    const auto [i, j] = l.uncertain[used[u]];
    Eigen::MatrixXd F = Eigen::MatrixXd::Zero(size, size);
    F(l.n + j, l.n + j) = radius(i, j) * radius(i, j);
    F(l.N + u, l.N + u) = -1.0;
    lmi.terms.emplace_back(l.tau_offset + used[u], packed(F));
  }
  if (slack) lmi.terms.emplace_back(l.last, packed(-Eigen::MatrixXd::Identity(size, size)));
  return lmi;
}

// lower ≼ W P_x W (and, with `upper_by_last`, W P_x W ≼ κ I with κ the last unknown; else ≼ cap I).
void normalisation(const Layout& l, const Eigen::VectorXd& W, bool upper_by_last, double cap,
                   std::vector<LinearMatrixInequality>& blocks) {
  LinearMatrixInequality lower, upper;
  lower.size = upper.size = l.N;
  lower.constant = packed(Eigen::MatrixXd::Identity(l.N, l.N));
  upper.constant = packed(upper_by_last ? Eigen::MatrixXd::Zero(l.N, l.N) : Eigen::MatrixXd(-cap * Eigen::MatrixXd::Identity(l.N, l.N)));
  for (std::size_t v = 0; v < l.p_entries.size(); ++v) {
    const Eigen::MatrixXd E = W.asDiagonal() * basis(l.N, l.p_entries[v]) * W.asDiagonal();
    lower.terms.emplace_back(static_cast<int>(v), packed(-E));
    upper.terms.emplace_back(static_cast<int>(v), packed(E));
  }
  if (upper_by_last) upper.terms.emplace_back(l.last, packed(-Eigen::MatrixXd::Identity(l.N, l.N)));
  blocks.push_back(std::move(lower));
  blocks.push_back(std::move(upper));
}

double largest_eigenvalue(const LinearMatrixInequality& block, const Eigen::VectorXd& y) {
  return symmetric_eigenvalues(evaluate(block, y)).maxCoeff();
}

// P = W P_x W: the weights of the balanced coordinates x = (√k2 e_q, e_v).
Eigen::VectorXd balancing(const Layout& l, double k2) {
  Eigen::VectorXd W = Eigen::VectorXd::Ones(l.N);
  W.head(l.n).setConstant(std::sqrt(k2));
  return W;
}

// A strictly feasible start for the slack problem: P_x = c I (c between 1 and the cap), each τ = c, and t above
// every vertex block's largest eigenvalue there (the last two blocks bound P_x and hold at c).
Eigen::VectorXd feasible_start(const Layout& l, const std::vector<LinearMatrixInequality>& blocks, double c) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(l.size());
  for (std::size_t v = 0; v < l.p_entries.size(); ++v) y(v) = l.p_entries[v].first == l.p_entries[v].second ? c : 0.0;
  y.segment(l.tau_offset, l.last - l.tau_offset).setConstant(c);
  double worst = 0.0;
  for (std::size_t b = 0; b + 2 < blocks.size(); ++b) worst = std::max(worst, largest_eigenvalue(blocks[b], y));
  y(l.last) = 2.0 * worst + 1.0;
  return y;
}

// What the SDP minimises (the last unknown): the vertex LMIs' slack t (feasibility); κ with I ≼ P ≼ κ I (the
// envelope constant k = sqrt(κ)); or, with P ⪰ diag(0, I), the floor's m >= λmax(Kᵀ P K) (floor_blocks).
enum class SdpObjective { slack, condition, floor };

// The sampled error floor's weight (docs/theory.md, "Deployment through the same P"): the measurement disturbance is
// w = G η + (0, ψ) = K (η, ψ / g) with G = (k1 I, k2 I), ||ψ|| <= g ||η||, so ||P^½ w||² <= 2 λmax(Kᵀ P K) ||η||²; with
// P ⪰ diag(0, I), (P⁻¹)_vv ≼ I and the ultimate velocity error is at most sqrt(2 m) ||d|| / γ. K is divided by k2,
// in balanced coordinates (P_x = W⁻¹ P W⁻¹: K_x = W K / k2).
void floor_blocks(const Layout& l, const Eigen::VectorXd& W, double k1, double k2, double model_gain,
                  std::vector<LinearMatrixInequality>& blocks) {
  LinearMatrixInequality lower, weight;
  lower.size = l.N;
  weight.size = l.N;
  Eigen::MatrixXd velocities = Eigen::MatrixXd::Zero(l.N, l.N);
  velocities.bottomRightCorner(l.n, l.n).setIdentity();
  lower.constant = packed(velocities);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(l.N, l.N);
  K.topLeftCorner(l.n, l.n).diagonal().setConstant(W(0) * k1 / k2);
  K.bottomLeftCorner(l.n, l.n).diagonal().setConstant(1.0);
  K.bottomRightCorner(l.n, l.n).diagonal().setConstant(model_gain / k2);
  for (std::size_t v = 0; v < l.p_entries.size(); ++v) {
    const Eigen::MatrixXd E = basis(l.N, l.p_entries[v]);
    lower.terms.emplace_back(static_cast<int>(v), packed(-E));
    weight.terms.emplace_back(static_cast<int>(v), packed(K.transpose() * E * K));
  }
  weight.terms.emplace_back(l.last, packed(-Eigen::MatrixXd::Identity(l.N, l.N)));
  blocks.push_back(std::move(lower));
  blocks.push_back(std::move(weight));
}

struct Solved {
  SdpResult sdp;
  Layout layout;
  std::vector<LinearMatrixInequality> blocks;
};

// slack: minimise t with every vertex LMI ≼ t I and I ≼ P_x ≼ cap I. Otherwise every vertex LMI ≼ 0, and either
// I ≼ P ≼ κ I in original coordinates, minimising κ, or the floor's normalisation and weight (floor_blocks).
Solved solve(const PerturbationPolytope& polytope, double k1, double k2, double gamma, SdpObjective objective_kind,
             const PolytopicOptions& options, double model_gain = 0.0) {
  const bool slack = objective_kind == SdpObjective::slack;
  Solved s{{}, layout_of(polytope), {}};
  const Layout& l = s.layout;
  const double scale = std::sqrt(k2);
  std::vector<LinearMatrixInequality>& blocks = s.blocks;
  for (std::size_t c = 0; c < polytope.cells.size(); ++c)
    for (const Eigen::MatrixXd& Phi : polytope.cells[c].vertices)
      blocks.push_back(vertex_lmi(l, static_cast<int>(c), balanced_matrix(k1, scale, Phi), polytope.cells[c].radius,
                                  gamma, slack));
  // The slack problem bounds P_x itself; the κ problem bounds P in original coordinates.
  if (objective_kind == SdpObjective::floor)
    floor_blocks(l, balancing(l, k2), k1, k2, model_gain, blocks);
  else
    normalisation(l, slack ? Eigen::VectorXd::Ones(l.N) : balancing(l, k2), !slack, options.condition_cap, blocks);
  Eigen::VectorXd objective = Eigen::VectorXd::Zero(l.size());
  objective(l.last) = -1.0;
  SdpOptions sdp = options.sdp;
  if (slack) sdp.start = feasible_start(l, blocks, std::sqrt(options.condition_cap));
  s.sdp = solve_sdp(l.size(), blocks, objective, sdp);
  return s;
}

Eigen::MatrixXd balanced_P(const Layout& l, const Eigen::VectorXd& y) {
  Eigen::MatrixXd P(l.N, l.N);
  for (std::size_t v = 0; v < l.p_entries.size(); ++v)
    P(l.p_entries[v].first, l.p_entries[v].second) = P(l.p_entries[v].second, l.p_entries[v].first) = y(v);
  return P;
}

}  // namespace

double polytopic_slack(const PerturbationPolytope& polytope, double k1, double k2, double gamma,
                       const PolytopicOptions& options) {
  if (!polytope.proven()) return kNotFound;
  PolytopicOptions feasibility = options;
  feasibility.sdp.enough = [](const Eigen::VectorXd& y) { return y(y.size() - 1) < 0.0; };
  const Solved s = solve(polytope, k1, k2, gamma, SdpObjective::slack, feasibility);
  // A negative t answers the question even when the solver stopped short of its optimum (numerical trouble, the
  // iteration limit), provided its last y satisfies every block: it started feasible, and this is checked.
  const double t = s.sdp.y(s.layout.last);
  if (!s.sdp.y.allFinite() || !(t < 0.0)) return s.sdp.solved && std::isfinite(t) ? t : kNotFound;
  // The vertex blocks hold LMI - tI: the LMIs themselves must be negative, λmax(LMI - tI) < -t. The last two
  // blocks bound P_x (I <= P_x <= cap I), to the solver's tolerance.
  const std::size_t vertex_blocks = s.blocks.size() - 2;
  for (std::size_t b = 0; b < s.blocks.size(); ++b)
    if (const double largest = largest_eigenvalue(s.blocks[b], s.sdp.y);
        b < vertex_blocks ? !(largest < -t) : largest > 1e-6 * options.condition_cap)
      return kNotFound;
  return t;
}

namespace {

// Between a point where the solver finds a P and one where it does not, the last point found, to a relative
// tolerance of the larger end.
double bisect(double found_at, double not_found_at, double tolerance, const std::function<bool(double)>& found) {
  while (std::abs(not_found_at - found_at) > tolerance * std::max(std::abs(found_at), std::abs(not_found_at))) {
    const double middle = 0.5 * (found_at + not_found_at);
    (found(middle) ? found_at : not_found_at) = middle;
  }
  return found_at;
}

}  // namespace

double polytopic_rate(const PerturbationPolytope& polytope, double k1, double k2, const PolytopicOptions& options) {
  const auto found = [&](double gamma) { return polytopic_slack(polytope, k1, k2, gamma, options) < 0.0; };
  if (!found(0.0)) return 0.0;
  double lo = 0.0, hi = 0.5 * k1;
  while (found(hi)) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e3 * k1) return lo;
  }
  return bisect(lo, hi, options.relative_tolerance, found);
}

double polytopic_theta_star(const PerturbationPolytope& polytope, double alpha, double beta, double gamma,
                            const PolytopicOptions& options) {
  const double solved_rate = gamma / (1.0 - options.rate_margin);
  const auto found = [&](double theta) {
    return polytopic_slack(polytope, theta * alpha, theta * theta * beta, solved_rate, options) < 0.0;
  };
  double hi = std::max(1.0, 2.0 * solved_rate / alpha);  // below that, γ >= k1 / 2 cannot hold
  while (!found(hi)) {
    hi *= 2.0;
    if (hi > 1e8) return std::numeric_limits<double>::infinity();
  }
  double lo = 0.5 * hi;
  while (lo > 1e-6 && found(lo)) lo *= 0.5;
  return bisect(hi, lo, options.relative_tolerance, found);
}

namespace {

// The solver's P for γ / (1 - rate_margin), rounded, and its proof at γ.
PolytopicCertificate checked(const PerturbationPolytope& polytope, double k1, double k2, double gamma, const Solved& s) {
  PolytopicCertificate cert;
  cert.gamma = gamma;
  if (!s.sdp.solved) {
    cert.status = fmt::format("the SDP solver found no P ({})", s.sdp.status);
    return cert;
  }
  const Eigen::VectorXd W = balancing(s.layout, k2);
  const Eigen::MatrixXd P = W.asDiagonal() * balanced_P(s.layout, s.sdp.y) * W.asDiagonal();
  cert.P = 0.5 * (P + P.transpose());
  cert.multipliers = s.sdp.y.segment(s.layout.tau_offset, s.layout.last - s.layout.tau_offset);
  cert.exists = polytopic_check(polytope, k1, k2, gamma, cert.P, cert.multipliers);
  const double smallest = smallest_eigenvalue_lower(cert.P);
  cert.k = smallest > 0.0 ? std::sqrt((Interval(largest_eigenvalue_upper(cert.P)) / Interval(smallest)).upper()) : 0.0;
  cert.status = cert.exists ? "every vertex LMI passed the interval Cholesky check"
                            : "the interval check failed: the solver's P does not certify γ";
  return cert;
}

}  // namespace

PolytopicCertificate polytopic_certificate(const PerturbationPolytope& polytope, double k1, double k2, double gamma,
                                           const PolytopicOptions& options) {
  return checked(polytope, k1, k2, gamma,
                 solve(polytope, k1, k2, gamma / (1.0 - options.rate_margin), SdpObjective::condition, options));
}

PolytopicCertificate polytopic_floor_certificate(const PerturbationPolytope& polytope, double k1, double k2,
                                                 double gamma_low, double gamma_high, double model_gain,
                                                 const PolytopicOptions& options) {
  const double margin = 1.0 - options.rate_margin;
  // Without ψ's column K misses the position directions and the SDP would be unbounded: a weight of at least
  // 1e-3 k2 keeps it bounded and changes only which P is chosen, never what is proven.
  const double weight = std::max(model_gain, 1e-3 * k2);
  const auto solved_at = [&](double gamma) {
    return solve(polytope, k1, k2, gamma / margin, SdpObjective::floor, options, weight);
  };
  // sqrt(m) / γ: the floor up to the constant factor sqrt(2) ||d|| k2 (floor_blocks); +∞ where no P is found. The
  // best solution seen is kept, so the γ chosen is not solved again.
  double gamma = gamma_high, best = kNotFound;
  std::optional<Solved> chosen;
  const auto floor_at = [&](double g) {
    Solved s = solved_at(g);
    const double m = s.sdp.solved ? s.sdp.y(s.layout.last) : -1.0;
    const double value = m > 0.0 ? std::sqrt(m) / g : kNotFound;
    if (!chosen || value < best) {
      best = value;
      gamma = g;
      chosen = std::move(s);
    }
    return value;
  };
  if (gamma_high > gamma_low * (1.0 + options.floor_rate_tolerance))
    minimize_golden(floor_at, gamma_low, gamma_high, options.floor_rate_tolerance * gamma_high,
                    options.floor_search_iterations);
  else
    floor_at(gamma_high);
  PolytopicCertificate cert = checked(polytope, k1, k2, gamma, *chosen);
  cert.status += fmt::format("; P chosen for the sampled error floor, at γ = {:.4g} in [{:.4g}, {:.4g}]", gamma,
                             gamma_low, gamma_high);
  return cert;
}

namespace {

// AᵀP + PA + 2γP in interval arithmetic (loops: Boost's and Eigen's operator* are ambiguous for these types).
IntervalMatrix lyapunov_term(const IntervalMatrix& A, const IntervalMatrix& P, double gamma) {
  const Eigen::Index N = A.rows();
  IntervalMatrix T(N, N);
  for (Eigen::Index a = 0; a < N; ++a)
    for (Eigen::Index b = 0; b < N; ++b) {
      Interval sum = Interval(2.0 * gamma) * P(a, b);
      for (Eigen::Index k = 0; k < N; ++k) sum += A(k, a) * P(k, b) + P(a, k) * A(k, b);
      T(a, b) = sum;
    }
  return T;
}

// -LMI of one vertex in original coordinates, in interval arithmetic.
IntervalMatrix negated_vertex_lmi(const Layout& l, int cell, const Eigen::MatrixXd& Phi, const Eigen::MatrixXd& radius,
                                  double k1, double k2, double gamma, const IntervalMatrix& P, const Eigen::VectorXd& tau) {
  const std::vector<int>& used = l.cell_entries[cell];
  const int size = l.N + static_cast<int>(used.size());
  IntervalMatrix A = IntervalMatrix::Zero(l.N, l.N);
  for (int i = 0; i < l.n; ++i) {
    A(i, i) = Interval(-k1);
    A(i, l.n + i) = Interval(1.0);
    A(l.n + i, i) = Interval(-k2);
    for (int j = 0; j < l.n; ++j) A(l.n + i, l.n + j) = Interval(Phi(i, j));
  }
  IntervalMatrix X = IntervalMatrix::Zero(size, size);
  X.topLeftCorner(l.N, l.N) = -lyapunov_term(A, P, gamma);
  for (std::size_t u = 0; u < used.size(); ++u) {
    const auto [i, j] = l.uncertain[used[u]];
    const int column = l.N + static_cast<int>(u);
    const Interval t(tau(used[u]));
    X(l.n + j, l.n + j) -= t * square(Interval(radius(i, j)));
    X.block(0, column, l.N, 1) = -P.col(l.n + i);
    X.block(column, 0, 1, l.N) = -P.col(l.n + i).transpose();
    X(column, column) = t;
  }
  return X;
}

}  // namespace

bool polytopic_check(const PerturbationPolytope& polytope, double k1, double k2, double gamma, const Eigen::MatrixXd& P,
                     const Eigen::VectorXd& multipliers) {
  const Layout l = layout_of(polytope);
  if (P.rows() != l.N || P.cols() != l.N || multipliers.size() != l.last - l.tau_offset)
    return false;
  const IntervalMatrix Pi = P.cast<Interval>();
  if (!positive_definite_proven(Pi)) return false;
  for (std::size_t c = 0; c < polytope.cells.size(); ++c)
    for (const Eigen::MatrixXd& Phi : polytope.cells[c].vertices)
      if (!positive_definite_proven(negated_vertex_lmi(l, static_cast<int>(c), Phi, polytope.cells[c].radius, k1, k2,
                                                       gamma, Pi, multipliers)))
        return false;
  return true;
}

}  // namespace obsgain
