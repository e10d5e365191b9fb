// Work shared out over threads so that no exception leaves a thread: a worker's
// exception (Cancelled included) stops the handing out of work, every thread
// is joined, and the first one is rethrown in the caller's thread. A thread
// destroyed while joinable, or an exception escaping its function, ends the
// process (std::terminate): never here.
#pragma once

#include <cstddef>
#include <functional>

namespace hapticcal {

// body(i) for every i in [0, n), on min(threads, n) threads (this one among
// them; at least one); items are taken in increasing order. After a body
// throws, no item not yet started is started; the first exception thrown is
// rethrown once every thread has been joined.
void parallel_for(std::size_t n, std::size_t threads, const std::function<void(std::size_t)>& body);

}  // namespace hapticcal
