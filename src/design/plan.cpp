// plan_poses (plan.hpp): the search for the N poses that make the two-step
// calibration predict best: greedy start, Fedorov exchange, continuous
// refinement, the path, and the comparison with random designs.
#include "hapticcal/design/plan.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <limits>
#include <numeric>
#include <random>

#include "design/plan_information.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {

namespace {

using detail::add_gains;
using detail::Design;
using detail::signed_gains;
using detail::TwoStepState;

// SplitMix64: independent streams from one seed.
std::uint64_t mix(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
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
      if (model_.outside_range(trial) < 0 &&
          (!o_.constraints.any() || o_.constraints.admits(prepared.forward(trial.data()).p))) {
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
  if (!user) check_option("--pool", o.pool, option_range::kPool);
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

}  // namespace hapticcal
