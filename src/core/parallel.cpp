// parallel_for (core/parallel.hpp).
#include "hapticcal/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace hapticcal {

void parallel_for(std::size_t n, std::size_t threads,
                  const std::function<void(std::size_t)>& body) {
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto worker = [&]() noexcept {
    for (std::size_t i; !stop.load() && (i = next++) < n;) {
      try {
        body(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        stop.store(true);
      }
    }
  };
  const std::size_t count = std::max<std::size_t>(1, std::min(threads, n));
  std::vector<std::thread> pool;
  pool.reserve(count - 1);
  try {
    for (std::size_t t = 1; t < count; ++t) pool.emplace_back(worker);
  } catch (...) {  // a thread the system would not start: the others do its share
  }
  worker();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace hapticcal
