// A proven lower bound of λmin(M(q)) that holds for every q: from the armature alone, and on a chain of revolute
// joints from the bodies' own rotational inertias too (docs/theory.md, "The inertia floor"). It keeps M⁻¹ finite over
// boxes too wide for its enclosure, so a published URDF without rotor inertia still gets finite bounds.
#pragma once

#include "obsgain/model/model.hpp"

namespace obsgain {

double inertia_floor(const Model& model);

}  // namespace obsgain
