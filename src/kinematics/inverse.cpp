// Inverse kinematics with a calibrated model (kinematics/inverse.hpp): damped
// least squares on the readings, every matrix of fixed largest size (no
// allocation).
#include "hapticcal/kinematics/inverse.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hapticcal {
namespace {

using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxDof>;
using Square =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxDof, kMaxDof>;
using Readings = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxDof, 1>;
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;

// The error of the tool at readings q: position, then the rotation vector of
// target R R(q)^T scaled by the rotation scale (rows 3..5, with orientation).
struct ToolError {
  Eigen::Matrix<double, 6, 1> r = Eigen::Matrix<double, 6, 1>::Zero();
  double position = 0, rotation = 0;
  double cost() const { return r.squaredNorm(); }
};

ToolError tool_error(const PreparedModel& model, const Frame<double>& target, const double* q,
                     const InverseOptions& o) {
  const Frame<double> T = model.forward(q, o.tip);
  ToolError e;
  e.r.head<3>() = target.p - T.p;
  e.position = e.r.head<3>().norm();
  if (o.orientation) {
    const Eigen::AngleAxisd turn(Mat3<double>(target.R * T.R.transpose()));
    e.rotation = std::abs(turn.angle());
    e.r.tail<3>() = o.rotation_scale * turn.angle() * turn.axis();
  }
  return e;
}

bool within(const ToolError& e, const InverseOptions& o) {
  return e.position <= o.position_tolerance &&
         (!o.orientation || e.rotation <= o.rotation_tolerance);
}

// The Jacobian of the tool's pose with respect to the readings (rows as
// ToolError's, rotation rows scaled): the geometric Jacobian times d theta / d r,
// the latter at the start (a transmission's slope barely changes over a step;
// the steps are judged by the model's own errors).
void reading_jacobian(const PreparedModel& model, const double* q, const Square& joint_reading,
                      const InverseOptions& o, Jacobian& J) {
  const int n = model.dof();
  Jacobian geometric(6, n);
  model.forward_jacobian(q, o.tip, JacobianFrame::kMeasurement, geometric.data());
  J.resize(6, n);
  J.noalias() = geometric * joint_reading;
  J.bottomRows<3>() *= o.rotation_scale;
}

double smallest_singular_value(const Jacobian& J, int rows) {
  const int n = static_cast<int>(J.cols());
  const auto used = J.topRows(rows);
  Small gram;
  if (n >= rows) {
    gram.resize(rows, rows);
    gram.noalias() = used * used.transpose();
  } else {
    gram.resize(n, n);
    gram.noalias() = used.transpose() * used;
  }
  const Eigen::SelfAdjointEigenSolver<Small> eigen(gram, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eigen.eigenvalues().minCoeff()));
}

}  // namespace

const char* to_string(InverseStatus status) {
  switch (status) {
    case InverseStatus::kConverged:
      return "converged";
    case InverseStatus::kNear:
      return "near a singularity";
    case InverseStatus::kOutsideLimits:
      return "outside the joint limits";
    case InverseStatus::kNotConverged:
      return "not converged";
  }
  return "?";
}

void reading_limits(const DeviceModel& model, double* lower, double* upper) {
  constexpr double kFree = std::numeric_limits<double>::infinity();
  for (int i = 0; i < model.dof(); ++i) {
    const Link& l = model.links[static_cast<size_t>(i)];
    lower[i] = l.continuous() ? -kFree : l.lower;
    upper[i] = l.continuous() ? kFree : l.upper;
  }
}

void check_ranges(const DeviceModel& model, const double* q, InverseResult& result) {
  if (result.status != InverseStatus::kConverged && result.status != InverseStatus::kNear) return;
  const int joint = model.outside_range(Eigen::Map<const Eigen::VectorXd>(q, model.dof()));
  if (joint < 0) return;
  result.status = InverseStatus::kOutsideLimits;
  result.outside_limit = joint;
}

InverseResult inverse_kinematics(const PreparedModel& model, const Frame<double>& target,
                                 const double* q_start, double* q, const InverseOptions& o,
                                 const double* lower, const double* upper) {
  const int n = model.dof();
  const int rows = o.orientation ? 6 : 3;
  Readings x = Eigen::Map<const Eigen::VectorXd>(q_start, n);
  Readings trial(n), step(n);
  ToolError error = tool_error(model, target, x.data(), o);
  Jacobian J(6, n);
  Square joint_reading(n, n);
  model.reading_jacobian(x.data(), joint_reading.data());
  Square A(n, n);
  Readings g(n);
  InverseResult result;
  double lambda = -1;   // set from the first Jacobian's scale
  int evaluations = 0;  // of the model: at most 3 an iteration over the call
  while (!within(error, o) && result.iterations < o.max_iterations &&
         evaluations < 3 * o.max_iterations) {
    ++result.iterations;
    reading_jacobian(model, x.data(), joint_reading, o, J);
    const auto used = J.topRows(rows);
    A.noalias() = used.transpose() * used;
    g.noalias() = used.transpose() * error.r.head(rows);
    const double scale = std::max(A.diagonal().maxCoeff(), 1e-12);
    if (lambda < 0) lambda = 1e-6 * scale;
    // Larger damping until a step lowers the error (Levenberg-Marquardt).
    bool improved = false;
    while (!improved && lambda <= 1e10 * scale && evaluations < 3 * o.max_iterations) {
      ++evaluations;
      Square damped = A;
      damped.diagonal().array() += lambda;
      step = damped.ldlt().solve(g);
      trial = x + step;
      const ToolError at = tool_error(model, target, trial.data(), o);
      if (std::isfinite(at.cost()) && at.cost() < error.cost()) {
        x = trial;
        error = at;
        lambda = std::max(lambda / 3, 1e-15 * scale);
        improved = true;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;  // no step lowers the error: a local minimum off the target
  }
  Eigen::Map<Eigen::VectorXd>(q, n) = x;
  result.position_error = error.position;
  result.rotation_error = o.orientation ? error.rotation : 0;
  reading_jacobian(model, x.data(), joint_reading, o, J);
  result.smallest_singular_value = smallest_singular_value(J, rows);
  for (int i = 0; lower && upper && i < n && result.outside_limit < 0; ++i) {
    if (!(x[i] >= lower[i] && x[i] <= upper[i])) result.outside_limit = i;
  }
  result.status = !within(error, o)           ? InverseStatus::kNotConverged
                  : result.outside_limit >= 0 ? InverseStatus::kOutsideLimits
                  : result.smallest_singular_value < o.singular_below ? InverseStatus::kNear
                                                                      : InverseStatus::kConverged;
  return result;
}

}  // namespace hapticcal
