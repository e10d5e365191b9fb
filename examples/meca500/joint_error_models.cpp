// Does a joint-space error model explain what the geometric calibration of the
// Meca500 leaves? Calibrates a set with hapticcal (27 parameters), then refits
// the same parameters together with one extra family of joint-angle errors
// dtheta_i(q) and prints the RMS position error on the calibration and
// validation logs for each family:
//   joint_error_models MODEL CAL_LOG VAL_LOG
// The families: a gear-ratio error c_i q_i; a quadratic c_i q_i^2; a first and a
// second harmonic c_i sin(k q_i) + s_i (cos(k q_i) - 1); coupling to the previous
// joint c_i q_(i-1); and gravity compliance of joints 2, 3 and 5, dtheta =
// c r.(z x g) with r from the joint axis to the wrist centre or the tool point
// (g along -z of the robot base, masses unknown: the c absorb them). Last, the
// lag-1 autocorrelation of the geometric fit's residuals in log order (drift).
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <iostream>

#include "hapticcal/core/error.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/study/evaluate.hpp"

namespace {

using namespace hapticcal;

enum class Family { kNone, kRatio, kQuadratic, kHarmonic1, kHarmonic2, kCoupling, kGravity };
constexpr int kExtra = 12;  // coefficients of the largest family (two per joint)

// Position residual of one row: FK with the joint angles plus the family's error.
struct Residual {
  ChainStructure s;
  Eigen::VectorXd joint;
  Eigen::Vector3d p_meas;
  Family family;

  template <typename T>
  bool operator()(T const* const* blocks, T* r) const {
    using std::cos;
    using std::sin;
    const T* params = blocks[0];
    const T* c = blocks[1];
    const ChainConstants<T> constants = chain_constants(s, params);
    std::array<T, kMaxDof> angle;
    for (int i = 0; i < s.dof; ++i) angle[i] = T(joint[i]);
    std::array<Frame<T>, kMaxDof + 1> frames;
    const Frame<T> rigid = forward_kinematics(s, constants, angle.data(), frames.data());
    for (int i = 0; i < s.dof; ++i) {
      const double q = joint[i];
      switch (family) {
        case Family::kNone:
          break;
        case Family::kRatio:
          angle[i] += c[i] * q;
          break;
        case Family::kQuadratic:
          angle[i] += c[i] * q * q;
          break;
        case Family::kHarmonic1:
          angle[i] += c[i] * sin(q) + c[6 + i] * (cos(q) - 1);
          break;
        case Family::kHarmonic2:
          angle[i] += c[i] * sin(2 * q) + c[6 + i] * (cos(2 * q) - 1);
          break;
        case Family::kCoupling:
          if (i > 0) angle[i] += c[i] * joint[i - 1];
          break;
        case Family::kGravity:
          break;
      }
    }
    if (family == Family::kGravity) {
      // MDH: joint i turns about z of frame i + 1; the wrist centre is frame 5.
      const Vec3<T> g = -constants.base.R.col(2);
      auto moment = [&](int i, const Vec3<T>& point) {
        const Frame<T>& axis = frames[i + 1];
        return Vec3<T>(axis.R.col(2)).dot((point - axis.p).cross(g));
      };
      const Vec3<T> wrist = frames[5].p;
      angle[1] += c[0] * moment(1, wrist) + c[1] * moment(1, rigid.p);
      angle[2] += c[2] * moment(2, wrist) + c[3] * moment(2, rigid.p);
      angle[4] += c[4] * moment(4, rigid.p);
    }
    const Vec3<T> p = forward_kinematics(s, constants, angle.data()).p;
    for (int k = 0; k < 3; ++k) r[k] = p[k] - T(p_meas[k]);
    return true;
  }
};

double rms_mm(const std::vector<Residual>& rows, const double* params, const double* c) {
  double sum = 0;
  for (const Residual& row : rows) {
    double r[3];
    const double* blocks[2] = {params, c};
    row(blocks, r);
    sum += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  }
  return std::sqrt(sum / static_cast<double>(rows.size())) * 1e3;
}

std::vector<Residual> rows_of(const DeviceModel& model, const Log& log, Family family) {
  std::vector<Residual> rows;
  for (int i = 0; i < log.rows; ++i) {
    const Eigen::VectorXd q = log.q.row(i).transpose();
    rows.push_back(
        {model.structure(), model.compensate(q), log.position.row(i).transpose(), family});
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: joint_error_models MODEL CAL_LOG VAL_LOG\n";
    return 2;
  }
  try {
    const DeviceModel nominal = load_device(argv[1]);
    const Log cal = read_log(argv[2]), val = read_log(argv[3]);
    check_log_fits(cal, nominal);
    check_log_fits(val, nominal);
    if (!cal.has_position || !val.has_position || nominal.dof() != 6 ||
        nominal.links[0].geometry != Geometry::kMdh) {
      throw InputError("joint_error_models needs a 6-joint MDH model and x, y, z logs");
    }
    CalibrationOptions every;  // the geometric model whole: every identifiable parameter
    every.keep_all = true;
    const CalibrationResult calibrated = calibrate(nominal, cal, every);
    const ChainStructure s = nominal.structure();
    std::vector<int> held;
    for (const ParameterEstimate& e : calibrated.kinematics.parameters) {
      if (!e.identifiable) held.push_back(e.slot);
    }
    fmt::print("{} identified parameters; RMS position error [mm]\n",
               calibrated.kinematics.identified);
    fmt::print("{:<44} {:>11} {:>11}  {}\n", "joint error added", "calibration", "validation",
               "solver");
    const std::pair<Family, const char*> families[] = {
        {Family::kNone, "none (the geometric calibration)"},
        {Family::kRatio, "gear-ratio error, 6"},
        {Family::kQuadratic, "quadratic, 6"},
        {Family::kHarmonic1, "first harmonic, 12"},
        {Family::kHarmonic2, "second harmonic, 12"},
        {Family::kCoupling, "coupling to the previous joint, 5"},
        {Family::kGravity, "gravity compliance of joints 2, 3, 5, 5"}};
    Eigen::VectorXd first_fit;
    for (const auto& [family, label] : families) {
      Eigen::VectorXd params = calibrated.calibrated.kinematic_parameters();
      std::array<double, kExtra> c{};
      const std::vector<Residual> cal_rows = rows_of(nominal, cal, family);
      ceres::Problem problem;
      for (const Residual& row : cal_rows) {
        auto* cost = new ceres::DynamicAutoDiffCostFunction<Residual, 8>(new Residual(row));
        cost->AddParameterBlock(s.num_slots());
        cost->AddParameterBlock(kExtra);
        cost->SetNumResiduals(3);
        problem.AddResidualBlock(cost, nullptr, params.data(), c.data());
      }
      problem.SetManifold(params.data(), new ceres::SubsetManifold(s.num_slots(), held));
      if (family == Family::kNone) problem.SetParameterBlockConstant(c.data());
      ceres::Solver::Options options;
      options.max_num_iterations = 200;
      options.function_tolerance = 1e-14;
      options.parameter_tolerance = 1e-14;
      options.logging_type = ceres::SILENT;
      ceres::Solver::Summary summary;
      ceres::Solve(options, &problem, &summary);
      if (family == Family::kNone) first_fit = params;
      fmt::print("{:<44} {:>11.4f} {:>11.4f}  {}\n", label,
                 rms_mm(cal_rows, params.data(), c.data()),
                 rms_mm(rows_of(nominal, val, family), params.data(), c.data()),
                 summary.termination_type == ceres::CONVERGENCE ? "converged" : "NOT CONVERGED");
    }
    // Drift would make the residuals of successive poses alike: their lag-1
    // autocorrelation per coordinate, for the geometric fit, in log order. One
    // row per pose (the log repeats each pose's readings on successive rows).
    const std::vector<Residual> rows = rows_of(nominal, cal, Family::kNone);
    const std::array<double, kExtra> none{};
    std::vector<Eigen::Vector3d> per_pose;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (i > 0 && rows[i].joint == rows[i - 1].joint) continue;
      const double* blocks[2] = {first_fit.data(), none.data()};
      Eigen::Vector3d e;
      rows[i](blocks, e.data());
      per_pose.push_back(e);
    }
    Eigen::MatrixXd r(per_pose.size(), 3);
    for (std::size_t i = 0; i < per_pose.size(); ++i) r.row(i) = per_pose[i].transpose();
    Eigen::Vector3d lag1;
    const Eigen::Index n = r.rows();
    for (int k = 0; k < 3; ++k) {
      const Eigen::VectorXd x = r.col(k).array() - r.col(k).mean();
      lag1[k] = x.head(n - 1).dot(x.tail(n - 1)) / x.squaredNorm();
    }
    fmt::print(
        "lag-1 autocorrelation of the residuals of {} poses (x, y, z): {:.3f} {:.3f} {:.3f}\n",
        r.rows(), lag1[0], lag1[1], lag1[2]);
  } catch (const std::exception& e) {
    std::cerr << "joint_error_models: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
