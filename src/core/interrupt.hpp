// What the signal thread of remove_staging_on_signals (output_set.hpp) needs
// from the rest of the library. Internal.
#pragma once

#include <sys/types.h>

#include <functional>
#include <shared_mutex>

namespace hapticcal::detail {

// Held (shared) by every file write: the signal thread takes it exclusively
// before it removes the staging folders, so no write is half-way through a
// folder being removed, and none starts after.
class WriteGuard {
 public:
  WriteGuard();
  // True once a signal is being handled: write nothing.
  bool aborted() const;

 private:
  std::shared_lock<std::shared_mutex> lock_;
};

// Starts a program we wait for (gnuplot) through `spawn` (returns its pid, or
// -1) unless a signal is being handled, and records it atomically with the
// signal thread's kill, so that none keeps writing into a removed folder.
pid_t spawn_tracked(const std::function<pid_t()>& spawn);
void untrack_child(pid_t pid);

}  // namespace hapticcal::detail
