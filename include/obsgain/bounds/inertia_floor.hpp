// A proven lower bound of λmin(M(q)) that holds for every q: from the armature alone, and on a chain of revolute
// joints from the bodies' own rotational inertias too (docs/theory.md, "The inertia floor"). It keeps M⁻¹ finite over
// boxes too wide for its enclosure, so a published URDF without rotor inertia still gets finite bounds.
#pragma once

#include "obsgain/model/model.hpp"

namespace obsgain {

double inertia_floor(const Model& model);

// A proven lower bound of λmin(S M(q) S) for S = diag(s), s > 0, and every q, given `floor` <= λmin(M(q)):
// M ≽ floor I gives floor min_k s_k², and M ≽ diag(armature) (the bodies' own part is positive semidefinite) gives
// min_k a_k s_k². The route of the floor for L_T (bounds/box_bounds.cpp) rests on it.
double similar_inertia_floor(const Model& model, double floor, const Eigen::VectorXd& s);

}  // namespace obsgain
