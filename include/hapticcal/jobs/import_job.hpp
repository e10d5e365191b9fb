// `import` as a job: recording::import_recording reads a recording or a
// tracker's export and makes the files; the job writes them, with import.json,
// as one output set (device.csv, tracker.csv or log.csv). Its request's options
// are bound here, as the other commands'.
#pragma once

#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/recording/import.hpp"

namespace hapticcal {

// import's options, bound by the command line and the Python module alike.
const CommandOptions<recording::ImportRequest>& import_options();

// Runs `import`: the files import_recording makes and import.json, written into
// request.out as one set (all of them or, on an error or a Ctrl-C, none); with
// `list`, the recording's topics and nothing written.
recording::ImportResult run_import(const recording::ImportRequest& request);

}  // namespace hapticcal
