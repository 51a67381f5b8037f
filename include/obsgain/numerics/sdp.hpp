// Semidefinite programs in the form the polytopic certificate needs: maximise cᵀy subject to
// F0_b + Σ_i y_i F_ib ≼ 0 for every block b (linear matrix inequalities, each small and sparse). Solved by DSDP,
// a dual-scaling interior-point method in C (Debian libdsdp-dev) on reference BLAS, single-threaded: the same
// problem gives the same y on every run (docs/theory.md, "The polytopic certificate").
// A solver's y is an estimate: whatever rests on it is checked again rigorously (certificate/polytopic.hpp).
#pragma once

#include <Eigen/Dense>

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace obsgain {

// A symmetric matrix by the nonzeros of its lower triangle, (i, j) with i >= j at index i (i + 1) / 2 + j.
struct PackedSymmetric {
  std::vector<int> index;
  std::vector<double> value;
};
PackedSymmetric packed(const Eigen::MatrixXd& symmetric);

struct LinearMatrixInequality {
  int size = 0;
  PackedSymmetric constant;                          // F0
  std::vector<std::pair<int, PackedSymmetric>> terms;  // (i, F_i) for the variables that appear
};

struct SdpOptions {
  double gap_tolerance = 1e-8;  // relative duality gap at which the solver stops
  int max_iterations = 300;
  double variable_bound = 1e8;  // |y_i| <= bound: keeps an infeasible problem from running away
  // A strictly feasible y to start from (empty: DSDP's infeasible start). From a feasible start every iterate
  // stays feasible, and the solver needs far fewer iterations.
  Eigen::VectorXd start;
  // Asked of every iterate: true stops the solver there (a question of feasibility needs no optimum).
  std::function<bool(const Eigen::VectorXd& y)> enough;
};

struct SdpResult {
  bool solved = false;  // converged with a feasible, bounded problem (false when `enough` stopped it)
  std::string status;   // the solver's reason, in words
  Eigen::VectorXd y;
};

// F0 + Σ_i y_i F_i, dense.
Eigen::MatrixXd evaluate(const LinearMatrixInequality& lmi, const Eigen::VectorXd& y);

SdpResult solve_sdp(int variables, const std::vector<LinearMatrixInequality>& blocks, const Eigen::VectorXd& objective,
                    const SdpOptions& options = {});

}  // namespace obsgain
