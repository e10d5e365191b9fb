#include "hapticcal/study/iso9283_cube.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/inverse.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

constexpr double kReached = 1e-11;    // m and rad: a pose is reached
constexpr double kLengthScale = 0.1;  // m/rad: an orientation error's weight against a position's
constexpr double kMinEdge = 0.01;     // m: a smaller cube is no test
constexpr double kMaxEdge = 10;       // m
constexpr double kEdgeResolution = 1e-4;  // m: the largest edge to this
constexpr double kGain = 1.01;            // a candidate is grown when it beats the best by this
constexpr double kSmallestMove = 1e-3;    // m: the centre's last step
constexpr int kMaxMoves = 60;

// A test pose's inverse kinematics: reached to kReached, near a singularity
// below kIsoAwayFromSingular (said, never refused by the solver itself).
InverseOptions reach_options(bool orientation) {
  InverseOptions o;
  o.orientation = orientation;
  o.position_tolerance = o.rotation_tolerance = kReached;
  o.rotation_scale = kLengthScale;
  o.max_iterations = 300;
  o.singular_below = kIsoAwayFromSingular;
  return o;
}

// The tool at a target: the readings, or why not.
struct Reach {
  std::optional<Eigen::VectorXd> q;
  std::string why;
};

// A candidate: a centre, the orientation held there and readings that reach it.
struct Seed {
  Eigen::Vector3d centre;
  Eigen::Matrix3d R;
  Eigen::VectorXd q;
};

// The cube's corner (sx, sy, sz in -1, +1).
Eigen::Vector3d corner(const Eigen::Vector3d& centre, const Eigen::Matrix3d& axes, double size,
                       double sx, double sy, double sz) {
  return centre + axes * (Eigen::Vector3d(sx, sy, sz) * size / 2);
}

constexpr std::array<std::array<double, 3>, 8> kCorners{{{-1, -1, -1},
                                                         {1, -1, -1},
                                                         {1, 1, -1},
                                                         {-1, 1, -1},
                                                         {-1, -1, 1},
                                                         {1, -1, 1},
                                                         {1, 1, 1},
                                                         {-1, 1, 1}}};

class CubeFitter {
 public:
  CubeFitter(const DeviceModel& model, const Eigen::Matrix3d& axes, bool orientation)
      : model_(model),
        prepared_(model),
        lower_(model.dof()),
        upper_(model.dof()),
        axes_(axes),
        orientation_(orientation) {
    reading_limits(model, lower_.data(), upper_.data());
  }

  // Readings near `from` that put the tool at `target` within the limits
  // (`away`: away from singularities too; `point`: its position alone).
  Reach reach(const Eigen::VectorXd& from, const Frame<double>& target, bool away,
              bool point = false) const {
    const InverseOptions o = reach_options(orientation_ && !point);
    Eigen::VectorXd q(model_.dof());
    InverseResult r = inverse_kinematics(prepared_, target, from.data(), q.data(), o, lower_.data(),
                                         upper_.data());
    check_ranges(model_, q.data(), r);
    if (!q.allFinite() || r.status == InverseStatus::kNotConverged) return {{}, "out of reach"};
    if (r.status == InverseStatus::kOutsideLimits) {
      return {{},
              fmt::format("outside {}'s limits",
                          model_.links[static_cast<std::size_t>(r.outside_limit)].name)};
    }
    if (r.status == InverseStatus::kNear && away) return {{}, "near a singularity"};
    return {q, ""};
  }

  // The five poses of a cube of edge `size` about the seed (P2 .. P5 from P1's
  // readings) and its eight corners within reach (the workspace's points: any
  // orientation); false and why not.
  bool place(const Seed& seed, double size, std::vector<IsoTestPose>& poses,
             std::string& why) const {
    const auto at = [&](double sx, double sy, double sz) {
      return corner(seed.centre, axes_, size, sx, sy, sz);
    };
    // P2 .. P5: 10 % of the plane's diagonal from the corners C1, C2, C7, C8,
    // i.e. 0.9 a corner + 0.1 the opposite one.
    const Eigen::Vector3d c1 = at(-1, -1, -1), c2 = at(1, -1, -1), c7 = at(1, 1, 1),
                          c8 = at(-1, 1, 1);
    const Eigen::Vector3d points[5] = {seed.centre, 0.9 * c1 + 0.1 * c7, 0.9 * c2 + 0.1 * c8,
                                       0.9 * c7 + 0.1 * c1, 0.9 * c8 + 0.1 * c2};
    poses.clear();
    Eigen::VectorXd from = seed.q;
    for (int k = 0; k < 5; ++k) {
      const Frame<double> target{seed.R, points[k]};
      const Reach r = reach(from, target, true);
      if (!r.q) return why = fmt::format("P{}: {}", k + 1, r.why), false;
      poses.push_back({fmt::format("P{}", k + 1), target, *r.q});
      if (k == 0) from = *r.q;
    }
    for (std::size_t k = 0; k < kCorners.size(); ++k) {
      const auto& [sx, sy, sz] = kCorners[k];
      if (const Reach r = reach(from, {seed.R, at(sx, sy, sz)}, false, true); !r.q)
        return why = fmt::format("corner C{}: {}", k + 1, r.why), false;
    }
    return true;
  }

  // The largest edge about the seed from `known` (which fits) up, to
  // kEdgeResolution; `why` what the next larger loses.
  double grow(const Seed& seed, double known, std::string& why) const {
    std::vector<IsoTestPose> poses;
    double good = known, bad = 2 * known;
    std::string lost;
    while (bad <= kMaxEdge && place(seed, bad, poses, lost)) good = bad, bad *= 2;
    if (bad > kMaxEdge) bad = kMaxEdge, lost = "the largest edge tried";
    while (bad - good > kEdgeResolution) {
      const double mid = (good + bad) / 2;
      std::string w;
      if (place(seed, mid, poses, w)) {
        good = mid;
      } else {
        bad = mid, lost = w;
      }
    }
    why = fmt::format("{} at {:.1f} mm", lost, bad * 1e3);
    return good;
  }

  const PreparedModel& prepared() const { return prepared_; }

 private:
  const DeviceModel& model_;
  PreparedModel prepared_;
  Eigen::VectorXd lower_, upper_;
  Eigen::Matrix3d axes_;
  bool orientation_;
};

// The readings the search starts from: the middle of every joint's range, then
// `draws` drawn uniformly within the limits (a continuous joint's in [-pi, pi]).
std::vector<Eigen::VectorXd> drawn_readings(const DeviceModel& model, int draws,
                                            std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Eigen::VectorXd> out;
  Eigen::VectorXd middle(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const Link& l = model.links[static_cast<std::size_t>(i)];
    middle[i] = l.continuous() ? 0.0 : (l.lower + l.upper) / 2;
  }
  if (model.outside_range(middle) < 0) out.push_back(middle);
  for (int k = 0; k < draws; ++k) {
    Eigen::VectorXd q(model.dof());
    do {
      for (int i = 0; i < model.dof(); ++i) {
        const Link& l = model.links[static_cast<std::size_t>(i)];
        const double lo = l.continuous() ? -std::numbers::pi : l.lower,
                     hi = l.continuous() ? std::numbers::pi : l.upper;
        q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
      }
    } while (model.outside_range(q) >= 0);  // a device file's ranges leave 1 draw in 1000 at least
    out.push_back(q);
  }
  return out;
}

// The candidates: each drawn reading's tool point and orientation, or (a
// given centre) the drawn readings' orientations reached at the centre.
std::vector<Seed> seeds_of(const CubeFitter& fitter, const std::vector<Eigen::VectorXd>& readings,
                           const IsoCubeOptions& options) {
  std::vector<Seed> seeds;
  for (const Eigen::VectorXd& q : readings) {
    const Frame<double> T = fitter.prepared().forward(q.data());
    const Eigen::Matrix3d R = options.orientation ? *options.orientation : T.R;
    if (!options.centre && !options.orientation) {
      seeds.push_back({T.p, R, q});
      continue;
    }
    const Reach r = fitter.reach(q, {R, options.centre ? *options.centre : T.p}, true);
    if (r.q) seeds.push_back({options.centre ? *options.centre : T.p, R, *r.q});
  }
  return seeds;
}

void check_options(const DeviceModel& model, const IsoCubeOptions& options) {
  if (model.dof() == 0) throw InputError("--iso9283: the model has no joints");
  if (model.tree()) throw InputError("--iso9283: a tree has several tips; give --tip one");
  if (options.cycles < 1) throw InputError("--cycles: at least 1");
  if (options.draws < 0 || options.draws > 100000)
    throw InputError("--iso9283: the search's draws: 0 to 100000");
  if (options.centre && !(options.centre->cwiseAbs().maxCoeff() <= kMaxCubeCentre)) {
    const Eigen::Vector3d& c = *options.centre;
    throw InputError(fmt::format(
        "--cube-centre: ({:.6g}, {:.6g}, {:.6g}) m: each coordinate within +-{:g} m (metres, in "
        "the measurement frame)",
        c.x(), c.y(), c.z(), kMaxCubeCentre));
  }
  if (options.size && !(*options.size >= kMinEdge && *options.size <= kMaxEdge)) {
    throw InputError(fmt::format("--cube-size: {:.6g} m: from {:g} to {:g} m", *options.size,
                                 kMinEdge, kMaxEdge));
  }
}

// What a failed search says: where it looked.
[[noreturn]] void no_cube(const IsoCubeOptions& options, int candidates, bool reached) {
  const std::string tried =
      fmt::format("{} {} tried, seed {}", candidates,
                  options.centre ? "orientations" : "centres and orientations", options.seed);
  const std::string centre =
      options.centre ? fmt::format("({:.1f}, {:.1f}, {:.1f}) mm", options.centre->x() * 1e3,
                                   options.centre->y() * 1e3, options.centre->z() * 1e3)
                     : "";
  if (options.centre && !reached) {
    throw InputError(fmt::format(
        "--cube-centre: the tool cannot reach {} within the joint limits away from singularities "
        "({})",
        centre, tried));
  }
  const std::string where = options.centre ? "about " + centre : "anywhere in the workspace";
  if (options.size) {
    throw InputError(fmt::format(
        "--cube-size: a cube of {:.1f} mm {} leaves a test pose outside the joint limits or near "
        "a singularity, or a corner out of reach ({})",
        *options.size * 1e3, where, tried));
  }
  throw InputError(fmt::format(
      "--iso9283: no cube of 10 mm or more {} keeps its test poses within the joint limits away "
      "from singularities and its corners within reach ({}){}",
      where, tried, options.centre ? "; give another --cube-centre" : ""));
}

}  // namespace

std::optional<Eigen::VectorXd> reach_pose(const DeviceModel& model, const Eigen::VectorXd& start,
                                          const Frame<double>& target, bool orientation) {
  const InverseOptions options = reach_options(orientation);
  Eigen::VectorXd q(model.dof()), lower(model.dof()), upper(model.dof());
  reading_limits(model, lower.data(), upper.data());
  InverseResult found = inverse_kinematics(PreparedModel(model), target, start.data(), q.data(),
                                           options, lower.data(), upper.data());
  check_ranges(model, q.data(), found);
  if (found.status == InverseStatus::kNotConverged ||
      found.status == InverseStatus::kOutsideLimits || !q.allFinite())
    return std::nullopt;
  return q;
}

std::string iso_search_text(const IsoCubeSearch& s) {
  if (s.size_given) {
    return fmt::format("the edge given; {} {} (seed {})", s.candidates,
                       s.centre_given ? "orientations tried about the centre given"
                                      : "centres and orientations tried over the workspace",
                       s.seed);
  }
  return fmt::format("the largest cube of {} {} (seed {}){}; a larger one loses {}", s.candidates,
                     s.centre_given ? "orientations about the centre given"
                                    : "centres and orientations searched over the workspace",
                     s.seed,
                     s.moves > 0 ? fmt::format(", its centre then moved {} times", s.moves) : "",
                     s.stopped);
}

IsoCubePlan plan_iso_cube(const DeviceModel& model, const IsoCubeOptions& options) {
  check_options(model, options);
  IsoCubePlan plan;
  plan.cycles = options.cycles;
  plan.orientation_held = model.dof() >= 6;
  plan.axes = base_frame(model.structure(), model.kinematic_parameters().data()).R;
  plan.search.centre_given = options.centre.has_value();
  plan.search.size_given = options.size.has_value();
  plan.search.seed = options.seed;
  const CubeFitter fitter(model, plan.axes, plan.orientation_held);
  const std::vector<Seed> seeds =
      seeds_of(fitter, drawn_readings(model, options.draws, options.seed), options);
  // Each candidate grown when a cube larger than the best yet fits about it.
  double best = 0;
  std::optional<Seed> kept;
  std::vector<IsoTestPose> poses;
  std::string why;
  for (const Seed& seed : seeds) {
    throw_if_cancelled();
    ++plan.search.candidates;
    const double trial = options.size ? *options.size : best > 0 ? kGain * best : kMinEdge;
    if (!fitter.place(seed, trial, poses, why)) continue;
    kept = seed;
    if (options.size) {
      best = *options.size;
      break;
    }
    best = fitter.grow(seed, trial, plan.search.stopped);
  }
  if (!kept) no_cube(options, plan.search.candidates, !seeds.empty());
  // The best centre moved along the axes while a larger cube fits about it.
  for (double step = best / 4; !options.centre && !options.size && step >= kSmallestMove &&
                               plan.search.moves < kMaxMoves;) {
    throw_if_cancelled();
    bool moved = false;
    for (int k = 0; k < 6 && !moved; ++k) {
      const Eigen::Vector3d centre = kept->centre + plan.axes.col(k / 2) * (k % 2 ? -step : step);
      const Reach r = fitter.reach(kept->q, {kept->R, centre}, true);
      if (!r.q) continue;
      const Seed seed{centre, kept->R, *r.q};
      ++plan.search.candidates;
      if (!fitter.place(seed, kGain * best, poses, why)) continue;
      best = fitter.grow(seed, kGain * best, plan.search.stopped);
      kept = seed, moved = true, ++plan.search.moves;
    }
    if (!moved) step /= 2;
  }
  plan.centre = kept->centre;
  plan.size = best;
  fitter.place(*kept, best, plan.poses, why);  // it fit when it was kept
  for (const auto& [sx, sy, sz] : kCorners)
    plan.corners.push_back(corner(plan.centre, plan.axes, plan.size, sx, sy, sz));
  return plan;
}

}  // namespace hapticcal
