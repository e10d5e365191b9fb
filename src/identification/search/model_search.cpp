// The model search (docs/calibrate.md, "The model search"): calibrate's candidate models -
// an estimator (the tolerance prior, the significance cut, least squares) x
// the joint-error families that apply x an instrument's zero held or fitted -
// compared by their honest held-out error (held_out.hpp), the simplest within
// one standard error of the best kept, and that one concluded. Families are
// added forward: each round offers every family not yet in the kept set, and
// the search stops when the kept model is not one of the new round's.
#include "identification/search/model_search.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <thread>
#include <tuple>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/parallel.hpp"
#include "hapticcal/identification/identification.hpp"
#include "identification/calibration_run.hpp"
#include "identification/problem/solver_options.hpp"
#include "identification/search/held_out.hpp"

namespace hapticcal {

const char* to_string(Estimator estimator) {
  switch (estimator) {
    case Estimator::kPrior:
      return "tolerance prior";
    case Estimator::kCut:
      return "significance cut";
    case Estimator::kLeastSquares:
      return "least squares";
  }
  return "?";
}

namespace detail::search {

// A family's note as the user reads it: one the search chose, where the user
// named none or others (--joint-errors), says so instead of naming the option.
void chosen_family_notes(std::vector<std::string>& notes, const std::vector<std::string>& named) {
  constexpr std::string_view kOption = "--joint-errors ";
  for (std::string& note : notes) {
    if (!note.starts_with(kOption)) continue;
    const std::size_t end = note.find(':', kOption.size());
    if (end == std::string::npos) continue;
    const std::string family = note.substr(kOption.size(), end - kOption.size());
    if (std::find(named.begin(), named.end(), family) != named.end()) continue;
    note = fmt::format("{} (kept by the model search){}", family, note.substr(end));
  }
}

bool names_it(const std::vector<std::string>& names, const char* name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

SearchSpace search_space(const CalibrationRun& run) {
  const CalibrationOptions& o = run.options;
  SearchSpace space;
  if (o.keep_all) {
    space.estimators = {Estimator::kLeastSquares};
  } else if (o.select) {
    space.estimators = {Estimator::kCut};
  } else if (o.prior || o.tolerances.scale) {
    space.estimators = {Estimator::kPrior};
  } else {
    space.estimators = {Estimator::kPrior, Estimator::kCut, Estimator::kLeastSquares};
  }
  if (run.zero_offered()) {
    if (names_it(o.fix, "instrument.zero")) {
      space.zero = {false};
    } else if (names_it(o.free, "instrument.zero")) {
      space.zero = {true};
    } else {
      space.zero = {true, false};
    }
  }
  space.families_fixed = !o.joint_errors.empty();
  space.families = o.joint_errors.empty()             ? applicable_families(run)
                   : o.joint_errors.front() == "none" ? std::vector<std::string>{}
                                                      : o.joint_errors;
  return space;
}

std::string model_words(const std::vector<std::string>& families) {
  return families.empty() ? "geometry"
                          : "geometry + " + fmt::format("{}", fmt::join(families, " + "));
}

// A family fit once judged: its system and its stack go (restack brings the
// stack back for the one concluded).
void release(FamilyFit& f) {
  f.system_units = f.system.unit_rows.size();
  f.system = HeldOutSystem();
  if (f.run) f.run->data = Stack();
}

void Search::family_names() {
  if (space_.families.empty()) return;
  CalibrationRun scratch(base_);
  scratch.options.joint_errors = space_.families;
  try {
    offer_joint_errors(scratch);
  } catch (const InputError&) {
    return;  // the family set's own fit says why
  }
  for (const ParameterInfo& pi : scratch.model.parameter_info()) {
    if (pi.block == ParameterBlock::kJointError) family_of_[pi.name] = pi.family;
  }
}

FamilyFit Search::fit_families(const std::vector<std::string>& families, bool first,
                               std::string& note, const DeviceModel* transmissions) const {
  FamilyFit f;
  f.families = families;
  CalibrationOptions o = base_.options;
  o.joint_errors = families.empty() ? std::vector<std::string>{"none"} : families;
  // Names of another family's parameters name nothing in this model.
  const auto elsewhere = [&](const std::string& name) {
    const auto it = family_of_.find(name);
    return it != family_of_.end() && !names_it(families, it->second.c_str());
  };
  std::erase_if(o.fix, elsewhere);
  std::erase_if(o.free, elsewhere);
  std::erase_if(o.tolerances.by_name, [&](const auto& item) { return elsewhere(item.first); });
  if (space_.zero.size() == 2) std::erase(o.fix, "instrument.zero");
  if (!transmissions && names_it(families, "coupling") &&
      !names_it(base_.options.joint_errors, "coupling") && o.transmissions &&
      !base_.result.transmissions.empty()) {
    // Step 1 again: the encoders of joints whose angle uses another joint's
    // reading read the coefficients this family fits (encoders_at_readings).
    f.run = std::make_unique<CalibrationRun>(base_.nominal, base_.log, o);
    f.run->result.notes.assign(base_.result.notes.begin(),
                               base_.result.notes.begin() + static_cast<long>(base_.checks_notes));
    step_one(*f.run);
  } else {
    f.run = std::make_unique<CalibrationRun>(base_);
    f.run->options = o;
    if (transmissions) f.run->model = *transmissions;  // another step 1's
  }
  // Families start from the geometry's fit (the same slots first); another
  // step 1's transmissions from the nominal.
  const Eigen::VectorXd start = first || transmissions ? Eigen::VectorXd() : geometry_solution_;
  if (first) {
    prepare_model(*f.run, start, kSearchTolerance);  // bad input is bad input
  } else {
    try {
      prepare_model(*f.run, start, kSearchTolerance);
    } catch (const InputError& e) {
      note = fmt::format("{} not compared: {}", model_words(families), e.what());
      f.run.reset();
      return f;
    }
  }
  CalibrationRun& r = *f.run;
  if (r.solution.termination != SolveTermination::kConverged || r.problem.compressed) {
    note = fmt::format("{} not compared: {}", model_words(families),
                       r.problem.compressed ? "the log is too long for per-pose fits"
                                            : "its least-squares fit did not converge");
    return f;
  }
  std::vector<int> columns = r.identified;
  for (const auto& [slot, why] : r.reason) {
    if (unexcited(why) && std::isfinite(r.tolerance[slot])) {
      columns.push_back(slot);
      f.unexcited = true;
    }
  }
  const std::vector<ParameterInfo> info = r.problem.model.parameter_info();
  for (size_t c = 0; c < columns.size(); ++c) {
    (c < r.identified.size() ? f.least_squares : f.with_prior).push_back(static_cast<int>(c));
    if (r.name.at(columns[c]) == "instrument.zero") f.zero_column = static_cast<int>(c);
    f.column_family.push_back(info[columns[c]].family);
  }
  f.with_prior.insert(f.with_prior.begin(), f.least_squares.begin(), f.least_squares.end());
  f.system =
      held_out_system(r.problem, r.data, columns, r.scale, r.problem.model.kinematic_parameters(),
                      r.solution.parameters, r.tolerance);
  return f;
}

void Search::round(const std::vector<std::vector<std::string>>& sets, bool named) {
  std::vector<FamilyFit> fits(sets.size());
  std::vector<std::vector<Entry>> judged(sets.size());
  std::vector<std::string> notes(sets.size());
  const int first = static_cast<int>(fits_.size());
  const auto work = [&](size_t i) {
    throw_if_cancelled();
    fits[i] = fit_families(sets[i], named, notes[i]);
    if (notes[i].empty()) {
      judged[i] = judge(fits[i], first + static_cast<int>(i), true);
      fits[i].least_squares_error = least_squares_errors(fits[i]);
    }
    release(fits[i]);
  };
  // Several at once unless one fit's Jacobian is large (memory grows with each).
  const FamilyFit& geometry = fits_.front();
  const double bytes = 8.0 * static_cast<double>(geometry.run->problem.joints.size()) *
                       rows_of(geometry.run->problem).dimension() *
                       geometry.run->problem.model.structure().num_slots();
  const size_t cores = base_.options.threads > 0
                           ? static_cast<size_t>(base_.options.threads)
                           : std::max(1u, std::thread::hardware_concurrency());
  const size_t threads = std::min<size_t>(sets.size(), bytes > kParallelBytes ? 1 : cores);
  parallel_for(sets.size(), threads, work);
  for (size_t i = 0; i < sets.size(); ++i) {
    if (!notes[i].empty()) notes_.push_back(notes[i]);
    fits_.push_back(std::move(fits[i]));
    for (Entry& e : judged[i]) entries_.push_back(std::move(e));
  }
}

std::vector<Entry> Search::judge(const FamilyFit& f, int family_fit, bool allowed) const {
  const CalibrationOptions& o = base_.options;
  NormalEquations whole;
  whole.G = f.system.A.transpose() * f.system.A;
  whole.g = f.system.A.transpose() * f.system.r;
  whole.rr = f.system.r.squaredNorm();
  std::vector<LinearCandidate> linear;
  std::vector<Entry> entries;
  const std::vector<bool> zeros = space_.zero.empty() ? std::vector<bool>{false} : space_.zero;
  for (Estimator e : space_.estimators) {
    // Least squares and the cut cannot hold what these poses do not excite.
    if (f.unexcited && e != Estimator::kPrior) continue;
    for (bool zero : zeros) {
      if (zero && f.zero_column < 0) continue;  // the rank test held it: as not fitted
      LinearCandidate c;
      c.estimator = e;
      c.fitted = e == Estimator::kPrior ? f.with_prior : f.least_squares;
      if (!zero) std::erase(c.fitted, f.zero_column);
      const std::optional<LinearEstimate> all =
          estimate(whole, f.system.dof_rows, f.system, c, o.selection_alpha, o.tolerances.scale);
      // A family the cut holds whole is not in the model: another family set's
      // (unless the options named the families: then it is the data's verdict).
      std::set<std::string> in_model;
      for (int column : all ? all->kept : c.fitted) {
        if (!f.column_family[column].empty()) in_model.insert(f.column_family[column]);
      }
      if (!space_.families_fixed && in_model.size() != f.families.size()) continue;
      linear.push_back(c);
      Entry entry;
      entry.family_fit = family_fit;
      entry.candidate.families = f.families;
      entry.candidate.zero = zero;
      entry.candidate.estimator = e;
      entry.candidate.allowed = allowed;
      if (all) entry.candidate.parameters = all->parameters;
      entries.push_back(entry);
    }
  }
  const std::vector<Eigen::VectorXd> errors =
      held_out_errors(f.system, linear, plan_, o.selection_alpha, o.tolerances.scale);
  std::vector<Entry> out;
  for (size_t c = 0; c < linear.size(); ++c) {
    Entry& entry = entries[c];
    entry.unit_error = errors[c];
    if (errors[c].size() == 0) {
      entry.candidate.note = "not computable: a fold's other poses cannot determine it";
    } else {
      entry.mse = errors[c].sum() / f.system.rows;
      entry.candidate.cv_rms = std::sqrt(entry.mse);
      const double units = static_cast<double>(errors[c].size());
      const Eigen::ArrayXd centred = errors[c].array() - errors[c].mean();
      const double se_mse =
          std::sqrt(units * centred.square().sum() / std::max(units - 1, 1.0)) / f.system.rows;
      entry.candidate.se = entry.candidate.cv_rms > 0 ? se_mse / (2 * entry.candidate.cv_rms) : 0;
    }
    out.push_back(std::move(entry));
  }
  return out;
}

void Search::choose() {
  const double rows = rows_;
  const auto eligible = [&](const Entry& e) {
    return e.candidate.allowed && e.candidate.usable && std::isfinite(e.mse);
  };
  for (Entry& e : entries_) {
    // A held-out error above the nominal's (by more than a nanometre, for
    // exact data) is unusable: a calibration must predict no worse than none.
    e.candidate.usable = !std::isfinite(nominal_.mse) || !std::isfinite(e.mse) ||
                         e.mse <= nominal_.mse + kExactFloor * kExactFloor;
  }
  out_.best = out_.kept = -1;
  for (int i = 0; i < static_cast<int>(entries_.size()); ++i) {
    if (eligible(entries_[i]) && (out_.best < 0 || entries_[i].mse < entries_[out_.best].mse))
      out_.best = i;
  }
  if (out_.best < 0) return;
  const Entry& best = entries_[out_.best];
  for (int i = 0; i < static_cast<int>(entries_.size()); ++i) {
    Entry& e = entries_[i];
    if (!std::isfinite(e.mse)) continue;
    const double se = difference_se(e, best, rows);
    e.candidate.difference_se = se / (e.candidate.cv_rms + best.candidate.cv_rms);
    if (!eligible(e) || e.mse - best.mse > se) continue;
    // Simpler: fewer joint-error families, then the instrument's zero held,
    // then fewer (effective) parameters; then the lower held-out error.
    const auto simplicity = [](const Entry& x) {
      return std::make_tuple(x.candidate.families.size(), x.candidate.zero, x.candidate.parameters,
                             x.mse);
    };
    if (out_.kept < 0 || simplicity(e) < simplicity(entries_[out_.kept])) out_.kept = i;
  }
}

CalibrationResult Search::run() {
  const CalibrationOptions& o = base_.options;
  // The geometry alone first (a reference where --joint-errors names
  // families): its problem gives the units and the yardstick.
  const bool geometry_allowed = !space_.families_fixed || space_.families.empty();
  std::string note;
  fits_.push_back(fit_families({}, true, note));
  if (!note.empty()) notes_.push_back(note);
  const FamilyFit& geometry = fits_.front();
  const int units = static_cast<int>(geometry.system.unit_rows.size());
  rows_ = geometry.system.rows;
  geometry_solution_ = geometry.run->solution.parameters;
  plan_ = fold_plan(units, o.seed);
  if (o.folds >= 2) plan_.folds = std::min(o.folds, std::max(units, 2));
  out_.folds = plan_.folds;
  out_.repeats = plan_.repeats;
  out_.seed = plan_.seed;
  out_.units = units;
  out_.measured_rows = geometry.system.measuring.sum();
  out_.unit = geometry.run->problem.labelled() ? "fixture group" : "pose";
  if (note.empty() && (o.folds < 2 || units < kMinUnits)) {
    notes_.push_back(o.folds < 2 ? std::string("--folds 0: no held-out poses")
                                 : fmt::format("{} {}{} to hold out, fewer than {}", units,
                                               out_.unit, units == 1 ? "" : "s", kMinUnits));
  }
  if (!note.empty() || o.folds < 2 || units < kMinUnits) return conclude();
  test_zero(geometry);
  entries_ = judge(geometry, 0, geometry_allowed);
  nominal_yardstick(*geometry.run);
  fits_.front().least_squares_error = least_squares_errors(fits_.front());
  release(fits_.front());
  if (std::none_of(entries_.begin(), entries_.end(),
                   [](const Entry& e) { return std::isfinite(e.mse); }))
    return conclude();
  if (space_.families_fixed) {
    if (!space_.families.empty()) round({space_.families}, true);
  } else {
    std::vector<std::string> kept;
    std::vector<std::string> pool = space_.families;
    while (!pool.empty()) {
      const size_t before = fits_.size();
      std::vector<std::vector<std::string>> sets;
      for (const std::string& family : pool) {
        sets.push_back(kept);
        sets.back().push_back(family);
      }
      round(sets);
      choose();
      if (out_.kept < 0 || entries_[out_.kept].family_fit < static_cast<int>(before)) break;
      kept = fits_[entries_[out_.kept].family_fit].families;
      std::erase_if(pool, [&](const std::string& f) { return names_it(kept, f.c_str()); });
    }
  }
  choose();
  return conclude();
}

CalibrationResult Search::finish(FamilyFit& f, Estimator estimator, bool zero, bool compared) {
  std::unique_ptr<CalibrationRun> final_run = std::move(f.run);
  if (final_run->data.J.size() == 0) restack(*final_run);
  if (!zero && f.zero_column >= 0) {
    // The zero held: its own problem (no slot for it).
    final_run = std::make_unique<CalibrationRun>(base_);
    CalibrationOptions& o = final_run->options;
    o.joint_errors = f.families.empty() ? std::vector<std::string>{"none"} : f.families;
    if (!names_it(o.fix, "instrument.zero")) o.fix.push_back("instrument.zero");
    std::erase(o.free, "instrument.zero");
    prepare_model(*final_run);
  }
  // Least squares is the fit itself: to rounding (the prior and the cut
  // solve again from it).
  if (estimator == Estimator::kLeastSquares) polish(*final_run);
  // The search's held-out error is the one reported: no second cross-validation
  // of the model kept (nor the suspect check's, which compares it).
  if (compared) final_run->options.folds = 0;
  apply_estimator(*final_run, estimator);
  return conclude_model(*final_run);
}

std::shared_ptr<const CalibrationResult> Search::conclude_geometry(bool compared) {
  // The geometry's candidates (allowed or a reference beside named families):
  // the best, and the simplest within one standard error of it, as choose().
  int best = -1, pick = -1;
  const auto geometry = [&](const Entry& e) { return e.family_fit == 0 && std::isfinite(e.mse); };
  for (int i = 0; i < static_cast<int>(entries_.size()); ++i) {
    if (geometry(entries_[i]) && (best < 0 || entries_[i].mse < entries_[best].mse)) best = i;
  }
  for (int i = 0; compared && best >= 0 && i < static_cast<int>(entries_.size()); ++i) {
    const Entry& e = entries_[i];
    if (!geometry(e) || e.mse - entries_[best].mse > difference_se(e, entries_[best], rows_))
      continue;
    const auto simplicity = [](const Entry& x) {
      return std::make_tuple(x.candidate.zero, x.candidate.parameters, x.mse);
    };
    if (pick < 0 || simplicity(e) < simplicity(entries_[pick])) pick = i;
  }
  const Estimator estimator =
      pick >= 0 ? entries_[pick].candidate.estimator : space_.estimators.front();
  const bool zero =
      pick >= 0 ? entries_[pick].candidate.zero : !space_.zero.empty() && space_.zero.front();
  auto out = std::make_shared<CalibrationResult>(finish(fits_.front(), estimator, zero, pick >= 0));
  if (pick < 0) return out;
  const SearchCandidate& c = entries_[pick].candidate;
  KinematicFit& fit = out->kinematics;
  fit.cv_rms = c.cv_rms;
  fit.cv_folds = out_.folds;
  fit.cv_note.clear();
  fit.choice = to_string(c.estimator);
  if (!c.usable && out->status == CalibrationStatus::kConverged) {
    out->status = CalibrationStatus::kImplausible;
    out->status_reason = fmt::format(
        "the geometry alone predicts held-out poses no better than the nominal model with its {} "
        "fitted ({:.4f} mm against {:.4f} mm)",
        out_.nominal_fitted.empty() ? "set-up" : out_.nominal_fitted, c.cv_rms * 1e3,
        out_.nominal_rms * 1e3);
  }
  return out;
}

CalibrationResult Search::conclude() {
  // The kept candidate; if none is usable, the best allowed one, concluded and
  // refused; if none could be compared (no held-out poses, a fixture of one
  // group, a log too long), the one model of the options' defaults.
  int pick = out_.kept;
  const bool refused =
      pick < 0 && std::any_of(entries_.begin(), entries_.end(), [](const Entry& e) {
        return e.candidate.allowed && std::isfinite(e.mse);
      });
  if (refused) {
    for (int i = 0; i < static_cast<int>(entries_.size()); ++i) {
      if (entries_[i].candidate.allowed && std::isfinite(entries_[i].mse) &&
          (pick < 0 || entries_[i].mse < entries_[pick].mse))
        pick = i;
    }
    out_.best = pick;
  }
  if (pick >= 0 && fits_.front().run) held_out_outliers(entries_[pick]);
  Estimator estimator = space_.estimators.front();
  int family_fit = 0;
  bool zero = !space_.zero.empty() && space_.zero.front();
  if (pick >= 0) {
    const SearchCandidate& c = entries_[pick].candidate;
    estimator = c.estimator;
    family_fit = entries_[pick].family_fit;
    zero = c.zero;
  } else if (space_.families_fixed && !space_.families.empty()) {
    std::string note;  // the families named, uncompared
    fits_.push_back(fit_families(space_.families, true, note));
    family_fit = static_cast<int>(fits_.size()) - 1;
  }
  FamilyFit& f = fits_[family_fit];
  if (pick >= 0) check_step_one(f);
  // The geometry alone first: the whole model's conclusion takes its run.
  std::shared_ptr<const CalibrationResult> geometry;
  if (!f.families.empty() && family_fit != 0 && fits_.front().run)
    geometry = conclude_geometry(pick >= 0);
  CalibrationResult result = finish(f, estimator, zero, pick >= 0);
  chosen_family_notes(result.notes, base_.options.joint_errors);
  result.geometry = std::move(geometry);
  KinematicFit& fit = result.kinematics;
  out_.ran = pick >= 0;
  // Without a comparison the first note is the reason, in out_.note.
  for (size_t i = out_.ran ? 0 : 1; i < notes_.size(); ++i)
    result.notes.push_back("model search: " + notes_[i]);
  for (const Entry& e : entries_) out_.candidates.push_back(e.candidate);
  if (!out_.ran) {
    std::string why = "no held-out poses";
    for (const Entry& e : entries_) {
      if (!e.candidate.note.empty()) why = e.candidate.note;
    }
    if (!notes_.empty()) why = notes_.front();
    out_.note =
        fmt::format("no candidate could be compared on held-out {}s ({}): the {} of the {}",
                    out_.unit, why, to_string(estimator), model_words(fits_[family_fit].families));
    out_.kept = -1;
    result.notes.push_back("model search: " + out_.note);
  } else {
    const SearchCandidate& c = out_.candidates[pick];
    fit.cv_rms = c.cv_rms;
    fit.cv_folds = out_.folds;
    fit.cv_note.clear();
    fit.choice = to_string(c.estimator);
    for (const SearchCandidate& g : out_.candidates) {
      if (g.families.empty() && std::isfinite(g.cv_rms) &&
          !(g.cv_rms >= fit.cv_rms_without_joint_errors))
        fit.cv_rms_without_joint_errors = g.cv_rms;  // the best of the geometry alone
    }
    result.notes.push_back(fmt::format(
        "model search: kept {} by the {}{} (held-out RMS {:.4f} +- {:.4f} mm, {:.1f} parameters) "
        "of {} candidates compared on {} {}s ({} folds x {}, seed {}); the nominal model with "
        "its {} fitted: {:.4f} mm",
        model_words(c.families), to_string(c.estimator),
        space_.zero.empty() ? ""
        : c.zero            ? ", the instrument's zero fitted"
                            : ", the instrument's zero held",
        c.cv_rms * 1e3, c.se * 1e3, c.parameters, out_.candidates.size(), out_.units, out_.unit,
        out_.folds, out_.repeats, out_.seed,
        out_.nominal_fitted.empty() ? "nothing" : out_.nominal_fitted, out_.nominal_rms * 1e3));
    if (step_one_failed_ && result.status == CalibrationStatus::kConverged) {
      result.status = CalibrationStatus::kImplausible;
      result.status_reason = fmt::format(
          "step 1's transmissions make the calibration predict held-out poses worse than the "
          "model's own: {:.4f} mm with them, {:.4f} mm without (the geometry by least squares): "
          "check each external encoder (ext<i>) against its joint",
          out_.with_step_one_rms * 1e3, out_.without_step_one_rms * 1e3);
    } else if (refused && result.status == CalibrationStatus::kConverged) {
      result.status = CalibrationStatus::kImplausible;
      result.status_reason = fmt::format(
          "no candidate model predicts held-out poses better than the nominal model with its {} "
          "fitted ({:.4f} mm; the best, {}, {:.4f} mm): check step 1, the model and the log",
          out_.nominal_fitted, out_.nominal_rms * 1e3, model_words(c.families), c.cv_rms * 1e3);
    }
  }
  fit.search = out_;
  return result;
}

}  // namespace detail::search

namespace detail {

CalibrationResult search_model(CalibrationRun& run) { return search::Search(run).run(); }

}  // namespace detail
}  // namespace hapticcal
