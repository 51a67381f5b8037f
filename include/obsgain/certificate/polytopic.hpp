// The polytopic certificate: one full P (2n x 2n, not P₂ ⊗ I) with (A + EΦ)ᵀP + P(A + EΦ) + 2γP ≼ 0 for every Φ in
// a proven polytope of the perturbation (bounds/perturbation_polytope.hpp), the polytope's entrywise remainder
// carried by an S-procedure term per entry and cell (docs/theory.md, "The polytopic certificate"). In original
// coordinates e = (q̂ - q, v̂ - v): A = [[-k1 I, I], [-k2 I, 0]], E = (0, I)ᵀ.
// The SDP solver (numerics/sdp.hpp) only proposes P: a certificate exists when the rounded P and multipliers pass
// a Cholesky factorisation of every vertex LMI in interval arithmetic. Rates and gains found by bisection on the
// solver's answer are estimates until then.
#pragma once

#include "obsgain/bounds/perturbation_polytope.hpp"
#include "obsgain/numerics/sdp.hpp"

#include <Eigen/Dense>

#include <string>

namespace obsgain {

struct PolytopicOptions {
  // P is solved for γ / (1 - rate_margin) and checked at γ: the gap is the slack that absorbs the solver's tolerance.
  double rate_margin = 0.01;
  double relative_tolerance = 1e-3;  // of the bisections in γ and θ
  // λmax / λmin of P in balanced coordinates while only feasibility is asked: wide enough for every P measured
  // (on the Pendubot 1e3 and 1e6 give the same answers), narrow enough for DSDP to converge (at 1e4 with 64 cells
  // it stalls).
  double condition_cap = 1e3;
  // polytopic_floor_certificate: the golden-section search of γ, to this fraction of the upper end, in at most this
  // many SDPs (about 1 s each on the Pendubot's 32 cells).
  double floor_rate_tolerance = 0.01;
  int floor_search_iterations = 14;
  // A design at a given θ searches γ from this fraction of the largest rate it certifies (on the Pendubot at
  // θ = 135.86 the floor is least at 0.91 of it; at the largest rate P has no freedom left).
  double floor_lowest_rate_fraction = 0.25;
  // --optimize-shape: from the norm-bound certificate's best α, a step of shape_log_tolerance either way; where one
  // improves, a golden section in log α on that side, up to this factor, to that width, in at most this many steps.
  // Each objective is a bisection of SDPs to this relative tolerance (about 10 SDPs, 1 to 2 s each on a two-joint
  // model's 32 cells). On the Pendubot the polytopic rate at θ = 65.67 peaks near α = 1.6 (30.7 against 26.0 at the
  // tight certificate's α = 1.27); θ* for a target is flat around the tight α on the two-joint examples.
  double shape_span = 1.6;
  double shape_log_tolerance = 0.08;
  int shape_iterations = 5;
  double shape_relative_tolerance = 2e-3;
  SdpOptions sdp;
};

struct PolytopicCertificate {
  bool exists = false;   // every vertex LMI and P > 0 passed the interval check
  Eigen::MatrixXd P;     // V(e) = eᵀ P e, original coordinates
  Eigen::VectorXd multipliers;  // the S-procedure's τ, one per uncertain entry (polytopic_check)
  double gamma = 0.0;    // the rate checked
  double k = 0.0;        // sqrt(λmax(P) / λmin(P)), from proven eigenvalue bounds
  std::string status;    // the solver's or the check's verdict, in words
};

// Whether the solver finds a P for γ at the gains (k1, k2): the LMIs' largest slack t (an estimate; < 0: found).
// Never found on a polytope that is not proven (no cells: nothing to hold P to).
double polytopic_slack(const PerturbationPolytope& polytope, double k1, double k2, double gamma,
                       const PolytopicOptions& options = {});
// The largest γ the solver finds a P for (an estimate: bisection on the slack's sign). May be <= 0.
double polytopic_rate(const PerturbationPolytope& polytope, double k1, double k2, const PolytopicOptions& options = {});
// The smallest θ (k1 = θα, k2 = θ²β) at which the solver finds a P for γ / (1 - rate_margin) (an estimate).
double polytopic_theta_star(const PerturbationPolytope& polytope, double alpha, double beta, double gamma,
                            const PolytopicOptions& options = {});
// Among the P the solver finds for γ / (1 - rate_margin), the one with the smallest k; then the proof at γ.
PolytopicCertificate polytopic_certificate(const PerturbationPolytope& polytope, double k1, double k2, double gamma,
                                           const PolytopicOptions& options = {});
// For a sampled deployment: among the P the solver finds for a rate γ in [gamma_low, gamma_high] (each over
// 1 - rate_margin), the P and γ with the smallest ultimate velocity error for a measurement disturbance
// w = (k1 η, k2 η + ψ), ||ψ|| <= model_gain ||η|| (docs/theory.md, "Deployment through the same P"); then the
// proof at that γ. The floor itself is bounded by the deployment (deployment/deployment.hpp) from the P chosen.
PolytopicCertificate polytopic_floor_certificate(const PerturbationPolytope& polytope, double k1, double k2,
                                                 double gamma_low, double gamma_high, double model_gain,
                                                 const PolytopicOptions& options = {});
// The proof alone: do P and the multipliers τ (one per entry (i, j) with a radius in some cell, row-major) satisfy
// every vertex LMI at γ, in interval arithmetic? And P > 0.
bool polytopic_check(const PerturbationPolytope& polytope, double k1, double k2, double gamma, const Eigen::MatrixXd& P,
                     const Eigen::VectorXd& multipliers);

}  // namespace obsgain
