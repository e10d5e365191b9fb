// A Google Benchmark main that, after the runs, prints the ratio of each
// measured benchmark's median real time to that of its reference run in the
// same process (the machines are shared and noisy: ratios and medians travel).
#pragma once

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace hapticcal::bench {

class MedianCollector : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      const std::string name = run.benchmark_name();
      const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
      const bool single = run.run_type == Run::RT_Iteration && run.repetitions <= 1;
      if (median || single) {
        const std::string base = name.substr(0, name.find('/'));
        const std::string key = median ? base.substr(0, base.rfind("_median")) : base;
        // In nanoseconds whatever the benchmark's display unit.
        medians_[key] =
            run.GetAdjustedRealTime() / benchmark::GetTimeUnitMultiplier(run.time_unit) * 1e9;
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  const std::map<std::string, double>& medians() const { return medians_; }

 private:
  std::map<std::string, double> medians_;
};

using Pairs = std::vector<std::pair<std::string, std::string>>;  // {measured, reference}

inline int ratio_main(int argc, char** argv, const Pairs& pairs) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  MedianCollector reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const auto& medians = reporter.medians();
  for (const auto& [name, ref] : pairs) {
    const auto a = medians.find(name), b = medians.find(ref);
    if (a == medians.end() || b == medians.end()) continue;
    fmt::print("ratio {} / {} (median real time): {:.3f}  ({:.1f} ns vs {:.1f} ns)\n", name, ref,
               a->second / b->second, a->second, b->second);
  }
  benchmark::Shutdown();
  return 0;
}

}  // namespace hapticcal::bench
