#include "obsgain/bounds/box_bounds.hpp"

#include "obsgain/bounds/box_forms.hpp"
#include "obsgain/bounds/inertia_floor.hpp"
#include "obsgain/bounds/taylor_matrix.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace obsgain {

namespace {

// J_j = ∂A/∂v at v = e_j as forms, (J_j)_ik = 2 N_i[j][k]: J(q, w) = Σ_j w_j J_j (docs/theory.md, "The constants").
std::vector<Taylor> unit_jacobian(const BoxForms& d, int j) {
  const int n = d.n;
  std::vector<Taylor> J(static_cast<std::size_t>(n * n));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) J[i * n + k] = 2.0 * d.N[(i * n + j) * n + k];
  return J;
}

// Split where splitting removes most of the bound's excess: each side's first- and second-order variation
// ||G_k||_F + Σ_l ||H_kl||_F (a side along which X is stationary at the centre has no first-order variation, and
// still a curvature), and its share of the third-order remainder: mostly by how much of M's variation comes from it
// (a side M does not depend on adds nothing), a tenth by its width (so that a wide side whose trigonometric
// enclosure went constant is split in the end). The largest over the choices.
void weigh_sides(const TaylorMatrix& X, const BoxForms& d, std::vector<double>& weights) {
  weights.resize(d.sides.size(), 0.0);
  double widths = 0.0, sensitivity = 0.0;
  for (std::size_t k = 0; k < d.sides.size(); ++k) {
    widths += d.sides[k].radius;
    sensitivity += d.sensitivity[k];
  }
  const auto pairs = symbol_pairs(X.symbols());
  std::vector<double> variation(d.sides.size(), 0.0);  // of each side, over its symbols
  // Symbols beyond the box's (velocity components carried as symbols) belong to no side.
  const auto side = [&](int symbol) { return symbol < d.symbols ? d.side_of[static_cast<std::size_t>(symbol)] : -1; };
  for (int k = 0; k < X.symbols(); ++k)
    if (side(k) >= 0) variation[side(k)] += X.slope(k).norm();
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const double h = X.curvature(static_cast<int>(p)).norm();
    const int first = side(pairs[p].first), second = side(pairs[p].second);
    if (first >= 0) variation[first] += h;
    if (second >= 0 && second != first) variation[second] += h;
  }
  for (std::size_t k = 0; k < d.sides.size(); ++k) {
    const double radius = d.sides[k].radius;
    const double share = 0.1 * radius / widths + (sensitivity > 0.0 ? 0.9 * d.sensitivity[k] / sensitivity : 0.9 * radius / widths);
    weights[k] = std::max(weights[k], variation[k] + X.remainder * share);
  }
}

// A proven lower bound of λmin(M) over the box (the model's inertia floor, bounds/inertia_floor.hpp, where that is
// higher).
double inertia_lower(const TaylorMatrix& M, double floor, const BoxForms& d, std::vector<double>& weights) {
  weigh_sides(M, d, weights);
  return std::max(smallest_eigenvalue_lower(M), floor);
}

// Where M⁻¹ cannot be enclosed (a box too wide for the Neumann series): ||M⁻¹(J D + F)|| <= (||J|| + ||F||) / λmin(M),
// finite once M is proven positive definite on the box (`friction`: ||F|| rounded up; `vertices`: the velocity
// vertices to take, J's combinations).
BoxBound lipschitz_by_inertia_floor(const TaylorMatrix& M, double floor, const std::vector<TaylorMatrix>& J,
                                    double friction, const BoxForms& d, const Eigen::MatrixXd& vertices) {
  BoxBound bound{kInfinity, {}};
  const double lambda = inertia_lower(M, floor, d, bound.split_weight);
  if (!(lambda > 0.0)) return bound;
  const double J_norm = largest_combination_frobenius_upper(J, vertices);
  bound.upper = ((Interval(J_norm) + Interval(friction)) / Interval(lambda)).upper();
  return bound;
}

// diag(rows) X diag(columns), entry by entry as forms (each product's rounding in the form).
std::vector<Taylor> scaled_forms(const std::vector<Taylor>& X, const Eigen::VectorXd& rows, const Eigen::VectorXd& columns) {
  const Eigen::Index n = rows.size();
  std::vector<Taylor> Y(X.size());
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 0; k < n; ++k) Y[i * n + k] = rows(i) * (columns(k) * X[i * n + k]);
  return Y;
}

// max_k a_k b_k, rounded up.
double largest_product(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  double largest = 0.0;
  for (Eigen::Index k = 0; k < a.size(); ++k) largest = std::max(largest, (Interval(a(k)) * Interval(b(k))).upper());
  return largest;
}

// The route of the inertia floor through G (bounds/box_bounds.hpp, FloorRoute); `J`: the unit Jacobians' forms
// unscaled.
BoxBound route_through(const Model& model, const FloorRoute& route, const BoxForms& d, const std::vector<TaylorMatrix>& J,
                       const Eigen::MatrixXd& vertices) {
  const bool plain = route.g.isOnes(0.0);
  std::vector<TaylorMatrix> scaled_J;
  if (!plain)
    for (int j = 0; j < d.n; ++j)
      scaled_J.push_back(taylor_matrix(scaled_forms(unit_jacobian(d, j), route.g, route.g).data(), d.n, d.n, d.symbols));
  const TaylorMatrix M = plain ? taylor_matrix(d.M.data(), d.n, d.n, d.symbols)
                               : taylor_matrix(scaled_forms(d.M, route.g, route.g).data(), d.n, d.n, d.symbols);
  const double friction =
      (Interval(spectral_norm_upper(model.friction)) * Interval(route.g.maxCoeff()) * Interval(route.g.maxCoeff())).upper();
  BoxBound bound = lipschitz_by_inertia_floor(M, route.floor, plain ? J : scaled_J, friction, d, vertices);
  if (!plain || !route.t.isOnes(0.0) || route.factor != 1.0)
    bound.upper = (Interval(bound.upper) * Interval(largest_product(route.t, route.g)) * Interval(route.factor)).upper();
  return bound;
}

// A value the inertia floor's route cannot go below on this box. Its λ is at most max(λmin(C_M), floor), C_M M's
// centre (its forms' value at ε = 0): a lower bound proven over the forms is at most their value there. Its
// bound of ||J(w)|| is Σ_j |w_j| r_j plus, over J's parts P (centre, slopes, curvatures), Σ_P ||Σ_j w_j P_j||_F, at
// its largest over the velocity vertices `W`: at least the centre's term alone, and at least its mean over the
// vertices, a Rademacher sum whose mean norm is at least 1/√2 of its root mean square (the Khintchine–Kahane
// inequality with Latała and Oleszkiewicz's constant), sqrt(Σ_j V_j² ||P_j||_F²). Where this is above a bound already
// proven, the route could not win and is not taken (docs/theory.md, "M⁻¹ over a box"). Through G: of G M G and
// G J G, times the route's factors. A choice of work, not a bound: computed in floating point, G's products as
// diagonal scalings (a dense G cost a heap product per part and joint: 4 % of a search on the Jaco2).
double route_at_least(const FloorRoute& route, const BoxForms& d, const std::vector<TaylorMatrix>& J,
                      const Eigen::VectorXd& V, const Eigen::MatrixXd& W) {
  const auto G = route.g.asDiagonal();
  Eigen::MatrixXd centre(d.n, d.n);
  for (int i = 0; i < d.n; ++i)
    for (int k = 0; k < d.n; ++k) centre(i, k) = 0.5 * (d.M[i * d.n + k].c + d.M[k * d.n + i].c);
  const double lambda =
      std::max(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(G * centre * G, Eigen::EigenvaluesOnly).eigenvalues()(0), route.floor);
  if (!(lambda > 0.0)) return kInfinity;
  Eigen::MatrixXd C(d.n * d.n, d.n);
  double remainders = 0.0;
  for (int j = 0; j < d.n; ++j) {
    C.col(j) = (G * J[j].centre() * G).reshaped();
    remainders += V(j) * J[j].remainder * route.g.maxCoeff() * route.g.maxCoeff();
  }
  const Eigen::MatrixXd gram = C.transpose() * C;
  const double centres = std::sqrt((gram * W).cwiseProduct(W).colwise().sum().maxCoeff());
  double means = 0.0;
  for (int t = 0; t < J[0].parts(); ++t) {
    double squares = 0.0;
    for (int j = 0; j < d.n; ++j) squares += V(j) * V(j) * (G * J[j].part(t) * G).squaredNorm();
    means += std::sqrt(0.5 * squares);
  }
  return (remainders + std::max(centres, means)) / lambda * route.t.cwiseProduct(route.g).maxCoeff() * route.factor;
}

// The routes a bound takes (bounds/box_bounds.hpp, FloorRoute): L_joint ||Φ||'s; L_T ||Φ||'s times the stretch, and
// for a diagonal T also through G = S = Y. (Through G = diag(a)^(-1/2) L_joint's route is lower on wide boxes, but
// the search then ends higher: docs/theory.md, "M⁻¹ over a box".)
std::vector<FloorRoute> floor_routes(const Model& model, double floor, const std::optional<Similarity>& scaling) {
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(model.dof());
  std::vector<FloorRoute> routes{{ones, ones, floor, scaling ? scaling->stretch : 1.0}};
  if (scaling && scaling->diagonal) {
    const Eigen::VectorXd t = scaling->rows.diagonal(), s = scaling->columns.diagonal();
    routes.push_back({s, t, similar_inertia_floor(model, floor, s)});
  }
  return routes;
}

// Column norms of A D + R term by term (the centre, each symbol's slope, each pair's curvature), with A's column j
// kept (d_j = 1) or dropped (d_j = 0): for any pattern, the centre's Frobenius norm and the variation
// Σ ||slope||_F + Σ ||curvature||_F + remainders over the box, without forming A D + R.
class PatternColumns {
 public:
  PatternColumns(const TaylorMatrix& A, const TaylorMatrix& R) : remainder_(A.remainder + R.remainder) {
    on_.resize(A.parts(), A.cols());
    off_.resize(A.parts(), A.cols());
    for (int t = 0; t < A.parts(); ++t) {
      on_.row(t) = (A.part(t) + R.part(t)).colwise().norm();
      off_.row(t) = R.part(t).colwise().norm();
    }
  }
  // Pattern `bits` (bit j: d_j = 1): the centre's Frobenius norm, and the variation. Each a sum of norms rounded up
  // (relative errors of a few ulps per norm, covered by the inflation).
  struct Sizes {
    double centre, variation;
  };
  Sizes pattern(unsigned bits) const {
    const Eigen::MatrixXd c = chosen(bits);
    return {up(c.row(0).norm()), up(c.bottomRows(c.rows() - 1).rowwise().norm().sum() + remainder_)};
  }

 private:
  Eigen::MatrixXd chosen(unsigned bits) const {
    Eigen::MatrixXd c = off_;
    for (Eigen::Index j = 0; j < on_.cols(); ++j)
      if ((bits >> j) & 1u) c.col(j) = on_.col(j);
    return c;
  }
  static double up(double x) { return (x * (1.0 + 0x1p-40)) * kTaylorInflation + kTaylorUnderflow; }
  Eigen::MatrixXd on_, off_;
  double remainder_;
};

// True when ||C||₂ <= t is proven from G, the Gram matrix CᵀC formed in floating point from terms of total size
// `magnitude` (Σ of their Frobenius norms, squared): a floating-point Cholesky factorisation of (t² - μ) I - G
// completes, with μ = 10⁻¹⁰ (t² + magnitude) far above the rounding of G and of the factorisation
// (docs/theory.md, "Cheap bounds of the choices").
bool centre_norm_below(const Eigen::MatrixXd& G, double t, double magnitude) {
  if (!(t > 0.0) || !std::isfinite(t) || !G.allFinite()) return false;
  const double mu = 1e-10 * (t * t + magnitude);
  Eigen::MatrixXd B = -G;
  B.diagonal().array() += t * t - mu;
  return Eigen::LLT<Eigen::MatrixXd>(B).info() == Eigen::Success;
}

// One choice of velocity vertex and saturation pattern (bit j: d_j = 1): its cheap (Frobenius) bound and the part of
// it that is the variation over the box.
struct Choice {
  double cheap, variation;
  unsigned vertex, bits;
};

// The largest bound over the choices, refined in decreasing order of their cheap bounds: once the next cheap bound
// cannot beat the best refined one (or the value attained elsewhere, `lower`), neither can any after it.
// `refine(choice, floor)` returns an upper bound of the choice's supremum, or `floor` when it is proven not above it.
// `refined` counts the refinements.
template <class Refine>
double refine_choices(std::vector<Choice>& choices, double lower, const Refine& refine, int& refined) {
  std::stable_sort(choices.begin(), choices.end(), [](const Choice& x, const Choice& y) { return x.cheap > y.cheap; });
  double best = 0.0;
  for (const Choice& choice : choices) {
    if (choice.cheap <= std::max(best, lower)) return std::max(best, choice.cheap);
    best = std::max(best, refine(choice, std::max(best, lower)));
    ++refined;
  }
  return best;
}

}  // namespace

std::vector<TaylorMatrix> unit_jacobians(const BoxForms& d) {
  std::vector<TaylorMatrix> J;
  for (int j = 0; j < d.n; ++j) J.push_back(taylor_matrix(unit_jacobian(d, j).data(), d.n, d.n, d.symbols));
  return J;
}

CountedModel counted_model(const Model& model) {
  CountedModel counted{.frictionless = model.friction.isZero(0.0)};
  const auto* chain = std::get_if<SerialChain>(&model.structure);
  if (!chain || chain->bodies.empty()) return counted;
  int offsets = 0;
  for (const RigidBody& body : chain->bodies) offsets += static_cast<int>((body.com.array() != 0.0).count());
  counted.centre_offsets = static_cast<double>(offsets) / (3.0 * static_cast<double>(chain->bodies.size()));
  return counted;
}

BoxCosts box_costs(int n, int symbols, const CountedModel& model) {
  // Seconds on the reference machine, the suite's (two cores): each step timed there on one core, per box, on
  // examples/arm6.urdf, arm7.urdf, iiwa14.urdf and the UR5 with armature, and halved for the two cores (the inertia
  // floor's route refitted in the seventh round of issue 18, after it became faster, the products scaled in the
  // eighth by how much faster they then became against the seventh's code on one machine, the
  // vertex step in the eleventh by 0.85 (its time against the tenth's code at the same boxes on one machine: 0.79-0.84
  // on arm6, arm7 and the iiwa, 0.86-0.90 on the Panda), the Gram bound in the sixteenth and E²'s cubic terms in the
  // seventeenth on random forms of 2-7 rows and 2-12 symbols, scaled by the time of a box there against its count
  // (1.9); the inertia step is an older fit's). The count ran a quarter ahead of that until the forty-fifth round,
  // which found a vertex's fine bounds taking about twice their count inside real searches: it now charges them what
  // they take and runs an eighth ahead, so that arm7's box costs what it did and every step of a box is counted alike
  // (docs/theory.md, "The budget"). `terms`: a Taylor matrix's n x n parts (centre, slopes, curvatures).
  constexpr double ahead = 1.125;
  const double n1 = n, n2 = n1 * n1, n3 = n2 * n1, s = symbols, terms = 1.0 + s + pair_count(symbols);
  const double vertices = std::ldexp(1.0, model.frictionless ? n - 1 : n);
  const double gram = ahead * (0.27e-6 + 0.057e-9 * n2 * terms * terms);
  const double refinement = ahead * (0.86e-6 + 3.45e-9 * n2 * terms);
  // E²'s cubic terms monomial by monomial: s pair_count(s) n³ multiplications, twice, and s pair_count(s) sums.
  const double sp = s * pair_count(symbols), cubic = ahead * (0.33e-6 + 0.192e-9 * sp * n3 + 12.6e-9 * sp);
  // The forms, on third-order forms since the thirtieth round: fitted to their timings on one core (arm3, arm6, the UR5
  // with armature, arm7, the iiwa, the Panda and the Jaco2 with armature, at 2-6 and 4-12 symbols) at 0.85 of them, the
  // second-order forms' count's mean share on arm6: within 18 % of each (the Jaco2's time 17-18 % above its count,
  // arm3's 9-13 % below), 1.25-1.88 times the second-order forms' count on six and seven joints. The structure is the
  // one the twenty-eighth round fitted (docs/history.md).
  const double forms = ahead * n2 * (3.74e-6 + 0.1376e-6 * terms) * (1.0 + 0.2 * model.centre_offsets);
  // The products' fit included two fine norm bounds (of η and ||E K||), which inverse_norm_upper no longer takes.
  const double products = ahead * (14.45e-6 + 14.45e-9 * n2 * n2 * s) + 2.0 * (gram - refinement);
  // Since the forty-first round M⁻¹ [J F] takes J's n(n + 1)/2 distinct columns, and E² half its matrix products: the
  // step, M⁻¹ and the products together, takes 0.79-0.80 of the time it took on six and seven joints. Since the forty-
  // second, K's products take one matrix product on an even n² and M⁻¹'s series skips the eigensolvers of a norm bound
  // it can tell from below will not be the smaller: the step takes 0.81-0.94 of the forty-first's time (a mean of
  // 0.88). A vertex's combination is formed by halves: the vertex step takes 0.50-0.64 of its instructions without
  // friction (where it forms no envelope either) and 0.85-0.92 with it (docs/history.md, the forty-second round).
  // Since the forty-third, M⁻¹'s series and M⁻¹ [J F] stay Taylor matrices, without forms between the products, and
  // [J F] is gathered from the J_j: the step takes 0.827-0.906 of its instructions (a mean of 0.87) on the UR5 with
  // armature, arm7 and the iiwa. A failed M⁻¹ stops before E² and the products.
  constexpr double symmetric_products = 0.8 * 0.88 * 0.87;
  // Since the forty-fifth round the choices' steps are timed inside real searches, apart from the rest of each box
  // (docs/theory.md, "The budget"): a vertex's combination and envelope at 0.69 of the vertex fit without friction and
  // 1.33 with it; its centre's test and fine bound at 2.1 times what they were charged (a choice, the variation's norm,
  // a refinement of an n x n matrix, or two of an envelope's 2n x n) without friction and 1.7 times with it; a pattern's
  // steps at 1.46 times. The variation's norm (variation_norm_upper) costs 0.047 of a fine bound: the mean of twelve
  // ratios, 0.020-0.064, on random Taylor matrices of n = 6 and 7, 6-14 rows and 4-12 symbols (docs/history.md, the
  // forty-fourth round).
  const double vertex_time = model.frictionless ? 0.69 : 1.33, fine_time = model.frictionless ? 2.1 : 1.7;
  const double envelope = model.frictionless ? 1.0 : 2.0;  // with friction a vertex's bound is its envelope's, 2n x n
  constexpr double variation_share = 0.047, pattern_time = 1.46;
  const double choice = ahead * (0.026e-6 + 2.45e-9 * n1 * terms);
  return {.inertia = 0.75e-6 * n3,
          .forms = forms,
          .products = symmetric_products * (products + cubic),
          .failed_inverse = 0.3 * products,
          .vertex = vertex_time * ahead * (0.33e-6 + 2.3e-9 * n2 * terms),
          .refinement = refinement,
          .gram = gram,
          .choice = choice,
          .vertex_test = fine_time * (choice + variation_share * envelope * refinement),
          .vertex_refinement = fine_time * envelope * refinement,
          .pattern = pattern_time * choice,
          .pattern_refinement = pattern_time * refinement,
          .point = ahead * (1.9e-6 + 2.8e-9 * vertices * n3),
          .jacobian_vertex = ahead * (0.36e-6 + 1.73e-9 * n2 * terms),
          .inertia_route = ahead * terms * (0.094e-6 + 0.27e-9 * n2 * (n2 + std::ldexp(1.0, n - 1)))};
}

Similarity similarity(const Eigen::MatrixXd& T) {
  const UpwardRounding upward;
  Similarity s;
  s.rows = T;
  s.diagonal = T.isDiagonal(0.0);
  if (s.diagonal) {
    const Eigen::VectorXd t = T.diagonal(), inverse = t.cwiseInverse();
    s.columns = inverse.asDiagonal();
    s.restore = 0.0;
    for (Eigen::Index k = 0; k < t.size(); ++k)
      s.restore = std::max(s.restore, (Interval(1.0) / (Interval(inverse(k)) * Interval(t(k)))).upper());
    s.stretch = (Interval(t.maxCoeff()) * Interval(inverse.maxCoeff())).upper();
    return s;
  }
  s.columns = T.inverse();
  // ||T Y - I|| <= its Frobenius norm, formed in interval arithmetic; (T Y)⁻¹ by the Neumann series.
  Interval squares(0.0);
  for (Eigen::Index i = 0; i < T.rows(); ++i)
    for (Eigen::Index k = 0; k < T.cols(); ++k) {
      Interval entry(i == k ? -1.0 : 0.0);
      for (Eigen::Index j = 0; j < T.cols(); ++j) entry += Interval(T(i, j)) * Interval(s.columns(j, k));
      squares += boost::numeric::square(entry);
    }
  const Interval delta = boost::numeric::sqrt(squares);
  s.restore = delta.upper() < 0.5 ? (Interval(1.0) / (Interval(1.0) - delta)).upper() : kInfinity;
  s.stretch = (Interval(spectral_norm_upper(T)) * Interval(spectral_norm_upper(s.columns))).upper();
  return s;
}

BoxBounds::BoxBounds(const Model& model, const JointSearch& search, const Eigen::VectorXd& velocity_bounds,
                     const Eigen::MatrixXd& scaling)
    : model_(model), search_(search), velocity_bounds_(velocity_bounds), vertices_(box_vertices(velocity_bounds)),
      count_(static_cast<unsigned>(vertices_.cols())), half_(count_ / 2), counted_(counted_model(model)),
      inertia_floor_(inertia_floor(model)) {
  if (scaling.size()) scaling_ = similarity(scaling);
  routes_ = floor_routes(model, inertia_floor_, scaling_);
}

double BoxBounds::value_work() const { return box_costs(model_.dof(), 0, counted_).point; }

BoxBound BoxBounds::inverse_inertia(const std::vector<Interval>& box) const {
  const BoxForms d = box_forms(model_, search_, box, false);
  const BoxCosts costs = box_costs(d.n, d.symbols, counted_);
  BoxBound bound{kInfinity, {}, costs.inertia + costs.refinement};
  const double lambda = inertia_lower(taylor_matrix(d.M.data(), d.n, d.n, d.symbols), inertia_floor_, d, bound.split_weight);
  if (lambda > 0.0) bound.upper = (Interval(1.0) / Interval(lambda)).upper();
  return bound;
}

BoxBound BoxBounds::jacobian(const std::vector<Interval>& box, double lower) const {
  const BoxForms d = box_forms(model_, search_, box, true);
  const std::vector<TaylorMatrix> J = unit_jacobians(d);
  const std::vector<double> J_frobenius = frobenius_uppers(J);
  const BoxCosts costs = box_costs(d.n, d.symbols, counted_);
  BoxBound bound{0.0, {}, costs.forms};
  for (unsigned c = half_; c < count_; ++c) {
    const TaylorMatrix Jw = linear_combination(J, vertices_.col(c), J_frobenius);
    weigh_sides(Jw, d, bound.split_weight);
    const double floor = std::max(bound.upper, lower);
    bound.work += costs.jacobian_vertex + (Jw.frobenius_upper() > floor ? costs.refinement : 0.0);
    bound.upper = std::max(bound.upper, norm_upper(Jw, floor));
  }
  return bound;
}

namespace {

// Φ = M⁻¹(J(w) D + F) = Σ_j w_j A_j D + R over a box, A_j = M⁻¹ J_j and R = M⁻¹ F as Taylor matrices of M⁻¹'s
// second-order part; M⁻¹'s third-order tail T (||T|| <= inverse tail) adds T (J(w) D + F), of norm at most
// tail · sup ||J(w) D + F|| over the box and every choice: `tail`, added once to every choice's bound.
struct LipschitzTerms {
  std::vector<TaylorMatrix> A;
  TaylorMatrix R;
  double tail = 0.0;
  double similar_inputs = 0.0;  // with a diagonal T: sup ||T (J(w) D + F) Y|| over the box and every choice
};

// With a diagonal T: T U X Y = (T U T⁻¹)(T X Y), and ||T U T⁻¹|| <= ||T U Y|| · restore: T stays inside both factors
// (tail_upper), at the price of two norm bounds.
double similar_tail(const LipschitzTerms& t, const TaylorInverse& inverse_M, const Similarity& scaling, int symbols) {
  const double tail = tail_upper(inverse_M, scaling.rows.diagonal(), scaling.columns.diagonal(), symbols);
  return (Interval(tail) * Interval(scaling.restore) * Interval(t.similar_inputs)).upper();
}

// With a diagonal scaling, the terms are T A_j Y and T R Y. With a full one, D does not commute with T: the terms are
// T A_j and T R Y, and each choice's T A(w) D is multiplied by Y on the right (similar_choices_upper). Either way
// the tail's matrix is stretched by at most ||T|| ||Y||; a diagonal T also bounds it as ||T U T⁻¹|| ||T X Y||, which
// does not pay the stretch where M varies in the directions T shrinks (docs/theory.md, "Similarity scaling").
LipschitzTerms lipschitz_terms(const Model& model, const BoxForms& d, const std::vector<TaylorMatrix>& J,
                               const Eigen::VectorXd& velocity_bounds, const TaylorInverse& inverse_M,
                               const Similarity* scaling = nullptr) {
  LipschitzTerms t;
  const bool diagonal = scaling && scaling->diagonal;
  const int n = d.n, blocks = n + 1;
  std::vector<Taylor> F(static_cast<std::size_t>(n * n));
  for (int i = 0; i < n * n; ++i) F[i] = Taylor(model.friction(i / n, i % n));
  const TaylorMatrix friction = taylor_matrix(F.data(), n, n, d.symbols);
  // M⁻¹ [J_1 ... J_n F] in one product: its coefficients are then matrix products. Column k of J_j is column j of
  // J_k, (J_j)_ik = 2 N_i[j][k], the same forms (box_forms mirrors N), and a product's column depends only on the
  // same column of its right factor: the product takes the columns with j <= k once, n(n + 1)/2 of the n² (and F's n).
  const int unique = n * (n + 1) / 2;
  const auto column = [n, unique](int j, int k) {
    if (j == n) return unique + k;  // F's
    const int low = std::min(j, k), high = std::max(j, k);
    return low * n - low * (low - 1) / 2 + (high - low);
  };
  std::vector<std::pair<const TaylorMatrix*, int>> distinct;
  for (int j = 0; j < n; ++j)
    for (int k = j; k < n; ++k) distinct.emplace_back(&J[static_cast<std::size_t>(j)], k);
  for (int k = 0; k < n; ++k) distinct.emplace_back(&friction, k);
  const TaylorMatrix X = product(inverse_M.entries, gathered_columns(distinct));
  std::vector<std::pair<const TaylorMatrix*, int>> block(static_cast<std::size_t>(n));
  for (int j = 0; j < blocks; ++j) {
    for (int k = 0; k < n; ++k) block[static_cast<std::size_t>(k)] = {&X, column(j, k)};
    TaylorMatrix term = gathered_columns(block);
    if (diagonal) scale_diagonally(term, scaling->rows.diagonal(), scaling->columns.diagonal());
    if (term.symbols() < d.symbols) term = with_symbols(term, d.symbols);
    if (j < n)
      t.A.push_back(std::move(term));
    else
      t.R = std::move(term);
  }
  if (scaling && !diagonal) {
    for (TaylorMatrix& A : t.A) A = sandwiched(scaling->rows, A, {});
    t.R = sandwiched(scaling->rows, t.R, scaling->columns);
  }
  const UpwardRounding upward;
  t.tail = (Interval(inverse_M.tail) * Interval(every_choice_upper(J, velocity_bounds, friction))).upper();
  if (scaling) t.tail = (Interval(t.tail) * Interval(scaling->stretch)).upper();
  if (diagonal)
    t.similar_inputs = every_choice_upper(J, velocity_bounds, friction, scaling->rows.diagonal(), scaling->columns.diagonal());
  return t;
}

// The velocity box, whether F = 0 (then only the full pattern) and what each step costs.
struct VelocityChoices {
  const Eigen::VectorXd& velocity_bounds;
  CountedModel counted;
  BoxCosts costs;
};

// The centre's Gram blocks of one vertex, A = A(w) at the centre and R: (A D + R)ᵀ(A D + R) = D AᵀA D + D AᵀR + RᵀA D + RᵀR
// for every pattern D, with the size of the terms (||A||_F + ||R||_F)².
struct CentreGram {
  Eigen::MatrixXd AA, AR;
  double magnitude;
};

// The patterns of one vertex one by one, A = A(w) over the box: each pattern's cheap bound first; a pattern whose
// cheap bound beats the running maximum is then tested on its centre (a Cholesky test, O(n³/6)), and refined
// (norm_upper) only when the centre's norm plus the variation may beat it.
double patterns_upper(const TaylorMatrix& A, double A_frobenius, const TaylorMatrix& R, double floor,
                      const BoxCosts& costs, double& work) {
  const auto n = static_cast<int>(A.cols());
  const double size = A.centre().norm() + R.centre().norm();
  const CentreGram g{A.centre().transpose() * A.centre(), A.centre().transpose() * R.centre(), size * size};
  const Eigen::MatrixXd RR = R.centre().transpose() * R.centre();
  const PatternColumns columns(A, R);
  std::vector<Choice> choices;
  for (unsigned bits = 0; bits < (1u << n); ++bits) {
    const PatternColumns::Sizes sizes = columns.pattern(bits);
    choices.push_back({(sizes.centre + sizes.variation) * kTaylorInflation, sizes.variation, 0u, bits});
  }
  work += static_cast<double>(choices.size()) * costs.pattern;
  int refined = 0, full = 0;
  const double R_frobenius = R.frobenius_upper();
  TaylorMatrix X;  // the refined pattern's Φ, its storage reused
  const double upper = refine_choices(choices, floor, [&](const Choice& choice, double above) {
    Eigen::VectorXd D(n);
    for (int j = 0; j < n; ++j) D(j) = (choice.bits >> j) & 1u;
    const Eigen::MatrixXd G = D.asDiagonal() * g.AA * D.asDiagonal() + D.asDiagonal() * g.AR +
                              g.AR.transpose() * D.asDiagonal() + RR;
    if (centre_norm_below(G, above - choice.variation, g.magnitude)) return above;
    ++full;
    scaled_sum(A, D, R, A_frobenius + R_frobenius, X);
    return norm_upper(X, above);
  }, refined);
  work += refined * costs.pattern + full * costs.pattern_refinement;
  return upper;
}

// One vertex w for every pattern at once: Aw = A(w) over the box and the envelope [Aw + R, R]ᵀ, whose norm bounds
// ||Aw D + R|| for every D (without friction Aw itself: D = I is then the maximum).
struct VertexEnvelope {
  TaylorMatrix Aw, envelope;  // envelope: not formed without friction, where Aw is its own
  double Aw_frobenius = 0.0;
  const TaylorMatrix& bounded() const { return envelope.rows() > 0 ? envelope : Aw; }
};

// Velocity components whose terms are this small against the largest (V_j ||A_j||_F) are carried as symbols rather
// than enumerated as vertices (on a seven-joint arm the wrist's three, which leaves 16 vertices of 128), while the box
// is wide: a symbol's cross terms with the others do not shrink with the box, so a component is enumerated again once
// its term is larger than the variation of every term over the box (and the bound converges as the box shrinks).
constexpr double kSymbolicVelocityShare = 0.25;

// Which velocity components are carried as symbols (docs/theory.md, "Every saturation pattern at once").
std::vector<bool> symbolic_velocities(const std::vector<TaylorMatrix>& A, const std::vector<double>& A_frobenius,
                                      const Eigen::VectorXd& V) {
  std::vector<double> influence(A.size());
  double variation = 0.0;
  for (std::size_t j = 0; j < A.size(); ++j) {
    const double Vj = V(static_cast<Eigen::Index>(j));
    influence[j] = Vj * A_frobenius[j];
    variation += Vj * std::max(0.0, A_frobenius[j] - A[j].centre().norm());
  }
  const double largest = *std::max_element(influence.begin(), influence.end());
  std::vector<bool> free(influence.size());
  for (std::size_t j = 0; j < influence.size(); ++j)
    free[j] = influence[j] <= kSymbolicVelocityShare * largest && influence[j] <= variation;
  return free;
}

// The velocity vertices over the components enumerated (the others at V_j, carried as symbols); without friction
// w and -w give the same norms: only those with the first enumerated component positive.
std::vector<Eigen::VectorXd> enumerated_vertices(const Eigen::VectorXd& V, const std::vector<bool>& free, bool frictionless) {
  std::vector<Eigen::Index> enumerated;
  for (Eigen::Index j = 0; j < V.size(); ++j)
    if (!free[static_cast<std::size_t>(j)]) enumerated.push_back(j);
  std::vector<Eigen::VectorXd> vertices;
  const unsigned count = 1u << enumerated.size();
  for (unsigned bits = frictionless && !enumerated.empty() ? 1u : 0u; bits < count; bits += frictionless ? 2u : 1u) {
    Eigen::VectorXd w = V;
    for (std::size_t e = 0; e < enumerated.size(); ++e) w(enumerated[e]) = (bits >> e) & 1u ? V(enumerated[e]) : -V(enumerated[e]);
    vertices.push_back(std::move(w));
  }
  return vertices;
}

// The maximum over the vertices w and the saturation patterns D of ||A(w) D + R||, vertex by vertex in decreasing order
// of the envelope's cheap bound: the envelope's centre tested (Cholesky; the variation's norm the smaller of the parts'
// Frobenius norms added and variation_norm_upper), then its fine bound; the patterns one by one
// (patterns_upper) only where what the envelope adds at the centre, at most ||R||² / (2 ||Aw + R||), is a tenth or
// more of what its fine bound leaves above the centre's norm (near the end of a search; the arms measured lose
// 0.04 % to 0.8 % to the envelope at a point, docs/theory.md).
double choices_upper(const LipschitzTerms& t, const BoxForms& d, const VelocityChoices& v, double lower,
                     std::vector<double>& weights, double& work) {
  const std::vector<double> A_frobenius = frobenius_uppers(t.A);
  const std::vector<bool> free = symbolic_velocities(t.A, A_frobenius, v.velocity_bounds);
  const SymbolicWeights symbolic = symbolic_weights(t.A, free);
  const std::vector<Eigen::VectorXd> ws = enumerated_vertices(v.velocity_bounds, free, v.counted.frictionless);
  std::vector<VertexEnvelope> vertices;
  std::vector<Choice> choices;
  // R over the vertices' symbols: the box's and one per velocity component carried as a symbol.
  const TaylorMatrix R = with_symbols(t.R, t.R.symbols() + static_cast<int>(symbolic.terms.size()));
  const double R_frobenius = R.frobenius_upper();
  for (TaylorMatrix& Aw : vertex_combinations(t.A, ws, symbolic, A_frobenius)) {
    VertexEnvelope e;
    e.Aw = std::move(Aw);
    e.Aw_frobenius = e.Aw.frobenius_upper();
    weigh_sides(e.Aw, d, weights);
    if (!v.counted.frictionless) e.envelope = pattern_envelope(e.Aw, R, e.Aw_frobenius + R_frobenius);
    const double centre = e.bounded().centre().norm();
    const double cheap = v.counted.frictionless ? e.Aw_frobenius : e.envelope.frobenius_upper();
    choices.push_back({cheap, cheap - centre, static_cast<unsigned>(vertices.size()), 0u});
    vertices.push_back(std::move(e));
  }
  // The vertices' forms carry the velocity symbols too: what each step costs grows with them.
  const BoxCosts costs = box_costs(d.n, R.symbols(), v.counted);
  work += static_cast<double>(choices.size()) * costs.vertex;
  int refined = 0, full = 0;
  const double R_centre = spectral_norm(t.R.centre());
  const double upper = refine_choices(choices, lower, [&](const Choice& choice, double floor) {
    const VertexEnvelope& e = vertices[choice.vertex];
    const TaylorMatrix::ConstPart C = e.bounded().centre();
    const double size = C.norm(), variation = std::min(choice.variation, e.bounded().variation_norm_upper());
    if (centre_norm_below(C.transpose() * C, floor - variation, size * size)) return floor;
    ++full;
    const double fine = norm_upper(e.bounded(), floor);
    if (v.counted.frictionless || fine <= floor) return fine;
    const double sigma = spectral_norm(C);
    const double added = R_centre * R_centre / (2.0 * spectral_norm(e.Aw.centre() + t.R.centre()));
    if (added < 0.1 * (fine - sigma)) return fine;
    return std::min(fine, patterns_upper(e.Aw, e.Aw_frobenius, R, floor, costs, work));
  }, refined);
  work += refined * costs.vertex_test + full * costs.vertex_refinement;
  return upper;
}

// A full similarity (lipschitz_terms): T Φ T⁻¹ = ((Σ_j w_j Ã_j) D Y + R̃)(T Y)⁻¹, every vertex and pattern bounded
// apart (the envelope of "Every saturation pattern at once" needs D at the end of the product), in decreasing order
// of a cheap bound: ||Ã(w) D||_F over the box, column by column, times ||Y||_F, plus ||R̃||_F.
double similar_choices_upper(const LipschitzTerms& t, const Eigen::MatrixXd& Y, const BoxForms& d,
                             const VelocityChoices& v, double lower, std::vector<double>& weights, double& work) {
  const std::vector<double> A_frobenius = frobenius_uppers(t.A);
  const std::vector<Eigen::VectorXd> ws =
      enumerated_vertices(v.velocity_bounds, std::vector<bool>(t.A.size(), false), v.counted.frictionless);
  const UpwardRounding upward;
  const double Y_frobenius = (Interval(Y.norm()) * Interval(1.0 + 1e-15)).upper(), R_frobenius = t.R.frobenius_upper();
  const TaylorMatrix zero(t.R.rows(), t.R.cols(), t.R.symbols());
  std::vector<TaylorMatrix> Aw;
  std::vector<Choice> choices;
  for (const Eigen::VectorXd& w : ws) {
    Aw.push_back(linear_combination(t.A, w, A_frobenius));
    weigh_sides(Aw.back(), d, weights);
    const PatternColumns columns(Aw.back(), zero);
    for (unsigned bits = 0; bits < (1u << d.n); ++bits) {
      const PatternColumns::Sizes sizes = columns.pattern(bits);
      const double cheap = ((Interval(sizes.centre) + Interval(sizes.variation)) * Interval(Y_frobenius) + Interval(R_frobenius)).upper();
      choices.push_back({cheap * kTaylorInflation, 0.0, static_cast<unsigned>(Aw.size() - 1), bits});
    }
  }
  work += static_cast<double>(choices.size()) * v.costs.choice;
  int refined = 0;
  TaylorMatrix scaled;
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(d.n);
  const double upper = refine_choices(choices, lower, [&](const Choice& choice, double floor) {
    Eigen::VectorXd D(d.n);
    for (int j = 0; j < d.n; ++j) D(j) = (choice.bits >> j) & 1u;
    scaled_sum(Aw[choice.vertex], D, zero, Aw[choice.vertex].frobenius_upper(), scaled);
    TaylorMatrix X;
    const TaylorMatrix right = sandwiched({}, scaled, Y);
    scaled_sum(right, ones, t.R, right.frobenius_upper() + R_frobenius, X);
    return norm_upper(X, floor);
  }, refined);
  work += refined * (v.costs.choice + 2.0 * v.costs.refinement);
  return upper;
}

}  // namespace

// Of the routes of the inertia floor, the one with the lowest value it cannot go below, and that value: the one route
// a box takes (each route taken would count the work of one).
std::pair<const FloorRoute*, double> BoxBounds::likeliest_route(const BoxForms& d, const std::vector<TaylorMatrix>& J) const {
  std::pair<const FloorRoute*, double> best{nullptr, kInfinity};
  for (const FloorRoute& route : routes_) {
    const double least = route_at_least(route, d, J, velocity_bounds_, vertices_);
    if (!best.first || least < best.second) best = {&route, least};
  }
  return best;
}

BoxBound BoxBounds::inertia_route(const FloorRoute& route, const BoxForms& d, const std::vector<TaylorMatrix>& J) const {
  return route_through(model_, route, d, J, vertices_.middleCols(half_, count_ - half_));
}

// L_joint over a box. On a wide box the product M⁻¹ J carries both factors' remainders, and the inertia route
// (||J|| + ||F||) / λmin(M) can be the tighter: where the cheap bound is far above the value attained, both are
// taken.
// With a scaling T, every bound below is of ||T Φ Y|| (the inertia route's of ||Φ|| times the stretch), and
// `restored` turns it into a bound of ||T Φ T⁻¹||. Without one both factors are 1 and the products exact.
BoxBound BoxBounds::joint_lipschitz(const std::vector<Interval>& box, double lower) const {
  const Similarity none{};
  const Similarity& scaling = scaling_ ? *scaling_ : none;
  const auto restored = [&](BoxBound bound) {
    bound.upper = (Interval(bound.upper) * Interval(scaling.restore)).upper();
    return bound;
  };
  const BoxForms d = box_forms(model_, search_, box, true);
  const std::vector<TaylorMatrix> J = unit_jacobians(d);
  const TaylorInverse inverse_M = inverse(d.M, d.n, d.symbols);
  const BoxCosts costs = box_costs(d.n, d.symbols, counted_);
  const double inertia_route_work = costs.refinement + costs.inertia_route;
  if (!inverse_M.proven) {
    BoxBound bound = inertia_route(routes_.size() == 1 ? routes_.front() : *likeliest_route(d, J).first, d, J);
    bound.work = costs.forms + costs.failed_inverse + inertia_route_work;
    return restored(std::move(bound));
  }
  LipschitzTerms t = lipschitz_terms(model_, d, J, velocity_bounds_, inverse_M, scaling_ ? &*scaling_ : nullptr);
  const UpwardRounding upward;
  const bool full = scaling_ && !scaling_->diagonal;
  // With a full T: ||(Σ w_j Ã_j D) Y + R̃||_F <= ||Σ w_j Ã_j D||_F ||Y||_F + ||R̃||_F.
  const auto every_similar_choice = [&] {
    const TaylorMatrix zero(t.R.rows(), t.R.cols(), t.R.symbols());
    const Interval stretch(scaling.columns.norm() * (1.0 + 1e-15));
    return (Interval(every_choice_upper(t.A, velocity_bounds_, zero)) * stretch + Interval(t.R.frobenius_upper())).upper();
  };
  const double every_choice = full ? every_similar_choice() : every_choice_upper(t.A, velocity_bounds_, t.R);
  BoxBound bound{0.0, {}, costs.forms + costs.products};
  // A diagonal T's tail with T inside, where the stretched one is a tenth of the bound or more.
  if (scaling_ && scaling_->diagonal && t.tail > 0.1 * (every_choice + t.tail)) {
    t.tail = std::min(t.tail, similar_tail(t, inverse_M, *scaling_, d.symbols));
    bound.work += 2.0 * (costs.refinement + costs.gram);
  }
  bound.upper = every_choice + t.tail;
  if (bound.upper <= lower) {  // cannot beat the value attained: no choice needs enumerating
    weigh_sides(linear_combination(t.A, velocity_bounds_, frobenius_uppers(t.A)), d, bound.split_weight);
    return restored(std::move(bound));
  }
  // The route of the inertia floor wins on wide boxes only (where M⁻¹'s series is loose): it is taken where the
  // bound is more than twice the value attained and the route could beat it.
  double cap = kInfinity;
  const auto route = bound.upper > 2.0 * lower ? likeliest_route(d, J) : std::pair<const FloorRoute*, double>{};
  if (route.first && route.second < bound.upper) {
    BoxBound by_inertia = inertia_route(*route.first, d, J);
    bound.work += inertia_route_work;
    if (by_inertia.upper <= lower) return restored({by_inertia.upper, std::move(by_inertia.split_weight), bound.work});
    cap = by_inertia.upper;
  }
  const VelocityChoices choices{velocity_bounds_, counted_, costs};
  const double polynomial = full ? similar_choices_upper(t, scaling.columns, d, choices, lower - t.tail, bound.split_weight, bound.work)
                                : choices_upper(t, d, choices, lower - t.tail, bound.split_weight, bound.work);
  bound.upper = std::min({cap, polynomial + t.tail, bound.upper});  // bound.upper: the entry moduli's
  return restored(std::move(bound));
}

}  // namespace obsgain

namespace obsgain {

PolytopeCell BoxBounds::perturbation_cell(const std::vector<Interval>& box) const {
  const BoxForms d = box_forms(model_, search_, box, true);
  const TaylorInverse inverse_M = inverse(d.M, d.n, d.symbols);
  PolytopeCell cell;
  cell.box = box;
  if (!inverse_M.proven) return cell;
  const LipschitzTerms t = lipschitz_terms(model_, d, unit_jacobians(d), velocity_bounds_, inverse_M);
  cell.constant = -t.R.centre();
  for (const TaylorMatrix& A : t.A) cell.slopes.push_back(-A.centre());
  const UpwardRounding upward;
  // M⁻¹'s tail adds a matrix of norm <= t.tail to Φ, hence at most t.tail to every entry.
  cell.radius = (t.R.spread().array() + t.tail).matrix();
  for (int j = 0; j < d.n; ++j) cell.radius += velocity_bounds_(j) * t.A[j].spread();
  cell.radius += point_rounding(cell, velocity_bounds_);
  cell.proven = true;
  return cell;
}


PerturbationForms BoxBounds::perturbation_forms(const std::vector<Interval>& box) const {
  const BoxForms d = box_forms(model_, search_, box, true);
  PerturbationForms forms;
  forms.costs = box_costs(d.n, d.symbols, counted_);
  const TaylorInverse inverse_M = inverse(d.M, d.n, d.symbols);
  const std::vector<TaylorMatrix> J = unit_jacobians(d);
  weigh_sides(linear_combination(J, velocity_bounds_, frobenius_uppers(J)), d, forms.split_weight);
  if (!inverse_M.proven) return forms;
  const LipschitzTerms t = lipschitz_terms(model_, d, J, velocity_bounds_, inverse_M);
  weigh_sides(linear_combination(t.A, velocity_bounds_, frobenius_uppers(t.A)), d, forms.split_weight);
  const UpwardRounding upward;
  // ||[F, J(w)]|| <= ||F||_F + ||Σ_j V_j |J_j|||_F.
  const std::vector<Taylor> none(static_cast<std::size_t>(d.n * d.n), Taylor(0.0));
  const double inputs =
      (Interval(every_choice_upper(J, velocity_bounds_, taylor_matrix(none.data(), d.n, d.n, d.symbols))) +
       Interval(model_.friction.norm() * (1.0 + 1e-13)))
          .upper();
  forms.tail = (Interval(inverse_M.tail) * Interval(inputs)).upper();
  forms.A = t.A;
  forms.R = t.R;
  forms.proven = true;
  return forms;
}

}  // namespace obsgain
