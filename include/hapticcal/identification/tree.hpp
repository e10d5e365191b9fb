// A tree's logs: several tips measured together (a log's x1, y1, z1 at the
// first tip, x2, y2, z2 at the second, ...) as one sample a tip (tip_samples),
// which the chain's procedure calibrates, evaluates and plans. The tree itself
// (DeviceTree, tree_model) is model_io/tree_model.hpp's.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/log.hpp"
#include "hapticcal/identification/identification.hpp"
#include "hapticcal/model/model.hpp"
#include "hapticcal/model_io/tree_model.hpp"

namespace hapticcal {

// A tree log (x1, y1, z1 at the first tip, x2, ... at the second, ...) as
// one sample a tip of each row, in row order (Log::tip): each a position of
// its tip, with the row's readings, directions, time and line. InputError
// naming the log for another number of marker points than the model's tips.
// M >= 3 markers a tip (x1 .. x<KM>, the first tip's M first): each sample
// its tip's markers, a rigid body (one layout on every tip: calibrate turns
// them into the body's poses, markers.hpp).
// A fixture log of a tree names a label a tip (point1 .. pointK, which the
// log reader keeps joined by ','): each sample its tip's label.
// `only`: that tip's sample of each row alone (none: every tip's).
Log tip_samples(const DeviceModel& tree, const Log& log, std::optional<int> only = std::nullopt);

// How many of the log's `noun`s ("row", "pose") `samples` of a fit are: "10
// poses" for a chain; a tree's a sample a tip of each, "5 poses of 2 tips, 10
// points".
std::string samples_text(int samples, int tips, const char* noun);

// Chain c's log: its readings (the tree's columns of its joints) and its tip's
// point (the tree log's marker c) as positions.
Log chain_log(const DeviceTree& tree, const Log& log, int chain);

}  // namespace hapticcal
