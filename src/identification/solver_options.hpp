// The Levenberg-Marquardt settings of both identification steps: dense QR for
// these small dense problems, silent, and tight tolerances so that the stopping
// point is the least-squares optimum to rounding (the Monte Carlo efficiency
// study depends on it). Internal.
#pragma once

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "hapticcal/core/cancel.hpp"

namespace hapticcal::detail {

// Ceres reports a non-finite residual through glog, tens of lines on stderr
// before hapticcal's own one-line message: glog's threshold is raised to FATAL
// once (a host program that wants glog's warnings sets FLAGS_minloglevel back).
inline void quiet_ceres() {
  static const bool once = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)once;
}

// The relative change of the cost and of the parameters that ends a solve:
// the optimum to rounding, or (the model search's candidate fits, polished
// when one is kept) to what its held-out comparison can tell.
constexpr double kTightTolerance = 1e-14;
constexpr double kSearchTolerance = 1e-10;

// Ends a solve at its next iteration once a host cancels the run (solve()
// then throws Cancelled).
class CancelCallback : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_requested() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }
};

inline ceres::Solver::Options levenberg_marquardt(int max_iterations,
                                                  double tolerance = kTightTolerance) {
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

// ceres::Solve, then Cancelled if the run was cancelled meanwhile.
inline void solve(const ceres::Solver::Options& options, ceres::Problem* problem,
                  ceres::Solver::Summary* summary) {
  ceres::Solve(options, problem, summary);
  throw_if_cancelled();
}

}  // namespace hapticcal::detail
