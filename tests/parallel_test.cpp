// parallel_for (core/parallel.hpp): every item once, and an exception on any
// thread - the caller's too, Cancelled among them - joins every thread and is
// rethrown, with no item started after it; never std::terminate.
#include "hapticcal/core/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "hapticcal/core/cancel.hpp"

namespace hapticcal {
namespace {

TEST(ParallelFor, RunsEveryItemOnceOnAnyNumberOfThreads) {
  for (std::size_t threads : {0u, 1u, 2u, 4u, 64u}) {
    std::vector<std::atomic<int>> runs(37);
    parallel_for(runs.size(), threads, [&](std::size_t i) { ++runs[i]; });
    for (const std::atomic<int>& r : runs) EXPECT_EQ(r.load(), 1) << threads << " threads";
  }
  parallel_for(0, 4, [](std::size_t) { FAIL() << "no item"; });
}

// Item 0 throws at once while the other threads are still running (the model
// search's round, cancelled by Ctrl-C on the caller's thread, once ended the
// process so). The exception comes back; every started item finishes; each
// other thread starts at most one item after it.
TEST(ParallelFor, AnExceptionOnTheCallersThreadJoinsTheOthersAndComesBack) {
  std::atomic<int> started{0}, finished{0};
  const auto body = [&](std::size_t i) {
    ++started;
    if (i == 0) throw Cancelled();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ++finished;
  };
  EXPECT_THROW(parallel_for(100, 4, body), Cancelled);
  EXPECT_EQ(finished.load(), started.load() - 1);
  EXPECT_LE(started.load(), 4 + 3);  // each other thread takes at most one more item
}

TEST(ParallelFor, TheFirstOfSeveralExceptionsIsRethrown) {
  const auto body = [](std::size_t i) {
    if (i == 3) throw std::runtime_error("item 3");
    if (i > 3) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      throw std::logic_error("later");
    }
  };
  try {
    parallel_for(8, 1, body);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "item 3");
  }
  EXPECT_THROW(parallel_for(8, 3, body), std::exception);
}

}  // namespace
}  // namespace hapticcal
