#include "obsgain/bounds/perturbation_polytope.hpp"
#include "obsgain/parsers/robots.hpp"

#include <gtest/gtest.h>

#include <random>

namespace {

struct Sample {
  Eigen::VectorXd q, w, D;
};

// A random configuration inside `cell` (the other joints anywhere), velocity w in the box, D in [0, 1]ⁿ.
Sample draw(const obsgain::PerturbationPolytope& polytope, const obsgain::PolytopeCell& cell, const Eigen::VectorXd& V,
            std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = polytope.dof;
  Sample s{Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n)};
  for (int i = 0; i < n; ++i) {
    s.q(i) = -3.0 + 6.0 * unit(rng);
    s.w(i) = V(i) * (2.0 * unit(rng) - 1.0);
    s.D(i) = unit(rng) < 0.2 ? 1.0 : unit(rng);  // full saturation often, as at the vertices
  }
  for (std::size_t k = 0; k < polytope.joints.size(); ++k)
    s.q(polytope.joints[k]) = cell.box[k].lower() + unit(rng) * (cell.box[k].upper() - cell.box[k].lower());
  return s;
}

// |Φ(q, w, D) - point(w, D)| <= radius at every sample (the polytope's claim), and the largest ratio seen: a radius
// that is never approached would be a loose polytope.
double worst_ratio(const obsgain::Model& model, const obsgain::PerturbationPolytope& polytope, int samples) {
  std::mt19937_64 rng(11);
  double worst = 0.0;
  for (int t = 0; t < samples; ++t) {
    const obsgain::PolytopeCell& cell = polytope.cells[t % polytope.cells.size()];
    const Sample s = draw(polytope, cell, model.velocity_bounds, rng);
    const Eigen::MatrixXd deviation =
        (obsgain::perturbation_matrix(model, s.q, s.w, s.D) - cell.point(s.w, s.D)).cwiseAbs();
    for (Eigen::Index i = 0; i < deviation.rows(); ++i)
      for (Eigen::Index j = 0; j < deviation.cols(); ++j) {
        EXPECT_LE(deviation(i, j), cell.radius(i, j)) << "sample " << t << " entry " << i << "," << j;
        if (cell.radius(i, j) > 0.0) worst = std::max(worst, deviation(i, j) / cell.radius(i, j));
      }
  }
  return worst;
}

TEST(PerturbationPolytope, PendubotCellsContainPhiAtRandomPoints) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::PerturbationPolytope polytope = obsgain::perturbation_polytope(model, model.velocity_bounds);
  ASSERT_TRUE(polytope.proven()) << polytope.unproven;
  EXPECT_EQ(polytope.cells.size(), 32u);  // 32 cells along q2, each with its own vertices
  EXPECT_EQ(polytope.joints, std::vector<int>{1});
  const double worst = worst_ratio(model, polytope, 20000);
  // The radius is the q-variation within a cell (first order) plus remainders: samples reach a good part of it.
  EXPECT_GT(worst, 0.2);
}

TEST(PerturbationPolytope, VerticesAreTheCornersOfTheBilinearPoint) {
  const obsgain::Model model = obsgain::pendubot();
  const obsgain::PerturbationPolytope polytope = obsgain::perturbation_polytope(model, model.velocity_bounds, {4});
  ASSERT_TRUE(polytope.proven());
  const Eigen::VectorXd V = model.velocity_bounds;
  for (const obsgain::PolytopeCell& cell : polytope.cells) {
    // Each corner (w = ±V, D in {0, 1}²) is a vertex; an interior point is their bilinear interpolation.
    for (unsigned bits = 0; bits < 16; ++bits) {
      const Eigen::Vector2d w((bits & 1u) ? V(0) : -V(0), (bits & 2u) ? V(1) : -V(1));
      const Eigen::Vector2d D((bits >> 2) & 1u, (bits >> 3) & 1u);
      const Eigen::MatrixXd corner = cell.point(w, D);
      EXPECT_TRUE(std::find(cell.vertices.begin(), cell.vertices.end(), corner) != cell.vertices.end());
    }
    const Eigen::Vector2d w(0.3 * V(0), -0.6 * V(1)), D(0.25, 0.5);
    // point is affine in each of w_j and D_j: the midpoint in w_0 is the mean of the two ends.
    const Eigen::Vector2d w_plus(V(0), w(1)), w_minus(-V(0), w(1));
    const double t = (w(0) + V(0)) / (2.0 * V(0));
    EXPECT_LT((cell.point(w, D) - (t * cell.point(w_plus, D) + (1 - t) * cell.point(w_minus, D))).norm(),
              1e-12 * cell.point(w_plus, D).norm() + 1e-300);
  }
}

TEST(PerturbationPolytope, ThreeJointArmMergedCellContainsPhi) {
  const obsgain::Model model = obsgain::load_robot({std::string(OBSGAIN_EXAMPLES_DIR) + "/arm3.urdf"});
  obsgain::PolytopeOptions options;
  options.cells = 1024;  // M is proven invertible on a 32 x 32 grid of (q2, q3)
  const obsgain::PerturbationPolytope polytope = obsgain::perturbation_polytope(model, model.velocity_bounds, options);
  ASSERT_TRUE(polytope.proven()) << polytope.unproven;
  ASSERT_EQ(polytope.cells.size(), 1u);  // above two joints the cells merge
  EXPECT_EQ(polytope.joints, (std::vector<int>{1, 2}));
  worst_ratio(model, polytope, 5000);
  // Coarser, a cell is too wide to prove M invertible: said, not a wrong polytope.
  options.cells = 4;
  const obsgain::PerturbationPolytope coarse = obsgain::perturbation_polytope(model, model.velocity_bounds, options);
  EXPECT_FALSE(coarse.proven());
  EXPECT_NE(coarse.unproven.find("more cells would help"), std::string::npos);
}

}  // namespace
