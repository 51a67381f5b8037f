// The polytopic certificate on arms of three and more joints (docs/theory.md, "The polytopic certificate by search"):
// one full P (2n x 2n) with (A + EΦ)ᵀP + P(A + EΦ) + 2γP ≼ 0 for every Φ the observer can see. Writing the error's
// perturbation as φ = −M⁻¹(J(w) δ + F e_v), δ = D e_v, the saturation becomes a sector condition per joint,
// δ_i (e_v,i − δ_i) >= 0, carried by one multiplier τ_i each: one LMI in (e, δ) per configuration and velocity
// vertex, with no enumeration of the 2ⁿ patterns and no grid of cells.
//   - P is chosen by an SDP on sampled configurations (numerics/sdp.hpp): the sampled configuration and velocity
//     vertex where the current P fails most join the SDP until every sample holds; then, among the P that hold, the
//     one with the smallest condition number (the envelope's k). An estimate.
//   - The proof: a branch and bound (bounds/branch_and_bound.hpp) over the joint domain on the LMI's largest
//     eigenvalue, bounded over each box from the Taylor forms of M⁻¹J_j and M⁻¹F (bounds/box_bounds.hpp). It ends
//     proven when every box is shown <= 0; a configuration where the LMI fails joins the samples, and P is chosen
//     again.
#pragma once

#include "obsgain/certificate/polytopic.hpp"
#include "obsgain/model/model.hpp"
#include "obsgain/numerics/sdp.hpp"

#include <Eigen/Dense>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace obsgain {

struct PolytopicSearchOptions {
  int samples = 400;  // random configurations of the searched joints (a fixed seed), beside the caller's seeds
  int cuts_per_round = 8;    // sampled (configuration, vertex) pairs added to the SDP per round
  int max_cut_rounds = 40;
  // P is solved for γ / (1 − m) and proven at γ: the slack the proof's boxes need. The design passes its own.
  double rate_margin = 0.03;
  double relative_tolerance = 1e-3;  // of the bisections in θ and γ
  double condition_cap = 1e3;        // λmax / λmin of P in balanced coordinates while feasibility is asked
  // The proofs' branch and bound stop once their counted work reaches this in all (reference seconds, docs/theory.md
  // "The budget").
  double proof_budget = 60.0;
  int proof_attempts = 3;  // a refuted proof adds its counterexample to the samples and P is solved again
  int retries = 4;         // the design's: a θ one rate margin higher (a rate one margin lower) per failed proof
  int threads = 0;         // 0: all cores (the result does not depend on it)
  SdpOptions sdp;
};

struct PolytopicSearchReport {
  int samples = 0;       // configurations the SDP's cuts are drawn from
  int cuts = 0;          // (configuration, vertex) LMIs in the last SDP
  int proof_boxes = 0;   // boxes the proofs evaluated
  double proof_work = 0.0;
  int refuted = 0;       // proofs that found a configuration where the chosen P fails
};

class PolytopicSearch {
 public:
  // `seeds`: configurations where the perturbation is large (the bounds' maximisers), sampled first.
  PolytopicSearch(const Model& model, const Eigen::VectorXd& velocity_bounds, const std::vector<Eigen::VectorXd>& seeds,
                  const PolytopicSearchOptions& options = {});
  ~PolytopicSearch();
  PolytopicSearch(const PolytopicSearch&) = delete;
  PolytopicSearch& operator=(const PolytopicSearch&) = delete;
  PolytopicSearch(PolytopicSearch&&) noexcept;
  PolytopicSearch& operator=(PolytopicSearch&&) noexcept;

  // Whether the SDP finds a P for γ at the gains (k1, k2) that holds at every sample (an estimate).
  bool feasible(double k1, double k2, double gamma);
  // The smallest θ (k1 = θα, k2 = θ²β) at which it finds a P for γ / (1 − rate_margin), searched upwards from `from`
  // (an estimate; infinite when none up to 1e8).
  double theta_star(double alpha, double beta, double gamma, double from);
  // The largest γ it finds a P for at (k1, k2) (an estimate; may be <= 0).
  double rate(double k1, double k2);
  // P solved for γ / (1 − rate_margin), the one with the smallest k among those that hold at the samples, then
  // proven at γ over the whole joint domain.
  PolytopicCertificate certificate(double k1, double k2, double gamma);

  const PolytopicSearchReport& report() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace obsgain
