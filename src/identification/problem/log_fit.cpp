// Whether a measurement log can be compared with a device model at all.
#include "hapticcal/identification/log_fit.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "hapticcal/core/error.hpp"
#include "hapticcal/identification/measurement.hpp"

namespace hapticcal {

bool encoders_only(const Log& log) {
  const std::vector<MeasurementType> kinds = measurement_types();
  return std::none_of(kinds.begin(), kinds.end(),
                      [&](MeasurementType t) { return kind_of(t).in_log(log); }) &&
         std::find(log.has_ext.begin(), log.has_ext.end(), true) != log.has_ext.end();
}

void check_tips(const Log& log, const DeviceModel& model) {
  if (const std::string why = tree_problem(model); !why.empty())
    throw InputError("", 0, "", fmt::format("the model '{}' is not a tree: {}", model.name, why));
  if (!model.tree() && log.tip.empty()) {
    for (size_t r = 0; r < log.label.size(); ++r) {
      if (log.label[r].find(',') == std::string::npos) continue;
      throw InputError(log.origin, r < log.line.size() ? log.line[r] : 0, "point1",
                       fmt::format("numbered labels (point1, point2, ...) are a tree's, one a tip; "
                                   "the model '{}' has one tip: its log's label column is 'point' "
                                   "or 'plane'",
                                   model.name));
    }
    return;
  }
  if (model.tree() && log.tip.size() != static_cast<size_t>(log.rows))
    throw InputError(log.origin, 0, "x1",
                     fmt::format("the model is a tree of {} tips: its log needs one sample a tip "
                                 "(tip_samples: each row's x<k>, y<k>, z<k> tip k's point)",
                                 model.tips()));
  for (size_t r = 0; r < log.tip.size(); ++r) {
    if (log.tip[r] < 0 || log.tip[r] >= model.tips())
      throw InputError(log.origin, r < log.line.size() ? log.line[r] : 0, "tip",
                       fmt::format("tip {} of a model with {} tip(s)", log.tip[r], model.tips()));
  }
}

void check_log_fits(const Log& log, const DeviceModel& model, bool measurements) {
  check_tips(log, model);
  if (log.dof() != model.dof()) {
    throw InputError(log.origin, 0, "",
                     fmt::format("the log has {} joint columns but the model '{}' has {} joints",
                                 log.dof(), model.name, model.dof()));
  }
  const std::vector<MeasurementType> kinds = measurement_types();
  if (measurements && std::none_of(kinds.begin(), kinds.end(),
                                   [&](MeasurementType t) { return kind_of(t).in_log(log); })) {
    throw InputError(log.origin, 0, "",
                     "no measurements: the log has neither a distance, x, y, z, a point nor a "
                     "plane column");
  }
  // Readings with a unit: angles for turning joints, lengths for prismatic ones.
  auto check = [&](const std::vector<ReadingUnit>& units, const std::vector<std::string>& names) {
    for (int j = 0; j < static_cast<int>(units.size()) && j < model.dof(); ++j) {
      const bool prismatic = model.links[j].prismatic();
      const ReadingUnit u = units[j];
      if (u == ReadingUnit::kNone || (u == ReadingUnit::kLength) == prismatic) continue;
      throw InputError(log.origin, 1, names[j],
                       fmt::format("{} is {}: its readings are {}", model.links[j].name,
                                   prismatic ? "prismatic" : "a turning joint",
                                   prismatic ? "lengths (m, mm, um)" : "angles (rad, deg)"));
    }
  };
  check(log.q_unit, log.q_column);
  check(log.ext_unit, log.ext_column);
}

}  // namespace hapticcal
