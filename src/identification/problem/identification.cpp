// Step 2's problem: the poses, the transmissions (step 1), the measurement frame
// and the Levenberg-Marquardt solve (paper eq. 5-7).
#include "hapticcal/identification/identification.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/log_fit.hpp"
#include "hapticcal/identification/registration.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "identification/problem/measurement_cost.hpp"
#include "identification/problem/solver_options.hpp"
#include "identification/problem/stack.hpp"

namespace hapticcal {
namespace detail {

Stack stack(const ChainStructure& s, const Eigen::VectorXd& params,
            const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
            const RowMatrix& measured, const Eigen::VectorXd& weights, bool compressed) {
  const int m = static_cast<int>(joints.size());
  if (compressed) {
    detail::CompressedRows z =
        detail::compress_rows(s, params.data(), joints, kind, measured, weights);
    return {Eigen::VectorXd(), std::move(z.R), z.rss(), kind.rows(m)};
  }
  Stack out{Eigen::VectorXd(kind.rows(m)), Eigen::MatrixXd()};
  all_rows(s, params.data(), joints, kind, measured, weights, out.r.data(), &out.J);
  out.rss = out.r.squaredNorm();
  out.residuals = out.r.size();
  return out;
}

Eigen::VectorXd residuals_at(const ChainStructure& s, const Eigen::VectorXd& params,
                             const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                             const RowMatrix& measured, const Eigen::VectorXd& weights) {
  Eigen::VectorXd r(kind.rows(static_cast<int>(joints.size())));
  all_rows(s, params.data(), joints, kind, measured, weights, r.data(), nullptr);
  return r;
}

double position_rss(const Eigen::VectorXd& r, const RowsOf& kind) {
  if (kind.labels) {  // the poses' rows, without the known distances'
    const Eigen::Index pose_rows =
        static_cast<Eigen::Index>(kind.labels->of_pose.size()) * kind.dimension();
    return r.head(pose_rows).squaredNorm();
  }
  const int d = kind.dimension(), length_rows = traits(kind.type).length_rows;
  if (length_rows == d) return r.squaredNorm();
  double sum = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i) {
    if (i % d < length_rows) sum += r[i] * r[i];
  }
  return sum;
}

std::vector<double> tip_rms(const KinematicProblem& problem, const Eigen::VectorXd& r,
                            const RowsOf& kind, const Eigen::VectorXd& repeat_weights) {
  if (!problem.tip) return {};
  const int d = kind.dimension(), length_rows = traits(kind.type).length_rows;
  std::vector<double> rss(static_cast<size_t>(problem.model.tips()), 0.0), rows(rss.size(), 0.0);
  for (size_t i = 0; i < problem.joints.size(); ++i) {
    const auto tip = static_cast<size_t>(problem.joints[i][*problem.tip]);
    const Eigen::Index at = static_cast<Eigen::Index>(i) * d;
    rss[tip] += r.segment(at, std::min(d, length_rows)).squaredNorm();
    const double w = repeat_weights.size() > 0 ? repeat_weights[static_cast<Eigen::Index>(i)] : 1;
    rows[tip] += w * w;
  }
  std::vector<double> rms(rss.size());
  for (size_t t = 0; t < rss.size(); ++t) rms[t] = measurement_rms(rss[t], rows[t]);
  return rms;
}

// The cost LM minimises over these poses: every row, or its compressed form.
ceres::CostFunction* measurement_cost(const ChainStructure& s,
                                      const std::vector<Eigen::VectorXd>& joints,
                                      const RowsOf& kind, const RowMatrix& measured,
                                      const Eigen::VectorXd& weights, bool compressed) {
  if (compressed) return new CompressedMeasurementCost(s, joints, kind, measured, weights);
  return new MeasurementCost(s, joints, kind, measured, weights);
}

// What the model at `params` predicts for these joint values: measurements
// without error (for the structural analysis, whose rows need a measured value).
RowMatrix predicted_values(const ChainStructure& s, const Eigen::VectorXd& params,
                           const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind) {
  RowMatrix out(joints.size(), traits(kind.type).width);
  if (kind.labels) return RowMatrix::Zero(out.rows(), out.cols());  // a fixture's: nothing measured
  const ChainConstants<double> constants = chain_constants(s, params.data());
  for (size_t i = 0; i < joints.size(); ++i) {
    const Frame<double> tool = pose_tool(s, constants, params.data(), joints[i].data(), kind.tip);
    double* row = out.row(i).data();
    hapticcal::predicted_values(kind.type, tool, row);
    // The instrument reads its zero d0 on top (step 2's "instrument.zero").
    if (s.instrument) kind_of(kind.type).add_zero(params[s.instrument_slot()], row);
  }
  return out;
}

std::string names_of(const std::vector<int>& slots, const std::map<int, std::string>& name,
                     size_t limit) {
  std::string out;
  for (size_t i = 0; i < slots.size() && i < limit; ++i)
    out += (out.empty() ? "" : ", ") + name.at(slots[i]);
  if (slots.size() > limit)
    out += fmt::format(" and {} more (results.json lists each parameter)", slots.size() - limit);
  return out;
}

// RMS of the per-measurement error, as `evaluate` reports it: the distance error,
// or the Euclidean norm of the position error.
// `rows` the log rows behind the residuals (their weights' sum of squares).
double measurement_rms(double rss, double rows) { return std::sqrt(rss / std::max(rows, 1.0)); }

}  // namespace detail

namespace {

using detail::CompressedMeasurementCost;
using detail::measurement_cost;
using detail::MeasurementCost;
using detail::position_rss;
using detail::residuals_at;
using detail::RowMatrix;
using detail::rows_of;
using detail::RowsOf;
using detail::Stack;
using detail::stack;

// The used rows of the log as measured values (the family's width a row).
RowMatrix pose_measurements(const Log& log, const std::vector<int>& rows, const RowsOf& kind) {
  RowMatrix out(rows.size(), traits(kind.type).width);
  for (size_t i = 0; i < rows.size(); ++i) {
    hapticcal::measured_values(kind.type, log, rows[i], out.row(i).data());
  }
  return out;
}

// An unknown measurement frame (a tracker's, a mocap system's): where the base
// is a free pose and the model's tool points lie far from the measured ones, the
// base is first registered in closed form (register_points: Horn / Kabsch on
// the predicted and measured tool points, weighted by the repeat counts), so
// that Levenberg-Marquardt starts near the solution. Applied when it halves the
// RMS point error and moves the base beyond the large-change bounds; returns
// the note saying so, or nothing.
std::optional<std::string> register_frame(DeviceModel& model,
                                          const std::vector<Eigen::VectorXd>& joints,
                                          const RowsOf& kind, const RowMatrix& measured,
                                          const Eigen::VectorXd& weights,
                                          const std::vector<int>& candidates) {
  if (!kind_of(kind.type).measures_point() || !model.base_is_pose()) {
    return {};  // no measured points to register to
  }
  for (int k = 0; k < kPoseSlots; ++k) {  // every base slot free
    if (std::find(candidates.begin(), candidates.end(), k) == candidates.end()) return {};
  }
  const ChainStructure s = model.structure();
  const Eigen::VectorXd p = model.kinematic_parameters();
  const ChainConstants<double> constants = chain_constants(s, p.data());
  const Eigen::Index m = static_cast<Eigen::Index>(joints.size());
  Eigen::Matrix3Xd a(3, m), b(3, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    a.col(i) = detail::pose_tool(s, constants, p.data(), joints[i].data(), kind.tip).p;
    b.col(i) = kind_of(kind.type).measured_point(measured.row(i).data());
  }
  const Eigen::VectorXd w =
      weights.size() ? Eigen::VectorXd(weights.cwiseAbs2()) : Eigen::VectorXd();
  Registration reg;
  try {
    reg = register_points(a, b, w);
  } catch (const InputError&) {
    return {};  // collinear tool points: no closed form; LM alone
  }
  const Eigen::VectorXd e2 = (a - b).colwise().squaredNorm().transpose();
  const double before = std::sqrt(w.size() ? e2.dot(w) / w.sum() : e2.mean());
  const Frame<double> B = constants.base;
  const Frame<double> moved{reg.R * B.R, reg.R * B.p + reg.t};
  const double shift = (moved.p - B.p).norm();
  const double turn = Eigen::AngleAxisd(reg.R).angle();
  if (!(reg.rms < 0.5 * before) || (shift <= kLargeChangeLength && turn <= kLargeChangeAngle)) {
    return {};
  }
  const Eigen::Vector3d rpy = matrix_rpy(moved.R);
  model.base = {moved.p[0], moved.p[1], moved.p[2], rpy[0], rpy[1], rpy[2]};
  return fmt::format(
      "the measurement frame was far from the model's base (RMS point error {:.1f} mm): it was "
      "registered in closed form first (Horn/Kabsch point-set alignment: base moved by {:.1f} mm "
      "and {:.2f} deg, RMS {:.2f} mm), then refined by Levenberg-Marquardt",
      before * 1e3, shift * 1e3, turn * 180 / M_PI, reg.rms * 1e3);
}

}  // namespace

std::vector<int> sample_rows(int rows, int samples, std::uint64_t seed) {
  std::vector<int> all(rows);
  for (int i = 0; i < rows; ++i) all[i] = i;
  if (samples <= 0 || samples >= rows) return all;
  // Partial Fisher-Yates with a bounded draw by rejection: the same rows for a
  // seed on every platform (std::uniform_int_distribution is not specified).
  std::mt19937_64 rng(seed);
  for (int i = 0; i < samples; ++i) {
    const std::uint64_t span = static_cast<std::uint64_t>(rows - i);
    const std::uint64_t limit = UINT64_MAX - UINT64_MAX % span;
    std::uint64_t draw;
    do {
      draw = rng();
    } while (draw >= limit);
    std::swap(all[i], all[i + static_cast<int>(draw % span)]);
  }
  all.resize(samples);
  std::sort(all.begin(), all.end());
  return all;
}

const char* to_string(CalibrationStatus status) {
  switch (status) {
    case CalibrationStatus::kConverged:
      return "converged";
    case CalibrationStatus::kNotConverged:
      return "not converged";
    case CalibrationStatus::kNumericalFailure:
      return "numerical failure";
    case CalibrationStatus::kSuspect:
      return "suspect";
    case CalibrationStatus::kRankDeficient:
      return "rank-deficient";
    case CalibrationStatus::kImplausible:
      return "implausible";
  }
  return "unknown";
}

Eigen::MatrixXd problem_jacobian(const KinematicProblem& problem,
                                 const Eigen::VectorXd& parameters) {
  return detail::stack(problem.model.structure(), parameters, problem.joints,
                       detail::rows_of(problem), problem.measured, problem.weights)
      .J;
}

void encoders_at_readings(const DeviceModel& model, Log& poses, std::vector<std::string>& notes,
                          bool fitted_coupling) {
  if (!model.coupled() || poses.ext.cols() != model.dof()) return;
  const int n = model.dof();
  std::vector<int> measured;
  std::vector<std::string> left_out;
  for (int i = 0; i < n; ++i) {
    if (!poses.has_ext[i]) continue;
    Eigen::RowVectorXd others = model.coupling.row(i);
    others[i] = 0;
    if (fitted_coupling && others.any()) {
      left_out.push_back(model.links[i].name);
    } else {
      measured.push_back(i);
    }
  }
  if (!left_out.empty()) {
    notes.push_back(fmt::format(
        "--joint-errors coupling: the external encoder(s) of {} are left out of step 1 (their "
        "joint angles use the coupling coefficients step 2 fits)",
        fmt::join(left_out, ", ")));
  }
  if (measured.empty()) {  // every encoder left out (or none given)
    for (int k = 0; k < n && !left_out.empty(); ++k) {
      if (model.reading_used(k) && !model.links[k].transmission.is_none()) {
        notes.push_back(fmt::format(
            "coupled joints: no external encoder is left to determine the reading of {}: its "
            "transmission is not fitted in step 1",
            model.links[k].name));
      }
    }
    poses.has_ext.assign(n, false);
    return;
  }
  Eigen::MatrixXd CA(measured.size(), n);  // C's rows of the joints with an encoder
  for (size_t a = 0; a < measured.size(); ++a) CA.row(a) = model.coupling.row(measured[a]);
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> solver(CA.transpose());
  Eigen::MatrixXd ext = Eigen::MatrixXd::Zero(poses.rows, n);
  std::vector<bool> has(n, false);
  std::vector<std::string> unseen;
  for (int k = 0; k < n; ++k) {
    if (!model.reading_used(k)) continue;
    const Eigen::VectorXd e = Eigen::VectorXd::Unit(n, k);
    const Eigen::VectorXd w = solver.solve(e);
    if ((CA.transpose() * w - e).norm() > 1e-9) {
      if (!model.links[k].transmission.is_none()) unseen.push_back(model.links[k].name);
      continue;
    }
    has[k] = true;
    for (size_t a = 0; a < measured.size(); ++a) ext.col(k) += w[a] * poses.ext.col(measured[a]);
  }
  poses.ext = ext;
  poses.has_ext = has;
  notes.push_back(
      "coupled joints: step 1 fits each reading's transmission to the external encoders' joint "
      "angles mapped back through the coupling");
  if (!unseen.empty()) {
    notes.push_back(
        fmt::format("coupled joints: the external encoders do not determine the reading of {}: its "
                    "transmission is not fitted in step 1",
                    fmt::join(unseen, ", ")));
  }
}

namespace {

// The length scale of the problem's current model and poses.
void set_scales(KinematicProblem& problem) {
  const ChainStructure s = problem.model.structure();
  const Eigen::VectorXd p = problem.model.kinematic_parameters();
  // Metres and radians made comparable: angle columns times a length scale, the
  // RMS distance of the tool point from the base origin; a pose's rotation rows
  // likewise (an orientation error phi counts as L phi at the tool).
  const ChainConstants<double> constants = chain_constants(s, p.data());
  double sum = 0;
  for (const Eigen::VectorXd& jq : problem.joints) {
    sum += (detail::pose_tool(s, constants, p.data(), jq.data(), problem.tip).p - constants.base.p)
               .squaredNorm();
  }
  problem.length_scale =
      std::max(std::sqrt(sum / std::max<double>(problem.joints.size(), 1)), 1e-3);
  problem.rotation_scale = problem.length_scale;
}

}  // namespace

std::string step_one_flag_reason(const TransmissionFit& fit, const DeviceModel& model,
                                 double resolution) {
  return fmt::format(
      "step 1: {}'s {} predicts left-out samples of ext{} to {:.4f} mrad, {:.1f} counts of the "
      "encoder's {:.4f} mrad (the limit is {:g}): the model does not capture this transmission",
      model.links[fit.joint].name, fit.model_choice, fit.joint + 1, fit.held_out_rms * 1e3,
      fit.held_out_rms / resolution, resolution * 1e3, kStepOneResolutionFactor);
}

std::vector<TransmissionFit> fit_transmissions(DeviceModel& model, const Log& poses,
                                               const CalibrationOptions& options,
                                               std::vector<std::string>& notes) {
  std::vector<TransmissionFit> fits;
  bool any_ext = false;
  for (int j = 0; j < model.dof(); ++j) any_ext = any_ext || poses.has_ext[j];
  if (!options.transmissions) {
    notes.push_back(
        "--no-transmission: transmissions kept as in the device file (kinematic-only calibration)");
    return fits;
  }
  for (int j = 0; j < model.dof(); ++j) {
    if (!poses.has_ext[j]) continue;
    // A harmonic stage an earlier step 2 fitted (--joint-errors): the external
    // encoder now sees the whole transmission error, so step 1 fits the link's
    // own model without it.
    Transmission& own = model.links[j].transmission;
    if (Transmission stripped = without_trailing_harmonic(own);
        stripped.kind() != own.kind() || stripped.num_parameters() != own.num_parameters()) {
      notes.push_back(fmt::format(
          "{}: the model's harmonic stage (an earlier step 2's joint errors) is left out: ext{} "
          "measures the whole transmission",
          model.links[j].name, j + 1));
      own = std::move(stripped);
    }
    TransmissionFit tf;
    const bool declared = !model.links[j].transmission.is_none();
    Transmission fitted =
        fit_transmission(model, j, poses.q.col(j), poses.ext.col(j), options.polynomial_order, tf);
    const std::string& name = model.links[j].name;
    if (!declared) {
      notes.push_back(fmt::format(
          "{} has no transmission in the model: a polynomial of order {} was fitted to ext{}", name,
          tf.value.size(), j + 1));
    }
    const int kept = static_cast<int>(tf.value.size());
    if (tf.kind == TransmissionKind::kPolynomial && kept < tf.requested_order) {
      const int supported = step_one_supported_order(tf.n);
      notes.push_back(fmt::format(
          "{}: step 1 kept a polynomial of order {} (leave-one-out {:.4f} mrad), not {}: {}", name,
          kept, tf.held_out_rms * 1e3, tf.requested_order,
          supported < tf.requested_order
              ? fmt::format("{} samples support order {} at most ({} a coefficient)", tf.n,
                            supported, kStepOneSamplesPerParameter)
              : std::string("the higher orders predicted left-out samples worse")));
    } else if (tf.kind == TransmissionKind::kCapstan && tf.model_choice != "eccentric drums") {
      notes.push_back(fmt::format("{}: step 1 kept the capstan with {} (leave-one-out {:.4f} mrad)",
                                  name, tf.model_choice, tf.held_out_rms * 1e3));
    }
    if (options.encoder_resolution &&
        tf.held_out_rms > kStepOneResolutionFactor * *options.encoder_resolution) {
      tf.flagged = true;
      notes.push_back(step_one_flag_reason(tf, model, *options.encoder_resolution));
    }
    if (!tf.converged) {
      notes.push_back(fmt::format("{}: the transmission fit did not converge: {}",
                                  model.links[j].name, tf.message));
    }
    if (auto* c = std::get_if<Capstan>(&fitted.model())) c->offset = tf.offset;
    model.links[j].transmission = fitted;
    fits.push_back(tf);
  }
  if (!any_ext) notes.push_back("no ext<i> columns: step 1 (transmissions) skipped");
  return fits;
}

KinematicProblem kinematic_problem(const DeviceModel& model, const Log& poses,
                                   const std::vector<int>& repeats,
                                   const CalibrationOptions& options) {
  check_log_fits(poses, model);
  KinematicProblem problem;
  problem.model = model;
  problem.joint_errors = joint_error_stages(model);
  problem.type = measurement_type(poses);
  const int m = poses.rows;
  const StepTwoJoints step_two(model);
  problem.bends = step_two.bends();
  problem.tip = step_two.tip();
  problem.joints.resize(m);
  for (int i = 0; i < m; ++i) problem.joints[i] = step_two.row(poses, i);
  std::vector<int> pose_index(m);
  std::iota(pose_index.begin(), pose_index.end(), 0);
  problem.measured = pose_measurements(poses, pose_index, RowsOf{problem.type});
  if (is_fixture(problem.type)) {
    problem.labels = fixture_labels(problem.type, poses, pose_index, options.point_distances,
                                    options.known_points);
  } else if (!options.point_distances.empty() || !options.known_points.empty()) {
    throw InputError(poses.origin, 0,
                     options.point_distances.empty() ? "--fixture" : "--point-distance",
                     "known distances are between fixture points: the log has no point column");
  }
  problem.rows = m;
  if (!repeats.empty()) {
    problem.rows = std::accumulate(repeats.begin(), repeats.end(), 0);
    // An average of k repeats has 1/k of one reading's variance: its rows weigh
    // sqrt(k) (none when no pose repeats, and then no arithmetic changes).
    if (problem.rows > m) {
      problem.weights.resize(m);
      for (int i = 0; i < m; ++i) problem.weights[i] = std::sqrt(static_cast<double>(repeats[i]));
    }
  }
  const int d = traits(problem.type).dimension;
  // Beyond options.max_jacobian_bytes the Jacobian is never formed (issue 10:
  // 10^6 rows): its R factor carries the same column geometry.
  // (A fixture problem's rows couple the poses of a label: never compressed.)
  problem.compressed = !problem.labelled() &&
                       static_cast<double>(m) * d * model.structure().num_slots() * sizeof(double) >
                           static_cast<double>(options.max_jacobian_bytes);
  set_scales(problem);
  return problem;
}

bool measurement_frame_unknown(const KinematicProblem& problem, const std::vector<int>& candidates,
                               bool registered) {
  if (!kind_of(problem.type).measures_point()) {
    return false;
  }
  if (!problem.model.base_is_pose()) return false;
  // A base the model gives (a device file's measured pose, the Meca500's
  // T_base) is the frame, known; none (a URDF's root) or one the log was far
  // from (registered) is not.
  const bool given = std::any_of(problem.model.base.begin(), problem.model.base.end(),
                                 [](double v) { return v != 0; });
  if (given && !registered) return false;
  for (int k = 0; k < kPoseSlots; ++k) {
    if (std::find(candidates.begin(), candidates.end(), k) == candidates.end()) return false;
  }
  return true;
}

bool register_measurement_frame(KinematicProblem& problem, const std::vector<int>& candidates,
                                std::vector<std::string>& notes) {
  auto note = register_frame(problem.model, problem.joints, rows_of(problem), problem.measured,
                             problem.weights, candidates);
  if (!note) return false;
  notes.push_back(*note);
  set_scales(problem);
  return true;
}

const char* to_string(SolveTermination termination) {
  switch (termination) {
    case SolveTermination::kConverged:
      return "converged";
    case SolveTermination::kNoConvergence:
      return "no convergence";
    case SolveTermination::kFailure:
      return "failure";
    case SolveTermination::kNothingToSolve:
      return "nothing to solve";
  }
  return "?";
}

namespace {

// The tolerance prior's rows: w_j (x_j - c_j) for every slot j of positive weight.
class PriorCost : public ceres::CostFunction {
 public:
  PriorCost(const Eigen::VectorXd& weight, const Eigen::VectorXd& centre)
      : weight_(weight), centre_(centre) {
    for (int j = 0; j < weight.size(); ++j) {
      if (weight[j] > 0) rows_.push_back(j);
    }
    set_num_residuals(static_cast<int>(rows_.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(weight.size()));
  }
  bool empty() const { return rows_.empty(); }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int n = static_cast<int>(weight_.size());
    for (size_t i = 0; i < rows_.size(); ++i) {
      const int j = rows_[i];
      residuals[i] = weight_[j] * (parameters[0][j] - centre_[j]);
      if (jacobians && jacobians[0]) {
        double* row = jacobians[0] + i * n;
        std::fill(row, row + n, 0.0);
        row[j] = weight_[j];
      }
    }
    return true;
  }

 private:
  Eigen::VectorXd weight_, centre_;
  std::vector<int> rows_;
};

}  // namespace

KinematicSolution solve_kinematics(const KinematicProblem& problem,
                                   const std::vector<int>& identified, int max_iterations) {
  const ChainStructure s = problem.model.structure();
  KinematicSolution out;
  out.parameters = problem.model.kinematic_parameters();
  if (problem.initial.size() == out.parameters.size()) {
    for (int slot : identified) out.parameters[slot] = problem.initial[slot];
  }
  if (identified.empty()) {
    out.termination = SolveTermination::kNothingToSolve;
    out.message = "no parameter is identifiable from these measurements";
    return out;
  }
  std::vector<int> constant;
  for (int k = 0; k < s.num_slots(); ++k) {
    if (std::find(identified.begin(), identified.end(), k) == identified.end())
      constant.push_back(k);
  }
  ceres::Problem lm;
  lm.AddResidualBlock(measurement_cost(s, problem.joints, rows_of(problem), problem.measured,
                                       problem.weights, problem.compressed),
                      nullptr, out.parameters.data());
  if (problem.prior_weight.size() == s.num_slots()) {
    auto prior = std::make_unique<PriorCost>(problem.prior_weight, problem.prior_centre);
    if (!prior->empty()) lm.AddResidualBlock(prior.release(), nullptr, out.parameters.data());
  }
  if (!constant.empty()) {
    lm.SetManifold(out.parameters.data(), new ceres::SubsetManifold(s.num_slots(), constant));
  }
  ceres::Solver::Summary summary;
  detail::solve(detail::levenberg_marquardt(max_iterations, problem.tolerance), &lm, &summary);
  out.termination = summary.termination_type == ceres::CONVERGENCE ? SolveTermination::kConverged
                    : summary.termination_type == ceres::FAILURE   ? SolveTermination::kFailure
                                                                 : SolveTermination::kNoConvergence;
  // Ceres lists iteration 0 (the start) too.
  out.iterations = std::max(static_cast<int>(summary.iterations.size()) - 1, 0);
  out.message = summary.message;
  return out;
}

}  // namespace hapticcal
