#include "hapticcal/design/plan.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <limits>
#include <numeric>
#include <random>

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/io/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

const char* to_string(PlanCriterion criterion) {
  switch (criterion) {
    case PlanCriterion::kD:
      return "D";
    case PlanCriterion::kA:
      return "A";
    case PlanCriterion::kI:
      return "I";
    case PlanCriterion::kE:
      return "E";
  }
  return "?";
}

std::optional<PlanCriterion> plan_criterion(const std::string& text) {
  if (text == "d" || text == "D") return PlanCriterion::kD;
  if (text == "a" || text == "A") return PlanCriterion::kA;
  if (text == "i" || text == "I") return PlanCriterion::kI;
  if (text == "e" || text == "E") return PlanCriterion::kE;
  return std::nullopt;
}

std::optional<MeasurementType> measurement_kind(const std::string& text) {
  for (MeasurementType t :
       {MeasurementType::kDistance, MeasurementType::kPosition, MeasurementType::kPose}) {
    if (text == traits(t).name) return t;
  }
  return std::nullopt;
}

bool PlanConstraints::admits(const Eigen::Vector3d& p) const {
  const double r = p.norm();
  if (r < min_distance || r > max_distance) return false;
  if (box) {
    for (int k = 0; k < 3; ++k) {
      if (p[k] < (*box)[2 * k] || p[k] > (*box)[2 * k + 1]) return false;
    }
  }
  return true;
}

namespace {

// SplitMix64: independent streams from one seed.
std::uint64_t mix(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Capstans with both eccentricities zero get kPlanCapstanEccentricity * D (see plan.hpp).
void linearisable(Transmission& t) {
  if (auto* c = std::get_if<Capstan>(&t.model())) {
    if (c->r_out == 0 && c->r_in == 0) {
      c->r_out = c->r_in = kPlanCapstanEccentricity * c->drum_distance;
    }
  } else if (auto* chain = std::get_if<Chain>(&t.model())) {
    for (Transmission& stage : chain->stages) linearisable(stage);
  }
}

Eigen::MatrixXd tip_rows(const Eigen::MatrixXd& G, int d) {
  if (d == 1) return G;
  const Eigen::Index poses = G.cols() / d;
  Eigen::MatrixXd out(G.rows(), poses * 3);
  for (Eigen::Index r = 0; r < poses; ++r) out.middleCols(3 * r, 3) = G.middleCols(d * r, 3);
  return out;
}

}  // namespace

Eigen::MatrixXd random_readings(const DeviceModel& model, int count, std::uint64_t seed,
                                const PlanConstraints& constraints, const Eigen::VectorXd& lower,
                                const Eigen::VectorXd& upper) {
  const int n = model.dof();
  std::mt19937_64 rng(seed);
  const PreparedModel prepared(model);
  Eigen::MatrixXd out(count, n);
  Eigen::VectorXd q(n);
  const long long max_tries = 1000LL * std::max(count, 10);
  long long tries = 0;
  for (int r = 0; r < count;) {
    if (++tries > max_tries) {
      throw InputError(fmt::format(
          "--distance-range / --box: only {} of {} random poses within the joint limits put the "
          "tool point inside the constraints",
          r, tries - 1));
    }
    for (int j = 0; j < n; ++j) {
      const double lo = lower.size() ? lower[j] : model.links[j].lower;
      const double hi = upper.size() ? upper[j] : model.links[j].upper;
      q[j] = std::uniform_real_distribution<double>(lo, hi)(rng);
    }
    if (constraints.any() && !constraints.admits(prepared.forward(q.data()).p)) continue;
    out.row(r++) = q.transpose();
  }
  return out;
}

// ---------------------------------------------------------------------------
// The problem.

PlanProblem::PlanProblem(const DeviceModel& model, MeasurementType type, double sigma_m,
                         double sigma_e, const Eigen::MatrixXd& analysis,
                         const std::vector<std::string>& fix, const std::vector<std::string>& free)
    : model_(model), type_(type), d_(traits(type).dimension), sigma_m_(sigma_m), sigma_e_(sigma_e) {
  for (Link& l : model_.links) linearisable(l.transmission);
  // The kinematic parameters these candidates can identify.
  Log log;
  log.origin = "plan candidates";
  log.rows = static_cast<int>(analysis.rows());
  log.q = analysis;
  log.ext.setZero(log.rows, model_.dof());
  log.has_ext.assign(model_.dof(), false);
  for (int r = 0; r < log.rows; ++r) log.line.push_back(r + 2);
  const MeasuredValues measured = predicted_measurements(model_, type, analysis);
  if (type == MeasurementType::kDistance) {
    log.has_distance = true;
    log.distance = measured.col(0);
  } else {
    log.has_position = true;
    log.position = measured.leftCols(3);
    if (type == MeasurementType::kPose) {
      log.has_orientation = true;
      log.orientation = measured.rightCols(4);
    }
  }
  const KinematicProblem problem = kinematic_problem(model_, log, {}, CalibrationOptions{});
  length_scale_ = problem.length_scale;
  rotation_scale_ = problem.rotation_scale;
  const std::vector<int> candidates = candidate_slots(model_, fix, free);
  const IdentifiabilityAnalysis ia = analyze_identifiability(problem, candidates);
  slots_ = ia.identified;
  const std::vector<ParameterInfo> info = model_.parameter_info();
  std::map<int, std::string> name;
  for (const ParameterInfo& p : info) name[p.slot] = p.name;
  for (const auto& [slot, why] : ia.reason) held_[name[slot]] = why;

  for (int j = 0; j < model_.dof(); ++j) {
    const Transmission& t = model_.links[j].transmission;
    if (t.is_none() || t.num_parameters() == 0) continue;
    StepOneModel s;
    s.joint = j;
    s.transmission = t;
    for (const std::string& p : t.parameter_names())
      s.names.push_back(model_.links[j].name + "." + p);
    step_one_offset_.push_back(static_cast<int>(names_.size()));
    names_.insert(names_.end(), s.names.begin(), s.names.end());
    names_.push_back(model_.links[j].name + ".encoder_zero");
    step_one_.push_back(std::move(s));
  }
  kinematic_offset_ = static_cast<int>(names_.size());
  for (int slot : slots_) names_.push_back(name[slot]);
}

Eigen::MatrixXd PlanProblem::prediction_rows(const Eigen::MatrixXd& readings) const {
  const TwoStepJacobians J =
      two_step_jacobians(model_, type_, rotation_scale_, slots_, step_one_, readings);
  const Eigen::Index rows = J.kinematic.rows();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(parameters(), rows);
  G.bottomRows(slots_.size()) = J.kinematic.transpose();
  for (size_t t = 0; t < step_one_.size(); ++t) {
    G.middleRows(step_one_offset_[t], J.step_one[t].measurement.cols()) =
        J.step_one[t].measurement.transpose();
  }
  return G;
}

Eigen::MatrixXd PlanProblem::fisher_rows(const Eigen::MatrixXd& readings) const {
  const TwoStepJacobians J =
      two_step_jacobians(model_, type_, rotation_scale_, slots_, step_one_, readings);
  const Eigen::Index m = readings.rows();
  const int r = rows_per_pose();
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(parameters(), m * r);
  for (Eigen::Index i = 0; i < m; ++i) {
    auto block = F.middleCols(i * r, r);
    block.bottomLeftCorner(slots_.size(), d_) =
        J.kinematic.middleRows(i * d_, d_).transpose() / sigma_m_;
    for (size_t t = 0; t < step_one_.size(); ++t) {
      const StepOneSensitivity& s = J.step_one[t];
      const Eigen::Index np = s.measurement.cols();
      block.block(step_one_offset_[t], 0, np, d_) =
          s.measurement.middleRows(i * d_, d_).transpose() / sigma_m_;
      block.block(step_one_offset_[t], d_ + t, np + 1, 1) = s.encoder.row(i).transpose() / sigma_e_;
    }
  }
  return F;
}

Eigen::MatrixXd PlanProblem::covariance(const Eigen::MatrixXd& design) const {
  const TwoStepJacobians J =
      two_step_jacobians(model_, type_, rotation_scale_, slots_, step_one_, design);
  const Eigen::MatrixXd C = two_step_covariance(J.kinematic, sigma_m_, J.step_one, sigma_e_);
  // C's order: each joint's parameters (no encoder zero), then the kinematic ones.
  std::vector<int> index;
  for (size_t t = 0; t < step_one_.size(); ++t) {
    for (int c = 0; c < step_one_[t].transmission.num_parameters(); ++c)
      index.push_back(step_one_offset_[t] + c);
  }
  for (size_t c = 0; c < slots_.size(); ++c) index.push_back(kinematic_offset_ + c);
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(parameters(), parameters());
  for (size_t a = 0; a < index.size(); ++a) {
    for (size_t b = 0; b < index.size(); ++b) out(index[a], index[b]) = C(a, b);
  }
  return out;
}

double PlanProblem::rms_sd_of(const Eigen::MatrixXd& C, const Eigen::MatrixXd& G) const {
  const Eigen::MatrixXd T = tip_rows(G, d_);
  const Eigen::Index poses = G.cols() / d_;
  const double total = (T.transpose() * C).cwiseProduct(T.transpose()).sum();
  return std::sqrt(std::max(total, 0.0) / static_cast<double>(poses));
}

double PlanProblem::predicted_rms_sd(const Eigen::MatrixXd& design,
                                     const Eigen::MatrixXd& validation) const {
  return rms_sd_of(covariance(design), prediction_rows(validation));
}

Conditioning PlanProblem::conditioning(const Eigen::MatrixXd& design) const {
  const TwoStepJacobians J = two_step_jacobians(model_, type_, rotation_scale_, slots_, {}, design);
  Eigen::MatrixXd Js = J.kinematic;
  const std::vector<ParameterInfo> info = model_.parameter_info();
  for (size_t c = 0; c < slots_.size(); ++c) {
    if (info[slots_[c]].unit == ParameterUnit::kAngle) Js.col(c) /= length_scale_;
  }
  return hapticcal::conditioning(Js, static_cast<double>(Js.rows()));
}

// ---------------------------------------------------------------------------
// The exchange.

namespace {

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
  void update(const Eigen::MatrixXd& add, const Eigen::MatrixXd& remove) {
    if (add.size()) M_ += add * add.transpose();
    if (remove.size()) M_ -= remove * remove.transpose();
    refresh();
  }
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
               const Eigen::MatrixXd& WAU) const {
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

 private:
  void refresh() {
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

  PlanCriterion criterion_;
  Eigen::MatrixXd W_, M_, A_;
  double value_ = 0;
};

// Screening gains of adding each block of F (p x r * count) to the design.
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

std::vector<int> top(const Eigen::VectorXd& gain, const std::vector<char>& excluded, int k) {
  std::vector<int> idx;
  for (Eigen::Index c = 0; c < gain.size(); ++c) {
    if (!excluded[c] && std::isfinite(gain[c])) idx.push_back(static_cast<int>(c));
  }
  k = std::min<int>(k, static_cast<int>(idx.size()));
  std::partial_sort(idx.begin(), idx.begin() + k, idx.end(), [&](int a, int b) {
    return gain[a] > gain[b] || (gain[a] == gain[b] && a < b);
  });
  idx.resize(k);
  return idx;
}

Eigen::VectorXd signs(int r, bool remove_second) {
  Eigen::VectorXd s = Eigen::VectorXd::Ones(remove_second ? 2 * r : r);
  if (remove_second) s.tail(r).setConstant(-1);
  return s;
}

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
  bool set(const Eigen::MatrixXd& Fd, int r) {
    const Eigen::Index p = Fd.rows();
    E_.setZero(p, p);
    L_.setZero(p, k_);
    for (Eigen::Index i = 0; i < Fd.cols() / r; ++i)
      accumulate(Fd.middleCols(i * r, r), 1.0, E_, L_);
    return refresh();
  }
  bool valid() const { return valid_; }
  double value() const { return valid_ ? design_.value() : -INFINITY; }
  const Design& design() const { return design_; }

  // The value with pose block `out` replaced by `add`, from scratch.
  double swapped(const Eigen::MatrixXd& add, const Eigen::MatrixXd& out) const {
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
  void swap(const Eigen::MatrixXd& add, const Eigen::MatrixXd& out) {
    accumulate(out, -1.0, E_, L_);
    accumulate(add, 1.0, E_, L_);
    refresh();
  }
  // Adds a pose block (without the gradient's terms: for evaluating updates).
  void add(const Eigen::MatrixXd& F) {
    accumulate(F, 1.0, E_, L_);
    refresh(false);
  }

  // The signed updates of Lambda of adding (sign +1) or removing (-1) each pose
  // block of F (p x r * count): U is p x (r + d) * count, one sign a column
  // (all 0 for a removal that would leave K singular).
  void updates(const Eigen::MatrixXd& F, int r, double sign, Eigen::MatrixXd& U,
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

  // The criterion's first-order change when one pose's rows F change by dF:
  //   tr(Z dLambda), Z = d value / d Lambda, dLambda from dE, dL, dK.
  double directional(const Eigen::MatrixXd& F, const Eigen::MatrixXd& dF) const {
    const auto m = F.leftCols(d_), dm = dF.leftCols(d_);
    const auto e = F.rightCols(F.cols() - d_), de = dF.rightCols(F.cols() - d_);
    double g = 2 * (e.transpose() * Z_ * de).trace();
    const Eigen::MatrixXd mk = m.bottomRows(k_), dmk = dm.bottomRows(k_);
    g += 2 * ((Y_ * mk).transpose() * dm).trace();
    g += 2 * ((Y_.transpose() * m).transpose() * dmk).trace();
    g -= 2 * ((X_ * mk).transpose() * dmk).trace();
    return g;
  }

 private:
  void accumulate(const Eigen::MatrixXd& F, double sign, Eigen::MatrixXd& E,
                  Eigen::MatrixXd& L) const {
    const auto m = F.leftCols(d_);
    const auto e = F.rightCols(F.cols() - d_);
    E.noalias() += sign * e * e.transpose();
    L.noalias() += sign * m * m.bottomRows(k_).transpose();
  }
  bool refresh(bool gradient = true) {
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

// The stages of plan_poses over one set of candidates, sharing their scaled
// information rows.
class Planner {
 public:
  Planner(const PlanProblem& problem, const PlanOptions& o, Eigen::MatrixXd candidates)
      : problem_(problem),
        o_(o),
        model_(problem.model()),
        candidates_(std::move(candidates)),
        user_(o.candidates.size() > 0),
        n_(model_.dof()),
        N_(o.poses),
        Nc_(static_cast<int>(candidates_.rows())),
        p_(problem.parameters()),
        r_(problem.rows_per_pose()),
        d_(problem.dimension()),
        w_(r_ + d_),
        lower_(n_),
        upper_(n_),
        exact_(o.criterion, Eigen::MatrixXd(), d_,
               static_cast<int>(problem.kinematic_slots().size()), kRidge) {
    // The workspace: the joint limits, or the candidates' range of each joint.
    for (int j = 0; j < n_; ++j) {
      lower_[j] = user_ ? candidates_.col(j).minCoeff() : model_.links[j].lower;
      upper_[j] = user_ ? candidates_.col(j).maxCoeff() : model_.links[j].upper;
    }
    // Whitened, scaled Fisher rows of every candidate: each parameter's mean
    // information per candidate pose becomes 1.
    F_ = problem.fisher_rows(candidates_);
    const Eigen::VectorXd info = F_.rowwise().squaredNorm() / static_cast<double>(Nc_);
    scale_.resize(p_);  // divides the rows of F and of the prediction gradients
    for (int k = 0; k < p_; ++k) scale_[k] = info[k] > 0 ? std::sqrt(info[k]) : 1.0;
    F_ = scale_.cwiseInverse().asDiagonal() * F_;
    W_ = Eigen::MatrixXd::Identity(p_, p_);
    if (o.criterion == PlanCriterion::kI) {
      const Eigen::MatrixXd V =
          random_readings(model_, o.validation_poses, mix(o.seed, 1), within(), lower_, upper_);
      const Eigen::MatrixXd G = scale_.cwiseInverse().asDiagonal() * problem.prediction_rows(V);
      W_ = G * G.transpose() / static_cast<double>(V.rows());
    }
    exact_ = TwoStepState(o.criterion, W_, d_, static_cast<int>(problem.kinematic_slots().size()),
                          kRidge);
    order_.resize(Nc_);
    std::iota(order_.begin(), order_.end(), 0);
    std::shuffle(order_.begin(), order_.end(), std::mt19937_64(mix(o.seed, 4)));
    in_design_.assign(Nc_, 0);
    plan_.criterion = o.criterion;
    plan_.seed = o.seed;
    plan_.pool = Nc_;
    say(fmt::format("{} candidates' information rows ready", Nc_));
  }

  Plan run() {
    greedy();
    exchange();
    readings_.resize(N_, n_);
    for (int i = 0; i < N_; ++i) readings_.row(i) = candidates_.row(chosen_[i]);
    plan_.candidate = chosen_;
    if (!user_ && o_.refine_passes > 0 && exact_.valid()) refine();
    plan_.two_step_refined = exact_.value();
    order_path();
    compare_with_random();
    return std::move(plan_);
  }

 private:
  // A ridge of 1e-10 of one mean pose's information keeps the information
  // invertible while a design is built; negligible for any design that
  // identifies the parameters.
  static constexpr double kRidge = 1e-10;
  // Candidates are screened at most kScreened at a time, in a random order.
  static constexpr int kScreened = 3000;
  static constexpr int kShortlist = 32;

  const PlanConstraints& within() const { return user_ ? none_ : o_.constraints; }
  void say(const std::string& s) const {
    if (o_.progress) o_.progress(s);
  }
  Eigen::MatrixXd block(int c) const { return F_.middleCols(c * r_, r_); }
  Eigen::MatrixXd scaled_rows(const Eigen::MatrixXd& readings) const {
    return scale_.cwiseInverse().asDiagonal() * problem_.fisher_rows(readings);
  }

  // The next `count` candidates of the screening order: their rows, indices and
  // whether they are in the design.
  void screen(int count, Eigen::MatrixXd& Fs, std::vector<int>& index,
              std::vector<char>& excluded) {
    Fs.resize(p_, count * r_);
    index.resize(count);
    excluded.resize(count);
    for (int c = 0; c < count; ++c) {
      index[c] = order_[(static_cast<size_t>(scans_) * count + c) % Nc_];
      Fs.middleCols(c * r_, r_) = block(index[c]);
      excluded[c] = in_design_[index[c]];
    }
    ++scans_;
  }

  void fill_design() {
    Fd_.resize(p_, N_ * r_);
    for (int i = 0; i < N_; ++i) Fd_.middleCols(i * r_, r_) = block(chosen_[i]);
  }

  // (1) Greedy start in batches on the joint information (additive): screen
  // candidates, then add the best of a shortlist one at a time with exact gains.
  void greedy() {
    Design design(o_.criterion, W_);
    design.set(kRidge * Eigen::MatrixXd::Identity(p_, p_));
    while (static_cast<int>(chosen_.size()) < N_) {
      const int left = N_ - static_cast<int>(chosen_.size());
      const int batch = std::min(left, std::max(1, (N_ + 2) / 3));
      Eigen::MatrixXd Fs;
      std::vector<int> index;
      std::vector<char> excluded;
      screen(std::min(Nc_, std::max(kScreened, N_ + batch + 8)), Fs, index, excluded);
      std::vector<int> shortlist =
          top(add_gains(design, Fs, r_, o_.criterion), excluded, batch + 8);
      for (int& c : shortlist) c = index[c];
      for (int b = 0; b < batch && !shortlist.empty(); ++b) {
        double best = -std::numeric_limits<double>::infinity();
        size_t best_k = 0;
        for (size_t k = 0; k < shortlist.size(); ++k) {
          const Eigen::MatrixXd U = block(shortlist[k]);
          const Eigen::MatrixXd AU = design.A() * U;
          const Eigen::MatrixXd WAU = design.trace_type() ? design.weighted(AU) : Eigen::MatrixXd();
          const double v = design.after(U, signs(r_, false), AU, WAU);
          if (v > best) {
            best = v;
            best_k = k;
          }
        }
        const int c = shortlist[best_k];
        shortlist.erase(shortlist.begin() + best_k);
        chosen_.push_back(c);
        in_design_[c] = 1;
        design.update(block(c), Eigen::MatrixXd());
      }
    }
    plan_.criterion_greedy = design.value();
    say(fmt::format("greedy start: criterion {:.6g}", design.value()));
  }

  // (2) Fedorov exchange on the exact two-step information: candidates
  // screened by their gain, the shortlist each tried against every design pose
  // with the exact value of the swap (add, then remove: two signed updates).
  void exchange() {
    fill_design();
    exact_.set(Fd_, r_);
    plan_.two_step_greedy = exact_.value();
    const int shortlist_size = std::min(Nc_ - N_, kShortlist);
    for (int sweep = 0; sweep < o_.max_sweeps && shortlist_size > 0 && exact_.valid(); ++sweep) {
      plan_.sweeps = sweep + 1;
      Eigen::MatrixXd Fs, U;
      std::vector<int> index;
      std::vector<char> excluded;
      screen(std::min(Nc_, kScreened), Fs, index, excluded);
      Eigen::VectorXd sign;
      exact_.updates(Fs, r_, 1.0, U, sign);
      std::vector<int> shortlist =
          top(signed_gains(exact_.design(), U, w_, sign, o_.criterion), excluded, shortlist_size);
      for (int& c : shortlist) c = index[c];
      int accepted = 0;
      for (int c : shortlist) {
        const int i = best_swap(c);
        if (i < 0) continue;
        in_design_[chosen_[i]] = 0;
        chosen_[i] = c;
        in_design_[c] = 1;
        fill_design();
        exact_.set(Fd_, r_);  // exact, no drift
        ++accepted;
        ++plan_.swaps;
      }
      say(fmt::format("exchange sweep {}: {} swaps, two-step criterion {:.6g}", sweep + 1, accepted,
                      exact_.value()));
      if (accepted == 0) break;
    }
    plan_.two_step_exchange = exact_.value();
  }

  // The design pose whose swap for candidate c improves the criterion most, or -1.
  int best_swap(int c) const {
    TwoStepState added = exact_;
    added.add(block(c));
    if (!added.valid()) return -1;
    Eigen::MatrixXd U;
    Eigen::VectorXd sign;
    added.updates(Fd_, r_, -1.0, U, sign);
    const Design& dz = added.design();
    const Eigen::MatrixXd AU = dz.A() * U;
    const Eigen::MatrixXd WAU = dz.trace_type() ? dz.weighted(AU) : Eigen::MatrixXd();
    double best = exact_.value();
    int best_i = -1;
    for (int i = 0; i < N_; ++i) {
      if (sign.segment(i * w_, w_).cwiseAbs().sum() == 0) continue;
      const double v = dz.after(
          U.middleCols(i * w_, w_), sign.segment(i * w_, w_), AU.middleCols(i * w_, w_),
          dz.trace_type() ? Eigen::MatrixXd(WAU.middleCols(i * w_, w_)) : Eigen::MatrixXd());
      if (v > best + 1e-10 * std::abs(best)) {
        best = v;
        best_i = i;
      }
    }
    return best_i;
  }

  // (3) Continuous refinement of random candidates on the same criterion: each
  // pose in turn moves along its gradient (the analytic derivative of the
  // criterion w.r.t. the pose's rows, the rows' derivatives by central
  // differences) within the limits, with a step adapted per pose.
  void refine() {
    const PreparedModel prepared(model_);
    std::vector<double> radius(N_, 0.05);
    for (int pass = 0; pass < o_.refine_passes; ++pass) {
      exact_.set(Fd_, r_);  // no drift from the updates
      const double before = exact_.value();
      for (int i = 0; i < N_; ++i) move_pose(i, radius[i], prepared);
      exact_.set(Fd_, r_);
      say(fmt::format("refinement pass {}: two-step criterion {:.6g}", pass + 1, exact_.value()));
      if (exact_.value() - before <= 1e-4 * std::abs(before)) break;
    }
  }

  void move_pose(int i, double& radius, const PreparedModel& prepared) {
    constexpr double h = 1e-6;
    const Eigen::VectorXd q = readings_.row(i).transpose();
    Eigen::MatrixXd probes(2 * n_, n_);
    Eigen::VectorXd step(n_);
    for (int j = 0; j < n_; ++j) {
      probes.row(2 * j) = probes.row(2 * j + 1) = q.transpose();
      probes(2 * j, j) = std::min(q[j] + h, model_.links[j].upper);
      probes(2 * j + 1, j) = std::max(q[j] - h, model_.links[j].lower);
      step[j] = probes(2 * j, j) - probes(2 * j + 1, j);
    }
    const Eigen::MatrixXd rows = scaled_rows(probes);
    const Eigen::MatrixXd out = Fd_.middleCols(i * r_, r_);
    Eigen::VectorXd grad(n_);
    for (int j = 0; j < n_; ++j) {
      grad[j] = step[j] > 0 ? exact_.directional(out, (rows.middleCols(2 * j * r_, r_) -
                                                       rows.middleCols((2 * j + 1) * r_, r_)) /
                                                          step[j])
                            : 0.0;
    }
    const double g = grad.cwiseAbs().maxCoeff();
    if (!(g > 0) || !std::isfinite(g)) return;
    const double current = exact_.value();
    for (int attempt = 0; attempt < 3; ++attempt) {
      Eigen::VectorXd trial = q + radius / g * grad;
      for (int j = 0; j < n_; ++j)
        trial[j] = std::clamp(trial[j], model_.links[j].lower, model_.links[j].upper);
      if (!o_.constraints.any() || o_.constraints.admits(prepared.forward(trial.data()).p)) {
        const Eigen::MatrixXd add = scaled_rows(trial.transpose());
        if (exact_.swapped(add, out) > current + 1e-12 * std::abs(current)) {
          exact_.swap(add, out);
          Fd_.middleCols(i * r_, r_) = add;
          readings_.row(i) = trial.transpose();
          plan_.candidate[i] = -1;
          ++plan_.refined_moves;
          radius = std::min(radius * 1.5, 0.5);
          return;
        }
      }
      radius /= 4;
    }
  }

  // (4) The path.
  void order_path() {
    const std::vector<int> path = short_path(readings_);
    plan_.path_length_unordered = path_length(readings_);
    plan_.readings.resize(N_, n_);
    std::vector<int> candidate(N_);
    for (int i = 0; i < N_; ++i) {
      plan_.readings.row(i) = readings_.row(path[i]);
      candidate[i] = plan_.candidate[path[i]];
    }
    plan_.candidate = candidate;
    plan_.path_length = path_length(plan_.readings);
  }

  // Predicted figures, planned against random designs of the same size.
  void compare_with_random() {
    say("evaluating against random designs");
    const Eigen::MatrixXd E =
        random_readings(model_, o_.evaluation_poses, mix(o_.seed, 2), within(), lower_, upper_);
    const Eigen::MatrixXd GE = problem_.prediction_rows(E);
    auto figures = [&](const Eigen::MatrixXd& d) {
      DesignFigures f;
      const Eigen::MatrixXd C = problem_.covariance(d);
      f.rms_sd = problem_.rms_sd_of(C, GE);
      f.sd = C.diagonal().cwiseMax(0).cwiseSqrt();
      f.conditioning = problem_.conditioning(d);
      return f;
    };
    plan_.planned = figures(plan_.readings);
    std::vector<std::pair<double, Eigen::MatrixXd>> draws;
    for (int k = 0; k < o_.random_draws; ++k) {
      Eigen::MatrixXd d(N_, n_);
      if (user_) {
        std::vector<int> idx(Nc_);
        std::iota(idx.begin(), idx.end(), 0);
        std::mt19937_64 rng(mix(o_.seed, 3 + k));
        std::shuffle(idx.begin(), idx.end(), rng);
        for (int i = 0; i < N_; ++i) d.row(i) = candidates_.row(idx[i]);
      } else {
        d = random_readings(model_, N_, mix(o_.seed, 3 + k), o_.constraints);
      }
      draws.emplace_back(problem_.rms_sd_of(problem_.covariance(d), GE), d);
    }
    if (draws.empty()) return;
    std::sort(draws.begin(), draws.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& dr : draws) plan_.random_rms_sd.push_back(dr.first);
    const size_t m = draws.size();
    plan_.random_median_rms_sd =
        m % 2 ? draws[m / 2].first : 0.5 * (draws[m / 2 - 1].first + draws[m / 2].first);
    plan_.random = figures(draws[(m - 1) / 2].second);
  }

  const PlanProblem& problem_;
  const PlanOptions& o_;
  const DeviceModel& model_;
  const Eigen::MatrixXd candidates_;
  const bool user_;
  const int n_, N_, Nc_, p_, r_, d_, w_;
  Eigen::VectorXd lower_, upper_, scale_;
  const PlanConstraints none_;
  Eigen::MatrixXd F_, W_, Fd_, readings_;
  TwoStepState exact_;
  std::vector<int> order_, chosen_;
  std::vector<char> in_design_;
  int scans_ = 0;
  Plan plan_;
};

}  // namespace

Plan plan_poses(const PlanProblem& problem, const PlanOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const DeviceModel& model = problem.model();
  const int n = model.dof();
  const int N = o.poses;
  const bool user = o.candidates.size() > 0;
  if (N < 1) throw InputError(fmt::format("--poses {}: must be at least 1", N));
  // The command line's bound, for every caller (Python asked for 10^9: MemoryError).
  constexpr int kMaxPool = 10000000;
  if (!user && (o.pool < 1 || o.pool > kMaxPool)) {
    throw InputError(fmt::format("--pool {}: not in [1, {}]", o.pool, kMaxPool));
  }
  if (user && o.candidates.cols() != n)
    throw InputError(
        fmt::format("candidates have {} joints, the model {}", o.candidates.cols(), n));
  const int kinematic = static_cast<int>(problem.kinematic_slots().size());
  if (N * problem.dimension() <= kinematic) {
    throw InputError(fmt::format(
        "--poses {}: {} poses give {} {} residuals for {} identifiable kinematic parameters", N, N,
        N * problem.dimension(), traits(problem.type()).name, kinematic));
  }
  Eigen::MatrixXd candidates =
      user ? o.candidates : random_readings(model, o.pool, mix(o.seed, 0), o.constraints);
  if (N > candidates.rows()) {
    throw InputError(fmt::format("--poses {}: more than the {} candidates", N, candidates.rows()));
  }
  Plan plan = Planner(problem, o, std::move(candidates)).run();
  plan.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return plan;
}

// ---------------------------------------------------------------------------
// Output and path.

std::string plan_to_csv(const Eigen::MatrixXd& readings) {
  std::string out;
  for (Eigen::Index j = 0; j < readings.cols(); ++j)
    out += fmt::format("{}q{}", j ? "," : "", j + 1);
  out += "\n";
  for (Eigen::Index r = 0; r < readings.rows(); ++r) {
    for (Eigen::Index j = 0; j < readings.cols(); ++j)
      out += fmt::format("{}{:.17g}", j ? "," : "", readings(r, j));
    out += "\n";
  }
  return out;
}

namespace {
double step(const Eigen::MatrixXd& q, int a, int b) {
  return (q.row(a) - q.row(b)).cwiseAbs().maxCoeff();
}
}  // namespace

double path_length(const Eigen::MatrixXd& readings) {
  double sum = 0;
  for (Eigen::Index i = 1; i < readings.rows(); ++i)
    sum += step(readings, static_cast<int>(i - 1), static_cast<int>(i));
  return sum;
}

std::vector<int> short_path(const Eigen::MatrixXd& q) {
  const int N = static_cast<int>(q.rows());
  std::vector<int> order;
  if (N == 0) return order;
  std::vector<char> used(N, 0);
  int at = 0;
  for (int i = 1; i < N; ++i) {
    if (q.row(i).cwiseAbs().maxCoeff() < q.row(at).cwiseAbs().maxCoeff()) at = i;
  }
  for (int k = 0; k < N; ++k) {
    order.push_back(at);
    used[at] = 1;
    int next = -1;
    for (int i = 0; i < N; ++i) {
      if (!used[i] && (next < 0 || step(q, at, i) < step(q, at, next))) next = i;
    }
    at = next;
  }
  // 2-opt on the open path (the first pose stays first): reverse order[i..j].
  bool improved = true;
  for (int round = 0; improved && round < 100; ++round) {
    improved = false;
    for (int i = 1; i < N - 1; ++i) {
      for (int j = i + 1; j < N; ++j) {
        const double before =
            step(q, order[i - 1], order[i]) + (j + 1 < N ? step(q, order[j], order[j + 1]) : 0.0);
        const double after =
            step(q, order[i - 1], order[j]) + (j + 1 < N ? step(q, order[i], order[j + 1]) : 0.0);
        if (after < before - 1e-12) {
          std::reverse(order.begin() + i, order.begin() + j + 1);
          improved = true;
        }
      }
    }
  }
  return order;
}

}  // namespace hapticcal
