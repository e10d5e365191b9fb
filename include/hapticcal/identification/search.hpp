// The model search's result types (identification.hpp's calibrate, docs/calibrate.md,
// "The model search"): the estimators step 2 can use, the candidate models it
// compared on held-out poses, and the one kept.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace hapticcal {

// How step 2 estimates a model's parameters (docs/calibrate.md, "Step 2's estimators"):
// each parameter pulled toward nominal by its tolerance (the tolerance prior,
// MAP at the scale of highest evidence), the significance cut (parameters the
// data do not support held at nominal), or plain least squares.
enum class Estimator { kPrior, kCut, kLeastSquares };
// "tolerance prior", "significance cut", "least squares".
const char* to_string(Estimator estimator);

// One model the search compared (docs/calibrate.md, "The model search"): its joint-error
// families, whether the instrument's zero was fitted, its estimator, and its
// honest held-out error.
struct SearchCandidate {
  std::vector<std::string> families;  // joint-error families ({}: the geometry alone)
  bool zero = false;                  // the instrument's zero fitted (a distance log)
  Estimator estimator = Estimator::kPrior;
  // Held-out RMS [m] (the measure of KinematicFit::rms_after) of the whole
  // estimator re-run on each fold's training poses; NaN: not computable (a
  // fold's other poses cannot determine it; `note` says so).
  double cv_rms = std::numeric_limits<double>::quiet_NaN();
  // Standard error [m] of its held-out RMS, and of its difference from the
  // best candidate's (paired over the same held-out poses; 0 for the best).
  double se = std::numeric_limits<double>::quiet_NaN();
  double difference_se = std::numeric_limits<double>::quiet_NaN();
  double parameters = 0;  // estimated on every pose ((effective) number)
  // Its held-out error beats the nominal model's with the set-up registered.
  bool usable = true;
  // The options allow it (false: a reference, such as the geometry alone
  // beside the families --joint-errors names).
  bool allowed = true;
  std::string note;
};

// The model search of calibrate (docs/calibrate.md, "The model search"): the candidates
// compared on held-out poses and the one kept.
struct ModelSearch {
  bool ran = false;
  std::string note;  // why it did not run, or what it could not compare
  int folds = 0, repeats = 0;
  std::uint64_t seed = 0;
  int units = 0;              // poses (a fixture: groups of labels) the folds hold out
  double measured_rows = 0;   // their rows that measure a length (a pose's rotation rows not)
  std::string unit = "pose";  // "pose" or "fixture group"
  std::vector<SearchCandidate> candidates;
  int best = -1;  // lowest held-out error
  int kept = -1;  // the simplest within one standard error of the best
  // RMS [m] of the nominal model on these poses with the set-up's unknowns
  // (the measurement frame, the tool point, an instrument's zero) fitted: what
  // a candidate must beat on held-out poses to be usable.
  double nominal_rms = std::numeric_limits<double>::quiet_NaN();
  std::string nominal_fitted;  // what of the set-up it fitted ("base, tool")
  // Step 1's own check: the held-out RMS [m] of the geometry by least squares
  // with step 1's transmissions and with the model's own (NaN: no step 1).
  double with_step_one_rms = std::numeric_limits<double>::quiet_NaN();
  double without_step_one_rms = std::numeric_limits<double>::quiet_NaN();
  // Poses (their log rows, 0-based) whose held-out error under the kept
  // candidate stands out (docs/outliers.md, "Few poses"): looked for where the
  // fit's own outlier test cannot be made; calibrate fits again without them.
  struct HeldOutOutlier {
    std::vector<int> rows;
    double error = 0;      // its held-out RMS component [m]
    double statistic = 0;  // that in the units' robust scale
  };
  std::vector<HeldOutOutlier> outliers;
  double outlier_threshold = 0;  // in robust scales
};

}  // namespace hapticcal
