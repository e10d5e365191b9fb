// Cooperative cancellation of a long run in a host program (Python's Ctrl-C):
// the host requests it from another thread; the library's long loops (every
// Levenberg-Marquardt iteration, the model search's candidates, the clocks'
// steps) see it within a fraction of a second and unwind with Cancelled, and
// no output set is committed, so the previous one stays as it was. The command
// line does not use it: its signals end the process (output_set.hpp).
#pragma once

#include <stdexcept>

namespace hapticcal {

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("interrupted: the run was cancelled") {}
};

// Asks every run in this process to stop; reset_cancel() before the next run.
void request_cancel();
void reset_cancel();
bool cancel_requested();
// Throws Cancelled once a cancel is requested.
inline void throw_if_cancelled() {
  if (cancel_requested()) throw Cancelled();
}

}  // namespace hapticcal
