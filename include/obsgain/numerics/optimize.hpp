// The two optimisers every search in obsgain uses: NLopt's DIRECT-L for a derivative-free global search
// over a box, and Ipopt for a gradient-based polish from a good point. Bounds, shape optimisation and the
// tight certificate all call these; their results are reported side by side so that a disagreement shows.
#pragma once

#include <Eigen/Dense>

#include <functional>

namespace obsgain {

using Objective = std::function<double(const Eigen::VectorXd&)>;

struct OptimumPoint {
  Eigen::VectorXd x;
  double value = 0.0;
  int evaluations = 0;
};

// Global maximisation over the box [lower, upper] (NLopt GN_DIRECT_L) with an evaluation budget.
OptimumPoint maximize_global(const Objective& f, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                             int max_evaluations);

// Minimisation of f over [lower, upper] by golden section until the bracket is narrower than `tolerance` (at most
// `max_iterations` steps). Returns the best point evaluated, so a function that is only roughly unimodal still
// gets the lowest value seen.
struct ScalarOptimum {
  double x = 0.0, value = 0.0;
  int evaluations = 0;
};
ScalarOptimum minimize_golden(const std::function<double(double)>& f, double lower, double upper, double tolerance,
                              int max_iterations);

// Local maximisation from x0 inside [lower, upper] (Ipopt, Newton's steps). Gradients are central differences and
// the Hessian second differences, so f must be smooth near the maximiser. Returns the best point Ipopt evaluated,
// never worse than x0.
OptimumPoint maximize_local(const Objective& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                            const Eigen::VectorXd& upper);

}  // namespace obsgain
