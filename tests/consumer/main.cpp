// A downstream project: the paper's ||S|| for α = β = 1 through the installed library.
#include <obsgain/certificate/lyapunov.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const double S_norm = obsgain::observer_lyapunov(1.0, 1.0, 2).S_norm;
  std::printf("%.7f\n", S_norm);
  return std::abs(S_norm - (5.0 + std::sqrt(5.0)) / 4.0) < 1e-12 ? 0 : 1;
}
