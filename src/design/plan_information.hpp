// Internal: the information of a design under construction, for plan_poses
// (plan.cpp): a criterion of the joint information and its change under
// low-rank updates (Design), and the exact two-step information with the
// signed updates of adding or removing a pose (TwoStepState). See plan.hpp for
// the criteria and the two-step information Lambda.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <utility>

#include "hapticcal/design/plan.hpp"

namespace hapticcal::detail {

// The criterion of an information matrix M (scaled parameters; larger is
// better) and its change under low-rank updates M + U S U^T, S = diag(+-1),
// through A = M^-1 (Woodbury).
class Design {
 public:
  Design(PlanCriterion criterion, Eigen::MatrixXd W) : criterion_(criterion), W_(std::move(W)) {}

  void set(const Eigen::MatrixXd& M) {
    M_ = M;
    refresh();
  }
  void update(const Eigen::MatrixXd& add, const Eigen::MatrixXd& remove);
  double value() const { return value_; }
  const Eigen::MatrixXd& M() const { return M_; }
  const Eigen::MatrixXd& A() const { return A_; }
  bool trace_type() const {
    return criterion_ == PlanCriterion::kI || criterion_ == PlanCriterion::kA;
  }
  // W * X (W = I for A).
  Eigen::MatrixXd weighted(const Eigen::MatrixXd& X) const {
    return criterion_ == PlanCriterion::kA ? X : Eigen::MatrixXd(W_ * X);
  }

  // The criterion of M + U S U^T, with AU = A U and WAU = W A U given (trace types).
  double after(const Eigen::MatrixXd& U, const Eigen::VectorXd& sign, const Eigen::MatrixXd& AU,
               const Eigen::MatrixXd& WAU) const;

 private:
  void refresh();

  PlanCriterion criterion_;
  Eigen::MatrixXd W_, M_, A_;
  double value_ = 0;
};

// Screening gains of adding each block of F (p x r * count) to the design.
Eigen::VectorXd add_gains(const Design& design, const Eigen::MatrixXd& F, int r,
                          PlanCriterion criterion);

// The exact information of the two-step estimate (step 1 from the encoders
// alone, step 2 with step 1's values), from sums over a design's poses:
//   Lambda = E + L K^-1 L^T,  E = sum of encoder rows e e^T,
//   L = sum m m_k^T (m a measurement row, m_k its kinematic part), K = sum m_k m_k^T,
// whose inverse is two_step_covariance (block inversion). Adding (sign +1) or
// removing (-1) a pose with rows m, e changes it by
//   sign (m m^T + e e^T) - sign (u - m) S^-1 (u - m)^T,
//   u = L K^-1 m_k,  S = I + sign m_k^T K^-1 m_k
// (Sherman-Morrison-Woodbury on K), a signed low-rank update.
class TwoStepState {
 public:
  TwoStepState(PlanCriterion criterion, const Eigen::MatrixXd& W, int d, int k, double ridge)
      : design_(criterion, W), criterion_(criterion), W_(W), d_(d), k_(k), ridge_(ridge) {}

  // From every pose block of Fd; false if the measurements leave K singular.
  bool set(const Eigen::MatrixXd& Fd, int r);
  bool valid() const { return valid_; }
  double value() const { return valid_ ? design_.value() : -INFINITY; }
  const Design& design() const { return design_; }

  // The value with pose block `out` replaced by `add`, from scratch.
  double swapped(const Eigen::MatrixXd& add, const Eigen::MatrixXd& out) const;
  void swap(const Eigen::MatrixXd& add, const Eigen::MatrixXd& out);
  // Adds a pose block (without the gradient's terms: for evaluating updates).
  void add(const Eigen::MatrixXd& F);

  // The signed updates of Lambda of adding (sign +1) or removing (-1) each pose
  // block of F (p x r * count): U is p x (r + d) * count, one sign a column
  // (all 0 for a removal that would leave K singular).
  void updates(const Eigen::MatrixXd& F, int r, double sign, Eigen::MatrixXd& U,
               Eigen::VectorXd& signs) const;

  // The criterion's first-order change when one pose's rows F change by dF:
  //   tr(Z dLambda), Z = d value / d Lambda, dLambda from dE, dL, dK.
  double directional(const Eigen::MatrixXd& F, const Eigen::MatrixXd& dF) const;

 private:
  void accumulate(const Eigen::MatrixXd& F, double sign, Eigen::MatrixXd& E,
                  Eigen::MatrixXd& L) const;
  bool refresh(bool gradient = true);

  Design design_;
  PlanCriterion criterion_;
  Eigen::MatrixXd W_;
  int d_, k_;
  double ridge_;
  Eigen::MatrixXd E_, L_, K_inverse_, LK_, Z_, Y_, X_;
  bool valid_ = false;
};

// Gains of signed updates of the design (blocks of `width` columns of U, one
// sign a column): D log det(I + S X), trace types tr((S + X)^-1 Y), X = U^T A U,
// Y = (A U)^T W (A U); E at first order.
Eigen::VectorXd signed_gains(const Design& design, const Eigen::MatrixXd& U, int width,
                             const Eigen::VectorXd& sign, PlanCriterion criterion);

}  // namespace hapticcal::detail
