#include "obsgain/numerics/sdp.hpp"

extern "C" {
#include <dsdp/dsdp5.h>
}

#include <fmt/format.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <memory>
#include <mutex>
#include <stdexcept>

namespace obsgain {

PackedSymmetric packed(const Eigen::MatrixXd& symmetric) {
  PackedSymmetric p;
  for (int i = 0; i < symmetric.rows(); ++i)
    for (int j = 0; j <= i; ++j)
      if (symmetric(i, j) != 0.0) {
        p.index.push_back(i * (i + 1) / 2 + j);
        p.value.push_back(symmetric(i, j));
      }
  return p;
}

Eigen::MatrixXd evaluate(const LinearMatrixInequality& lmi, const Eigen::VectorXd& y) {
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(lmi.size, lmi.size);
  const auto add = [&](double scale, const PackedSymmetric& m) {
    for (std::size_t e = 0; e < m.index.size(); ++e) {
      // index = i (i + 1) / 2 + j with j <= i
      int i = static_cast<int>((std::sqrt(8.0 * m.index[e] + 1.0) - 1.0) / 2.0);
      while (i * (i + 1) / 2 > m.index[e]) --i;
      while ((i + 1) * (i + 2) / 2 <= m.index[e]) ++i;
      const int j = m.index[e] - i * (i + 1) / 2;
      F(i, j) += scale * m.value[e];
      if (i != j) F(j, i) += scale * m.value[e];
    }
  };
  add(1.0, lmi.constant);
  for (const auto& [variable, matrix] : lmi.terms) add(y(variable), matrix);
  return F;
}

namespace {

const char* stop_reason(DSDPTerminationReason reason) {
  switch (reason) {
    case DSDP_CONVERGED: return "converged";
    case DSDP_MAX_IT: return "iteration limit";
    case DSDP_INFEASIBLE_START: return "infeasible start";
    case DSDP_INDEFINITE_SCHUR_MATRIX: return "indefinite Schur matrix";
    case DSDP_SMALL_STEPS: return "short steps";
    case DSDP_NUMERICAL_ERROR: return "numerical error";
    default: return "stopped";
  }
}

void check(int code, const char* call) {
  if (code != 0) throw std::runtime_error(fmt::format("DSDP: {} failed with code {}", call, code));
}

// DSDP keeps pointers to the data arrays, which live in `blocks` until the solver is destroyed. In DSDP's form,
// C - Σ y_i A_i ⪰ 0 with C = -F0 and A_i = F_i.
void set_blocks(DSDP dsdp, const std::vector<LinearMatrixInequality>& blocks) {
  SDPCone cone = nullptr;
  check(DSDPCreateSDPCone(dsdp, static_cast<int>(blocks.size()), &cone), "DSDPCreateSDPCone");
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const int block = static_cast<int>(b);
    const LinearMatrixInequality& lmi = blocks[b];
    check(SDPConeSetBlockSize(cone, block, lmi.size), "SDPConeSetBlockSize");
    const auto set = [&](int variable, double scale, const PackedSymmetric& m) {
      if (m.index.empty()) return;
      check(SDPConeSetASparseVecMat(cone, block, variable, lmi.size, scale, 0, m.index.data(), m.value.data(),
                                    static_cast<int>(m.index.size())),
            "SDPConeSetASparseVecMat");
    };
    set(0, -1.0, lmi.constant);
    for (const auto& [variable, matrix] : lmi.terms) set(variable + 1, 1.0, matrix);
  }
}

// DSDP's setup prints a line on stdout when it picks its sparse Schur solver, and the apps write JSON there: stdout
// points at /dev/null while the solver sets up and runs (one solver at a time).
class QuietStdout {
 public:
  QuietStdout() : lock_(mutex()) {
    std::fflush(stdout);
    saved_ = dup(STDOUT_FILENO);
    const int null = open("/dev/null", O_WRONLY);
    if (saved_ >= 0 && null >= 0) dup2(null, STDOUT_FILENO);
    if (null >= 0) close(null);
  }
  ~QuietStdout() {
    std::fflush(stdout);
    if (saved_ >= 0) {
      dup2(saved_, STDOUT_FILENO);
      close(saved_);
    }
  }
  QuietStdout(const QuietStdout&) = delete;
  QuietStdout& operator=(const QuietStdout&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  int saved_ = -1;
};

// DSDP's monitor, called at every iteration: stops the solver once options.enough accepts the iterate.
struct EnoughMonitor {
  const SdpOptions* options;
  Eigen::VectorXd y;
};

int stop_when_enough(DSDP dsdp, void* data) {
  auto* monitor = static_cast<EnoughMonitor*>(data);
  if (DSDPGetY(dsdp, monitor->y.data(), static_cast<int>(monitor->y.size())) == 0 && monitor->options->enough(monitor->y))
    DSDPSetConvergenceFlag(dsdp, DSDP_UPPERBOUND);
  return 0;
}

}  // namespace

SdpResult solve_sdp(int variables, const std::vector<LinearMatrixInequality>& blocks, const Eigen::VectorXd& objective,
                    const SdpOptions& options) {
  DSDP dsdp = nullptr;
  check(DSDPCreate(variables, &dsdp), "DSDPCreate");
  const std::unique_ptr<std::remove_pointer_t<DSDP>, int (*)(DSDP)> owner(dsdp, DSDPDestroy);
  set_blocks(dsdp, blocks);
  for (int i = 0; i < variables; ++i) check(DSDPSetDualObjective(dsdp, i + 1, objective(i)), "DSDPSetDualObjective");
  check(DSDPSetYBounds(dsdp, -options.variable_bound, options.variable_bound), "DSDPSetYBounds");
  check(DSDPSetGapTolerance(dsdp, options.gap_tolerance), "DSDPSetGapTolerance");
  check(DSDPSetMaxIts(dsdp, options.max_iterations), "DSDPSetMaxIts");
  check(DSDPSetStandardMonitor(dsdp, 0), "DSDPSetStandardMonitor");
  if (options.start.size() == variables) {
    for (int i = 0; i < variables; ++i) check(DSDPSetY0(dsdp, i + 1, options.start(i)), "DSDPSetY0");
    check(DSDPSetR0(dsdp, 0.0), "DSDPSetR0");
  }
  EnoughMonitor monitor{&options, Eigen::VectorXd::Zero(variables)};
  if (options.enough) check(DSDPSetMonitor(dsdp, stop_when_enough, &monitor), "DSDPSetMonitor");
  SdpResult result;
  result.y = Eigen::VectorXd::Zero(variables);
  const QuietStdout quiet;
  if (DSDPSetup(dsdp) != 0 || DSDPSolve(dsdp) != 0) {
    result.status = "setup or solve failed";
    return result;
  }
  DSDPTerminationReason reason;
  DSDPSolutionType type;
  check(DSDPStopReason(dsdp, &reason), "DSDPStopReason");
  check(DSDPGetSolutionType(dsdp, &type), "DSDPGetSolutionType");
  check(DSDPGetY(dsdp, result.y.data(), variables), "DSDPGetY");
  result.solved = reason == DSDP_CONVERGED && type == DSDP_PDFEASIBLE;
  result.status = type == DSDP_INFEASIBLE ? "infeasible" : type == DSDP_UNBOUNDED ? "unbounded" : stop_reason(reason);
  return result;
}

}  // namespace obsgain
