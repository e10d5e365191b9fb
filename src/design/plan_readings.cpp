// The plain parts of experiment design (plan.hpp): criterion and measurement
// names, the tool point's constraints, random readings within the joint limits,
// plan.csv and the path through the planned poses.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>

#include "hapticcal/core/error.hpp"
#include "hapticcal/design/plan.hpp"
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
  const std::optional<MeasurementType> type = measurement_type_named(text);
  if (type && is_fixture(*type)) return std::nullopt;  // a plan is of poses, not of labels
  return type;
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
    if (model.outside_range(q) >= 0) continue;  // a coupled joint beyond its range
    if (constraints.any() && !constraints.admits(prepared.forward(q.data()).p)) continue;
    out.row(r++) = q.transpose();
  }
  return out;
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
