// Whether a measurement log can be compared with a device model at all.
#pragma once

#include "hapticcal/core/log.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Throws InputError unless the log's joint count is the model's, it holds
// distances, positions or fixture labels to compare the model with, and each
// joint reading's unit (an angle or a length) fits its joint's type.
void check_log_fits(const Log& log, const DeviceModel& model);

}  // namespace hapticcal
