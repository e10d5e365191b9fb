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

void check_log_fits(const Log& log, const DeviceModel& model, bool measurements) {
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
