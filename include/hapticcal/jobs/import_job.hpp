// `import` as a job: recording::run_import reads a recording or a tracker's
// export and writes the output set (device.csv, tracker.csv or log.csv,
// import.json); its request's options are bound here, as the other commands'.
#pragma once

#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/recording/import.hpp"

namespace hapticcal {

// import's options, bound by the command line and the Python module alike.
const CommandOptions<recording::ImportRequest>& import_options();

}  // namespace hapticcal
