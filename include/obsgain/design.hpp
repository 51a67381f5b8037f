// design_gains: from a model and what the user asks (a target rate γ, or a gain θ to evaluate) to the
// observer gains and their certificate, with every number the certificate rests on.
#pragma once

#include "obsgain/bounds.hpp"
#include "obsgain/certified_bounds.hpp"
#include "obsgain/deployment.hpp"
#include "obsgain/lyapunov.hpp"
#include "obsgain/model.hpp"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace obsgain {

enum class CertificateKind { paper, tight };
enum class LipschitzKind { paper, joint };
enum class BoundMethod { certified, numeric };
// What a --gamma design minimises: θ (the smallest gain certifying the rate), or the certified ultimate
// velocity error of the sampled, quantised observer (needs a deployment).
enum class DesignObjective { rate, velocity_error };

struct DesignOptions {
  std::optional<double> gamma;  // target rate: θ is the smallest gain that certifies it
  std::optional<double> theta;  // or: evaluate this gain and report the rate it certifies
  double alpha = 1.0;
  double beta = 1.0;
  bool optimize_shape = false;  // β = 1, best α for the chosen certificate (design notes §6)
  LipschitzKind lipschitz = LipschitzKind::joint;
  std::optional<double> L_override;  // e.g. the paper's 54.01
  CertificateKind certificate = CertificateKind::tight;
  // The tight certificate's rate is a supremum; its matrix P is computed at γ_sup (1 - rate_margin), which
  // buys a finite, much smaller envelope constant k. A target-γ design raises θ so that γ itself is certified.
  double rate_margin = 0.01;
  Eigen::VectorXd velocity_bounds;  // empty: the model's own
  // certified: interval branch and bound; a model that cannot be evaluated on intervals then gets an
  // estimate that is never called certified. numeric: the optimisers' lower estimates, by request.
  BoundMethod bound_method = BoundMethod::certified;
  BoundOptions bounds;
  CertifiedOptions certified_bounds;
  // The observer as deployed: sample period, encoders, acceleration box (deployment.hpp). Adds the sampled,
  // quantised certificate to the design.
  std::optional<DeploymentOptions> deployment;
  DesignObjective objective = DesignObjective::rate;
  // Told the start of each phase that can take seconds (robots of more than two joints); the apps print it
  // on stderr unless --quiet.
  std::function<void(const std::string&)> progress;
};

// One certificate evaluated for the design, so that paper and tight can be shown side by side.
struct CertificateSummary {
  double theta_star = 0.0;      // smallest θ for the target γ (for a θ evaluation: for any positive rate)
  double theta = 0.0;           // the gain this certificate's design uses
  double gamma = 0.0;           // the rate certified at θ (a supremum for tight; may be <= 0)
  double envelope_gamma = 0.0;  // the rate of the envelope ||e(t)|| <= k ||e(0)|| e^{-γ t}
  double k = 0.0;               // envelope constant, in the original error coordinates
  double k1 = 0.0, k2 = 0.0;    // observer gains θα and θ²β
  Eigen::Matrix2d P = Eigen::Matrix2d::Zero();  // V(e) = eᵀ (P ⊗ I_n) e
  std::optional<double> lmi_max_eig;            // tight only: the LMI check, <= 0 certifies
  bool certified = false;                       // a positive rate with a valid P, on the bounds used
};

struct ShapeReport {
  bool optimized = false;
  std::string objective;               // what was minimised: "S_norm", "theta_star" or "-gamma"
  double alpha_global = 0.0, alpha_polish = 0.0;          // NLopt DIRECT-L, then Ipopt
  double objective_global = 0.0, objective_polish = 0.0;
  int evaluations = 0;
};

struct Design {
  std::string robot_name;
  RobotSource robot_source;
  int dof = 0;
  Eigen::VectorXd armature;  // the model's reflected rotor inertias (zero: none)
  std::string robot_fingerprint;  // the model file's, so that a later validation can refuse a changed file
  Eigen::VectorXd velocity_bounds;
  BoundReport bounds;
  double L_used = 0.0;
  std::string L_source;  // "joint", "paper" or "override"
  double alpha = 1.0, beta = 1.0;
  ShapeReport shape;
  LyapunovSolution lyapunov;
  CertificateKind certificate = CertificateKind::tight;
  std::optional<double> target_gamma;
  double rate_margin = 0.0;
  CertificateSummary paper, tight;
  DesignObjective objective = DesignObjective::rate;
  std::optional<DeploymentCertificate> deployment;
  std::vector<TradeoffPoint> tradeoff;  // the θ sweep of the ultimate errors at the deployment's T and δ
  std::vector<std::string> notes;     // what loading the model decided (chain, lumped bodies, armature)
  std::vector<std::string> warnings;
  // The certificate is a proof only if every bound it uses is proven: certified bounds, or an L given by the
  // user (whose responsibility it then is). Otherwise the design is an estimate, and this says why.
  std::string not_proven_reason;
  double wall_seconds = 0.0;

  bool proven() const { return not_proven_reason.empty(); }

  const CertificateSummary& selected() const { return certificate == CertificateKind::paper ? paper : tight; }
};

// Throws InputError for invalid options (non-positive or NaN numbers, both or neither of γ and θ, ...).
void validate_design_options(const DesignOptions& options);

Design design_gains(const Model& model, const DesignOptions& options);

// The bounds a design rests on: numeric search, then certified brackets when asked and possible.
// Appends a warning when certified bounds were asked for but the model cannot give them.
BoundReport design_bounds(const Model& model, const Eigen::VectorXd& velocity_bounds, const DesignOptions& options,
                          std::vector<std::string>& warnings);

// Given the bounds, the rest of the design.
Design design_from_bounds(const Model& model, const BoundReport& bounds, const DesignOptions& options);

// Why a design does not meet what was asked (the apps exit 1 with this line), or empty: a --gamma request
// needs the selected certificate to hold, on proven bounds unless the user chose --bounds numeric.
std::string unmet_request(const Design& design, const DesignOptions& options);

// The deployed design (deployment.cpp): for --objective velocity-error the (α, θ) with the smallest certified
// ultimate velocity error that still certifies the target rate; else the rate design. Either way with the
// sampled certificate and the trade-off sweep. `sensitivity` is C_q's bracket.
Design deployed_design(const Model& model, const BoundReport& bounds, const DesignOptions& options,
                       const BoundBracket& sensitivity);

const char* to_string(CertificateKind kind);
const char* to_string(LipschitzKind kind);

}  // namespace obsgain
