// verify-bounds: everything a reviewer needs to check a design — the certified brackets, the design and
// both certificates, a Monte Carlo verdict, and the data behind the report's plots.
#pragma once

#include "obsgain/deployment/deployment.hpp"
#include "obsgain/validation/montecarlo.hpp"

#include <string>
#include <vector>

namespace obsgain {

struct VerificationOptions {
  DesignOptions design;
  std::optional<DeploymentOptions> deployment;
  MonteCarloOptions monte_carlo;  // defaults below: 200 trials, horizon 1 s
  std::string command_line;       // shown in the report's verdict box
  int curve_points = 721;         // samples of the bound curves over the searched joint
  int error_traces = 12;          // Monte Carlo trials drawn in the error plot
  VerificationOptions() { monte_carlo.trials = 200; }
};

// One sample of the bound curves over the searched joint (the others at the M0 argmax).
struct BoundCurvePoint {
  double angle;
  double inverse_inertia_norm;    // ||M(q)⁻¹||
  double jacobian_norm;           // max over vertices of ||J(q, w)||
  double joint_lipschitz_norm;    // max over vertices and D of ||M⁻¹(J D + F)||
};

struct RateCurvePoint {
  double theta, paper_gamma, tight_gamma;
  double scaled_gamma;     // the scaled certificate's rate where the bounds kept a similarity scaling; else NaN
  double polytopic_gamma;  // the SDP's rate (an estimate) where the design is polytopic, on a coarser grid; else NaN
};

struct VerificationReport {
  std::string robot;
  int curve_joint = 0;  // the joint the bound curves sweep
  DeployedDesign design;
  MonteCarloReport monte_carlo;
  std::vector<BoundCurvePoint> bound_curve;
  std::vector<TrajectorySample> paper_run;             // trial 0 of example_scenario (for the Pendubot: Fig. 2)
  std::string command_line;  // as the user typed it (the app fills it), for the report's verdict box
  std::string date;          // UTC, ISO 8601
  std::string example_scenario;                        // "paper" for the paper's two-link family, else "random"
  std::vector<std::vector<TrajectorySample>> error_traces;  // Monte Carlo trials for the error plot
  std::vector<RateCurvePoint> rate_curve;
};

VerificationReport verify_design(const Model& model, const VerificationOptions& options);

}  // namespace obsgain
