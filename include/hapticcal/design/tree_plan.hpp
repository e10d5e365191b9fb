// Experiment design for a tree (issue 26, item 4): which poses of a robot with
// several tips (identification/tree.hpp) to measure, every tip's point at each,
// so that calibrate_tree predicts best.
//
// The parameters are those the rank test identifies on the candidate pool (base
// first, then the tools, then the joints: the tracker's frame is unknown). A
// pose contributes 3 rows a tip (sd sigma), angle columns scaled by the length
// scale. The design is plan_poses' greedy start and Fedorov exchange on these
// rows: poses added one at a time, each the candidate of the largest gain of
// the criterion of the summed information M (regularised by 1e-9 of its mean
// diagonal until it has full rank),
//   D: log det M         I: -mean over validation poses of the tips' prediction variance,
// then each design pose in turn swapped for the candidate that gains most in
// its place, in sweeps until one swaps none. No continuous refinement on a tree
// yet. The figures are from the linearised covariance sigma^2 M^-1 at the
// nominal tree.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "hapticcal/design/plan.hpp"
#include "hapticcal/identification/tree.hpp"

namespace hapticcal {

struct TreePlanOptions {
  int poses = 0;
  int pool = 5000;  // random candidate readings within the joint limits
  PlanCriterion criterion = PlanCriterion::kI;
  std::uint64_t seed = 1;
  double sigma = kPlanSigmaPosition;  // sd of a point's coordinate [m]
  int validation_poses = 500;         // the I criterion's sample of the workspace
  int evaluation_poses = 2000;        // the figures' (another sample)
  int random_draws = 20;              // random designs of the same size, for comparison
  int max_sweeps = 6;                 // exchange sweeps at most
};

struct TreePlan {
  Eigen::MatrixXd readings;                 // poses x tree dof, in path order
  std::vector<std::string> parameters;      // identified, in the rank test's order
  std::map<std::string, std::string> held;  // candidates held: why
  Eigen::VectorXd sd;                       // predicted sd a parameter [m, rad]
  double rms_sd = 0;                        // predicted RMS sd of a tip's point [m]
  double rms_sd_greedy = 0;                 // the same of the greedy start (0: undetermined)
  double criterion_greedy = 0, criterion_exchange = 0;  // the criterion maximised (above)
  int sweeps = 0, swaps = 0;                            // of the exchange
  std::vector<double> random_rms_sd;                    // each random design's, sorted
  double random_median_rms_sd = 0;
  double path_length = 0, path_length_unordered = 0;  // sum of max |dq_j| between poses
  int pool = 0;
};

// InputError for a number of poses outside 1..100000 or fewer poses than
// parameters / (3 x tips).
TreePlan plan_tree(const DeviceTree& tree, const TreePlanOptions& options);

// The predicted RMS sd of the tips' points over `validation` readings (poses x
// tree dof) after calibrate_tree on `design` (poses x tree dof), noise sd
// `sigma` a coordinate, over the parameters `plan_tree` identifies.
double tree_predicted_rms_sd(const DeviceTree& tree, const Eigen::MatrixXd& design,
                             const Eigen::MatrixXd& validation, double sigma);

}  // namespace hapticcal
