// The lumped planar two-link family of the paper (Pendubot, Acrobot, fully actuated two-link arms) as data,
// parameterised by π1..π5 (Zhang & Tarn), and its dynamics as templates on the scalar: the same code runs on
// double, on intervals and on Taylor forms.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cmath>

namespace obsgain {

struct Planar2RParameters {
  std::array<double, 5> pi{};  // π1..π5
  double g0 = 9.81;
  std::array<double, 2> armature{};  // reflected rotor inertias, added to M's diagonal
};

// The dynamics as functions of the joints' cosines and sines, which the callers compute as suits their scalar (once
// per configuration in double; as enclosures of cos q2 and of cos(q1 + q2) on intervals).

// M(q) depends on q2 only, through c2 = cos q2.
template <class Scalar>
Eigen::Matrix<Scalar, 2, 2> planar_2r_mass_matrix(const Planar2RParameters& p, const Scalar& c2) {
  const Scalar off = p.pi[1] + p.pi[2] * c2;
  Eigen::Matrix<Scalar, 2, 2> M;
  M << p.pi[0] + p.pi[1] + p.armature[0] + 2.0 * p.pi[2] * c2, off, off, Scalar(p.pi[1] + p.armature[1]);
  return M;
}

// N_1, N_2 with A_i = vᵀ N_i v: A_1 = -π3 s2 (2 v1 v2 + v2²), A_2 = π3 s2 v1², s2 = sin q2.
template <class Scalar>
std::array<Eigen::Matrix<Scalar, 2, 2>, 2> planar_2r_coriolis_tensors(const Planar2RParameters& p, const Scalar& s2) {
  const Scalar h = p.pi[2] * s2;
  const Scalar zero(0.0);
  Eigen::Matrix<Scalar, 2, 2> N1, N2;
  N1 << zero, -h, -h, -h;
  N2 << h, zero, zero, zero;
  return {N1, N2};
}

// g(q) from c1 = cos q1 and c12 = cos(q1 + q2).
template <class Scalar>
Eigen::Matrix<Scalar, 2, 1> planar_2r_gravity(const Planar2RParameters& p, const Scalar& c1, const Scalar& c12) {
  Eigen::Matrix<Scalar, 2, 1> g;
  g << p.pi[3] * p.g0 * c1 + p.pi[4] * p.g0 * c12, p.pi[4] * p.g0 * c12;
  return g;
}

}  // namespace obsgain
