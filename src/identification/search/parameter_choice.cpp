// What step 2 changes: least squares (--keep-all), the significance cut
// (--select, the model selection) or the tolerance prior (prior.cpp); the
// model search (model_search.cpp) chooses between them by held-out error.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "identification/calibration_run.hpp"
#include "identification/search/prior.hpp"

namespace hapticcal::detail {
namespace {

// A note names at most this many parameters (a tree of 32 tips holds hundreds).
constexpr size_t kNamesInANote = 20;

// The fit again with the parameters the selection held back at their start: from
// the full fit, a few iterations (none if the selection kept nothing).
KinematicSolution refit_selected(const CalibrationRun& run, const ModelSelection& selection,
                                 const std::vector<int>& held) {
  const Eigen::VectorXd start = run.problem.model.kinematic_parameters();
  KinematicSolution refit;
  if (selection.kept.empty()) {
    // The data support no change from the model: it stays as it is.
    refit.parameters = start;
    refit.termination = SolveTermination::kConverged;
    refit.message = "model selection: no parameter changed";
    return refit;
  }
  KinematicProblem warm = run.problem;
  Eigen::VectorXd from = run.solution.parameters;
  for (int slot : held) from[slot] = start[slot];
  warm.model.set_kinematic_parameters(from);
  return solve_kinematics(warm, selection.kept, run.iterations);
}

// The tolerance prior (the default): every identifiable parameter, and those
// these poses do not excite, pulled toward nominal by its tolerance at the
// scale of highest evidence (MAP); the least-squares fit stays if it cannot be formed.
void apply_prior(CalibrationRun& run) {
  PriorFit& prior = run.fit().prior;
  if (run.solution.termination != SolveTermination::kConverged) {
    prior.note = "not applied: the least-squares fit did not converge";
    return;
  }
  if (run.problem.compressed) {
    prior.note = "not applied: the log is too long for it (compressed Jacobian)";
    run.result.notes.push_back("tolerance prior " + prior.note);
    return;
  }
  std::vector<int> slots = run.identified;
  for (const auto& [slot, why] : run.reason) {
    if (unexcited(why) && std::isfinite(run.tolerance[slot])) slots.push_back(slot);
  }
  // The start's angles within pi of nominal: the prior measures the change from it.
  KinematicSolution start = run.solution;
  start.parameters =
      angles_near(run.problem.model, start.parameters, run.problem.model.kinematic_parameters());
  std::string why_not;
  const double rows = static_cast<double>(run.data.residuals - run.problem.labels.unknowns());
  std::optional<detail::PriorSolution> map =
      detail::solve_with_prior(run.problem, slots, run.tolerance, start, run.data, rows,
                               run.options.tolerances.scale, run.iterations, why_not);
  if (!map) {
    prior.note = "not applied: " + why_not;
    run.result.notes.push_back("tolerance prior " + prior.note + "; least squares kept");
    return;
  }
  for (int slot : slots) run.reason.erase(slot);
  run.identified = slots;
  run.solution = map->solution;
  run.data = map->data;
  run.prior_weight = map->weight;
  run.data_share = map->data_share;
  prior = map->fit;
  run.prior_scale = prior.scale;
  run.fit().rank_deficient = std::any_of(run.reason.begin(), run.reason.end(),
                                         [](const auto& r) { return unexcited(r.second); });
  std::vector<int> by_prior;
  for (int slot : slots) {
    if (run.data_share[slot] < 0.5) by_prior.push_back(slot);
  }
  run.result.notes.push_back(fmt::format(
      "tolerance prior: scale {:.3g} of the tolerances (highest evidence), {:.1f} effective "
      "parameters of the {} estimated{}",
      prior.scale, prior.effective_parameters, slots.size(),
      by_prior.empty() ? std::string()
                       : "; set by the prior (the data do not see them): " +
                             names_of(by_prior, run.name, kNamesInANote)));
}

// Model selection: hold what the data do not support, and fit again.
void select_parameters(CalibrationRun& run) {
  KinematicFit& fit = run.fit();
  const int selection_folds = run.options.folds >= 2 ? run.options.folds : kDefaultFolds;
  if (run.solution.termination != SolveTermination::kConverged) {
    fit.selection_note = "skipped: the fit of every identifiable parameter did not converge";
    return;
  }
  if (run.problem.compressed) {
    fit.selection_note = "skipped: the log is too long for per-pose fits (compressed Jacobian)";
    run.result.notes.push_back("model selection " + fit.selection_note);
    return;
  }
  const ModelSelection selection =
      detail::select_model(run.problem, run.identified, run.solution.parameters, run.data,
                           run.options.selection_alpha, selection_folds, run.options.seed);
  fit.model_selection = true;
  fit.selection_folds = std::min(selection_folds, run.m);
  fit.selection_path = selection.path;
  if (selection.kept.size() >= run.identified.size()) return;
  std::vector<int> held;
  for (const auto& [slot, why] : selection.reason) held.push_back(slot);
  const KinematicSolution refit = refit_selected(run, selection, held);
  if (refit.termination != SolveTermination::kConverged) {
    fit.model_selection = false;
    fit.selection_note =
        "its re-fit did not converge (" + refit.message + "): every identifiable parameter kept";
    run.result.notes.push_back("model selection: " + fit.selection_note);
    return;
  }
  run.identified = selection.kept;
  run.solution = refit;
  run.held_by_selection = held;
  for (const auto& [slot, why] : selection.reason) run.reason[slot] = why;
  run.data = stack(run.model.structure(), run.solution.parameters, run.problem.joints, run.kind(),
                   run.problem.measured, run.problem.weights);
  run.result.notes.push_back(fmt::format(
      "model selection held {} of the {} identifiable parameters at nominal (not supported "
      "by these data; --keep-all keeps them): {}",
      held.size(), fit.structurally_identified, names_of(held, run.name, kNamesInANote)));
}

}  // namespace

// The K-fold cross-validated RMS of the run's fit (with the prior's rows if it
// has them); NaN with the reason when it cannot be computed.
CrossValidation held_out(const CalibrationRun& run) {
  if (run.solution.termination != SolveTermination::kConverged) {
    CrossValidation none;
    none.note = "not computed: the fit did not converge";
    return none;
  }
  const Eigen::VectorXd centre = run.problem.model.kinematic_parameters();
  return detail::cross_validate(
      run.problem, run.identified,
      run.prior_weight.size()
          ? detail::with_prior_rows(run.data, run.prior_weight, run.solution.parameters - centre)
          : run.data,
      run.options.folds >= 2 ? run.options.folds : kDefaultFolds, run.options.seed);
}

void apply_estimator(CalibrationRun& run, Estimator estimator) {
  KinematicFit& fit = run.fit();
  fit.estimator = estimator;
  switch (estimator) {
    case Estimator::kLeastSquares:
      fit.selection_note = "off: least squares";
      return;
    case Estimator::kCut:
      select_parameters(run);
      return;
    case Estimator::kPrior:
      fit.selection_note = "off: the tolerance prior";
      apply_prior(run);
      return;
  }
}

}  // namespace hapticcal::detail
