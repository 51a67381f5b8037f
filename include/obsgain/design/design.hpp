// design_gains: from a model and what the user asks (a target rate γ, or a gain θ to evaluate) to the
// observer gains and their certificate, with every number the certificate rests on.
#pragma once

#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/certified_bounds.hpp"
#include "obsgain/bounds/perturbation_polytope.hpp"
#include "obsgain/certificate/polytopic.hpp"
#include "obsgain/certificate/polytopic_search.hpp"
#include "obsgain/certificate/lyapunov.hpp"
#include "obsgain/model/model.hpp"
#include "obsgain/runtime/certified_observer.hpp"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace obsgain {

enum class LipschitzKind { paper, joint };
enum class BoundMethod { certified, numeric };

struct DesignOptions {
  std::optional<double> gamma;  // target rate: θ is the smallest gain that certifies it
  std::optional<double> theta;  // or: evaluate this gain and report the rate it certifies
  double alpha = 1.0;
  double beta = 1.0;
  bool optimize_shape = false;  // β = 1, best α for the chosen certificate (docs/theory.md, "Shape optimisation")
  LipschitzKind lipschitz = LipschitzKind::joint;
  std::optional<double> L_override;  // e.g. the paper's 54.01
  // Unset: the tight certificate, or the scaled one where the bounds kept a similarity scaling whose proven L_T is below
  // L_joint (the same bounded-real lemma on a smaller L: a smaller θ for a target, a larger rate at a θ).
  std::optional<CertificateKind> certificate;
  // The tight certificate's rate is a supremum; its matrix P is computed at γ_sup (1 - rate_margin), which
  // buys a finite, much smaller envelope constant k. A target-γ design raises θ so that γ itself is certified.
  double rate_margin = 0.01;
  // A warning says what the proof costs when the proven upper end of the constant the selected certificate rests on
  // (L_T for the scaled one, else L_joint) exceeds the value attained by this factor.
  double wide_bracket = 1.5;
  // The warning also extrapolates the search's own pace (excess_per_doubling, bounds.hpp) to the budget that would
  // bring the bracket within that factor, and θ within theta_within of its value on the value attained (the bar
  // docs/theory.md sets for gains a controller runs), up to this multiple of the budget given; beyond it, it says so.
  double extrapolate_budget_up_to = 64.0;
  double theta_within = 1.1;
  Eigen::VectorXd velocity_bounds;  // empty: the model's own
  // certified: interval branch and bound; a model that cannot be evaluated on intervals then gets an
  // estimate that is never called certified. numeric: the optimisers' lower estimates, by request.
  BoundMethod bound_method = BoundMethod::certified;
  BoundOptions bounds;
  CertifiedOptions certified_bounds;
  // --certificate polytopic: the cells of the perturbation's polytope and the SDP's policy (with --optimize-shape, the
  // search of α around the norm-bound certificate's best α: PolytopicOptions::shape_*).
  PolytopeOptions polytope;
  PolytopicOptions polytopic;
  // --certificate polytopic above PolytopeOptions::separate_cells_up_to_dof joints: P chosen on sampled
  // configurations and proven by branch and bound (certificate/polytopic_search.hpp).
  PolytopicSearchOptions polytopic_search;
  // Set by a sampled deployment (deployment/deployment.hpp): the polytopic certificate then chooses P, and γ up to
  // the rate θ certifies, for the smallest sampled error floor instead of the smallest k (polytopic_floor_certificate).
  struct SampledFloor {
    double model_gain = 0.0;   // M0 C_q: what the model loses per unit of measurement error
    double lowest_rate = 0.0;  // γ is not traded below this (a velocity-error deployment's target)
  };
  std::optional<SampledFloor> sampled_floor;
  // Told the start of each phase (bounds, certified bounds, ...); the apps print it on stderr for robots of more
  // than two joints, unless --quiet.
  std::function<void(const std::string&)> progress;
};

// One certificate evaluated for the design, so that paper and tight can be shown side by side.
struct CertificateSummary {
  CertifiedObserver observer;  // the gains at the chosen θ and what they certify (observer.gamma: the envelope's rate)
  double theta_star = 0.0;     // smallest θ for the target γ (for a θ evaluation: for any positive rate)
  double rate = 0.0;           // the rate certified at θ (a supremum for tight; may be <= 0)
  std::optional<double> lmi_max_eig;  // tight and scaled: the LMI check, <= 0 certifies
  std::string status;                 // polytopic only: the SDP solver's and the interval check's verdict
};

// What a polytopic certificate rests on: a grid of cells (bounds/perturbation_polytope.hpp), or, above two joints,
// sampled configurations and a branch and bound over the joint domain (certificate/polytopic_search.hpp).
struct PolytopeSummary {
  std::string method = "grid";  // "grid" or "search"
  int cells = 0, vertices = 0, grid = 0;
  int samples = 0, cuts = 0, proof_boxes = 0, refuted = 0;  // "search": see PolytopicSearchReport
  double proof_work = 0.0;                                   // "search": counted work of the proofs (reference s)
  std::string unproven;  // why it could not be built, or empty
  double seconds = 0.0;  // polytope and SDPs (and proofs)
};

struct ShapeReport {
  bool optimized = false;
  std::string objective;               // what was minimised: "S_norm", "theta_star" or "-gamma"
  double alpha_global = 0.0, alpha_polish = 0.0;          // NLopt DIRECT-L, then Ipopt
  double objective_global = 0.0, objective_polish = 0.0;
  int evaluations = 0;
  // --certificate polytopic: the same objective on the polytopic certificate (θ* for a target, −γ at a θ; estimates,
  // bisections on the SDP solver's answer), searched in log α from the α above, which is kept unless beaten
  // (docs/theory.md, "Shape optimisation").
  struct Polytopic {
    double alpha = 0.0, objective = 0.0;
    double objective_at_norm_bound_alpha = 0.0;
    int evaluations = 0;  // θ* or rate bisections
  };
  std::optional<Polytopic> polytopic;
};

struct Design {
  std::string robot_name;
  RobotSource robot_source;
  int dof = 0;
  Eigen::VectorXd armature;  // the model's reflected rotor inertias (zeros: none)
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
  std::optional<CertificateSummary> scaled;     // when the bounds kept a similarity scaling (bounds.scaling) for L_joint
  std::optional<CertificateSummary> polytopic;  // --certificate polytopic: its result, even when it fell back
  std::optional<PolytopeSummary> polytope;
  // The selected norm-bound certificate (tight or scaled) once more, at the same α and β, on the value its constant
  // attains (the bracket's lower end) in place of the proven upper end: what a proof without a gap would give, θ for a
  // target (with the same rate margin) and the rate for a given θ. No proof of that constant does better; the distance
  // to the design is what the proof costs, and a larger --bound-budget narrows it. Certified bounds only.
  struct AtAttained {
    // Two θ, or two rates, closer than this relative distance are the same in the price lines and in choosing
    // other_at_attained.
    static constexpr double same_within = 1e-4;
    const char* constant = nullptr;     // "L_joint" or "L_T"
    const char* certificate = nullptr;  // the norm-bound certificate on it: "tight" on L_joint, "scaled" on L_T
    double L = 0.0, theta = 0.0, rate = 0.0;
  };
  std::optional<AtAttained> at_attained;
  // The other norm-bound certificate on its constant's attained value (the scaled one on L_T where the design rests on
  // L_joint, or the reverse), where it does better than `at_attained`: the design the numeric estimate chooses, whose
  // constant's proof went less far (docs/theory.md, "The proof's price").
  std::optional<AtAttained> other_at_attained;
  std::vector<std::string> notes;     // what loading the model (chain, lumped bodies, armature) and the search decided
  std::vector<std::string> warnings;
  // The certificate is a proof only if every bound it uses is proven: certified bounds, or an L given by the
  // user (whose responsibility it then is). Otherwise the design is an estimate, and this says why.
  std::string not_proven_reason;
  // Set when the bounds could not support any certificate (no finite proven L within the budget): the certificates
  // are then not computed, and the request is not met (exit 1, with what would help).
  std::string unfinished;
  double wall_seconds = 0.0;

  bool proven() const { return not_proven_reason.empty(); }

  // The computed constant the selected certificate rests on, with its bracket: L_T for the scaled certificate, L_joint
  // for the tight and paper ones on the computed L_joint; none (bracket null) for a polytopic certificate, which rests
  // on its polytope or proof, for L_paper and for the user's L.
  struct UsedConstant {
    const char* name = nullptr;
    const BoundBracket* bracket = nullptr;
  };
  UsedConstant used_constant() const;

  const CertificateSummary& selected() const {
    if (certificate == CertificateKind::polytopic && polytopic) return *polytopic;
    if (certificate == CertificateKind::scaled && scaled) return *scaled;
    return certificate == CertificateKind::paper ? paper : tight;
  }
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

// The velocity box a request means: its own, or the model's (InputError when neither gives one).
Eigen::VectorXd requested_velocity_bounds(const Model& model, const DesignOptions& options);

// Why a design does not meet what was asked (the apps exit 1 with this line), or empty: a --gamma request
// needs the selected certificate to hold, on proven bounds unless the user chose --bounds numeric.
std::string unmet_request(const Design& design, const DesignOptions& options);

// The polytopic certificate's search above two joints (certificate/polytopic_search.hpp) as the design runs it: its
// options, the bound search's thread count and SDP settings, and the bounds' maximisers as its first samples.
PolytopicSearch polytopic_search_for(const Model& model, const Design& design, const DesignOptions& options);

const char* to_string(LipschitzKind kind);

}  // namespace obsgain
