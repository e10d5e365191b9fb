// What the signal thread of remove_staging_on_signals (output_set.hpp) needs
// from the rest of the library. Internal.
#pragma once

#include <sys/types.h>

namespace hapticcal::detail {

// True once a signal is being handled: nothing more may be written.
bool output_aborted();
// Programs we started and wait for (gnuplot): killed on a signal, so that none
// writes into a staging folder that is being removed.
void track_child(pid_t pid);
void untrack_child(pid_t pid);

}  // namespace hapticcal::detail
