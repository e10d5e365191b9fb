// The Levenberg-Marquardt settings of both identification steps
// (solver_options.hpp), and the process-wide quieting of Ceres' glog.
#include "identification/problem/solver_options.hpp"

#include <glog/logging.h>

#include "hapticcal/core/cancel.hpp"

namespace hapticcal::detail {
namespace {

// Ends a solve at its next iteration once a host cancels the run (solve()
// then throws Cancelled).
class CancelCallback : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_requested() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }
};

void quiet_ceres() {
  static const bool once = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)once;
}

}  // namespace

ceres::Solver::Options levenberg_marquardt(int max_iterations, double tolerance) {
  quiet_ceres();
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::DENSE_QR;
  options.logging_type = ceres::SILENT;
  options.max_num_iterations = max_iterations;
  options.function_tolerance = tolerance;
  options.parameter_tolerance = tolerance;
  options.gradient_tolerance = 1e-16;
  static CancelCallback cancel;
  options.callbacks.push_back(&cancel);
  return options;
}

void solve(const ceres::Solver::Options& options, ceres::Problem* problem,
           ceres::Solver::Summary* summary) {
  ceres::Solve(options, problem, summary);
  throw_if_cancelled();
}

}  // namespace hapticcal::detail
