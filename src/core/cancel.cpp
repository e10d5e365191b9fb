// Cooperative cancellation (core/cancel.hpp): one flag for the process.
#include "hapticcal/core/cancel.hpp"

#include <atomic>

namespace hapticcal {
namespace {
std::atomic<bool> cancelled{false};
}  // namespace

void request_cancel() { cancelled.store(true); }
void reset_cancel() { cancelled.store(false); }
bool cancel_requested() { return cancelled.load(std::memory_order_relaxed); }

}  // namespace hapticcal
