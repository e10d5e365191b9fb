// Internal: the stacked residuals and identification Jacobian of step 2 at
// given parameters, for the fit's statistics, the model selection and the
// cross-validation.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/problem/measurement_cost.hpp"

namespace ceres {
class CostFunction;
}

namespace hapticcal::detail {

// The cost Levenberg-Marquardt minimises over these poses: every row, or its
// compressed form (identification.cpp).
ceres::CostFunction* measurement_cost(const ChainStructure& s,
                                      const std::vector<Eigen::VectorXd>& joints,
                                      const RowsOf& kind, const RowMatrix& measured,
                                      const Eigen::VectorXd& weights, bool compressed);
// What the model at `params` predicts for these joint values: measurements
// without error (for the structural analysis, whose rows need a measured value).
RowMatrix predicted_values(const ChainStructure& s, const Eigen::VectorXd& params,
                           const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind);
// The parameter names of `slots`, comma-separated; beyond `limit`, how many more.
std::string names_of(const std::vector<int>& slots, const std::map<int, std::string>& name,
                     size_t limit = std::numeric_limits<size_t>::max());
// RMS of the per-measurement error, as `evaluate` reports it: the distance error,
// or the Euclidean norm of the position error. `rows` the log rows behind the
// residuals (their weights' sum of squares).
double measurement_rms(double rss, double rows);
// Checks of a log before it is fitted (input_checks.cpp). Readings outside the
// model's joint limits: an InputError when most of a joint's readings are out
// (a unit missing from the header, or another device), unless forced; a warning
// otherwise.
// RMS scatter of a pose's genuine repeats about their mean (identification.cpp).
double repeatability(const Log& log, const std::vector<std::vector<int>>& poses,
                     MeasurementType type);
void check_joint_limits(const Log& log, const DeviceModel& model, bool force,
                        std::vector<std::string>& notes);
// An external encoder's reading beyond any joint's travel: bad input naming its line.
void check_encoder_readings(const Log& log);
// A nominal error beyond kImplausibleErrorFraction of the reach, even with the
// base pose (then also the tool point) fitted: an InputError unless forced.
void check_reach(const ChainStructure& s, const DeviceModel& nominal,
                 const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                 const RowMatrix& measured, const Eigen::VectorXd& weights, double rows,
                 bool compressed, double rms_before, bool force, std::vector<std::string>& notes);
// One candidate's fate in the greedy rank test (identifiability.cpp).
struct RankVerdict {
  enum Kind { kIdentified, kNoEffect, kDependent } kind = kIdentified;
  std::vector<int> on;  // slots it depends on
};
// Greedy rank test in priority order on scale-free (unit) columns: a column
// with no effect, or whose part outside the span of the columns accepted before
// it is below `tolerance` of its norm, is held.
std::map<int, RankVerdict> rank_test(const Eigen::MatrixXd& J, const std::vector<int>& order,
                                     double tolerance);
// Why a beta is not a candidate (identifiability.cpp).
std::string beta_left_out_reason(const DeviceModel& model, int link);

// The stacked residuals and identification Jacobian at `params`; compressed
// (detail::compress_rows) for logs whose Jacobian would not fit in memory.
// Every residual row is weighted by its pose's detail::weigh weight, the
// square root of its repeat count (none: all 1).
struct Stack {
  Eigen::VectorXd r;  // every (weighted) residual; empty when compressed
  Eigen::MatrixXd J;  // rows x slots; when compressed R (slots x slots): same column geometry
  double rss = 0;     // sum of the squared weighted residuals
  Eigen::Index residuals = 0;  // rows of the fit: poses x residuals a pose
};
Stack stack(const ChainStructure& s, const Eigen::VectorXd& params,
            const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
            const RowMatrix& measured, const Eigen::VectorXd& weights, bool compressed = false);

// The residuals alone, weighted.
Eigen::VectorXd residuals_at(const ChainStructure& s, const Eigen::VectorXd& params,
                             const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                             const RowMatrix& measured, const Eigen::VectorXd& weights);

// The squared residuals that measure a position or distance error: all of them,
// but of a pose only its position rows (its rotation rows are reported apart).
double position_rss(const Eigen::VectorXd& r, const RowsOf& kind);
// A tree's measurement RMS a tip (the rows of its poses; measurement_rms of
// each, its rows the poses' repeats: `repeat_weights` sqrt(repeats) a pose, as
// before any robust reweighting); empty for a chain.
std::vector<double> tip_rms(const KinematicProblem& problem, const Eigen::VectorXd& r,
                            const RowsOf& kind, const Eigen::VectorXd& repeat_weights);

// The rows of a problem: its measurement type, rotation scale and fixture labels.
inline RowsOf rows_of(const KinematicProblem& problem) {
  return {problem.type,
          problem.rotation_scale,
          problem.labelled() ? &problem.labels : nullptr,
          problem.joint_errors.empty() ? nullptr : &problem.joint_errors,
          problem.bends,
          problem.tip};
}

// The unit each pose is held out with (0, 1, ...): itself, or a tree's
// samples of one pose (its tips, consecutive: tip_samples) together.
std::vector<int> pose_units(const KinematicProblem& problem);
// Each pose's fold (pose_folds over the units).
std::vector<int> unit_folds(const KinematicProblem& problem, int folds, std::uint64_t seed);

// select_model and cross_validate (identification.hpp) at a fit whose stack
// (not compressed) is `at`.
ModelSelection select_model(const KinematicProblem& problem, const std::vector<int>& identified,
                            const Eigen::VectorXd& solution, const Stack& at, double alpha,
                            int folds, std::uint64_t seed);
CrossValidation cross_validate(const KinematicProblem& problem, const std::vector<int>& identified,
                               const Stack& at, int folds, std::uint64_t seed);

}  // namespace hapticcal::detail
