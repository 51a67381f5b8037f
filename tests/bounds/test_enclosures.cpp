// The enclosures of M, N_i and g over boxes of configurations (bounds/enclosures.hpp) against the double dynamics
// and their finite differences at random points of random boxes.
#include "obsgain/bounds/enclosures.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/parsers/robots.hpp"

#include "test_files.hpp"
#include <gtest/gtest.h>

#include <random>

namespace {

using obsgain_test::examples;

// Random boxes, random points inside: the DualInterval evaluation encloses M, N, g and the derivatives of M
// and g (central differences) at every point, for n = 2, 3, 6, 7.
TEST(Enclosures, EncloseValuesAndDerivativesAtRandomPointsOfRandomBoxes) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const char* file : {"pendubot.urdf", "arm3.urdf", "arm6.urdf", "arm7.urdf"}) {
    const obsgain::Model model = obsgain::load_robot({examples + "/" + file});
    const int n = model.dof();
    const int m = n - 1;  // the searched joints 2..n
    for (int trial = 0; trial < 10; ++trial) {
      std::vector<obsgain::DualInterval> box(n);
      std::vector<double> lo(n), hi(n);
      for (int i = 0; i < n; ++i) {
        const double width = (trial < 5 ? 0.05 : 1.0) * unit(rng);
        lo[i] = -3.0 + 6.0 * unit(rng) * 0.9;
        hi[i] = lo[i] + width;
        box[i] = i == 0 ? obsgain::DualInterval(obsgain::Interval(lo[0]))
                        : obsgain::DualInterval::variable(obsgain::Interval(lo[i], hi[i]), i - 1, m);
      }
      hi[0] = lo[0];
      const obsgain::MatrixEnclosure M = obsgain::mass_matrix_enclosure(model, box);
      const std::vector<obsgain::MatrixEnclosure> N = obsgain::coriolis_tensor_enclosures(model, box);
      const obsgain::MatrixEnclosure g = obsgain::gravity_enclosure(model, box);
      for (int point = 0; point < 10; ++point) {
        Eigen::VectorXd q(n);
        for (int i = 0; i < n; ++i) q(i) = lo[i] + unit(rng) * (hi[i] - lo[i]);
        Eigen::MatrixXd Mq(n, n);
        obsgain::mass_matrix(model, q, Mq);
        std::vector<Eigen::MatrixXd> Nq;
        obsgain::coriolis_tensors(model, q, Nq);
        const auto inside = [](const obsgain::Interval& x, double value, double slack) {
          return x.lower() - slack <= value && value <= x.upper() + slack;
        };
        for (int r = 0; r < n; ++r)
          for (int c = 0; c < n; ++c) {
            EXPECT_TRUE(inside(M.value(r, c), Mq(r, c), 0.0)) << file << " M(" << r << "," << c << ")";
            for (int i = 0; i < n; ++i) EXPECT_TRUE(inside(N[i].value(r, c), Nq[i](r, c), 1e-12 * (1 + Mq.norm()))) << file;
          }
        Eigen::VectorXd gq(n);
        obsgain::gravity(model, q, gq);
        for (int r = 0; r < n; ++r) EXPECT_TRUE(inside(g.value(r, 0), gq(r), 0.0)) << file << " g(" << r << ")";
        // Derivatives by central differences (their error, O(h²), is the slack).
        const double h = 1e-6;
        for (int k = 0; k < m; ++k) {
          if (q(k + 1) - h < lo[k + 1] || q(k + 1) + h > hi[k + 1]) continue;
          Eigen::VectorXd plus = q, minus = q;
          plus(k + 1) += h;
          minus(k + 1) -= h;
          Eigen::MatrixXd Mp(n, n), Mm(n, n);
          obsgain::mass_matrix(model, plus, Mp);
          obsgain::mass_matrix(model, minus, Mm);
          const Eigen::MatrixXd dM = (Mp - Mm) / (2 * h);
          for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c)
              EXPECT_TRUE(inside(M.derivative[k](r, c), dM(r, c), 1e-6 * (1 + Mq.norm()))) << file << " dM/dq" << k + 2;
          Eigen::VectorXd gp(n), gm(n);
          obsgain::gravity(model, plus, gp);
          obsgain::gravity(model, minus, gm);
          for (int r = 0; r < n; ++r)
            EXPECT_TRUE(inside(g.derivative[k](r, 0), (gp(r) - gm(r)) / (2 * h), 1e-6 * (1 + gq.norm())))
                << file << " dg/dq" << k + 2;
        }
      }
    }
  }
}

}  // namespace
