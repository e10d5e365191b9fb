// The Levenberg-Marquardt settings of both identification steps: dense QR for
// these small dense problems, silent, and tight tolerances so that the stopping
// point is the least-squares optimum to rounding (the Monte Carlo efficiency
// study depends on it). Internal.
#pragma once

#include <ceres/ceres.h>

namespace hapticcal::detail {

// The relative change of the cost and of the parameters that ends a solve:
// the optimum to rounding, or (the model search's candidate fits, polished
// when one is kept) to what its held-out comparison can tell.
constexpr double kTightTolerance = 1e-14;
constexpr double kSearchTolerance = 1e-10;

// Levenberg-Marquardt with dense QR, silent, stopping at `tolerance`, ending
// at its next iteration once a host cancels the run (core/cancel.hpp). The
// first call raises glog's threshold to FATAL for the process: Ceres reports a
// non-finite residual through glog, tens of lines on stderr before hapticcal's
// own one-line message (a host program that wants glog's warnings sets
// FLAGS_minloglevel back).
ceres::Solver::Options levenberg_marquardt(int max_iterations, double tolerance = kTightTolerance);

// ceres::Solve, then Cancelled if the run was cancelled meanwhile.
void solve(const ceres::Solver::Options& options, ceres::Problem* problem,
           ceres::Solver::Summary* summary);

}  // namespace hapticcal::detail
