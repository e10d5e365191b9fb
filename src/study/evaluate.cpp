#include "hapticcal/study/evaluate.hpp"

#include <fmt/format.h>

#include <cmath>

#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/io/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

ErrorStats stats(const Eigen::VectorXd& e) {
  return {std::sqrt(e.squaredNorm() / static_cast<double>(e.size())), e.cwiseAbs().maxCoeff()};
}

}  // namespace

Evaluation evaluate(const DeviceModel& model, const Log& log) {
  check_log_fits(log, model);
  const PreparedModel prepared(model);
  Evaluation ev;
  ev.n = log.rows;
  if (log.has_distance) ev.distance_error.resize(log.rows);
  if (log.has_position) ev.position_error.resize(log.rows);
  if (log.has_orientation) ev.orientation_error.resize(log.rows);
  Eigen::VectorXd q(model.dof());
  for (int r = 0; r < log.rows; ++r) {
    q = log.q.row(r).transpose();
    const Frame<double> tool = prepared.forward(q.data());
    const Eigen::Vector3d& p = tool.p;
    if (log.has_orientation) {
      const Eigen::Quaterniond measured(log.orientation(r, 0), log.orientation(r, 1),
                                        log.orientation(r, 2), log.orientation(r, 3));
      ev.orientation_error[r] =
          rotation_log(Eigen::Matrix3d(tool.R * measured.toRotationMatrix().transpose())).norm();
    }
    if (log.has_distance) ev.distance_error[r] = p.norm() - log.distance[r];
    if (log.has_position) ev.position_error[r] = (p - log.position.row(r).transpose()).norm();
    const bool finite = (!log.has_distance || std::isfinite(ev.distance_error[r])) &&
                        (!log.has_position || std::isfinite(ev.position_error[r]));
    if (!finite) {
      throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0, "",
                       "the model's error on this row is not finite: a value is too large");
    }
  }
  if (log.has_distance) ev.distance = stats(ev.distance_error);
  if (log.has_position) ev.position = stats(ev.position_error);
  if (log.has_orientation) ev.orientation = stats(ev.orientation_error);
  return ev;
}

double rms_improvement_pct(double rms_calibrated, double rms_uncalibrated) {
  return (rms_uncalibrated - rms_calibrated) / std::abs(rms_uncalibrated) * 100.0;
}

EvaluationComparison compare_to_reference(const DeviceModel& model, const DeviceModel& reference,
                                          const Log& log) {
  EvaluationComparison c{evaluate(model, log), evaluate(reference, log), {}, {}};
  if (c.model.distance && c.reference.distance) {
    c.improvement_distance_pct =
        rms_improvement_pct(c.model.distance->rms, c.reference.distance->rms);
  }
  if (c.model.position && c.reference.position) {
    c.improvement_position_pct =
        rms_improvement_pct(c.model.position->rms, c.reference.position->rms);
  }
  return c;
}

}  // namespace hapticcal
