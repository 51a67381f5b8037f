#include "obsgain/certificate/polytopic_search.hpp"

#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/bounds/taylor_matrix.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/interval.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>

namespace obsgain {

namespace {

// Φ's terms at one configuration: Ψ_F = −M⁻¹F and Ψ_j = −M⁻¹J_j, so that φ = Ψ_F e_v + Σ_j w_j Ψ_j δ.
struct Sample {
  Eigen::VectorXd q;
  Eigen::MatrixXd friction_term;
  std::vector<Eigen::MatrixXd> jacobian_terms;
};

Sample sample_at(const Model& model, const Eigen::VectorXd& q) {
  const int n = model.dof();
  Eigen::MatrixXd M(n, n);
  mass_matrix(model, q, M);
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  Sample s{q, -llt.solve(model.friction), {}};
  for (int j = 0; j < n; ++j) s.jacobian_terms.push_back(-llt.solve(coriolis_jacobian(N, Eigen::VectorXd::Unit(n, j))));
  return s;
}

// The balanced coordinates x = (s e_q, e_v), s the power of two nearest sqrt(k2): A's entries have one size, and
// P = W P_x W (W = diag(s I, I)) is exact in floating point.
double balance(double k2) { return std::exp2(std::round(std::log2(std::sqrt(k2)))); }

// Where the unknowns sit in the solver's y: P_x's lower triangle, the multipliers τ, then the slack t.
struct Layout {
  int n = 0, N = 0;
  std::vector<std::pair<int, int>> p_entries;
  int tau = 0, last = 0;
};

Layout layout_for(int n) {
  Layout l{n, 2 * n, {}, 0, 0};
  for (int a = 0; a < l.N; ++a)
    for (int b = 0; b <= a; ++b) l.p_entries.emplace_back(a, b);
  l.tau = static_cast<int>(l.p_entries.size());
  l.last = l.tau + n;
  return l;
}

Eigen::MatrixXd linear_part(int n, double k1, double k2, double s) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  A.topLeftCorner(n, n).diagonal().setConstant(-k1);
  A.topRightCorner(n, n).diagonal().setConstant(s);
  A.bottomLeftCorner(n, n).diagonal().setConstant(-k2 / s);
  return A;
}

// The LMI in z = (x, δ) at one configuration and velocity vertex w:
// [[A_xᵀP + P A_x + 2γP, P B + E_v T / 2], [·, −T]], A_x = linear part + E Ψ_F E_vᵀ, B = E Σ_j w_j Ψ_j.
Eigen::MatrixXd lmi_at(const Layout& l, const Eigen::MatrixXd& A, const Sample& s, const Eigen::VectorXd& w,
                       double gamma, const Eigen::MatrixXd& P, const Eigen::VectorXd& tau) {
  const int n = l.n;
  Eigen::MatrixXd Ax = A;
  Ax.bottomRightCorner(n, n) = s.friction_term;
  Eigen::MatrixXd Bw = Eigen::MatrixXd::Zero(n, n);
  for (int j = 0; j < n; ++j) Bw += w(j) * s.jacobian_terms[j];
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  X.topLeftCorner(l.N, l.N) = Ax.transpose() * P + P * Ax + 2.0 * gamma * P;
  Eigen::MatrixXd coupling = P.rightCols(n) * Bw;
  coupling.bottomRows(n).diagonal() += 0.5 * tau;
  X.topRightCorner(l.N, n) = coupling;
  X.bottomLeftCorner(n, l.N) = coupling.transpose();
  X.bottomRightCorner(n, n).diagonal() = -tau;
  return X;
}

LinearMatrixInequality lmi_block(const Layout& l, const Eigen::MatrixXd& A, const Sample& s, const Eigen::VectorXd& w,
                                 double gamma, bool slack) {
  const int n = l.n, size = 3 * n;
  LinearMatrixInequality lmi;
  lmi.size = size;
  Eigen::MatrixXd Ax = A;
  Ax.bottomRightCorner(n, n) = s.friction_term;
  Eigen::MatrixXd Bw = Eigen::MatrixXd::Zero(n, n);
  for (int j = 0; j < n; ++j) Bw += w(j) * s.jacobian_terms[j];
  for (std::size_t v = 0; v < l.p_entries.size(); ++v) {
    Eigen::MatrixXd E = Eigen::MatrixXd::Zero(l.N, l.N);
    E(l.p_entries[v].first, l.p_entries[v].second) = E(l.p_entries[v].second, l.p_entries[v].first) = 1.0;
    Eigen::MatrixXd F = Eigen::MatrixXd::Zero(size, size);
    F.topLeftCorner(l.N, l.N) = Ax.transpose() * E + E * Ax + 2.0 * gamma * E;
    F.topRightCorner(l.N, n) = E.rightCols(n) * Bw;
    F.bottomLeftCorner(n, l.N) = F.topRightCorner(l.N, n).transpose();
    lmi.terms.emplace_back(static_cast<int>(v), packed(F));
  }
  for (int i = 0; i < n; ++i) {
    Eigen::MatrixXd F = Eigen::MatrixXd::Zero(size, size);
    F(n + i, l.N + i) = F(l.N + i, n + i) = 0.5;
    F(l.N + i, l.N + i) = -1.0;
    lmi.terms.emplace_back(l.tau + i, packed(F));
  }
  if (slack) lmi.terms.emplace_back(l.last, packed(-Eigen::MatrixXd::Identity(size, size)));
  return lmi;
}

// W = diag(s I, I): P = W P_x W in original coordinates.
Eigen::VectorXd original_weights(const Layout& l, double s) {
  Eigen::VectorXd W = Eigen::VectorXd::Ones(l.N);
  W.head(l.n).setConstant(s);
  return W;
}

// I ≼ W P_x W, and W P_x W ≼ cap I, or with no cap ≼ κ I with κ the last unknown: the SDP's normalisation of P, in
// balanced coordinates (W = I) or original ones.
void normalisation(const Layout& l, const Eigen::VectorXd& W, std::optional<double> cap,
                   std::vector<LinearMatrixInequality>& blocks) {
  LinearMatrixInequality lower, upper;
  lower.size = upper.size = l.N;
  lower.constant = packed(Eigen::MatrixXd::Identity(l.N, l.N));
  upper.constant = packed(-cap.value_or(0.0) * Eigen::MatrixXd::Identity(l.N, l.N));
  for (std::size_t v = 0; v < l.p_entries.size(); ++v) {
    Eigen::MatrixXd E = Eigen::MatrixXd::Zero(l.N, l.N);
    E(l.p_entries[v].first, l.p_entries[v].second) = E(l.p_entries[v].second, l.p_entries[v].first) = 1.0;
    E = W.asDiagonal() * E * W.asDiagonal();
    lower.terms.emplace_back(static_cast<int>(v), packed(-E));
    upper.terms.emplace_back(static_cast<int>(v), packed(E));
  }
  if (!cap) upper.terms.emplace_back(l.last, packed(-Eigen::MatrixXd::Identity(l.N, l.N)));
  blocks.push_back(std::move(lower));
  blocks.push_back(std::move(upper));
}

Eigen::MatrixXd p_of(const Layout& l, const Eigen::VectorXd& y) {
  Eigen::MatrixXd P(l.N, l.N);
  for (std::size_t v = 0; v < l.p_entries.size(); ++v)
    P(l.p_entries[v].first, l.p_entries[v].second) = P(l.p_entries[v].second, l.p_entries[v].first) = y(static_cast<Eigen::Index>(v));
  return P;
}

// A uniform number in [0, 1) from 53 bits of the generator: the same on every platform.
double uniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1p-53; }

}  // namespace

struct PolytopicSearch::State {
  const Model& model;
  Eigen::VectorXd velocity_bounds;
  PolytopicSearchOptions options;
  JointSearch search;
  BoxBounds box_bounds;
  Layout layout;
  Eigen::MatrixXd vertices;  // n x 2ⁿ
  std::vector<Sample> samples;
  std::vector<std::pair<int, int>> cuts;  // (sample, vertex)
  PolytopicSearchReport report;

  State(const Model& m, const Eigen::VectorXd& V, const std::vector<Eigen::VectorXd>& seeds, const PolytopicSearchOptions& o)
      : model(m),
        velocity_bounds(V),
        options(o),
        search(joint_search(m, configuration_joints(m))),
        box_bounds(m, search, V),
        layout(layout_for(m.dof())) {
    const int n = m.dof();
    vertices.resize(n, 1 << n);
    for (int c = 0; c < (1 << n); ++c)
      for (int j = 0; j < n; ++j) vertices(j, c) = ((c >> j) & 1) ? V(j) : -V(j);
    for (const Eigen::VectorXd& q : seeds) samples.push_back(sample_at(m, q));
    std::mt19937_64 rng(20261125);
    Eigen::VectorXd x(static_cast<Eigen::Index>(search.domain.size()));
    for (int i = 0; i < o.samples; ++i) {
      for (Eigen::Index k = 0; k < x.size(); ++k) {
        const Interval& side = search.domain[static_cast<std::size_t>(k)];
        x(k) = side.lower() + uniform(rng) * (side.upper() - side.lower());
      }
      samples.push_back(sample_at(m, search.configuration(x)));
    }
    report.samples = static_cast<int>(samples.size());
  }

  // The SDP on the cuts: minimise t with every cut's LMI ≼ t I, I ≼ P_x ≼ cap I. Returns y (P_x, τ, t).
  Eigen::VectorXd solve_cuts(double k1, double k2, double gamma) const;
  // The largest eigenvalue of the LMI at each sample's worst vertex under y, worst first.
  std::vector<std::pair<double, std::pair<int, int>>> worst_samples(double k1, double k2, double gamma,
                                                                     const Eigen::VectorXd& y) const;
  // Cutting planes until every sample holds (true, y set) or the SDP's slack is not negative (false).
  bool solve(double k1, double k2, double gamma, Eigen::VectorXd& y);
  // Among the P (with τ) that hold at every sample for γ, the one with the smallest λmax/λmin in original coordinates
  // (k² of the envelope), by cutting planes as in `solve`; the samples are checked at `gamma_check` < γ, since that P
  // sits on its cuts' boundary at γ. `y` (from `solve`: it holds at every sample) is the solver's start, and is
  // replaced when such a P is found.
  void smallest_condition(double k1, double k2, double gamma, double gamma_check, Eigen::VectorXd& y);
  BoxBound box_bound(const std::vector<Interval>& box, const Eigen::MatrixXd& P, const Eigen::MatrixXd& constant,
                     double constant_radius) const;
  double largest_at(const Eigen::VectorXd& q, const Eigen::MatrixXd& A, double gamma, const Eigen::MatrixXd& P,
                    const Eigen::VectorXd& tau) const;
  BoundBracket prove(double k1, double k2, double gamma, const Eigen::MatrixXd& P, const Eigen::VectorXd& tau);
};

Eigen::VectorXd PolytopicSearch::State::solve_cuts(double k1, double k2, double gamma) const {
  const Layout& l = layout;
  const Eigen::MatrixXd A = linear_part(l.n, k1, k2, balance(k2));
  std::vector<LinearMatrixInequality> blocks;
  for (const auto& [s, v] : cuts) blocks.push_back(lmi_block(l, A, samples[s], vertices.col(v), gamma, true));
  normalisation(l, Eigen::VectorXd::Ones(l.N), options.condition_cap, blocks);
  // A strictly feasible start: P_x = c I, τ = c, t above every block's largest eigenvalue there.
  const double c = std::sqrt(options.condition_cap);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(l.last + 1);
  for (std::size_t v = 0; v < l.p_entries.size(); ++v)
    y(static_cast<Eigen::Index>(v)) = l.p_entries[v].first == l.p_entries[v].second ? c : 0.0;
  y.segment(l.tau, l.n).setConstant(c);
  double worst = 0.0;
  for (std::size_t b = 0; b + 2 < blocks.size(); ++b)
    worst = std::max(worst, symmetric_eigenvalues(evaluate(blocks[b], y)).maxCoeff());
  y(l.last) = 2.0 * worst + 1.0;
  SdpOptions o = options.sdp;
  o.start = y;
  Eigen::VectorXd objective = Eigen::VectorXd::Zero(l.last + 1);
  objective(l.last) = -1.0;
  return solve_sdp(l.last + 1, blocks, objective, o).y;
}

double PolytopicSearch::State::largest_at(const Eigen::VectorXd& q, const Eigen::MatrixXd& A, double gamma,
                                          const Eigen::MatrixXd& P, const Eigen::VectorXd& tau) const {
  const Sample s = sample_at(model, q);
  double largest = -kInfinity;
  for (Eigen::Index v = 0; v < vertices.cols(); ++v)
    largest = std::max(largest, symmetric_eigenvalues(lmi_at(layout, A, s, vertices.col(v), gamma, P, tau)).maxCoeff());
  return largest;
}

std::vector<std::pair<double, std::pair<int, int>>> PolytopicSearch::State::worst_samples(double k1, double k2,
                                                                                         double gamma,
                                                                                         const Eigen::VectorXd& y) const {
  const Layout& l = layout;
  const Eigen::MatrixXd A = linear_part(l.n, k1, k2, balance(k2));
  const Eigen::MatrixXd P = p_of(l, y);
  const Eigen::VectorXd tau = y.segment(l.tau, l.n);
  std::vector<std::pair<double, std::pair<int, int>>> worst;
  for (std::size_t s = 0; s < samples.size(); ++s) {
    std::pair<double, std::pair<int, int>> w{-kInfinity, {static_cast<int>(s), 0}};
    for (Eigen::Index v = 0; v < vertices.cols(); ++v) {
      const double e = symmetric_eigenvalues(lmi_at(l, A, samples[s], vertices.col(v), gamma, P, tau)).maxCoeff();
      if (e > w.first) w = {e, {static_cast<int>(s), static_cast<int>(v)}};
    }
    worst.push_back(w);
  }
  std::stable_sort(worst.begin(), worst.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  return worst;
}

bool PolytopicSearch::State::solve(double k1, double k2, double gamma, Eigen::VectorXd& y) {
  if (cuts.empty()) cuts.emplace_back(0, 0);
  for (int round = 0; round < options.max_cut_rounds; ++round) {
    y = solve_cuts(k1, k2, gamma);
    report.cuts = static_cast<int>(cuts.size());
    if (!(y(layout.last) < 0.0)) return false;
    const auto worst = worst_samples(k1, k2, gamma, y);
    if (worst.front().first < 0.0) return true;
    for (int c = 0; c < options.cuts_per_round && worst[static_cast<std::size_t>(c)].first >= 0.0; ++c)
      if (std::find(cuts.begin(), cuts.end(), worst[static_cast<std::size_t>(c)].second) == cuts.end())
        cuts.push_back(worst[static_cast<std::size_t>(c)].second);
  }
  return false;
}

void PolytopicSearch::State::smallest_condition(double k1, double k2, double gamma, double gamma_check,
                                               Eigen::VectorXd& y) {
  const Layout& l = layout;
  const double s = balance(k2);
  const Eigen::MatrixXd A = linear_part(l.n, k1, k2, s);
  const Eigen::VectorXd W = original_weights(l, s);
  // y scaled so that λmin(P) > 1, κ above λmax(P): strictly feasible, the LMIs being homogeneous in (P, τ).
  const Eigen::VectorXd eigenvalues = symmetric_eigenvalues(W.asDiagonal() * p_of(l, y) * W.asDiagonal());
  if (!(eigenvalues.minCoeff() > 0.0)) return;
  const double scale = 1.01 / eigenvalues.minCoeff();
  Eigen::VectorXd start = scale * y;
  start(l.last) = 1.01 * scale * eigenvalues.maxCoeff();
  Eigen::VectorXd objective = Eigen::VectorXd::Zero(l.last + 1);
  objective(l.last) = -1.0;
  for (int round = 0; round < options.max_cut_rounds; ++round) {
    std::vector<LinearMatrixInequality> blocks;
    for (const auto& [c, v] : cuts) blocks.push_back(lmi_block(l, A, samples[c], vertices.col(v), gamma, false));
    normalisation(l, W, std::nullopt, blocks);
    SdpOptions o = options.sdp;
    o.start = start;
    const SdpResult r = solve_sdp(l.last + 1, blocks, objective, o);
    if (!r.solved || !r.y.allFinite()) return;
    const auto worst = worst_samples(k1, k2, gamma_check, r.y);
    if (worst.front().first < 0.0) {
      y = r.y;
      return;
    }
    const std::size_t before = cuts.size();
    for (int c = 0; c < options.cuts_per_round && worst[static_cast<std::size_t>(c)].first >= 0.0; ++c)
      if (std::find(cuts.begin(), cuts.end(), worst[static_cast<std::size_t>(c)].second) == cuts.end())
        cuts.push_back(worst[static_cast<std::size_t>(c)].second);
    if (cuts.size() == before) return;
  }
}

namespace {

// X placed at (row, col) of a size x size zero matrix.
TaylorMatrix placed(const TaylorMatrix& X, int size, int row, int col) {
  TaylorMatrix Y(size, size, X.symbols());
  for (int t = 0; t < X.parts(); ++t) Y.part(t).block(row, col, X.rows(), X.cols()) = X.part(t);
  Y.remainder = X.remainder;
  return Y;
}

TaylorMatrix transposed(const TaylorMatrix& X) {
  TaylorMatrix Y;
  Y.shape(X.cols(), X.rows(), X.symbols());
  for (int t = 0; t < X.parts(); ++t) Y.part(t) = X.part(t).transpose();
  Y.remainder = X.remainder;
  return Y;
}

// X + Xᵀ of the off-diagonal block X (placed at (row, col)).
void add_symmetric_pair(const TaylorMatrix& X, int size, int row, int col, std::vector<TaylorMatrix>& terms) {
  terms.push_back(placed(X, size, row, col));
  terms.push_back(placed(transposed(X), size, col, row));
}

TaylorMatrix negated(TaylorMatrix X) {
  X.parts(0, X.parts()) = -X.parts(0, X.parts());
  return X;
}

// An upper bound of λmax(X(ε)) over the box: cheaply, λmax of the centre (proven) plus the variation's Frobenius
// norms; where that is not enough, the fine bound of λmin(−X) (bounds/taylor_matrix.hpp).
double largest_eigenvalue_bound(const TaylorMatrix& X) {
  const UpwardRounding upward;
  Interval cheap = Interval(largest_eigenvalue_upper(X.centre())) + Interval(X.remainder);
  for (int t = 1; t < X.parts(); ++t) cheap += Interval(X.part(t).norm() * (1.0 + 1e-13));
  if (cheap.upper() <= 0.0) return cheap.upper();
  return std::min(cheap.upper(), -smallest_eigenvalue_lower(negated(X)));
}

}  // namespace

// Over the box, for every vertex w: X(ε) = constant + [P E (−R(ε)) E_vᵀ + ·ᵀ] + [P E (−A(w, ε)) in the δ columns + ·ᵀ],
// and M⁻¹'s tail U adds −2 xᵀ P E U [F, J(w)] (e_v, δ), a symmetric perturbation of norm <= 2 ||P E|| · tail.
BoxBound PolytopicSearch::State::box_bound(const std::vector<Interval>& box, const Eigen::MatrixXd& P,
                                           const Eigen::MatrixXd& constant, double constant_radius) const {
  const int n = layout.n, N = layout.N, size = 3 * n;
  const PerturbationForms forms = box_bounds.perturbation_forms(box);
  // A vertex's 3n x 3n Taylor matrix and its eigenvalue bound: 38 refinements of an n x n form, timed on the suite's
  // machine.
  const double vertex_work = 38.0 * forms.costs.refinement;
  BoxBound bound{kInfinity, forms.split_weight, forms.costs.point + forms.costs.forms + forms.costs.products};
  if (!forms.proven) return bound;
  const Eigen::MatrixXd PE = P.rightCols(n);
  const int symbols = forms.R.symbols();
  TaylorMatrix fixed(constant.rows(), constant.cols(), 0);
  fixed.centre() = constant;
  {
    const UpwardRounding upward;
    // x and (e_v, δ) share e_v: the symmetric part of the coupling has norm up to twice the block's.
    fixed.remainder =
        (Interval(constant_radius) + Interval(2.0) * Interval(PE.norm() * (1.0 + 1e-13)) * Interval(forms.tail)).upper();
  }
  std::vector<TaylorMatrix> common{with_symbols(fixed, symbols)};
  add_symmetric_pair(sandwiched(-PE, forms.R, {}), size, 0, n, common);
  const std::vector<double> A_frobenius = frobenius_uppers(forms.A);
  bound.upper = -kInfinity;
  for (Eigen::Index v = 0; v < vertices.cols(); ++v) {
    std::vector<TaylorMatrix> terms = common;
    add_symmetric_pair(sandwiched(-PE, linear_combination(forms.A, vertices.col(v), A_frobenius), {}), size, 0, N, terms);
    const TaylorMatrix X = linear_combination(terms, Eigen::VectorXd::Ones(static_cast<Eigen::Index>(terms.size())),
                                              frobenius_uppers(terms));
    bound.upper = std::max(bound.upper, largest_eigenvalue_bound(X));
    bound.work += vertex_work;
  }
  bound.upper = std::max(bound.upper, 0.0);
  return bound;
}

BoundBracket PolytopicSearch::State::prove(double k1, double k2, double gamma, const Eigen::MatrixXd& P,
                                           const Eigen::VectorXd& tau) {
  const int n = layout.n, size = 3 * n;
  const double s = balance(k2);
  // The LMI's constant part in interval arithmetic: [[A₀ᵀP + P A₀ + 2γP, E_v T / 2], [·, −T]].
  IntervalMatrix C = IntervalMatrix::Constant(size, size, Interval(0.0));
  {
    const UpwardRounding upward;
    // A₀ᵀP + P A₀ + 2γP entry by entry: A₀ has at most two nonzeros per row and column, exact doubles.
    const Eigen::MatrixXd A0 = linear_part(n, k1, k2, s);
    for (int i = 0; i < 2 * n; ++i)
      for (int j = 0; j < 2 * n; ++j) {
        Interval x = Interval(2.0 * gamma) * Interval(P(i, j));
        for (int k = 0; k < 2 * n; ++k) {
          if (A0(k, i) != 0.0) x += Interval(A0(k, i)) * Interval(P(k, j));
          if (A0(k, j) != 0.0) x += Interval(P(i, k)) * Interval(A0(k, j));
        }
        C(i, j) = x;
      }
    for (int i = 0; i < n; ++i) {
      C(n + i, 2 * n + i) = C(2 * n + i, n + i) = Interval(0.5) * Interval(tau(i));
      C(2 * n + i, 2 * n + i) = -Interval(tau(i));
    }
  }
  Eigen::MatrixXd centre(size, size), radius(size, size);
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j) {
      centre(i, j) = obsgain::centre(C(i, j));
      radius(i, j) = std::max(C(i, j).upper() - centre(i, j), centre(i, j) - C(i, j).lower());
    }
  double constant_radius = 0.0;
  {
    const UpwardRounding upward;
    constant_radius = radius.norm() * (1.0 + 1e-13);
  }
  const Eigen::MatrixXd A = linear_part(n, k1, k2, s);
  BranchAndBoundOptions o;
  o.relative_gap = 1.0 - 1e-9;  // ends at the first configuration where the LMI fails
  o.work_budget = std::max(0.0, options.proof_budget - report.proof_work);
  o.threads = options.threads;
  o.name = "polytopic LMI";
  o.deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                      std::chrono::duration<double>(3.0 * options.proof_budget + 30.0));
  const Eigen::VectorXd seed = samples.front().q;
  const BoundBracket r = search_joints(
      search, [&](const std::vector<Interval>& box, double) { return box_bound(box, P, centre, constant_radius); },
      [&](const Eigen::VectorXd& q) { return std::max(0.0, largest_at(q, A, gamma, P, tau)); }, seed, o);
  report.proof_boxes += r.boxes;
  report.proof_work += r.work;
  return r;
}

PolytopicSearch::PolytopicSearch(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                 const std::vector<Eigen::VectorXd>& seeds, const PolytopicSearchOptions& options)
    : state_(std::make_unique<State>(model, velocity_bounds, seeds, options)) {}

PolytopicSearch::~PolytopicSearch() = default;
PolytopicSearch::PolytopicSearch(PolytopicSearch&&) noexcept = default;
PolytopicSearch& PolytopicSearch::operator=(PolytopicSearch&&) noexcept = default;

const PolytopicSearchReport& PolytopicSearch::report() const { return state_->report; }

bool PolytopicSearch::feasible(double k1, double k2, double gamma) {
  Eigen::VectorXd y;
  return state_->solve(k1, k2, gamma, y);
}

double PolytopicSearch::theta_star(double alpha, double beta, double gamma, double from) {
  const double g = gamma / (1.0 - state_->options.rate_margin);
  const auto holds = [&](double theta) { return feasible(theta * alpha, theta * theta * beta, g); };
  double hi = from;
  while (!holds(hi)) {
    hi *= 2.0;
    if (hi > 1e8) return kInfinity;
  }
  double lo = hi / 2.0;
  while (holds(lo)) {
    hi = lo;
    lo /= 2.0;
    if (lo < 1e-6) return hi;
  }
  while (hi - lo > state_->options.relative_tolerance * hi) {
    const double mid = 0.5 * (lo + hi);
    (holds(mid) ? hi : lo) = mid;
  }
  return hi;
}

double PolytopicSearch::rate(double k1, double k2) {
  double lo = 0.0, hi = k1;
  if (!feasible(k1, k2, lo)) return -kInfinity;
  while (hi - lo > state_->options.relative_tolerance * hi) {
    const double mid = 0.5 * (lo + hi);
    (feasible(k1, k2, mid) ? lo : hi) = mid;
  }
  return lo;
}

PolytopicCertificate PolytopicSearch::certificate(double k1, double k2, double gamma) {
  State& st = *state_;
  const Layout& l = st.layout;
  PolytopicCertificate cert;
  cert.gamma = gamma;
  const double g = gamma / (1.0 - st.options.rate_margin);
  const auto over_budget = [&] {
    return fmt::format("not proven within the proof budget of {} s, {} boxes", st.options.proof_budget,
                       st.report.proof_boxes);
  };
  for (int attempt = 0; attempt < st.options.proof_attempts; ++attempt) {
    if (st.report.proof_work >= st.options.proof_budget) {
      cert.status = over_budget();
      return cert;
    }
    Eigen::VectorXd y;
    if (!st.solve(k1, k2, g, y)) {
      cert.status = fmt::format("the SDP found no P for gamma = {:.6g} at the {} sampled configurations", g,
                                st.samples.size());
      return cert;
    }
    st.smallest_condition(k1, k2, g, 0.5 * (g + gamma), y);
    const Eigen::MatrixXd P_x = p_of(l, y);
    const Eigen::VectorXd tau = y.segment(l.tau, l.n);
    const BoundBracket proof = st.prove(k1, k2, gamma, P_x, tau);
    if (proof.lower > 0.0) {  // refuted: the configuration joins the samples
      ++st.report.refuted;
      st.samples.push_back(sample_at(st.model, proof.argmax));
      st.report.samples = static_cast<int>(st.samples.size());
      cert.status = "the chosen P failed at a configuration the samples missed";
      continue;
    }
    if (!(proof.upper <= 0.0)) {
      cert.status = over_budget();
      return cert;
    }
    const Eigen::VectorXd W = original_weights(l, balance(k2));
    cert.P = W.asDiagonal() * P_x * W.asDiagonal();  // exact: W's entries are powers of two
    cert.multipliers = tau;
    const double smallest = smallest_eigenvalue_lower(cert.P);
    cert.exists = smallest > 0.0 && positive_definite_proven(cert.P.cast<Interval>());
    if (cert.exists) {
      const UpwardRounding upward;
      cert.k = std::sqrt((Interval(largest_eigenvalue_upper(cert.P)) / Interval(smallest)).upper());
    }
    cert.status = cert.exists ? fmt::format("proven by branch and bound over {} boxes", proof.boxes) : "P not proven positive definite";
    return cert;
  }
  return cert;
}

}  // namespace obsgain
