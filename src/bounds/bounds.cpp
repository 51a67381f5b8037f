#include "obsgain/bounds/bounds.hpp"

#include "obsgain/bounds/perturbation_polytope.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/optimize.hpp"
#include "obsgain/numerics/parallel.hpp"
#include "obsgain/numerics/processes.hpp"
#include "obsgain/numerics/sdp.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <random>
#include <sstream>

namespace obsgain {

namespace {

// The (q, discrete choice) structure shared by the three bounds: for each q, a finite family of smooth
// functions f_c(q) (one per vertex / saturation pattern) whose maximum is the objective.
struct BoundProblem {
  std::string name;  // "M0", "B", "L_joint" or "L_T"
  // Evaluates max_c f_c(q); writes the maximising choice.
  std::function<double(const Eigen::VectorXd& q, int& choice)> all_choices;
  // Evaluates one f_c(q).
  std::function<double(const Eigen::VectorXd& q, int choice)> one_choice;
};

struct SearchSpace {
  std::vector<int> joints;  // the joints M and C depend on
  Eigen::VectorXd lower, upper;
  Eigen::VectorXd fixed_q;  // values of all joints outside the search
};

SearchSpace search_space(const Model& model) {
  SearchSpace space;
  space.joints = configuration_joints(model);
  const int n = model.dof();
  space.fixed_q = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    const JointDomain& joint = model.joints[i];
    space.fixed_q(i) = joint.continuous ? 0.0 : 0.5 * (joint.lower + joint.upper);
  }
  const auto d = static_cast<Eigen::Index>(space.joints.size());
  space.lower.resize(d);
  space.upper.resize(d);
  for (Eigen::Index k = 0; k < d; ++k) {
    const JointDomain& joint = model.joints[space.joints[k]];
    space.lower(k) = joint.continuous ? -std::numbers::pi : joint.lower;
    space.upper(k) = joint.continuous ? std::numbers::pi : joint.upper;
  }
  return space;
}

Eigen::VectorXd full_configuration(const SearchSpace& space, const Eigen::VectorXd& x) {
  Eigen::VectorXd q = space.fixed_q;
  for (Eigen::Index k = 0; k < x.size(); ++k) q(space.joints[k]) = x(k);
  return q;
}

// Continuous joints are periodic: report their argmax inside (-π, π].
Eigen::VectorXd wrap_configuration(const Model& model, Eigen::VectorXd q) {
  for (int i = 0; i < q.size(); ++i) {
    if (model.joints[i].continuous) q(i) = std::remainder(q(i), 2.0 * std::numbers::pi);
  }
  return q;
}

// The model's refusal at a configuration: "model 'name': <what> at q = (...)<why>".
[[noreturn]] void refuse_at(const Model& model, const std::string& what, const Eigen::VectorXd& q, const std::string& why) {
  std::ostringstream msg;
  msg << "model '" << model.name << "': " << what << " at q = ("
      << q.transpose().format(Eigen::IOFormat(6, Eigen::DontAlignCols, ", ", ", ")) << ")" << why;
  throw InputError(msg.str());
}

[[noreturn]] void singular_inertia(const Model& model, const Eigen::VectorXd& q) {
  refuse_at(model, "inertia matrix M(q) is singular or indefinite", q, "");
}

// Eigenvalues of M(q), refusing a numerically singular or indefinite M: the bounds would be meaningless.
Eigen::VectorXd inertia_eigenvalues(const Model& model, const Eigen::VectorXd& q, Eigen::MatrixXd& M) {
  M.resize(model.dof(), model.dof());
  mass_matrix(model, q, M);
  const Eigen::VectorXd lambda = symmetric_eigenvalues(M);
  if (!(lambda(0) > 1e-12 * lambda(lambda.size() - 1))) singular_inertia(model, q);
  return lambda;
}

Eigen::LLT<Eigen::MatrixXd> factor_inertia(const Model& model, const Eigen::VectorXd& q) {
  Eigen::MatrixXd M;
  inertia_eigenvalues(model, q, M);
  return Eigen::LLT<Eigen::MatrixXd>(M);
}

// max_c f_c(q), refusing a value that is not finite: M is refused where singular, so only numbers past double's range
// (a friction of 1e308, say) get here, and the optimisers would pass such values over without a word.
double finite_value(const Model& model, const BoundProblem& problem, const Eigen::VectorXd& q, int& choice) {
  const double value = problem.all_choices(q, choice);
  if (!std::isfinite(value))
    refuse_at(model, problem.name + " is not finite", q,
              ": the model's numbers (masses, inertias, friction, velocity bounds) overflow double precision");
  return value;
}

// Nothing to search when M and C depend on no joint (a single joint): the value at any configuration.
BoundMaximum constant_maximum(const Model& model, const SearchSpace& space, const BoundProblem& problem) {
  BoundMaximum result;
  int choice = 0;
  result.value = result.global_value = result.polish_value = finite_value(model, problem, space.fixed_q, choice);
  result.global_evaluations = 1;
  result.q = space.fixed_q;
  return result;
}

// An Ipopt polish's result as bytes, its doubles bit for bit, to come back from a child process (map_in_processes):
// the value, the evaluations, then x.
constexpr std::size_t kPolishHead = sizeof(double) + sizeof(int);

std::string to_bytes(const OptimumPoint& p) {
  const std::size_t x_size = sizeof(double) * static_cast<std::size_t>(p.x.size());
  std::string bytes(kPolishHead + x_size, '\0');
  std::memcpy(bytes.data(), &p.value, sizeof(double));
  std::memcpy(bytes.data() + sizeof(double), &p.evaluations, sizeof(int));
  std::memcpy(bytes.data() + kPolishHead, p.x.data(), x_size);
  return bytes;
}

OptimumPoint from_bytes(const std::string& bytes) {
  OptimumPoint p;
  std::memcpy(&p.value, bytes.data(), sizeof(double));
  std::memcpy(&p.evaluations, bytes.data() + sizeof(double), sizeof(int));
  p.x.resize(static_cast<Eigen::Index>((bytes.size() - kPolishHead) / sizeof(double)));
  std::memcpy(p.x.data(), bytes.data() + kPolishHead, bytes.size() - kPolishHead);
  return p;
}

// Ipopt from each start, on the choice (velocity vertex, saturation pattern) that is largest there. The polishes are
// independent; Ipopt's linear solver is not thread-safe, so on several cores they run in child processes
// (numerics/processes.hpp), with the same results, in the starts' order, as one after the other.
std::vector<OptimumPoint> polish_each(const Model& model, const SearchSpace& space, const BoundProblem& problem,
                                      const std::vector<std::pair<double, Eigen::VectorXd>>& starts, int threads) {
  const auto d = static_cast<int>(space.joints.size());
  const auto polish = [&](int i) {
    const Eigen::VectorXd& x0 = starts[static_cast<std::size_t>(i)].second;
    int choice = 0;
    problem.all_choices(full_configuration(space, x0), choice);
    // Search a continuous joint one period around the start, so that a maximiser near ±π is interior.
    Eigen::VectorXd lower = space.lower, upper = space.upper;
    for (int k = 0; k < d; ++k) {
      if (model.joints[space.joints[k]].continuous) {
        lower(k) = x0(k) - std::numbers::pi;
        upper(k) = x0(k) + std::numbers::pi;
      }
    }
    const Objective smooth = [&](const Eigen::VectorXd& x) {
      return problem.one_choice(full_configuration(space, x), choice);
    };
    return to_bytes(maximize_local(smooth, x0, lower, upper));
  };
  const int count = static_cast<int>(starts.size());
  const std::vector<std::string> bytes = map_in_processes(count, resolve_threads(threads), polish);
  std::vector<OptimumPoint> polished;
  for (const std::string& b : bytes) polished.push_back(from_bytes(b));
  return polished;
}

BoundMaximum search(const Model& model, const BoundProblem& problem, const BoundOptions& options) {
  const SearchSpace space = search_space(model);
  const auto d = static_cast<int>(space.joints.size());
  if (d == 0) return constant_maximum(model, space, problem);
  BoundMaximum result;

  const Objective objective = [&](const Eigen::VectorXd& x) {
    int choice = 0;
    return finite_value(model, problem, full_configuration(space, x), choice);
  };
  const OptimumPoint global = maximize_global(objective, space.lower, space.upper,
                                              options.global_evaluations_per_dimension * std::max(d, 1));
  result.global_value = global.value;
  result.global_evaluations = global.evaluations;

  // Polish starts: the global argmax, then the best points of a reproducible uniform sample.
  std::vector<std::pair<double, Eigen::VectorXd>> starts{{global.value, global.x}};
  std::mt19937_64 rng(20260101);
  std::vector<std::pair<double, Eigen::VectorXd>> samples;
  for (int s = 0; s < options.samples_per_dimension * std::max(d, 1); ++s) {
    Eigen::VectorXd x(d);
    for (int k = 0; k < d; ++k)
      x(k) = std::uniform_real_distribution<double>(space.lower(k), space.upper(k))(rng);
    samples.emplace_back(objective(x), x);
  }
  result.global_evaluations += static_cast<int>(samples.size());
  std::sort(samples.begin(), samples.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& sample : samples) {
    if (static_cast<int>(starts.size()) >= options.polish_starts) break;
    starts.push_back(sample);
  }

  const std::vector<OptimumPoint> polished = polish_each(model, space, problem, starts, options.threads);
  result.polish_value = -std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_x = global.x;
  for (const OptimumPoint& p : polished) {
    result.polish_evaluations += p.evaluations;
    int final_choice = 0;
    const double confirmed = problem.all_choices(full_configuration(space, p.x), final_choice);
    if (confirmed > result.polish_value) {
      result.polish_value = confirmed;
      if (confirmed >= result.global_value) best_x = p.x;
    }
  }
  result.value = std::max(result.global_value, result.polish_value);
  result.q = wrap_configuration(model, full_configuration(space, best_x));
  return result;
}

// Index c of a vertex of the box: bit i set means w_i = +V_i.
Eigen::VectorXd vertex(const Eigen::VectorXd& velocity_bounds, unsigned c) {
  Eigen::VectorXd w(velocity_bounds.size());
  for (Eigen::Index i = 0; i < w.size(); ++i) w(i) = ((c >> i) & 1u) ? velocity_bounds(i) : -velocity_bounds(i);
  return w;
}

Eigen::VectorXd pattern(int n, unsigned c) {
  Eigen::VectorXd D(n);
  for (int i = 0; i < n; ++i) D(i) = ((c >> i) & 1u) ? 1.0 : 0.0;
  return D;
}

// Tracks max λ_max(G) over a family of Gram matrices G = XᵀX without an eigensolver for most of them:
// λ_max(G) <= ||G||_F, and λ_max(G) <= b² exactly when b² I - G is positive semidefinite (a Cholesky test).
// Only a G that beats the running maximum is solved, so the result is the maximum to rounding.
class LargestSingularValue {
 public:
  explicit LargestSingularValue(int n) : shifted_(n, n), llt_(n) {}

  // Returns true (and raises the maximum) when ||X|| = sqrt(λ_max(G)) beats it.
  bool offer(const Eigen::MatrixXd& G) {
    if (best_squared_ >= 0.0) {
      if (G.squaredNorm() <= best_squared_ * best_squared_) return false;
      shifted_ = -G;
      shifted_.diagonal().array() += best_squared_;
      llt_.compute(shifted_);
      if (llt_.info() == Eigen::Success) return false;
    }
    const double largest = symmetric_eigenvalues(G).maxCoeff();
    if (largest <= best_squared_) return false;
    best_squared_ = largest;
    return true;
  }

  // True when λ_max(G) <= the maximum so far is shown (a Frobenius or a Cholesky test): nothing G bounds can beat it.
  bool cannot_beat(const Eigen::MatrixXd& G) {
    if (best_squared_ < 0.0) return false;
    if (G.squaredNorm() <= best_squared_ * best_squared_) return true;
    shifted_ = -G;
    shifted_.diagonal().array() += best_squared_;
    llt_.compute(shifted_);
    return llt_.info() == Eigen::Success;
  }

  double value() const { return std::sqrt(std::max(best_squared_, 0.0)); }

 private:
  double best_squared_ = -1.0;
  Eigen::MatrixXd shifted_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};


// J(q, -w) = -J(q, w): the vertices with w_n < 0 (bit n-1 clear) repeat the others for ||J||, and for
// ||M⁻¹(J D + F)|| too when F = 0.
double coriolis_jacobian_maximum(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds,
                                 int& choice) {
  const int n = model.dof();
  const unsigned vertex_count = 1u << n;
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  LargestSingularValue largest(n);
  Eigen::MatrixXd J(n, n), G(n, n);
  for (unsigned c = vertex_count / 2; c < vertex_count; ++c) {
    J = coriolis_jacobian(N, vertex(velocity_bounds, c));
    G.noalias() = J.transpose() * J;
    if (largest.offer(G)) choice = static_cast<int>(c);
  }
  return largest.value();
}

// The Gram matrix (A D + R)ᵀ(A D + R) of pattern `bits` (bit j: d_j = 1) from the blocks AᵀA, AᵀR, RᵀR: O(n²).
void pattern_gram(const Eigen::MatrixXd& AA, const Eigen::MatrixXd& AR, const Eigen::MatrixXd& RR, unsigned bits,
                  Eigen::MatrixXd& G) {
  const auto n = AA.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    const bool dj = (bits >> j) & 1u;
    for (Eigen::Index i = 0; i < n; ++i) {
      const bool di = (bits >> i) & 1u;
      G(i, j) = RR(i, j) + (di && dj ? AA(i, j) : 0.0) + (di ? AR(i, j) : 0.0) + (dj ? AR(j, i) : 0.0);
    }
  }
}

// Choices for L_joint: vertex index in the low n bits, saturation pattern in the next n bits. With
// X = A D + R, A = M⁻¹J, R = M⁻¹F: XᵀX = D AᵀA D + D AᵀR + RᵀA D + RᵀR, so each of the 2^n patterns costs
// O(n²) once the three Gram blocks of a vertex are formed. A vertex whose patterns cannot beat the maximum so far is
// passed over: X Xᵀ ≼ (A + R)(A + R)ᵀ + R Rᵀ for every pattern (docs/theory.md, "Every saturation pattern at once"),
// and without friction only D = I can (||A D|| <= ||A||).
// With a diagonal scaling T = diag(t), A and R become T A T⁻¹ and T R T⁻¹ (D is diagonal: T (A D + R) T⁻¹ = T A T⁻¹ D + T R T⁻¹).
double diagonal_lipschitz_maximum(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds,
                                  const Eigen::VectorXd& t, int& choice) {
  const int n = model.dof();
  const unsigned vertex_count = 1u << n;
  const unsigned first_vertex = model.friction.isZero(0.0) ? vertex_count / 2 : 0u;
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  const Eigen::LLT<Eigen::MatrixXd> llt = factor_inertia(model, q);
  const Eigen::MatrixXd R = t.asDiagonal() * llt.solve(model.friction) * t.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd RR = R.transpose() * R;
  LargestSingularValue largest(n);
  Eigen::MatrixXd A(n, n), AA(n, n), AR(n, n), G(n, n);
  const bool frictionless = model.friction.isZero(0.0);
  const Eigen::MatrixXd RRt = R * R.transpose();
  Eigen::MatrixXd envelope(n, n);
  for (unsigned c = first_vertex; c < vertex_count; ++c) {
    A = t.asDiagonal() * llt.solve(coriolis_jacobian(N, vertex(velocity_bounds, c))) * t.cwiseInverse().asDiagonal();
    envelope.noalias() = (A + R) * (A + R).transpose();
    envelope += RRt;
    if (largest.cannot_beat(envelope)) continue;
    AA.noalias() = A.transpose() * A;
    AR.noalias() = A.transpose() * R;
    // Full patterns first: they usually win, and a high running maximum prunes the rest.
    for (unsigned s = vertex_count; s-- > (frictionless ? vertex_count - 1 : 0u);) {
      pattern_gram(AA, AR, RR, s, G);
      if (largest.offer(G)) choice = static_cast<int>(c | (s << n));
    }
  }
  return largest.value();
}

// The same with a full T, which D does not commute with: X = T (A D + R) T⁻¹ = (Ã D + R̃) T⁻¹ with Ã = T A and
// R̃ = T R, so XᵀX = T⁻ᵀ G T⁻¹ with G the Gram matrix of Ã D + R̃ (the same O(n²) per pattern). Every pattern is
// offered: the envelope needs D at the end of the product.
double similarity_lipschitz_maximum(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds,
                                    const Eigen::MatrixXd& T, int& choice) {
  const int n = model.dof();
  const unsigned vertex_count = 1u << n;
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  const Eigen::LLT<Eigen::MatrixXd> llt = factor_inertia(model, q);
  const Eigen::MatrixXd T_inverse = T.inverse();
  const Eigen::MatrixXd R = T * llt.solve(model.friction);
  const Eigen::MatrixXd RR = R.transpose() * R;
  LargestSingularValue largest(n);
  Eigen::MatrixXd A(n, n), AA(n, n), AR(n, n), G(n, n);
  for (unsigned c = model.friction.isZero(0.0) ? vertex_count / 2 : 0u; c < vertex_count; ++c) {
    A = T * llt.solve(coriolis_jacobian(N, vertex(velocity_bounds, c)));
    AA.noalias() = A.transpose() * A;
    AR.noalias() = A.transpose() * R;
    for (unsigned s = vertex_count; s-- > 0u;) {
      pattern_gram(AA, AR, RR, s, G);
      if (largest.offer(T_inverse.transpose() * G * T_inverse)) choice = static_cast<int>(c | (s << n));
    }
  }
  return largest.value();
}

bool is_diagonal(const Eigen::MatrixXd& S) { return S.isDiagonal(0.0); }

double joint_lipschitz_maximum(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds,
                               const Eigen::MatrixXd& scaling, int& choice) {
  if (scaling.size() == 0)
    return diagonal_lipschitz_maximum(model, q, velocity_bounds, Eigen::VectorXd::Ones(model.dof()), choice);
  if (is_diagonal(scaling)) return diagonal_lipschitz_maximum(model, q, velocity_bounds, scaling.diagonal(), choice);
  return similarity_lipschitz_maximum(model, q, velocity_bounds, scaling, choice);
}

// The search of L_joint (scaling empty) or of L_T, with the maximising vertex and pattern.
BoundMaximum lipschitz_search(const Model& model, const Eigen::VectorXd& velocity_bounds, const Eigen::MatrixXd& scaling,
                              const BoundOptions& options) {
  const int n = model.dof();
  const unsigned vertex_count = 1u << n;
  BoundProblem lj;
  lj.name = scaling.size() == 0 ? "L_joint" : "L_T";
  lj.all_choices = [&](const Eigen::VectorXd& q, int& choice) {
    return joint_lipschitz_maximum(model, q, velocity_bounds, scaling, choice);
  };
  lj.one_choice = [&](const Eigen::VectorXd& q, int choice) {
    const auto c = static_cast<unsigned>(choice);
    return joint_lipschitz_norm(model, q, vertex(velocity_bounds, c & (vertex_count - 1)), pattern(n, c >> n), scaling);
  };
  BoundMaximum result = search(model, lj, options);
  int choice = 0;
  lj.all_choices(result.q, choice);
  const auto c = static_cast<unsigned>(choice);
  result.velocity_vertex = vertex(velocity_bounds, c & (vertex_count - 1));
  result.saturation_pattern = pattern(n, c >> n);
  return result;
}

// ||T Φ T⁻¹||.
double similar_norm(const Eigen::MatrixXd& T, const Eigen::MatrixXd& Phi) {
  return is_diagonal(T) ? spectral_norm(T.diagonal().asDiagonal() * Phi * T.diagonal().cwiseInverse().asDiagonal())
                        : spectral_norm(T * Phi * T.inverse());
}

// The T that minimises the maximum of ||T Φ T⁻¹|| over the configurations, every vertex and pattern at each (full, or
// diagonal): T is chosen on the maximising matrices found so far, and each configuration's maximising choice under
// that T joins them, until none beats the maximum T was chosen on.
Eigen::MatrixXd scaling_on(const Model& model, const Eigen::VectorXd& V, const std::vector<Eigen::VectorXd>& configurations,
                           const BoundOptions& options, double& chosen_on) {
  const int n = model.dof();
  const bool full = n <= options.full_scaling_max_dof;
  std::vector<Eigen::MatrixXd> matrices;
  Eigen::MatrixXd T = Eigen::MatrixXd::Identity(n, n);
  for (int iteration = 0; iteration < 20; ++iteration) {  // two to five on the arms measured; 20 bounds the work
    bool added = false;
    for (const Eigen::VectorXd& q : configurations) {
      int choice = 0;
      const double value = joint_lipschitz_maximum(model, q, V, T, choice);
      if (matrices.empty() || value > chosen_on * (1.0 + 1e-9)) {
        const auto c = static_cast<unsigned>(choice);  // vertex in the low n bits, pattern in the next n
        matrices.push_back(perturbation_matrix(model, q, vertex(V, c & ((1u << n) - 1)), pattern(n, c >> n)));
        added = true;
      }
      chosen_on = std::max(chosen_on, value);
    }
    if (!added) break;
    T = full ? best_similarity(matrices, options.full_scaling_max_condition)
             : Eigen::MatrixXd(best_diagonal_scaling(matrices, options.scaling_slack).asDiagonal());
    chosen_on = 0.0;
    for (const Eigen::MatrixXd& Phi : matrices) chosen_on = std::max(chosen_on, similar_norm(T, Phi));
  }
  return T;
}

// Similarity scaling: T from the worst configurations known (the three searches' maximisers), then L_T searched; its
// maximiser joins them and T is chosen again, until L_T's search finds nothing above what T was chosen on. Kept
// when L_T is scaling_min_gain below L_joint. Every T gives L_T >= the maximum over those configurations, and T
// minimises that maximum (globally: a quasi-convex problem in W = TᵀT, or convex in log T): once it is not below the
// threshold, no T is.
void choose_scaling(const Model& model, BoundReport& report, const BoundOptions& options) {
  const Eigen::VectorXd& V = report.velocity_bounds;
  std::vector<Eigen::VectorXd> worst{report.L_joint.q, report.M0.q, report.B.q};
  const double keep = (1.0 - options.scaling_min_gain) * report.L_joint.value;
  for (int round = 0; round < options.scaling_rounds; ++round) {
    double chosen_on = 0.0;
    const Eigen::MatrixXd T = scaling_on(model, V, worst, options, chosen_on);
    if (chosen_on >= keep) return;
    const BoundMaximum L = lipschitz_search(model, V, T, options);
    if (L.value < keep && (!report.scaled() || L.value < report.L_scaled.value)) {
      report.scaling = T;
      report.L_scaled = L;
    }
    if (L.value <= chosen_on * (1.0 + 1e-3)) return;
    worst.push_back(L.q);
  }
}

}  // namespace

Eigen::MatrixXd box_vertices(const Eigen::VectorXd& velocity_bounds) {
  const auto n = velocity_bounds.size();
  Eigen::MatrixXd vertices(n, 1 << n);
  for (unsigned c = 0; c < (1u << n); ++c) vertices.col(c) = vertex(velocity_bounds, c);
  return vertices;
}

double inverse_inertia_norm(const Model& model, const Eigen::VectorXd& q) {
  Eigen::MatrixXd M;
  return 1.0 / inertia_eigenvalues(model, q, M)(0);
}

double coriolis_jacobian_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& w) {
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  return spectral_norm(coriolis_jacobian(N, w));
}

double joint_lipschitz_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& w,
                            const Eigen::VectorXd& saturation_pattern, const Eigen::MatrixXd& scaling) {
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  const Eigen::MatrixXd X = coriolis_jacobian(N, w) * saturation_pattern.asDiagonal() + model.friction;
  const Eigen::MatrixXd Phi = factor_inertia(model, q).solve(X);
  return scaling.size() == 0 ? spectral_norm(Phi) : similar_norm(scaling, Phi);
}

double max_coriolis_jacobian_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds) {
  int choice = 0;
  return coriolis_jacobian_maximum(model, q, velocity_bounds, choice);
}

double max_joint_lipschitz_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds,
                                const Eigen::MatrixXd& scaling) {
  int choice = 0;
  return joint_lipschitz_maximum(model, q, velocity_bounds, scaling, choice);
}

namespace {

// A basis of the metrics W searched: every symmetric n x n matrix (ones at one entry of the lower triangle, packed row
// by row, and at its mirror) or every diagonal one (a one on the diagonal).
std::vector<Eigen::MatrixXd> metric_basis(int n, bool diagonal) {
  std::vector<Eigen::MatrixXd> units;
  for (int i = 0; i < n; ++i)
    for (int j = diagonal ? i : 0; j <= i; ++j) {
      Eigen::MatrixXd E = Eigen::MatrixXd::Zero(n, n);
      E(i, j) = E(j, i) = 1.0;
      units.push_back(std::move(E));
    }
  return units;
}

// Some W in the span of the units with I ≼ W ≼ κ I and Φ̂ᵀ W Φ̂ ≺ W for every Φ̂ given (empty when the solver finds
// none): minimise τ over Φ̂ᵀ W Φ̂ - W ≼ τ I, stopped at the first iterate with τ < 0 that every block confirms in double.
Eigen::MatrixXd contracting_metric(const std::vector<Eigen::MatrixXd>& matrices, const std::vector<Eigen::MatrixXd>& units,
                                   double kappa) {
  const auto n = static_cast<int>(matrices.front().rows());
  const auto p = static_cast<int>(units.size());
  const auto W_of = [&](const Eigen::VectorXd& y) {
    Eigen::MatrixXd W = Eigen::MatrixXd::Zero(n, n);
    for (int k = 0; k < p; ++k) W += y(k) * units[static_cast<std::size_t>(k)];
    return W;
  };
  std::vector<LinearMatrixInequality> blocks;
  for (const Eigen::MatrixXd& Phi : matrices) {
    LinearMatrixInequality lmi{n, packed(Eigen::MatrixXd::Zero(n, n)), {}};
    for (int k = 0; k < p; ++k) {
      const Eigen::MatrixXd& E = units[static_cast<std::size_t>(k)];
      lmi.terms.emplace_back(k, packed(Phi.transpose() * E * Phi - E));
    }
    lmi.terms.emplace_back(p, packed(-Eigen::MatrixXd::Identity(n, n)));
    blocks.push_back(std::move(lmi));
  }
  LinearMatrixInequality below{n, packed(Eigen::MatrixXd::Identity(n, n)), {}}, above{n, packed(-kappa * Eigen::MatrixXd::Identity(n, n)), {}};
  for (int k = 0; k < p; ++k) {
    below.terms.emplace_back(k, packed(-units[static_cast<std::size_t>(k)]));
    above.terms.emplace_back(k, packed(units[static_cast<std::size_t>(k)]));
  }
  blocks.push_back(std::move(below));
  blocks.push_back(std::move(above));
  // A strictly feasible start: W = √κ I, τ above every block's largest eigenvalue.
  const double c = std::sqrt(kappa);
  double tau = 0.0;
  for (const Eigen::MatrixXd& Phi : matrices) tau = std::max(tau, c * (spectral_norm(Phi) * spectral_norm(Phi) - 1.0));
  SdpOptions o;
  o.start = Eigen::VectorXd::Zero(p + 1);
  for (int k = 0; k < p; ++k) o.start(k) = units[static_cast<std::size_t>(k)].trace() > 0.0 ? c : 0.0;
  o.start(p) = tau + 1.0;
  const auto confirmed = [&](const Eigen::VectorXd& y) {
    if (!(y(p) < 0.0)) return false;
    for (const LinearMatrixInequality& lmi : blocks)
      if (symmetric_eigenvalues(evaluate(lmi, y)).maxCoeff() >= 0.0) return false;
    return true;
  };
  o.enough = confirmed;
  const SdpResult r = solve_sdp(p + 1, blocks, [&] {
    Eigen::VectorXd objective = Eigen::VectorXd::Zero(p + 1);
    objective(p) = -1.0;
    return objective;
  }(), o);
  return confirmed(r.y) ? W_of(r.y) : Eigen::MatrixXd();
}

// The bisection both searches below share: the least parameter in (low, high] at which `metric` finds a W (none is
// assumed at low, one at high), until `resolved(low, high)` or 60 halvings. `W` becomes the last W found.
template <typename Metric, typename Resolved>
double least_feasible(double low, double high, const Metric& metric, const Resolved& resolved, Eigen::MatrixXd& W) {
  for (int step = 0; step < 60 && !resolved(low, high); ++step) {
    const double middle = 0.5 * (low + high);
    Eigen::MatrixXd found = metric(middle);
    if (found.size() == 0) {
      low = middle;
    } else {
      high = middle;
      W = std::move(found);
    }
  }
  return high;
}

// The smallest t (to the relative resolution given) for which some W of the units' span with I ≼ W ≼ κ I has
// ||W^½ Φ W^-½|| < t for every Φ, and that W: T = I gives max ||Φ||, so a bisection on t below it, on Φ / t.
Eigen::MatrixXd smallest_contraction(const std::vector<Eigen::MatrixXd>& matrices, const std::vector<Eigen::MatrixXd>& units,
                                     double kappa, double resolution, double& t_best) {
  const auto n = matrices.front().rows();
  double largest = 0.0;
  for (const Eigen::MatrixXd& Phi : matrices) largest = std::max(largest, spectral_norm(Phi));
  Eigen::MatrixXd best_W = Eigen::MatrixXd::Identity(n, n);
  std::vector<Eigen::MatrixXd> scaled(matrices.size());
  const auto metric = [&](double t) {
    for (std::size_t i = 0; i < matrices.size(); ++i) scaled[i] = matrices[i] / t;
    return contracting_metric(scaled, units, kappa);
  };
  t_best = least_feasible(0.0, largest, metric, [&](double low, double high) { return high - low <= resolution * high; },
                          best_W);
  return best_W;
}

// cond(T) of a diagonal T at most 10³ (a factor 10⁶ in W); the minimum and the smallest cond within the slack, each
// to a relative 1e-6.
constexpr double kDiagonalMaxCondition = 1e3;
constexpr double kDiagonalResolution = 1e-6;

}  // namespace

Eigen::VectorXd best_diagonal_scaling(const std::vector<Eigen::MatrixXd>& matrices, double slack) {
  const auto n = static_cast<int>(matrices.front().rows());
  const std::vector<Eigen::MatrixXd> units = metric_basis(n, true);
  const double kappa = kDiagonalMaxCondition * kDiagonalMaxCondition;
  double t_best = 0.0;
  Eigen::MatrixXd W = smallest_contraction(matrices, units, kappa, kDiagonalResolution, t_best);
  if (slack > 0.0) {
    // The minimum is flat along the joints that matter little: within the slack, the smallest cond(W) = κ
    // (docs/theory.md, "Similarity scaling"), by a bisection on log κ at t = (1 + slack) t_best.
    const double limit = t_best * (1.0 + slack);
    std::vector<Eigen::MatrixXd> scaled(matrices.size());
    for (std::size_t i = 0; i < matrices.size(); ++i) scaled[i] = matrices[i] / limit;
    least_feasible(
        0.0, std::log(kappa), [&](double log_kappa) { return contracting_metric(scaled, units, std::exp(log_kappa)); },
        [](double low, double high) { return high - low <= kDiagonalResolution; }, W);
  }
  const Eigen::VectorXd w = W.diagonal();
  return (w / w(0)).cwiseSqrt();
}

Eigen::MatrixXd best_similarity(const std::vector<Eigen::MatrixXd>& matrices, double max_condition) {
  const auto n = static_cast<int>(matrices.front().rows());
  double t_best = 0.0;
  const Eigen::MatrixXd W =
      smallest_contraction(matrices, metric_basis(n, false), max_condition * max_condition, 1e-4, t_best);
  // W = TᵀT with T upper triangular (Cholesky), normalised to T(0, 0) = 1.
  const Eigen::MatrixXd T = Eigen::LLT<Eigen::MatrixXd>(W).matrixU();
  return T / T(0, 0);
}

std::optional<double> excess_per_doubling(const BoundBracket& bracket) {
  if (bracket.stop == SearchStop::gap || !(bracket.work > 0.0)) return std::nullopt;
  const UpperAtWork* half = nullptr;
  for (const UpperAtWork& point : bracket.trace)
    if (point.work <= 0.5 * bracket.work) half = &point;
  if (!half) return std::nullopt;
  const double before = half->upper - bracket.lower, after = bracket.upper - bracket.lower;
  if (!(before > 0.0) || !std::isfinite(before) || !(after >= 0.0)) return std::nullopt;
  return std::pow(after / before, 1.0 / std::log2(bracket.work / half->work));
}

BoundReport compute_bounds(const Model& model, const Eigen::VectorXd& velocity_bounds, const BoundOptions& options) {
  validate_velocity_bounds(model, velocity_bounds);
  const auto start = std::chrono::steady_clock::now();
  const int n = model.dof();

  BoundReport report;
  report.velocity_bounds = velocity_bounds;
  report.F_norm = spectral_norm(model.friction);

  BoundProblem m0;
  m0.name = "M0";
  m0.all_choices = [&](const Eigen::VectorXd& q, int& choice) {
    choice = 0;
    return inverse_inertia_norm(model, q);
  };
  m0.one_choice = [&](const Eigen::VectorXd& q, int) { return inverse_inertia_norm(model, q); };
  report.M0 = search(model, m0, options);

  BoundProblem b;
  b.name = "B";
  b.all_choices = [&](const Eigen::VectorXd& q, int& choice) { return coriolis_jacobian_maximum(model, q, velocity_bounds, choice); };
  b.one_choice = [&](const Eigen::VectorXd& q, int c) {
    return coriolis_jacobian_norm(model, q, vertex(velocity_bounds, static_cast<unsigned>(c)));
  };
  report.B = search(model, b, options);
  {
    int choice = 0;
    b.all_choices(report.B.q, choice);
    report.B.velocity_vertex = vertex(velocity_bounds, static_cast<unsigned>(choice));
  }

  report.L_joint = lipschitz_search(model, velocity_bounds, {}, options);
  if (options.diagonal_scaling && n > 1 && n <= options.scaling_max_dof) choose_scaling(model, report, options);

  report.L_paper = report.M0.value * (report.B.value + report.F_norm);
  report.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace obsgain
