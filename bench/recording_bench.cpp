// Recordings in, linear in their size: `hapticcal import` (run_import) of a ROS
// 1 bag of JointStates of 64,000 joints against the same of 8,000, a TF topic
// of 16,000 transforms a message against 2,000, and a message definition of
// 100,000 fields and 100,000 sections parsed against 12,500 of each. Each ratio is about 8 when the
// work is linear in the input (a linear scan for each field made them about 64: 16-25 s for one
// message of 64,000 joints). The bags are written in memory by tests/support/ros1_bag_writer.hpp
// and imported from a scratch folder.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "hapticcal/jobs/import_job.hpp"
#include "hapticcal/recording/import.hpp"
#include "hapticcal/recording/ros_message.hpp"
#include "ratio_main.hpp"
#include "ros1_bag_writer.hpp"

namespace {

using namespace hapticcal;
namespace fs = std::filesystem;
using recording::builtin_definition;
using recording::Encoding;

constexpr std::int64_t kT0 = 1'733'390'000'000'000'000;
constexpr int kMessages = 4;

std::string scratch() {
  static const std::string dir = [] {
    const fs::path d =
        fs::temp_directory_path() / ("recording_bench_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d.string();
  }();
  return dir;
}

std::string write_bag(const std::string& name, const testing::Ros1BagWriter& w) {
  const std::string path = scratch() + "/" + name;
  std::ofstream(path, std::ios::binary) << w.bytes();
  return path;
}

// kMessages JointStates of `joints` joints.
std::string joint_state_bag(int joints) {
  testing::Ros1BagWriter w;
  w.connection(0, "/joint_states", "sensor_msgs/JointState",
               builtin_definition("sensor_msgs/JointState", Encoding::kRos1));
  std::vector<std::string> names;
  std::vector<double> q;
  for (int k = 0; k < joints; ++k) names.push_back("joint" + std::to_string(k)), q.push_back(k);
  for (int i = 0; i < kMessages; ++i) {
    const std::int64_t t = kT0 + i * 1000000;
    w.message(0, t, testing::ros1_joint_state(t, names, q));
  }
  return write_bag("joints" + std::to_string(joints) + ".bag", w);
}

// kMessages TFMessages of `transforms` transforms from map.
std::string tf_bag(int transforms) {
  testing::Ros1BagWriter w;
  w.connection(0, "/tf", "tf2_msgs/TFMessage",
               builtin_definition("tf2_msgs/TFMessage", Encoding::kRos1));
  std::vector<testing::Transform> ts(static_cast<std::size_t>(transforms));
  for (std::size_t k = 0; k < ts.size(); ++k)
    ts[k].parent = "map", ts[k].child = "link" + std::to_string(k), ts[k].p[0] = 1e-3 * k;
  for (int i = 0; i < kMessages; ++i) {
    const std::int64_t t = kT0 + i * 1000000;
    w.message(0, t, testing::ros1_tf_message(t, ts));
  }
  return write_bag("tf" + std::to_string(transforms) + ".bag", w);
}

void import(benchmark::State& state, const std::string& bag, const std::string& frames) {
  recording::ImportRequest request;
  request.recording = bag;
  request.frames = frames;
  request.out = scratch() + "/out";
  for (auto _ : state) {
    const recording::ImportResult r = run_import(request);
    benchmark::DoNotOptimize(r.device_rows + r.tracker_rows);
  }
}

void BM_ImportJointState(benchmark::State& state, int joints) {
  import(state, joint_state_bag(joints), "");
}

void BM_ImportTf(benchmark::State& state, int transforms) {
  import(state, tf_bag(transforms), "map,link" + std::to_string(transforms - 1));
}

// `fields` fields, then as many sections of types the message does not use.
void BM_ParseDefinition(benchmark::State& state, int fields) {
  std::string text;
  for (int k = 0; k < fields; ++k) text += "float64 f" + std::to_string(k) + "\n";
  for (int k = 0; k < fields; ++k) text += "===\nMSG: pkg/S" + std::to_string(k) + "\nint32 x\n";
  for (auto _ : state) {
    const auto type = recording::MessageType::parse("pkg/Wide", text, Encoding::kRos1, "bench");
    benchmark::DoNotOptimize(type.get());
  }
}

void register_pair(const char* name, void (*fn)(benchmark::State&, int), int small, int large) {
  for (const int n : {small, large})
    benchmark::RegisterBenchmark((std::string(name) + "_" + std::to_string(n)).c_str(), fn, n)
        ->Unit(benchmark::kMillisecond)
        ->Repetitions(3)
        ->ReportAggregatesOnly(true);
}

}  // namespace

int main(int argc, char** argv) {
  register_pair("ImportJointState", BM_ImportJointState, 8000, 64000);
  register_pair("ImportTf", BM_ImportTf, 2000, 16000);
  register_pair("ParseDefinition", BM_ParseDefinition, 12500, 100000);
  const int code =
      hapticcal::bench::ratio_main(argc, argv,
                                   {{"ImportJointState_64000", "ImportJointState_8000"},
                                    {"ImportTf_16000", "ImportTf_2000"},
                                    {"ParseDefinition_100000", "ParseDefinition_12500"}});
  fs::remove_all(scratch());
  return code;
}
