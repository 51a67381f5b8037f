// The certificate for the observer as it runs: sampled every T seconds, on quantised encoder positions
// (docs/theory.md, "Deployment"). The implementation it covers is the Observer class (runtime/observer.hpp):
// between samples it integrates the observer's equations with the measurement interpolated linearly between the
// last two samples, the model evaluated there (clamped to the joint limits). Under the velocity box |v_i| <= V_i
// and an acceleration box |q''_i| <= A_i, that measurement differs from q(t) by at most
//   d_i = δ_i / 2 + A_i T² / 8 (+ V_i τ when the samples arrive τ late)
// (quantisation, plus the interpolation error of a C² signal), which enters the error equation as a bounded
// disturbance w = (k1 η, k2 η + ψ), |η_i| <= d_i, ||ψ|| <= M0 C_q ||d|| (the model evaluated at the measured
// position). The design's quadratic certificate V = eᵀPe then gives, with W = sqrt(V),
//   W(t) <= e^{-γt} W(0) + R,   R = max ||P^½ w|| / γ (bounded blockwise, or through w = (k1, k2) η + (0, ψ)),
//   ||e(t)|| <= k e^{-γt} ||e(0)|| + R / sqrt(λmin(P)),
// and the ultimate ellipsoid W <= R bounds ||e_q|| by R sqrt(λmax((P⁻¹)_qq)) and ||e_v|| by R sqrt(λmax((P⁻¹)_vv)).
#pragma once

#include "obsgain/bounds/certified_bounds.hpp"
#include "obsgain/design/design.hpp"

#include <Eigen/Dense>

#include <optional>
#include <string>
#include <vector>

namespace obsgain {

// What a deployment design minimises: θ (the smallest gain certifying the rate: the design's own), or the
// certified ultimate velocity error of the sampled, quantised observer that still certifies the rate.
enum class DesignObjective { rate, velocity_error };

struct DeploymentOptions {
  double sample_period = 0.0;            // T [s]
  Eigen::VectorXd encoder_resolution;    // δ_i, one encoder count in joint units [rad or m]; one value: every joint
  Eigen::VectorXd acceleration_bounds;   // A_i: |q''_i(t)| <= A_i along the observed motion; one value: every joint
  double latency = 0.0;                  // τ: the sample used at t_k was taken at t_k - τ (bus, filters) [s]
  // max_sample_period is the largest T whose certified ultimate velocity error norm stays within this;
  // 0: the smallest velocity bound (an estimate whose guaranteed error exceeds the velocities it estimates is
  // no estimate).
  double velocity_error_tolerance = 0.0;
  DesignObjective objective = DesignObjective::rate;
  // The branch and bound of C_q. It stops at a 5 % gap: C_q enters the ultimate bounds through M0 C_q + k2, so 5 %
  // on it moves them by less than that. Budget: unset, a tenth of the design's bound budget within [1, 60] s
  // (60 s when that budget is unlimited).
  double sensitivity_gap = 0.05;
  std::optional<double> sensitivity_budget_seconds;
};

// What a request gives of a deployment (the command line's options, Python's keywords), each part optional.
struct DeploymentRequest {
  std::optional<double> sample_period, latency, velocity_error_tolerance;
  std::optional<Eigen::VectorXd> encoder_counts, acceleration_bounds;  // one value, or one per joint
  DesignObjective objective = DesignObjective::rate;
};

// The deployment a request means: none when none of it was given. InputError when T, the encoders or the
// accelerations are missing, or when the velocity-error objective comes without a deployment.
std::optional<DeploymentOptions> deployment_options(const DeploymentRequest& request);

// Counts per revolution -> one count in radians: 2π / N.
Eigen::VectorXd encoder_resolution_from_counts(const Eigen::VectorXd& counts_per_revolution);

// Throws InputError naming the bad value (sizes, non-positive or non-finite numbers).
void validate_deployment_options(const DeploymentOptions& options, int dof);

// What the sampled, quantised certificate gives for one gain choice (closed forms, rounded upwards).
struct SampledErrorBounds {
  double disturbance_position = 0.0;  // bound of ||k1 η||
  double disturbance_velocity = 0.0;  // bound of ||k2 η + ψ||
  double level = 0.0;                 // R: W(t) <= e^{-γt} W(0) + R
  double offset = 0.0;                // r: ||e(t)|| <= k e^{-γt} ||e(0)|| + r
  double position_norm = 0.0;         // limsup ||e_q|| <= R sqrt(λmax((P⁻¹)_qq))
  double velocity_norm = 0.0;         // limsup ||e_v|| <= R sqrt(λmax((P⁻¹)_vv))
};
SampledErrorBounds sampled_error_bounds(const CertifiedObserver& observer, double model_gain, double measurement_error_norm);

// d_i = δ_i / 2 + A_i T² / 8 + V_i τ.
Eigen::VectorXd measurement_error_bound(const DeploymentOptions& options, const Eigen::VectorXd& velocity_bounds,
                                        double sample_period);

struct DeploymentCertificate {
  double sample_period = 0.0, latency = 0.0;
  Eigen::VectorXd encoder_resolution, acceleration_bounds;
  Eigen::VectorXd measurement_error;   // d_i
  BoundBracket position_sensitivity;   // C_q (certified_bounds.hpp); upper end used
  double M0 = 0.0;                     // the design's proven (or estimated) sup ||M⁻¹||
  double model_gain = 0.0;             // M0 C_q: ||ψ|| <= model_gain ||η||
  double gamma = 0.0, k = 0.0;         // the design's envelope rate and constant
  SampledErrorBounds bounds;
  Eigen::VectorXd ultimate_position_error, ultimate_velocity_error;  // per joint (each at most the norm's bound)
  double velocity_error_tolerance = 0.0;
  double max_sample_period = 0.0;      // largest T with bounds.velocity_norm <= tolerance (0: none, even T -> 0)
  int substeps = 0;                    // RK4 steps per sample the Observer class takes at T
  std::string not_proven_reason;       // empty: every number above is proven

  bool proven() const { return not_proven_reason.empty(); }
  bool within_tolerance() const { return bounds.velocity_norm <= velocity_error_tolerance; }
};

// One row of the velocity-error trade-off (--objective velocity-error, verify-bounds' plot).
struct TradeoffPoint {
  CertifiedObserver observer;
  double position_norm = 0.0, velocity_norm = 0.0;  // ultimate bounds at the deployment's T and δ
};

// What deploying adds to a design: the sampled certificate and the θ sweep it was chosen along.
struct Deployment {
  DeploymentCertificate certificate;
  std::vector<TradeoffPoint> tradeoff;
  DesignObjective objective = DesignObjective::rate;
};

// A design and, when it was asked for, its deployment.
struct DeployedDesign {
  Design design;
  std::optional<Deployment> deployment;
};

// The sampled certificate of a design, given C_q (certify_position_sensitivity) and whether it is proven.
DeploymentCertificate deployment_certificate(const Design& design, const DeploymentOptions& options,
                                             const BoundBracket& sensitivity, bool sensitivity_proven);

// From the request to the deployed observer: the design's bounds, C_q, and for --objective velocity-error the
// (α, θ) with the smallest certified ultimate velocity error that still certifies the target rate (else the rate
// design), with the sampled certificate and the trade-off sweep. Without deployment options, the design alone.
DeployedDesign design_observer(const Model& model, const DesignOptions& options,
                               const std::optional<DeploymentOptions>& deployment);

// unmet_request of the design, and for a deployment: a certified ultimate velocity error beyond the tolerance.
std::string unmet_request(const DeployedDesign& result, const DesignOptions& options);

}  // namespace obsgain
