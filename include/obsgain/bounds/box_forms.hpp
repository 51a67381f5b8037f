// The model's M (and the Christoffel tensors N) over one box of the searched joints, as second-order Taylor forms
// (numerics/taylor.hpp): what every certified bound of a box starts from.
//
// A side of radius up to kArcRadius carries one symbol, its joint's angle q = m + ρ ε, and cos q, sin q are Taylor
// expansions in ε. A wider revolute side carries two: its joint's cosine and sine are enclosed by the rectangle
// around the arc they trace, (cos q, sin q) = R(m) (x, y) with x = cos(q - m) ∈ [cos ρ, 1] and y = sin(q - m) in
// [-sin ρ, sin ρ], each of them a symbol. The rotations are then affine in the symbols, so the composite-rigid-body
// algorithm's products of rotations stay low in degree and what it cannot keep (third-order terms) stays small: on
// the iiwa 14 at L_joint's maximiser, a box of half-width 0.1 in every joint and the full range of the wrist's: the
// bound of ||Φ|| is 3.75 with arcs against 4.28 with angles (attained: 3.16), docs/theory.md, "Taylor forms".
#pragma once

#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/model.hpp"
#include "obsgain/numerics/taylor.hpp"

#include <Eigen/Dense>

#include <vector>

namespace obsgain {

// Sides wider than this (half-width, rad) carry the arc's two symbols.
inline constexpr double kArcRadius = 0.05;

// How a side is carried by the symbols.
struct BoxSide {
  int joint = 0;                      // the model's joint
  double centre = 0.0, radius = 0.0;  // the box's side inside centre ± radius
  int symbol = 0;                     // the angle's (a narrow side), or y's (an arc)
  int arc_symbol = -1;                // x's, for an arc (-1: a narrow side)
  double x_centre = 0.0, x_radius = 0.0, y_radius = 0.0;  // x = x_centre + x_radius ε, y = y_radius ε (an arc)
};

struct BoxForms {
  int n = 0, symbols = 0;
  std::vector<BoxSide> sides;
  std::vector<int> side_of;         // the side each symbol belongs to
  std::vector<Taylor> M, N;         // row-major: M[i * n + j], N[(i * n + j) * n + k] (N empty unless asked)
  std::vector<double> sensitivity;  // of M to each side: radius · Σ over entries of sup |∂M_ij/∂q_k| over the box

  // The symbols' values at a configuration inside the box (every joint's position; tests).
  std::vector<double> symbols_at(const Eigen::VectorXd& q) const;
};

// `tensors`: N too (the Christoffel symbols of M's derivatives on forward-mode duals), M and N then computed on
// third-order forms (numerics/taylor3.hpp) and returned as second-order ones; otherwise M alone, on second-order forms,
// its sensitivities from derivatives on intervals.
BoxForms box_forms(const Model& model, const JointSearch& search, const std::vector<Interval>& box, bool tensors);

}  // namespace obsgain
