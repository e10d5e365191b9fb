// Internal: the tolerance prior of step 2 (docs/calibrate.md, "Step 2's estimators"): each link
// parameter's change from nominal is a priori normal, sd = scale x its
// tolerance; the scale is the one that maximises the evidence (the marginal
// likelihood of the measurements) of the problem linearised at a fit.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "identification/problem/stack.hpp"

namespace hapticcal::detail {

// The linear-Gaussian model behind the evidence, at a fit x_c: residuals
// r(x) = r_c + J (x - x_c) with noise sd sigma, and for each prior column j
// (x_j - x0_j) ~ N(0, (scale t_j)^2); the other columns are free (a flat
// prior: the set-up's base, tool, instrument zero). With lambda = (sigma /
// scale)^2 the MAP solves (J^T J + lambda T^-2) dx = ..., T the tolerances.
struct PriorChoice {
  double lambda = 0;  // (sigma / scale)^2: the weight of the prior rows
  double scale = std::numeric_limits<double>::quiet_NaN();
  double sigma =
      std::numeric_limits<double>::quiet_NaN();  // noise sd at the evidence's optimum [m]
  double log_evidence = std::numeric_limits<double>::quiet_NaN();  // profiled over sigma
  // Per column of `slots`: 1 - lambda (H + lambda P)^-1_jj in tolerance units,
  // how much the data (not the prior) determine it (1 for free columns).
  Eigen::VectorXd data_share;
  double effective = 0;  // sum of data_share: the parameters the data pay for
  // The profile log evidence over log10(lambda), for the report's figure.
  std::vector<std::pair<double, double>> curve;
  // The MAP's change of each column from the fit (the linearised problem's).
  Eigen::VectorXd step;
};

// The normal equations of min |r + J dx|^2 over some columns: G = J^T J,
// g = J^T r, rr = |r|^2.
struct NormalEquations {
  Eigen::MatrixXd G;
  Eigen::VectorXd g;
  double rr = 0;
};

// Chooses lambda by maximising the evidence profiled over the noise sd (a grid
// over log lambda, refined by golden section), or from a given scale (sigma at
// its optimum for that scale). `tolerance` per column of `slots`: infinite for
// a free column. `deviation` per column: x_c - x0. `rows`: the residual rows
// (less a fixture's eliminated unknowns). Nothing if the free columns are
// singular or there are no more rows than free columns.
std::optional<PriorChoice> choose_prior(const Stack& at, const std::vector<int>& slots,
                                        const Eigen::VectorXd& tolerance,
                                        const Eigen::VectorXd& deviation, double rows,
                                        std::optional<double> scale);
// The same on the normal equations of the columns (tolerance and deviation per
// column of `ne`).
std::optional<PriorChoice> choose_prior(const NormalEquations& ne, const Eigen::VectorXd& tolerance,
                                        const Eigen::VectorXd& deviation, double rows,
                                        std::optional<double> scale);

// The prior's rows appended to a stack over every slot: sqrt(lambda) (x_j - x0_j)
// / t_j for each prior column j (`weight` per slot: sqrt(lambda) / t_j, 0 for
// none; `deviation` per slot). The rows belong to no pose: cross-validation
// keeps them in every training set.
Stack with_prior_rows(const Stack& at, const Eigen::VectorXd& weight,
                      const Eigen::VectorXd& deviation);

// Per slot of the model: its tolerance from `t` (by name, else by family for a
// link's parameter), infinite for a free one (base, tool, instrument zero).
// Throws InputError for a name in t.by_name that is not a parameter.
Eigen::VectorXd slot_tolerances(const DeviceModel& model, const Tolerances& t);

// The MAP fit of `slots` under the prior: rounds of choose_prior at the
// current fit and Levenberg-Marquardt with the prior's rows from it, starting at
// the least-squares fit `start` (`at` its stack), until lambda moves less than
// 5 % (at most kPriorRounds). Nothing, with the reason, if the evidence cannot
// be formed or a solve does not converge.
struct PriorSolution {
  KinematicSolution solution;
  Stack data;                  // at the solution: the measurements' rows
  Eigen::VectorXd weight;      // per slot: sqrt(lambda) / tolerance (0: none)
  Eigen::VectorXd data_share;  // per slot (NaN: not estimated)
  PriorFit fit;
};
std::optional<PriorSolution> solve_with_prior(const KinematicProblem& problem,
                                              const std::vector<int>& slots,
                                              const Eigen::VectorXd& tolerance,
                                              const KinematicSolution& start, const Stack& at,
                                              double rows, std::optional<double> scale,
                                              int iterations, std::string& why_not);

}  // namespace hapticcal::detail
