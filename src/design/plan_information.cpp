// The information of a design under construction (plan_information.hpp): a
// criterion and its low-rank updates, and the exact two-step information.
#include "design/plan_information.hpp"

#include <Eigen/Dense>
#include <limits>

namespace hapticcal::detail {

void Design::update(const Eigen::MatrixXd& add, const Eigen::MatrixXd& remove) {
  if (add.size()) M_ += add * add.transpose();
  if (remove.size()) M_ -= remove * remove.transpose();
  refresh();
}

double Design::after(const Eigen::MatrixXd& U, const Eigen::VectorXd& sign,
                     const Eigen::MatrixXd& AU, const Eigen::MatrixXd& WAU) const {
  if (criterion_ == PlanCriterion::kE) {
    Eigen::MatrixXd M = M_;
    M.noalias() += U * sign.asDiagonal() * U.transpose();
    return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M, Eigen::EigenvaluesOnly)
        .eigenvalues()[0];
  }
  const Eigen::MatrixXd X = U.transpose() * AU;
  const Eigen::Index k = X.rows();
  // I + S X (S^2 = I): det(M') = det(M) det(I + S X).
  const Eigen::MatrixXd IX = Eigen::MatrixXd::Identity(k, k) + sign.asDiagonal() * X;
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(IX);
  const double det = lu.determinant();
  if (!(det > 0)) return -std::numeric_limits<double>::infinity();
  if (criterion_ == PlanCriterion::kD) return value_ + std::log(det);
  // (M')^-1 = A - A U (S + X)^-1 U^T A; trace(W (M')^-1) drops by trace((S + X)^-1 Y).
  const Eigen::MatrixXd Y = AU.transpose() * WAU;
  const Eigen::MatrixXd SX = Eigen::MatrixXd(sign.asDiagonal()) + X;
  return value_ + SX.partialPivLu().solve(Y).trace();
}

void Design::refresh() {
  const Eigen::Index p = M_.rows();
  const Eigen::LLT<Eigen::MatrixXd> llt(M_);
  A_ = llt.solve(Eigen::MatrixXd::Identity(p, p));
  switch (criterion_) {
    case PlanCriterion::kD:
      value_ = 2 * llt.matrixLLT().diagonal().array().log().sum();
      break;
    case PlanCriterion::kA:
      value_ = -A_.trace();
      break;
    case PlanCriterion::kI:
      value_ = -A_.cwiseProduct(W_).sum();
      break;
    case PlanCriterion::kE:
      value_ = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M_, Eigen::EigenvaluesOnly)
                   .eigenvalues()[0];
      break;
  }
}

Eigen::VectorXd add_gains(const Design& design, const Eigen::MatrixXd& F, int r,
                          PlanCriterion criterion) {
  const Eigen::Index count = F.cols() / r;
  Eigen::VectorXd gain(count);
  if (criterion == PlanCriterion::kE) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(design.M());
    const Eigen::VectorXd v = eig.eigenvectors().col(0);
    const Eigen::VectorXd proj = F.transpose() * v;
    for (Eigen::Index c = 0; c < count; ++c) gain[c] = proj.segment(c * r, r).squaredNorm();
    return gain;
  }
  const Eigen::MatrixXd AF = design.A() * F;
  Eigen::MatrixXd WAF;
  if (design.trace_type()) WAF = design.weighted(AF);
  const Eigen::VectorXd plus = Eigen::VectorXd::Ones(r);
  for (Eigen::Index c = 0; c < count; ++c) {
    const auto Fc = F.middleCols(c * r, r);
    const auto AFc = AF.middleCols(c * r, r);
    const Eigen::MatrixXd S = Eigen::MatrixXd::Identity(r, r) + Fc.transpose() * AFc;
    const Eigen::LLT<Eigen::MatrixXd> llt(S);
    if (criterion == PlanCriterion::kD) {
      gain[c] = 2 * llt.matrixLLT().diagonal().array().log().sum();
    } else {
      gain[c] = llt.solve(AFc.transpose() * WAF.middleCols(c * r, r)).trace();
    }
  }
  return gain;
}

bool TwoStepState::set(const Eigen::MatrixXd& Fd, int r) {
  const Eigen::Index p = Fd.rows();
  E_.setZero(p, p);
  L_.setZero(p, k_);
  for (Eigen::Index i = 0; i < Fd.cols() / r; ++i) accumulate(Fd.middleCols(i * r, r), 1.0, E_, L_);
  return refresh();
}

double TwoStepState::swapped(const Eigen::MatrixXd& add, const Eigen::MatrixXd& out) const {
  Eigen::MatrixXd E = E_, L = L_;
  accumulate(out, -1.0, E, L);
  accumulate(add, 1.0, E, L);
  const Eigen::LLT<Eigen::MatrixXd> kllt(L.bottomRows(k_));
  if (kllt.info() != Eigen::Success) return -INFINITY;
  Eigen::MatrixXd Lambda = E;
  Lambda.noalias() += L * kllt.solve(L.transpose());
  Lambda.diagonal().array() += ridge_;
  const Eigen::LLT<Eigen::MatrixXd> llt(Lambda);
  if (llt.info() != Eigen::Success) return -INFINITY;
  switch (criterion_) {
    case PlanCriterion::kD:
      return 2 * llt.matrixLLT().diagonal().array().log().sum();
    case PlanCriterion::kA:
      return -llt.solve(Eigen::MatrixXd::Identity(E.rows(), E.rows())).trace();
    case PlanCriterion::kI:
      return -llt.solve(W_).trace();
    case PlanCriterion::kE:
      return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Lambda, Eigen::EigenvaluesOnly)
          .eigenvalues()[0];
  }
  return -INFINITY;
}

void TwoStepState::swap(const Eigen::MatrixXd& add, const Eigen::MatrixXd& out) {
  accumulate(out, -1.0, E_, L_);
  accumulate(add, 1.0, E_, L_);
  refresh();
}

void TwoStepState::add(const Eigen::MatrixXd& F) {
  accumulate(F, 1.0, E_, L_);
  refresh(false);
}

void TwoStepState::updates(const Eigen::MatrixXd& F, int r, double sign, Eigen::MatrixXd& U,
                           Eigen::VectorXd& signs) const {
  const Eigen::Index p = F.rows(), count = F.cols() / r, w = r + d_;
  U.resize(p, w * count);
  signs.resize(w * count);
  Eigen::MatrixXd mk(k_, d_ * count);
  for (Eigen::Index c = 0; c < count; ++c)
    mk.middleCols(c * d_, d_) = F.block(p - k_, c * r, k_, d_);
  const Eigen::MatrixXd u = LK_ * mk;
  const Eigen::MatrixXd Kmk = K_inverse_ * mk;
  for (Eigen::Index c = 0; c < count; ++c) {
    const auto m = F.middleCols(c * r, d_);
    Eigen::MatrixXd S = Eigen::MatrixXd::Identity(d_, d_);
    S.noalias() += sign * mk.middleCols(c * d_, d_).transpose() * Kmk.middleCols(c * d_, d_);
    const Eigen::LLT<Eigen::MatrixXd> llt(S);
    auto block = U.middleCols(c * w, w);
    block.leftCols(r) = F.middleCols(c * r, r);
    signs.segment(c * w, r).setConstant(sign);
    if (llt.info() != Eigen::Success) {
      block.setZero();
      signs.segment(c * w, w).setZero();
      continue;
    }
    const Eigen::MatrixXd diff = u.middleCols(c * d_, d_) - m;
    block.rightCols(d_) = llt.matrixL().solve(diff.transpose()).transpose();
    signs.segment(c * w + r, d_).setConstant(-sign);
  }
}

double TwoStepState::directional(const Eigen::MatrixXd& F, const Eigen::MatrixXd& dF) const {
  const auto m = F.leftCols(d_), dm = dF.leftCols(d_);
  const auto e = F.rightCols(F.cols() - d_), de = dF.rightCols(F.cols() - d_);
  double g = 2 * (e.transpose() * Z_ * de).trace();
  const Eigen::MatrixXd mk = m.bottomRows(k_), dmk = dm.bottomRows(k_);
  g += 2 * ((Y_ * mk).transpose() * dm).trace();
  g += 2 * ((Y_.transpose() * m).transpose() * dmk).trace();
  g -= 2 * ((X_ * mk).transpose() * dmk).trace();
  return g;
}

void TwoStepState::accumulate(const Eigen::MatrixXd& F, double sign, Eigen::MatrixXd& E,
                              Eigen::MatrixXd& L) const {
  const auto m = F.leftCols(d_);
  const auto e = F.rightCols(F.cols() - d_);
  E.noalias() += sign * e * e.transpose();
  L.noalias() += sign * m * m.bottomRows(k_).transpose();
}

bool TwoStepState::refresh(bool gradient) {
  const Eigen::MatrixXd K = L_.bottomRows(k_);
  const Eigen::LLT<Eigen::MatrixXd> kllt(K);
  valid_ = kllt.info() == Eigen::Success;
  if (!valid_) return false;
  K_inverse_ = kllt.solve(Eigen::MatrixXd::Identity(k_, k_));
  LK_ = L_ * K_inverse_;
  Eigen::MatrixXd Lambda = E_;
  Lambda.noalias() += LK_ * L_.transpose();
  Lambda.diagonal().array() += ridge_;
  design_.set(Lambda);
  if (!gradient) return valid_ = std::isfinite(design_.value());
  const Eigen::MatrixXd& A = design_.A();
  switch (criterion_) {
    case PlanCriterion::kD:
      Z_ = A;
      break;
    case PlanCriterion::kA:
      Z_ = A * A;
      break;
    case PlanCriterion::kI:
      Z_ = A * W_ * A;
      break;
    case PlanCriterion::kE: {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Lambda);
      Z_ = eig.eigenvectors().col(0) * eig.eigenvectors().col(0).transpose();
      break;
    }
  }
  Y_ = Z_ * LK_;
  X_ = LK_.transpose() * Y_;
  return valid_ = std::isfinite(design_.value());
}

Eigen::VectorXd signed_gains(const Design& design, const Eigen::MatrixXd& U, int width,
                             const Eigen::VectorXd& sign, PlanCriterion criterion) {
  const Eigen::Index count = U.cols() / width;
  Eigen::VectorXd gain(count);
  if (criterion == PlanCriterion::kE) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(design.M());
    const Eigen::VectorXd proj = U.transpose() * eig.eigenvectors().col(0);
    for (Eigen::Index c = 0; c < count; ++c) {
      gain[c] = proj.segment(c * width, width).cwiseAbs2().dot(sign.segment(c * width, width));
    }
    return gain;
  }
  const Eigen::MatrixXd AU = design.A() * U;
  Eigen::MatrixXd WAU;
  if (design.trace_type()) WAU = design.weighted(AU);
  for (Eigen::Index c = 0; c < count; ++c) {
    const auto Uc = U.middleCols(c * width, width);
    const auto AUc = AU.middleCols(c * width, width);
    const Eigen::VectorXd s = sign.segment(c * width, width);
    if (s.cwiseAbs().sum() == 0) {
      gain[c] = -INFINITY;
      continue;
    }
    const Eigen::MatrixXd X = Uc.transpose() * AUc;
    if (criterion == PlanCriterion::kD) {
      const Eigen::MatrixXd IX = Eigen::MatrixXd::Identity(width, width) + s.asDiagonal() * X;
      const double det = IX.partialPivLu().determinant();
      gain[c] = det > 0 ? std::log(det) : -INFINITY;
    } else {
      Eigen::MatrixXd SX = X;
      SX.diagonal() += s;
      gain[c] = SX.partialPivLu().solve(AUc.transpose() * WAU.middleCols(c * width, width)).trace();
    }
  }
  return gain;
}

}  // namespace hapticcal::detail
