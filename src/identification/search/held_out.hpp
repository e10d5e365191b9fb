// Internal: the honest held-out error of candidate models of step 2 (docs/calibrate.md,
// "The model search"). A candidate is a set of parameters and an estimator (least
// squares, the significance cut, the tolerance prior); its held-out error is
// that of the whole estimator, re-run on each fold's training poses (the cut's
// elimination and the prior's evidence included), on the problem linearised at
// a fit. Folds are of units (a pose with its repeats, or a fixture's group of
// labels), repeated with other shuffles where the units are few.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "identification/problem/stack.hpp"
#include "identification/search/prior.hpp"

namespace hapticcal::detail {

// A normal matrix (equilibrated to a unit diagonal) with a pivot below this is
// singular: the poses cannot determine the parameters. A fold's normal matrix
// is the whole one less the fold's rows, so a singular one keeps pivots of
// rounding size (~1e-16); a Meca500 set's (condition number up to 1500 of the
// scaled Jacobian) has pivots above 1e-7.
constexpr double kSingularPivot = 1e-12;
// The solution of G x = b for a symmetric positive semi-definite G, and G's
// inverse; nothing if G is numerically singular.
std::optional<Eigen::VectorXd> solve_normal(const Eigen::MatrixXd& G, const Eigen::VectorXd& b);
std::optional<Eigen::MatrixXd> inverse_normal(const Eigen::MatrixXd& G);

// Step 2 linearised at a fit, its columns scaled (an angle's by the length
// scale): residuals r + A x for a change x of the columns.
struct HeldOutSystem {
  Eigen::MatrixXd A;
  Eigen::VectorXd r;
  Eigen::VectorXd measuring;  // per row: 1 if it measures a distance or position, else 0
  // The rows of each unit a fold holds out together, and the unknowns (a
  // fixture's eliminated points) each takes with it.
  std::vector<std::vector<Eigen::Index>> unit_rows;
  std::vector<double> unit_unknowns;
  double rows = 1;       // the log rows behind the poses: the RMS's denominator
  double dof_rows = 0;   // residual rows less the unknowns
  Eigen::VectorXd back;  // per column: the change that takes it back to its start
  // Per column: the prior's tolerance (scaled), infinite for a free column.
  Eigen::VectorXd tolerance;
  std::vector<int> slots;  // per column: its slot in step 2's vector
};

// One candidate on a system: the columns it estimates (the others stay at
// their start) and how.
struct LinearCandidate {
  std::vector<int> fitted;  // column positions
  Estimator estimator = Estimator::kLeastSquares;
};

// An estimator's change of every column (held ones: back to their start) on
// normal equations over `dof_rows` residual freedoms, and its (effective)
// number of parameters; none if the equations cannot determine it.
struct LinearEstimate {
  Eigen::VectorXd x;
  double parameters = 0;
  std::vector<int> kept;  // the columns estimated (the cut's survivors), positions
};
std::optional<LinearEstimate> estimate(const NormalEquations& ne, double dof_rows,
                                       const HeldOutSystem& system,
                                       const LinearCandidate& candidate, double alpha,
                                       std::optional<double> prior_scale);

// The folds of the units: `folds` of them (at most the units), drawn anew for
// each of `repeats` shuffles from `seed`.
struct FoldPlan {
  int folds = 5;
  int repeats = 1;
  std::uint64_t seed = 1;
};
// The plan for `units` units: 5 folds (fewer units: one a fold), repeated
// until about kHeldOutPredictions units are predicted (at most kMaxRepeats).
FoldPlan fold_plan(int units, std::uint64_t seed);
constexpr int kHeldOutPredictions = 1000;
constexpr int kMaxRepeats = 20;

// Each candidate's held-out squared errors (measuring rows) per unit, the mean
// over the repeats; empty where a fold cannot determine the candidate.
std::vector<Eigen::VectorXd> held_out_errors(const HeldOutSystem& system,
                                             const std::vector<LinearCandidate>& candidates,
                                             const FoldPlan& plan, double alpha,
                                             std::optional<double> prior_scale);

// The system of a fit: `columns` (slots) of the stack `at`, scaled by `scale`
// per slot; `start` and `solution` the parameter vectors (back = start -
// solution, scaled); `tolerance` per slot (infinite: free); the units: a pose
// each (fixture problems: the groups of labels a known distance joins).
HeldOutSystem held_out_system(const KinematicProblem& problem, const Stack& at,
                              const std::vector<int>& columns, const Eigen::VectorXd& scale,
                              const Eigen::VectorXd& start, const Eigen::VectorXd& solution,
                              const Eigen::VectorXd& tolerance);

}  // namespace hapticcal::detail
