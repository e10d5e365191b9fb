// Internal: the stacked residuals and identification Jacobian of step 2 at
// given parameters, for the fit's statistics, the model selection and the
// cross-validation.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/measurement_cost.hpp"

namespace hapticcal::detail {

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

// The rows of a problem: its measurement type, rotation scale and fixture labels.
inline RowsOf rows_of(const KinematicProblem& problem) {
  return {problem.type, problem.rotation_scale,
          is_fixture(problem.type) ? &problem.labels : nullptr};
}

// select_model and cross_validate (identification.hpp) at a fit whose stack
// (not compressed) is `at`.
ModelSelection select_model(const KinematicProblem& problem, const std::vector<int>& identified,
                            const Eigen::VectorXd& solution, const Stack& at, double alpha,
                            int folds, std::uint64_t seed);
CrossValidation cross_validate(const KinematicProblem& problem, const std::vector<int>& identified,
                               const Stack& at, int folds, std::uint64_t seed);

}  // namespace hapticcal::detail
