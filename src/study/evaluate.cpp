#include "hapticcal/study/evaluate.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numeric>
#include <optional>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"
#include "hapticcal/kinematics/kinematics.hpp"

namespace hapticcal {
namespace {

ErrorStats stats(const Eigen::VectorXd& e) {
  return {std::sqrt(e.squaredNorm() / static_cast<double>(e.size())), e.cwiseAbs().maxCoeff()};
}

// The figures the kinds in `log` report, a name once (Evaluation::figures),
// each with where its error sits among its kind's (`at`).
struct Reported {
  MeasurementType type;
  std::vector<int> at;  // per figure of the kind: its index in ev.figures, or -1
};
std::vector<Reported> reported_figures(const Log& log, Evaluation& ev) {
  std::vector<Reported> out;
  for (MeasurementType t : kinds_in(log)) {
    Reported r{t, {}};
    for (const ErrorFigure& f : kind_of(t).error_figures()) {
      if (ev.figure(f.name)) {
        r.at.push_back(-1);
        continue;
      }
      r.at.push_back(static_cast<int>(ev.figures.size()));
      ev.figures.push_back({f, t, {}, Eigen::VectorXd(log.rows)});
    }
    if (!r.at.empty()) out.push_back(std::move(r));
  }
  return out;
}

}  // namespace

namespace {

// Fixture logs: the spread of each label's predicted tool points (evaluate).
void evaluate_fixture(const Log& log, const std::vector<Eigen::Vector3d>& points,
                      const std::vector<PointDistance>& point_distances,
                      const std::vector<KnownPoint>& known_points, Evaluation& ev) {
  const MeasurementType type = measurement_type(log);
  std::vector<int> rows(log.rows);
  std::iota(rows.begin(), rows.end(), 0);
  FixtureLabels labels = fixture_labels(type, log, rows, point_distances, known_points);
  // The spread is about each label's centre, known or not; the known positions
  // are compared on their own.
  const std::vector<std::optional<Eigen::Vector3d>> known = std::move(labels.known_point);
  labels.known_point.assign(labels.count(), std::nullopt);
  Eigen::VectorXd raw(3 * log.rows);
  for (int r = 0; r < log.rows; ++r) raw.segment<3>(3 * r) = points[r];
  Eigen::VectorXd residual(fixture_rows(type, labels, log.rows));
  fixture_residuals(type, labels, Eigen::VectorXd(), raw, nullptr, residual.data(), nullptr);
  const bool point = labels.points;
  ev.fixture_error.resize(log.rows);
  ev.labels.resize(labels.count());
  for (int l = 0; l < labels.count(); ++l) ev.labels[l].name = labels.names[l];
  double sum = 0, sum2 = 0, known_sum2 = 0;
  int known_rows = 0;
  for (int r = 0; r < log.rows; ++r) {
    const double e = point ? residual.segment<3>(3 * r).norm() : residual[r];
    ev.fixture_error[r] = e;
    const int l = labels.of_pose[r];
    Evaluation::Label& label = ev.labels[l];
    if (known[l]) {
      const double k2 = (points[r] - *known[l]).squaredNorm();
      label.rms_known_error = label.rms_known_error.value_or(0) + k2;
      known_sum2 += k2;
      ++known_rows;
    }
    ++label.samples;
    label.centre += points[r];
    label.mean_deviation += std::abs(e);
    label.rms_deviation += e * e;
    sum += std::abs(e);
    sum2 += e * e;
  }
  for (Evaluation::Label& label : ev.labels) {
    label.centre /= label.samples;
    label.mean_deviation /= label.samples;
    label.rms_deviation = std::sqrt(label.rms_deviation / label.samples);
    if (label.rms_known_error)
      label.rms_known_error = std::sqrt(*label.rms_known_error / label.samples);
  }
  if (known_rows > 0) ev.rms_known_point_error = std::sqrt(known_sum2 / known_rows);
  if (!point) {
    ev.rms_plane_distance = std::sqrt(sum2 / log.rows);
    return;
  }
  ev.mean_point_deviation = sum / log.rows;
  ev.rms_point_deviation = std::sqrt(sum2 / log.rows);
  if (labels.distances.empty()) return;
  double worst = 0;
  for (const FixtureLabels::Known& d : labels.distances) {
    const double measured = (ev.labels[d.a].centre - ev.labels[d.b].centre).norm();
    worst = std::max(worst, std::abs(measured - d.metres));
  }
  ev.max_point_distance_error = worst;
}

// evaluate --register's lines: what was fitted and how far it moved; `reference`
// names the reference model (registered on its own), empty for the model.
void registration_lines(const FrameFit& fit, const std::string& reference,
                        std::vector<std::string>& lines) {
  const std::string whose = reference.empty() ? "" : fmt::format(" for {} (on its own)", reference);
  lines.push_back(fmt::format(
      "registered{}: measurement frame fitted on this log (moved {:.1f} mm, {:.2f} deg from the "
      "model's base; RMS before registration {:.4f} mm)",
      whose, fit.moved * 1e3, fit.turned * 180 / M_PI, fit.rms_position_before * 1e3));
  if (!fit.tool) return;
  const Eigen::Vector3d& d = fit.tool_offset;
  lines.push_back(fmt::format(
      "registered{}: tool fitted on this log (tool point moved {:.3f} mm: x {:+.3f}, y {:+.3f}, "
      "z {:+.3f} mm in the last link's frame; turned {:.3f} deg)",
      whose, d.norm() * 1e3, d.x() * 1e3, d.y() * 1e3, d.z() * 1e3, fit.tool_turned * 180 / M_PI));
}

}  // namespace

Evaluation evaluate(const DeviceModel& model, const Log& log,
                    const std::vector<PointDistance>& point_distances,
                    const std::vector<KnownPoint>& known_points) {
  check_log_fits(log, model);
  std::vector<Eigen::Vector3d> points;
  const PreparedModel prepared(model);
  Evaluation ev;
  ev.n = log.rows;
  const std::vector<Reported> reported = reported_figures(log, ev);
  const bool fixture = holds_fixture(log);
  Eigen::VectorXd q(model.dof());
  std::vector<double> measured, errors;
  // A backlash moves the joint values by the side each joint came from.
  const bool backlash = model.has_backlash() && log.any_direction();
  if (backlash && model.tree())
    throw InputError(log.origin, 0, "dir1", "a backlash on a tree is not evaluated yet");
  const ChainStructure s = model.structure();
  const Eigen::VectorXd params = model.kinematic_parameters();
  const ChainConstants<double> constants = chain_constants(s, params.data());
  for (int r = 0; r < log.rows; ++r) {
    q = log.q.row(r).transpose();
    Frame<double> tool;
    if (backlash) {
      Eigen::VectorXd joint(model.dof());
      prepared.compensate(q.data(), joint.data());
      model.apply_backlash(log.direction.row(r), joint);
      const std::optional<ChainConstants<double>> bent = prepared.bent_constants(q.data());
      tool = forward_kinematics(s, bent ? *bent : constants, joint.data());
    } else {  // a tree's sample: its tip's pose (Log::tip)
      tool = prepared.forward(q.data(), log.tip.empty() ? 0 : log.tip[static_cast<size_t>(r)]);
    }
    const Eigen::Vector3d& p = tool.p;
    if (fixture) {
      if (!p.allFinite()) {
        throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0, "",
                         "the model's tool point on this row is not finite");
      }
      points.push_back(p);
    }
    for (const Reported& k : reported) {
      const int width = traits(k.type).width;
      measured.resize(static_cast<size_t>(width));
      errors.resize(k.at.size());
      measured_values(k.type, log, r, measured.data());
      kind_of(k.type).errors(tool, measured.data(), errors.data());
      for (size_t f = 0; f < k.at.size(); ++f)
        if (k.at[f] >= 0) ev.figures[static_cast<size_t>(k.at[f])].error[r] = errors[f];
    }
    // Squared: an error of 1e308 is finite, its square (the RMS) is not.
    bool finite = true;
    for (const Evaluation::FigureErrors& f : ev.figures)
      finite = finite && std::isfinite(f.error[r] * f.error[r]);
    if (!finite) {
      throw InputError(log.origin, r < static_cast<int>(log.line.size()) ? log.line[r] : 0, "",
                       "the model's error on this row is not finite: a value is too large");
    }
  }
  for (Evaluation::FigureErrors& f : ev.figures) f.stats = stats(f.error);
  if (fixture) {
    evaluate_fixture(log, points, point_distances, known_points, ev);
  } else if (!point_distances.empty() || !known_points.empty()) {
    throw InputError(log.origin, 0, point_distances.empty() ? "--fixture" : "--point-distance",
                     "known distances are between fixture points: the log has no point column");
  }
  return ev;
}

const Evaluation::FigureErrors* Evaluation::figure(std::string_view name) const {
  for (const FigureErrors& f : figures)
    if (name == f.figure.name) return &f;
  return nullptr;
}

const Eigen::VectorXd& sample_errors(const Evaluation& ev, MeasurementType type) {
  if (ev.fixture_error.size()) return ev.fixture_error;
  for (const ErrorFigure& f : kind_of(type).error_figures())
    if (const Evaluation::FigureErrors* e = ev.figure(f.name)) return e->error;
  static const Eigen::VectorXd none;
  return ev.figures.empty() ? none : ev.figures[0].error;
}

double rms_improvement_pct(double rms_calibrated, double rms_uncalibrated) {
  return (rms_uncalibrated - rms_calibrated) / std::abs(rms_uncalibrated) * 100.0;
}

namespace {

// EvaluationComparison::setup_only.
bool differs_in_setup_only(const DeviceModel& model, const DeviceModel& reference, const Log& log) {
  if (model.tree() || reference.tree() || model.dof() != reference.dof()) return false;
  DeviceModel same = model;
  same.base_kind = reference.base_kind;
  same.base = reference.base;
  same.tool = reference.tool;
  const PreparedModel a(same), b(reference), given(model);
  bool differ = false;  // the models as given: the set-up's differ somewhere
  const auto close = [](const Frame<double>& x, const Frame<double>& y) {
    return (x.p - y.p).norm() <= 1e-12 && (x.R - y.R).norm() <= 1e-12;
  };
  for (int row = 0; row < log.rows; ++row) {
    const Eigen::VectorXd q = log.q.row(row).transpose();
    const Frame<double> y = b.forward(q.data());
    if (!close(a.forward(q.data()), y)) return false;
    differ = differ || !close(given.forward(q.data()), y);
  }
  return differ;
}

}  // namespace

EvaluationComparison compare_to_reference(const DeviceModel& model, const DeviceModel& reference,
                                          const Log& log,
                                          const std::vector<PointDistance>& point_distances,
                                          const std::vector<KnownPoint>& known_points,
                                          std::optional<RegisterWhat> registration) {
  const auto score = [&](const DeviceModel& m) {
    return registration ? evaluate_registered(m, log, *registration, point_distances, known_points)
                        : evaluate(m, log, point_distances, known_points);
  };
  EvaluationComparison c{score(model), score(reference), {}};
  c.setup_only = differs_in_setup_only(model, reference, log);
  return c;
}

std::vector<std::string> evaluation_lines(const EvaluationComparison* cmp, const Evaluation& ev,
                                          const std::string& reference_name) {
  std::vector<std::string> lines;
  const Evaluation* ref = cmp ? &cmp->reference : nullptr;
  if (ev.registered) registration_lines(*ev.registered, "", lines);
  if (ref && ref->registered) registration_lines(*ref->registered, reference_name, lines);
  for (const Evaluation::FigureErrors& f : ev.figures) {
    lines.push_back(fmt::format("{} error: RMS {:.4f} {}, max {:.4f} {}", f.figure.name,
                                f.stats.rms * 1e3, f.figure.unit(), f.stats.max * 1e3,
                                f.figure.unit()));
  }
  for (const auto& l : ev.labels) {
    lines.push_back(
        fmt::format("{} '{}' ({} samples): {} {:.4f} mm mean, {:.4f} mm RMS",
                    ev.mean_point_deviation ? "point" : "plane", l.name, l.samples,
                    ev.mean_point_deviation ? "spread about its centre" : "distance from its plane",
                    l.mean_deviation * 1e3, l.rms_deviation * 1e3));
    if (l.rms_known_error) {
      lines.push_back(
          fmt::format("  against its known position: {:.4f} mm RMS", *l.rms_known_error * 1e3));
    }
  }
  if (ev.mean_point_deviation) {
    lines.push_back(fmt::format("point deviation (every sample): mean {:.4f} mm, RMS {:.4f} mm{}",
                                *ev.mean_point_deviation * 1e3, *ev.rms_point_deviation * 1e3,
                                ref && ref->mean_point_deviation
                                    ? fmt::format(" ({} : mean {:.4f} mm)", reference_name,
                                                  *ref->mean_point_deviation * 1e3)
                                    : std::string()));
  }
  if (ev.max_point_distance_error) {
    lines.push_back(fmt::format("known distances: largest error {:.4f} mm",
                                *ev.max_point_distance_error * 1e3));
  }
  if (ev.rms_known_point_error) {
    lines.push_back(
        fmt::format("known positions: RMS error {:.4f} mm", *ev.rms_known_point_error * 1e3));
  }
  if (ev.rms_plane_distance) {
    lines.push_back(fmt::format("plane distance: RMS {:.4f} mm", *ev.rms_plane_distance * 1e3));
  }
  const char* setup_only =
      cmp && cmp->setup_only
          ? "; the models differ only in their set-up (the frame, the tool): the set-up's "
            "improvement, not the device's"
          : "";
  for (const Evaluation::FigureErrors& f : ev.figures) {
    const Evaluation::FigureErrors* theirs = ref ? ref->figure(f.figure.name) : nullptr;
    if (!theirs) continue;
    lines.push_back(fmt::format(
        "against {}: {} RMS {:.4f} {} -> {:.4f} {}, improvement {:.1f} % (eq. 9){}", reference_name,
        f.figure.name, theirs->stats.rms * 1e3, f.figure.unit(), f.stats.rms * 1e3, f.figure.unit(),
        rms_improvement_pct(f.stats.rms, theirs->stats.rms), setup_only));
  }
  return lines;
}

}  // namespace hapticcal
