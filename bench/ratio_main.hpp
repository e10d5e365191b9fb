// A Google Benchmark main that, after the runs, prints the ratio of each
// benchmark's median time to that of its reference run in the same process:
// pairs are named BM_<Task>_Hapticcal and BM_<Task>_<Reference>.
#pragma once

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <map>
#include <string>
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
        medians_[median ? base.substr(0, base.rfind("_median")) : base] =
            run.GetAdjustedRealTime();  // in the run's time unit (ns by default)
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  const std::map<std::string, double>& medians() const { return medians_; }

 private:
  std::map<std::string, double> medians_;
};

inline int ratio_main(int argc, char** argv, const std::vector<std::string>& references) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  MedianCollector reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  for (const auto& [name, t] : reporter.medians()) {
    if (!name.ends_with("_Hapticcal")) continue;
    const std::string task = name.substr(0, name.size() - std::string("_Hapticcal").size());
    for (const std::string& ref : references) {
      const auto it = reporter.medians().find(task + "_" + ref);
      if (it == reporter.medians().end()) continue;
      fmt::print("ratio {} / {}_{} (median real time): {:.3f}  ({:.1f} ns vs {:.1f} ns)\n", name,
                 task, ref, t / it->second, t, it->second);
    }
  }
  benchmark::Shutdown();
  return 0;
}

}  // namespace hapticcal::bench
