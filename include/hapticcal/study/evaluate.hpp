// Model accuracy on a log: predicted distance (paper eq. 5), position and
// orientation against the measured ones.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct ErrorStats {
  double rms = 0;
  double max = 0;  // largest absolute error
};

struct Evaluation {
  int n = 0;
  // Set when the model was registered to the log first (evaluate_registered).
  std::optional<FrameFit> registered;
  // What the log's kinds report (MeasurementKind::error_figures), in the
  // kinds' order, a figure's name once: a distance log's distance (predicted -
  // measured, signed) [m], a position log's position (|p_model - p_measured|)
  // [m], a pose log's position and orientation (the angle of R_model
  // R_measured^T) [rad], a registered kind's own.
  struct FigureErrors {
    ErrorFigure figure;
    MeasurementType type;  // the kind that reports it
    ErrorStats stats;
    Eigen::VectorXd error;  // per row
  };
  std::vector<FigureErrors> figures;
  // The figure named `name`, or null if the log's kinds do not report it.
  const FigureErrors* figure(std::string_view name) const;

  // Fixture logs. Points: each label's predicted tool points against their
  // mean; over all rows (labels weighted by their samples, as MUKCa's KPI)
  // the mean and RMS of |p_i - mean|; the largest error of a known distance
  // between two labels' means. Planes: the RMS distance of the points from
  // each label's best plane.
  struct Label {
    std::string name;
    int samples = 0;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // the mean point [m]
    double mean_deviation = 0, rms_deviation = 0;      // of |p_i - centre| or plane distance
    std::optional<double> rms_known_error;  // of |p_i - known position|, if it is known [m]
  };
  std::vector<Label> labels;
  std::optional<double> mean_point_deviation, rms_point_deviation;  // [m]
  std::optional<double> max_point_distance_error;                   // [m]
  std::optional<double> rms_plane_distance;                         // [m]
  // Over the rows of labels with a known position: the RMS of |p_i - known| [m].
  std::optional<double> rms_known_point_error;
  Eigen::VectorXd fixture_error;  // per row: |p_i - centre| or the signed plane distance
};

// Each sample's error in the measurement `type` of the evaluated log: a
// fixture's, else the first figure the kind reports (a pose's: its position's).
const Eigen::VectorXd& sample_errors(const Evaluation& ev, MeasurementType type);

// Throws InputError if the log does not fit the model (check_log_fits), or a
// known distance or position names a label the log lacks (fixture_labels).
Evaluation evaluate(const DeviceModel& model, const Log& log,
                    const std::vector<PointDistance>& point_distances = {},
                    const std::vector<KnownPoint>& known_points = {});

// evaluate() of the registered model, with `registered` set (known distances
// and points are refused as evaluate() refuses them on a log of positions).
Evaluation evaluate_registered(const DeviceModel& model, const Log& log, RegisterWhat what,
                               const std::vector<PointDistance>& point_distances = {},
                               const std::vector<KnownPoint>& known_points = {});

// Paper eq. (9), signed: (RMS(e_nc) - RMS(e_c)) / RMS(e_nc) * 100. It equals the
// paper's |RMS(e_c) - RMS(e_nc)| / |RMS(e_nc)| * 100 whenever calibration helps,
// and is negative when the "calibrated" model is worse, which eq. (9) would hide.
double rms_improvement_pct(double rms_calibrated, double rms_uncalibrated);

// A model against a reference model on the same log (evaluate --reference):
// both evaluations (eq. (9)'s improvement of each figure: rms_improvement_pct).
struct EvaluationComparison {
  Evaluation model, reference;
  // The model is the reference but for its set-up (base, tool, an instrument's
  // zero): at every row of the log the two agree once the model takes the
  // reference's set-up. The improvement is then the set-up's, not the device's.
  bool setup_only = false;
};

// Throws InputError if the log does not fit either model. With `registration`,
// each model is registered to the log on its own (evaluate_registered).
EvaluationComparison compare_to_reference(const DeviceModel& model, const DeviceModel& reference,
                                          const Log& log,
                                          const std::vector<PointDistance>& point_distances = {},
                                          const std::vector<KnownPoint>& known_points = {},
                                          std::optional<RegisterWhat> registration = {});

// What `evaluate` prints, one line each (mm, mrad), and its report's headline:
// the errors of `ev`, the fixture figures, and with a comparison (whose
// `model` is `ev`) the reference `reference_name`'s figures and eq. (9).
std::vector<std::string> evaluation_lines(const EvaluationComparison* comparison,
                                          const Evaluation& ev, const std::string& reference_name);

}  // namespace hapticcal
