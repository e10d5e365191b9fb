// Whether a measurement log can be compared with a device model at all.
#pragma once

#include "hapticcal/core/log.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

// Throws InputError unless the log's joint count is the model's, it holds
// distances, positions or fixture labels to compare the model with, and each
// joint reading's unit (an angle or a length) fits its joint's type.
// With `measurements` false a log without them passes (calibrate's step 1
// alone, on a log of external encoders).
void check_log_fits(const Log& log, const DeviceModel& model, bool measurements = true);
// A tree model's log is one sample a tip (Log::tip, tip_samples), each naming
// one of its tips; a chain's names none but its own. InputError naming the log.
void check_tips(const Log& log, const DeviceModel& model);

// A log of readings and external encoders with nothing measured: calibrate
// runs step 1 alone on it.
bool encoders_only(const Log& log);

}  // namespace hapticcal
