// Internal: the model search's pieces (docs/calibrate.md, "The model search"). model_search.cpp
// runs it (the family sets' fits, their candidates judged on held-out poses,
// the rule, the conclusion); search_checks.cpp holds its yardsticks (the
// nominal with the set-up registered, the instrument's zero, step 1's check).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "identification/search/held_out.hpp"

namespace hapticcal::detail {
struct CalibrationRun;  // calibration_run.hpp: the run the search fits on
}  // namespace hapticcal::detail

namespace hapticcal::detail::search {

// The dimensions of the search the options leave open.
struct SearchSpace {
  std::vector<Estimator> estimators;
  std::vector<bool> zero;             // the instrument's zero fitted: {true, false}, one, or none
  bool families_fixed = false;        // --joint-errors named them
  std::vector<std::string> families;  // the fixed set, or the pool to add from
};

// Whether `names` holds `name`.
bool names_it(const std::vector<std::string>& names, const char* name);
// The dimensions of the search the run's options leave open.
SearchSpace search_space(const CalibrationRun& run);
// "geometry + compliance + harmonic".
std::string model_words(const std::vector<std::string>& families);

// One family set's least-squares fit and the system its candidates are judged on.
struct FamilyFit {
  std::vector<std::string> families;
  std::unique_ptr<CalibrationRun> run;  // the fit with the zero fitted, if it may be
  HeldOutSystem system;
  std::vector<int> least_squares;          // column positions: the identified parameters
  std::vector<int> with_prior;             // and those only the prior can hold (unexcited)
  std::vector<std::string> column_family;  // per column: its joint-error family ("": geometry)
  // Least squares' held-out squared errors per unit (step 1's check) and the
  // system's units (kept when the system goes).
  Eigen::VectorXd least_squares_error;
  size_t system_units = 0;
  int zero_column = -1;
  bool unexcited = false;
};

// One candidate as the search keeps it: the table's entry and its errors.
struct Entry {
  SearchCandidate candidate;
  int family_fit = 0;
  Eigen::VectorXd unit_error;  // held-out squared error per unit (empty: not computable)
  double mse = std::numeric_limits<double>::infinity();
};

double difference_se(const Entry& a, const Entry& b, double rows);

// Step 1's held-out check: refused when the geometry with its transmissions
// predicts held-out poses worse than without them by this factor (RMS) and
// this many standard errors: a gross failure (a forged encoder: 5.7 times),
// not a step 1 a little worse than the model's own transmissions.
constexpr double kStepOneMargin = 1.5;
constexpr double kStepOneSds = 3;
// A family fit's Jacobian of more bytes than this: the family sets are fitted
// one at a time (each holds its own while it is judged).
constexpr double kParallelBytes = 16e6;

// A family fit once judged: its system and its stack go (restack brings the
// stack back for the one concluded).
void release(FamilyFit& f);

// The fewest units (poses, fixture groups) the search compares on: with two,
// each fold's fit rests on the other alone.
constexpr int kMinUnits = 3;
// The held-out outlier test's floor, in the poses' robust scales: a held-out
// error holds the model's own error beside the noise, with heavier tails.
constexpr double kHeldOutFloor = 2.3;
// Held-out errors this close [m] are equal (exact, noise-free data).
constexpr double kExactFloor = 1e-9;
constexpr double kFreeColumn = std::numeric_limits<double>::infinity();

class Search {
 public:
  explicit Search(CalibrationRun& base) : base_(base), space_(search_space(base)) {
    family_names();
  }

  CalibrationResult run();

 private:
  // The least-squares fit of `families` (InputError propagates for the first,
  // the geometry alone, which every search fits); `note` says why it cannot
  // be judged (then its system is empty).
  FamilyFit fit_families(const std::vector<std::string>& families, bool first, std::string& note,
                         const DeviceModel* transmissions = nullptr) const;
  // Each candidate's held-out errors on family fit `f` (index `family_fit`).
  std::vector<Entry> judge(const FamilyFit& f, int family_fit, bool allowed) const;
  // A round of the forward search: each family set fitted and judged (on
  // several threads), then added in order; `named`: the sets the options name
  // (their bad input is bad input).
  void round(const std::vector<std::vector<std::string>>& sets, bool named = false);
  // The nominal model with the set-up registered: the yardstick of usability.
  void nominal_yardstick(const CalibrationRun& geometry);
  // Whether the geometry's least-squares fit supports an instrument's zero;
  // if not, the zero is held in every candidate.
  void test_zero(const FamilyFit& geometry);
  // On a log too small for the fit's own outlier test: the poses whose held-out
  // error under `kept` stands out (ModelSearch::outliers).
  void held_out_outliers(const Entry& kept);
  // Step 1's own held-out check on the kept model's families: their least
  // squares with step 1's transmissions against the same without them (the
  // nominal's).
  void check_step_one(const FamilyFit& kept);
  Eigen::VectorXd least_squares_errors(const FamilyFit& f) const;
  // The best candidate and the simplest within one standard error of it.
  void choose();
  CalibrationResult conclude();
  // Family fit `f` refitted on every pose by `estimator` (the instrument's
  // zero fitted or held) and concluded; `compared`: its held-out error is the
  // search's (no cross-validation of its own).
  CalibrationResult finish(FamilyFit& f, Estimator estimator, bool zero, bool compared);
  // The geometry alone as a format that holds no joint-error family writes
  // it (CalibrationResult::geometry): its simplest candidate within one
  // standard error of its best, refitted on every pose.
  std::shared_ptr<const CalibrationResult> conclude_geometry(bool compared);

  // The joint-error parameters' names of every family searched, by family:
  // options naming them (--fix, --free, --tolerance) apply to the family sets
  // that have them.
  void family_names();

  CalibrationRun& base_;
  SearchSpace space_;
  std::map<std::string, std::string> family_of_;
  bool step_one_failed_ = false;
  Entry nominal_;    // the nominal with the set-up registered: the yardstick
  double rows_ = 1;  // the log rows behind the poses (every system's RMS denominator)
  Eigen::VectorXd geometry_solution_;  // the geometry's least-squares fit: families start there
  ModelSearch out_;
  FoldPlan plan_;
  std::vector<FamilyFit> fits_;
  std::vector<Entry> entries_;
  std::vector<std::string> notes_;
};

}  // namespace hapticcal::detail::search
