// The model search's yardsticks (model_search.hpp): what a candidate must beat
// to be usable (the nominal model with the set-up registered, held out as the
// candidates are), whether an instrument's zero is supported, and step 1's own
// held-out check.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "identification/calibration_run.hpp"
#include "identification/problem/stack.hpp"
#include "identification/search/model_search.hpp"

namespace hapticcal::detail::search {

void Search::nominal_yardstick(const CalibrationRun& geometry) {
  const ChainStructure s = geometry.problem.model.structure();
  std::vector<int> free;
  std::vector<std::string> what;
  // The set-up's parameters the geometry's fit identified (a candidate the
  // rank test held would leave a fold's equations singular).
  const auto candidate = [&](int slot) {
    return std::find(geometry.identified.begin(), geometry.identified.end(), slot) !=
           geometry.identified.end();
  };
  bool base = false, tool = false;
  for (int k = 0; k < s.base_slots(); ++k) {
    if (candidate(k)) free.push_back(k), base = true;
  }
  for (int k = s.tool_slot(); k < s.instrument_slot(); ++k) {  // every tip's tool
    if (candidate(k)) free.push_back(k), tool = true;
  }
  if (s.instrument && candidate(s.instrument_slot())) free.push_back(s.instrument_slot());
  if (base) what.push_back("measurement frame");
  if (tool) what.push_back("tool");
  if (s.instrument && candidate(s.instrument_slot())) what.push_back("instrument zero");
  out_.nominal_fitted = fmt::format("{}", fmt::join(what, ", "));
  Eigen::VectorXd registered;
  nominal_rms_with(geometry, free, &registered);
  // Its held-out error: the set-up refitted on each fold's training poses
  // (the problem linearised at its registration), as every candidate's.
  DeviceModel model = geometry.step2_nominal;
  model.base = geometry.problem.model.base;
  const Stack at = stack(model.structure(), registered, geometry.nominal_joints, geometry.kind(),
                         geometry.problem.measured, geometry.problem.weights);
  nominal_.family_fit = -1;
  const HeldOutSystem system =
      held_out_system(geometry.problem, at, free, geometry.scale, registered, registered,
                      Eigen::VectorXd::Constant(registered.size(), kFreeColumn));
  LinearCandidate setup;
  setup.fitted.resize(free.size());
  std::iota(setup.fitted.begin(), setup.fitted.end(), 0);
  nominal_.unit_error = held_out_errors(system, {setup}, plan_, base_.options.selection_alpha,
                                        base_.options.tolerances.scale)
                            .front();
  if (nominal_.unit_error.size()) nominal_.mse = nominal_.unit_error.sum() / system.rows;
  out_.nominal_rms = std::sqrt(nominal_.mse);
}

// The held-out error cannot tell an instrument's zero from the device's
// lengths: both predict the instrument's readings, but the calibrated model
// leaves the zero out. Its Student t on the geometry's least-squares fit
// decides (the significance cut's family-wise threshold over the parameters
// fitted): a zero the data do not support is held, so that the device does
// not carry a noise the instrument was given.
void Search::test_zero(const FamilyFit& geometry) {
  if (space_.zero.size() != 2 || geometry.zero_column < 0) return;
  const HeldOutSystem& s = geometry.system;
  const auto columns =
      std::vector<Eigen::Index>(geometry.least_squares.begin(), geometry.least_squares.end());
  const Eigen::MatrixXd A = s.A(Eigen::all, columns);
  const std::optional<Eigen::MatrixXd> inverse = inverse_normal(A.transpose() * A);
  if (!inverse) return;
  const auto at = std::find(columns.begin(), columns.end(), geometry.zero_column) - columns.begin();
  const double dof = s.dof_rows - static_cast<double>(columns.size());
  const double sigma = std::sqrt(s.r.squaredNorm() / std::max(dof, 1.0));
  const double sd = sigma * std::sqrt((*inverse)(at, at));
  const double t = std::abs(s.back[geometry.zero_column]) / sd;
  const double threshold =
      significance_threshold(base_.options.selection_alpha, static_cast<int>(columns.size()), dof);
  if (t >= threshold) return;
  space_.zero = {false};
  notes_.push_back(fmt::format(
      "the instrument's zero, {:+.4f} +- {:.4f} mm ({:.2f} sd, below the threshold of {:.2f} sd), "
      "is not supported by these data: held at 0 in every candidate (--free instrument.zero "
      "fits it)",
      -s.back[geometry.zero_column] * 1e3, sd * 1e3, t, threshold));
}

// A step 1 that is no description of the device (an external encoder that
// reads another angle than its joint's) is absorbed by bending the geometry,
// which then predicts held-out poses worse than the geometry fitted to the
// readings through the nominal's transmissions. Refused when worse by more
// than kStepOneMargin and kStepOneSds standard errors (paired over the units):
// a step 1 that fits noise makes no such difference.
// The held-out squared errors per unit of family fit `f`'s geometry and
// families by least squares (the instrument's zero as the space's first
// choice); empty if not computable.
Eigen::VectorXd Search::least_squares_errors(const FamilyFit& f) const {
  LinearCandidate c;
  c.fitted = f.least_squares;
  if (f.zero_column >= 0 && !space_.zero.front()) std::erase(c.fitted, f.zero_column);
  return held_out_errors(f.system, {c}, plan_, base_.options.selection_alpha,
                         base_.options.tolerances.scale)
      .front();
}

void Search::check_step_one(const FamilyFit& kept) {
  if (base_.result.transmissions.empty() || !base_.options.transmissions) return;
  if (kept.least_squares_error.size() == 0) return;
  std::string note;
  const FamilyFit plain = fit_families(kept.families, false, note, &base_.nominal);
  if (!note.empty() || plain.system.unit_rows.size() != kept.system_units) return;
  Entry with, without;
  with.unit_error = kept.least_squares_error;
  without.unit_error = least_squares_errors(plain);
  if (without.unit_error.size() == 0) return;
  with.mse = with.unit_error.sum() / rows_;
  without.mse = without.unit_error.sum() / rows_;
  out_.with_step_one_rms = std::sqrt(with.mse);
  out_.without_step_one_rms = std::sqrt(without.mse);
  const double se = difference_se(with, without, rows_);
  step_one_failed_ = with.mse > kStepOneMargin * kStepOneMargin * without.mse &&
                     with.mse - without.mse > kStepOneSds * se;
}

// SE of the difference of two candidates' held-out MSE, paired over the units.
double difference_se(const Entry& a, const Entry& b, double rows) {
  const Eigen::ArrayXd d = (a.unit_error - b.unit_error).array();
  const double units = static_cast<double>(d.size());
  return std::sqrt(units * (d - d.mean()).square().sum() / std::max(units - 1, 1.0)) / rows;
}

// A pose held out cannot hide in the fit: where the poses are too few for the
// fit's own outlier test (robust.cpp: fewer residual freedoms than parameters),
// each pose's held-out RMS component under the kept candidate is compared with
// the poses' robust scale, the median component over the normal's median
// (sqrt(chi^2_d(1/2) / d)). Beyond the Bonferroni quantile over the poses, and
// at least kHeldOutFloor scales, a pose is named.
void Search::held_out_outliers(const Entry& kept) {
  const CalibrationRun& run = *fits_.front().run;
  const KinematicProblem& problem = run.problem;
  if (out_.unit != "pose" || kept.unit_error.size() == 0) return;  // a fixture: groups
  const std::vector<int> unit = pose_units(problem);
  const Eigen::Index units = kept.unit_error.size();
  // Measured rows a sample (a tree's tips are a pose's samples).
  const double d = out_.measured_rows / static_cast<double>(problem.joints.size());
  // Where the fit's own test ran, only on few poses (fewer than three measured
  // rows a parameter): there it has the freedoms, but a pose still pulls the
  // fit towards itself.
  const bool few = out_.measured_rows < 3.0 * static_cast<double>(run.identified.size());
  if (run.fit().robust.tested && !(few && run.fit().robust.outliers.empty())) return;
  std::vector<double> rows_of(static_cast<size_t>(units), 0), component(rows_of.size());
  for (int u : unit) rows_of[static_cast<size_t>(u)] += d;
  for (Eigen::Index u = 0; u < units; ++u) {
    const size_t k = static_cast<size_t>(u);
    component[k] = std::sqrt(kept.unit_error[u] / std::max(rows_of[k], 1.0));
  }
  std::vector<double> sorted = component;
  std::nth_element(sorted.begin(), sorted.begin() + units / 2, sorted.end());
  const double scale =
      sorted[static_cast<size_t>(units / 2)] / std::sqrt(chi_square_quantile(0.5, d) / d);
  if (!(scale > 0)) return;
  out_.outlier_threshold = std::max(
      std::sqrt(
          chi_square_quantile(1 - base_.options.outlier_alpha / static_cast<double>(units), d) / d),
      kHeldOutFloor);
  for (Eigen::Index u = 0; u < units; ++u) {
    const double statistic = component[static_cast<size_t>(u)] / scale;
    if (!(statistic > out_.outlier_threshold)) continue;
    ModelSearch::HeldOutOutlier o;
    o.error = component[static_cast<size_t>(u)];
    o.statistic = statistic;
    for (size_t i = 0; i < unit.size(); ++i) {
      if (unit[i] != u) continue;
      const std::vector<int>& rows = run.result.poses[i];
      o.rows.insert(o.rows.end(), rows.begin(), rows.end());
    }
    std::sort(o.rows.begin(), o.rows.end());
    out_.outliers.push_back(std::move(o));
  }
}

}  // namespace hapticcal::detail::search
