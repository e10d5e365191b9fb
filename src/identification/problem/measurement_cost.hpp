// Internal: the step-2 measurement cost (predicted - measured, measurement.hpp) with its analytic
// Jacobian, in a header so that tests can check the Jacobian against central differences.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal::detail {

// Measured values, one row per sample (traits(type).width values), contiguous.
using RowMatrix = MeasuredValues;

// The family's rows with a pose's rotation scale (measurement.hpp).
struct RowsOf {
  MeasurementType type = MeasurementType::kDistance;
  double rotation_scale = 1;              // metres per radian of a pose's rotation rows
  const FixtureLabels* labels = nullptr;  // a fixture problem's (fixture points or planes)
  const std::vector<JointErrorStage>* errors = nullptr;  // step 2's joint-error stages
  // Where a pose's values hold its links' lateral bends (StepTwoJoints::bends:
  // a lateral compliance step 2 holds), if they do.
  std::optional<int> bends;
  // A tree's (ChainStructure::tips > 1): where a pose's values hold the tip it
  // measures (StepTwoJoints::tip); none: the first.
  std::optional<int> tip;
  int dimension() const { return traits(type).dimension; }
  // Residual rows of `poses` poses: a fixture problem's include its known distances.
  int rows(int poses) const {
    return labels ? fixture_rows(type, *labels, poses) : poses * dimension();
  }
};

// Tip k's chain of a tree (ChainStructure::tip) at the tree's joint values
// `joint` and link constants: its structure in the tree's vector, its
// constants (its path's links, its tool) and its joint values.
struct TipChain {
  ChainStructure s;
  ChainConstants<double> constants;
  std::array<double, kMaxDof> joint;
};
inline void tip_chain(const ChainStructure& tree, const ChainConstants<double>& constants,
                      const double* params, const double* joint, int k, TipChain& out) {
  std::array<int, kMaxDof> links;
  const int n = tree.path(k, links.data());
  out.s = tree.tip(k);
  out.constants.base = constants.base;
  out.constants.tool = tool_frame(out.s, params);
  for (int i = 0; i < n; ++i) {
    out.constants.links[i] = constants.links[links[i]];
    out.joint[i] = joint[links[i]];
  }
}
// The tip a pose's values name (a chain's: 0).
inline int tip_of(const ChainStructure& s, const double* values, std::optional<int> tip_at) {
  return s.tips > 1 && tip_at ? static_cast<int>(values[*tip_at]) : 0;
}

// T_meas_tool of a pose at its values (a tree's: of the tip they name, at
// tip_at: RowsOf::tip).
inline Frame<double> pose_tool(const ChainStructure& s, const ChainConstants<double>& constants,
                               const double* params, const double* values,
                               std::optional<int> tip_at) {
  if (s.tips == 1) return forward_kinematics(s, constants, values);
  TipChain chain;
  tip_chain(s, constants, params, values, tip_of(s, values, tip_at), chain);
  return forward_kinematics(chain.s, chain.constants, chain.joint.data());
}

// The family's rows of one pose at its joint values `joint` (dof values, the
// kinematics' links' constants `constants`): a tree's of the tip the pose's
// values name (kind.tip), on that tip's chain in the tree's vector.
inline void tip_rows(const ChainStructure& s, const ChainConstants<double>& constants,
                     const double* params, const double* joint, const double* values,
                     const RowsOf& kind, const double* measured, double* residual,
                     Eigen::Ref<Eigen::MatrixXd> J) {
  if (s.tips == 1) {
    hapticcal::measurement_rows(kind.type, s, constants, params, joint, measured,
                                kind.rotation_scale, residual, J);
    return;
  }
  TipChain chain;
  tip_chain(s, constants, params, joint, tip_of(s, values, kind.tip), chain);
  hapticcal::measurement_rows(kind.type, chain.s, chain.constants, params, chain.joint.data(),
                              measured, kind.rotation_scale, residual, J);
}

// The rows of one pose and their Jacobian; with joint-error stages
// (JointErrorStage) the joint values moved by them first, and each stage
// parameter's column its feature times its joint value's column.
// Stages that bend a link (a lateral compliance's) and a held lateral
// compliance (kind.bends) change the pose's link constants: its own copy.
inline void measurement_rows(const ChainStructure& s, const ChainConstants<double>& constants,
                             const double* params, const double* joint, const RowsOf& kind,
                             const double* measured, double* residual,
                             Eigen::Ref<Eigen::MatrixXd> J) {
  if (!kind.errors && !kind.bends) {
    tip_rows(s, constants, params, joint, joint, kind, measured, residual, J);
    return;
  }
  static const std::vector<JointErrorStage> kNoStages;
  const std::vector<JointErrorStage>& stages = kind.errors ? *kind.errors : kNoStages;
  constexpr int kMaxFeatures = 2 * static_cast<int>(Harmonic::kMaxFrequencies);
  std::array<double, kMaxDof> moved;
  std::copy(joint, joint + s.dof, moved.begin());
  // A harmonic stage's features (one stage a link) from its joint's value; the
  // others' the pose's.
  std::array<std::array<double, kMaxFeatures>, kMaxDof> formed;
  auto features = [&](const JointErrorStage& e) {
    return e.feature >= 0 ? joint + e.feature : formed[e.link].data();
  };
  const bool bent = kind.bends || std::any_of(stages.begin(), stages.end(),
                                              [](const JointErrorStage& e) { return e.geometry; });
  std::optional<ChainConstants<double>> pose;
  if (bent) pose.emplace(constants);
  std::array<double, kMaxDof> bend{};
  if (kind.bends) std::copy(joint + *kind.bends, joint + *kind.bends + s.dof, bend.begin());
  for (const JointErrorStage& e : stages) {
    if (e.feature < 0) e.harmonic.parameter_jacobian(joint[e.link], formed[e.link].data());
    const double* x = features(e);
    double& target = e.geometry ? bend[e.link] : moved[e.link];
    for (int c = 0; c < e.count; ++c) target += (params[e.slot + c] - e.nominal) * x[c];
  }
  if (bent) bend_links(s, bend.data(), pose->links.data());
  tip_rows(s, bent ? *pose : constants, params, moved.data(), joint, kind, measured, residual, J);
  for (const JointErrorStage& e : stages) {
    const double* x = features(e);
    // A bend turns the link's alpha / roll: that slot's column.
    const int column =
        e.geometry ? s.link_slot(e.link) + lateral_slot(s.joints[e.link]) : e.joint_column;
    for (int c = 0; c < e.count; ++c) J.col(e.slot + c) = x[c] * J.col(column);
  }
}

// A pose's rows times its weight (the square root of its repeat count: an
// average of k readings has 1/k of one's variance); no weights: all 1.
inline void weigh(const Eigen::VectorXd& weights, size_t pose, double* residual,
                  Eigen::Ref<Eigen::MatrixXd> J) {
  if (weights.size() == 0) return;
  const double w = weights[static_cast<Eigen::Index>(pose)];
  for (Eigen::Index k = 0; k < J.rows(); ++k) residual[k] *= w;
  J *= w;
}

// Every residual row of the poses (kind.rows), weighted, and if J its Jacobian
// (rows x slots): the family's rows pose by pose, or a fixture problem's rows
// from the poses' tool points (fixture_residuals).
inline void all_rows(const ChainStructure& s, const double* params,
                     const std::vector<Eigen::VectorXd>& joints, const RowsOf& kind,
                     const RowMatrix& measured, const Eigen::VectorXd& weights, double* residual,
                     Eigen::MatrixXd* J) {
  const int m = static_cast<int>(joints.size());
  const int n = s.num_slots();
  const ChainConstants<double> constants = chain_constants(s, params);
  if (kind.labels) {
    Eigen::VectorXd raw(3 * m);
    Eigen::MatrixXd raw_J(3 * m, n);
    for (int i = 0; i < m; ++i) {
      measurement_rows(s, constants, params, joints[i].data(), kind, measured.row(i).data(),
                       raw.data() + 3 * i, raw_J.middleRows(3 * i, 3));
    }
    fixture_residuals(kind.type, *kind.labels, weights, raw, J ? &raw_J : nullptr, residual, J);
    return;
  }
  const int d = kind.dimension();
  Eigen::MatrixXd Ji(d, n);
  if (J) J->resize(static_cast<Eigen::Index>(m) * d, n);
  for (int i = 0; i < m; ++i) {
    measurement_rows(s, constants, params, joints[i].data(), kind, measured.row(i).data(),
                     residual + d * i, Ji);
    weigh(weights, i, residual + d * i, Ji);
    if (J) J->middleRows(static_cast<Eigen::Index>(d) * i, d) = Ji;
  }
}

// Ceres cost over a set of poses: kind.dimension() rows per pose,
// parameters all slots of `s`, each pose's rows weighted (weigh).
class MeasurementCost : public ceres::CostFunction {
 public:
  MeasurementCost(ChainStructure s, std::vector<Eigen::VectorXd> joints, RowsOf kind,
                  RowMatrix measured, Eigen::VectorXd weights = {})
      : s_(s),
        joints_(std::move(joints)),
        kind_(kind),
        measured_(std::move(measured)),
        weights_(std::move(weights)) {
    set_num_residuals(kind.rows(static_cast<int>(joints_.size())));
    mutable_parameter_block_sizes()->push_back(s.num_slots());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int d = kind_.dimension();
    const int n = s_.num_slots();
    if (kind_.labels) {  // a fixture problem: rows that couple the poses of a label
      Eigen::MatrixXd J;
      const bool jacobian = jacobians && jacobians[0];
      all_rows(s_, parameters[0], joints_, kind_, measured_, weights_, residuals,
               jacobian ? &J : nullptr);
      if (jacobian) Eigen::Map<RowMatrix>(jacobians[0], J.rows(), n) = J;
      return true;
    }
    Eigen::MatrixXd J(d, n);
    const ChainConstants<double> constants = chain_constants(s_, parameters[0]);
    for (size_t i = 0; i < joints_.size(); ++i) {
      measurement_rows(s_, constants, parameters[0], joints_[i].data(), kind_,
                       measured_.row(i).data(), residuals + d * i, J);
      weigh(weights_, i, residuals + d * i, J);
      if (jacobians && jacobians[0]) {
        Eigen::Map<RowMatrix>(jacobians[0] + static_cast<size_t>(d) * i * n, d, n) = J;
      }
    }
    return true;
  }

 private:
  ChainStructure s_;
  std::vector<Eigen::VectorXd> joints_;
  RowsOf kind_;
  RowMatrix measured_;
  Eigen::VectorXd weights_;
};

// The measurement problem over many poses compressed to n + 1 rows (n slots):
// with [J r] = Q [R c; 0 e], accumulated block by block of poses (a tall-skinny
// QR: memory does not grow with the poses), 1/2 |r|^2 = 1/2 |[c; e]|^2,
// J^T J = R^T R and J^T r = R^T c. So R stands in for J wherever only column
// geometry matters (the rank test, the covariance, singular values).
struct CompressedRows {
  Eigen::MatrixXd R;  // n x n, upper triangular
  Eigen::VectorXd c;  // n
  double e = 0;       // the part of r outside the span of J
  double rss() const { return c.squaredNorm() + e * e; }
};

inline CompressedRows compress_rows(const ChainStructure& s, const double* params,
                                    const std::vector<Eigen::VectorXd>& joints, RowsOf kind,
                                    const RowMatrix& measured, const Eigen::VectorXd& weights) {
  constexpr int kBlockPoses = 256;
  const int d = kind.dimension(), n = s.num_slots();
  const ChainConstants<double> constants = chain_constants(s, params);
  // Rows 0..n: the factor so far; below: the next block's [J r].
  Eigen::MatrixXd work = Eigen::MatrixXd::Zero(n + 1 + kBlockPoses * d, n + 1);
  Eigen::MatrixXd J(d, n);
  Eigen::Matrix<double, 6, 1> r;
  const int m = static_cast<int>(joints.size());
  for (int first = 0; first < m; first += kBlockPoses) {
    const int count = std::min(kBlockPoses, m - first);
    for (int i = 0; i < count; ++i) {
      measurement_rows(s, constants, params, joints[first + i].data(), kind,
                       measured.row(first + i).data(), r.data(), J);
      weigh(weights, first + i, r.data(), J);
      work.block(n + 1 + d * i, 0, d, n) = J;
      work.block(n + 1 + d * i, n, d, 1) = r.head(d);
    }
    const int rows = n + 1 + d * count;
    Eigen::Ref<Eigen::MatrixXd> block = work.topRows(rows);
    const Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(block);  // in place
    work.topRows(n + 1) = work.topRows(n + 1).triangularView<Eigen::Upper>();
    work.middleRows(n + 1, rows - n - 1).setZero();
  }
  CompressedRows out;
  out.R = work.topLeftCorner(n, n);
  out.c = work.block(0, n, n, 1);
  out.e = work(n, n);
  return out;
}

// MeasurementCost through compress_rows: n + 1 residuals [c; e] with the
// Jacobian [R; 0]. Levenberg-Marquardt sees the same cost, gradient and
// Gauss-Newton matrix as with every row, without the rows x n Jacobian.
// Holds references: the poses and measurements must outlive it.
class CompressedMeasurementCost : public ceres::CostFunction {
 public:
  CompressedMeasurementCost(ChainStructure s, const std::vector<Eigen::VectorXd>& joints,
                            RowsOf kind, const RowMatrix& measured, const Eigen::VectorXd& weights)
      : s_(s), joints_(joints), kind_(kind), measured_(measured), weights_(weights) {
    set_num_residuals(s.num_slots() + 1);
    mutable_parameter_block_sizes()->push_back(s.num_slots());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int n = s_.num_slots();
    if (!jacobians || !jacobians[0]) {  // the cost alone: |r| in one residual
      const int d = kind_.dimension();
      const ChainConstants<double> constants = chain_constants(s_, parameters[0]);
      Eigen::MatrixXd J(d, n);
      Eigen::Matrix<double, 6, 1> r;
      double rss = 0;
      for (size_t i = 0; i < joints_.size(); ++i) {
        measurement_rows(s_, constants, parameters[0], joints_[i].data(), kind_,
                         measured_.row(i).data(), r.data(), J);
        weigh(weights_, i, r.data(), J);
        for (int k = 0; k < d; ++k) rss += r[k] * r[k];
      }
      Eigen::Map<Eigen::VectorXd>(residuals, n + 1).setZero();
      residuals[0] = std::sqrt(rss);
      return std::isfinite(rss);
    }
    const CompressedRows z = compress_rows(s_, parameters[0], joints_, kind_, measured_, weights_);
    Eigen::Map<Eigen::VectorXd> res(residuals, n + 1);
    res.head(n) = z.c;
    res[n] = z.e;
    Eigen::Map<RowMatrix> jac(jacobians[0], n + 1, n);
    jac.topRows(n) = z.R;
    jac.row(n).setZero();
    return res.allFinite() && jac.allFinite();
  }

 private:
  ChainStructure s_;
  const std::vector<Eigen::VectorXd>& joints_;
  RowsOf kind_;
  const RowMatrix& measured_;
  const Eigen::VectorXd& weights_;
};

}  // namespace hapticcal::detail
