// libFuzzer target: trackers' CSV exports (Motive, Vicon, a generic CSV with a
// column map), each reader with a few choices of body, markers and units. Bad
// input must end in hapticcal::InputError; any other exception, a crash, a
// sanitizer report, a hang or a stream that breaks its own invariants (sizes,
// times not increasing, values not finite, quaternions off unit norm) is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/recording/tracker_export.hpp"

namespace {

using hapticcal::recording::TrackerExportOptions;
using hapticcal::recording::TrackerStream;

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "tracker stream invariant broken: %s\n", what);
  std::abort();
}

void check(const TrackerStream& s) {
  const std::size_t n = s.t.size();
  if (!s.p.empty() && s.p.size() != n) finding("p size");
  if (!s.q.empty() && s.q.size() != n) finding("q size");
  if (!s.markers.empty() && s.markers.size() != n) finding("markers size");
  if (s.p.empty() == s.markers.empty() && n > 0) finding("neither or both of p and markers");
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(s.t[i]) || (i > 0 && !(s.t[i] > s.t[i - 1]))) finding("time");
    if (!s.p.empty()) {
      for (const double v : s.p[i]) {
        if (!std::isfinite(v)) finding("position");
      }
    }
    if (!s.q.empty()) {
      double norm = 0;
      for (const double v : s.q[i]) norm += v * v;
      if (!(std::abs(norm - 1) < 1e-9)) finding("quaternion norm");
    }
    if (!s.markers.empty()) {
      if (s.markers[i].size() != s.marker_names.size()) finding("markers per sample");
      for (const auto& m : s.markers[i]) {
        for (const double v : m) {
          if (!std::isfinite(v)) finding("marker");
        }
      }
    }
  }
}

template <typename Read>
void attempt(Read read) {
  try {
    check(read());
  } catch (const hapticcal::InputError&) {
    // the expected outcome of bad input
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  namespace rec = hapticcal::recording;
  const std::string format = rec::tracker_export_format(text);
  if (format != "Motive" && format != "Vicon" && format != "CSV") finding("format");
  std::vector<TrackerExportOptions> choices(4);
  choices[1].body = "stylus";
  choices[1].length_unit = "mm";
  choices[2].markers = {"Marker1", "Marker2"};
  choices[2].time_unit = "s";
  choices[3].body = "stylus";
  choices[3].markers = {"M1"};
  choices.emplace_back().markers = {"Marker1", "stylus:Marker1"};  // one marker named twice
  for (const TrackerExportOptions& o : choices) {
    attempt([&] { return rec::read_motive_csv(text, "fuzz.csv", o); });
    attempt([&] { return rec::read_vicon_csv(text, "fuzz.csv", o); });
  }
  TrackerExportOptions generic;
  generic.length_unit = "m";
  generic.time_unit = "s";
  for (const char* map : {"t=t,x=x,y=y,z=z,qw=qw,qx=qx,qy=qy,qz=qz",
                          "t=Time,x=PosX,y=PosY,z=PosZ,rx[deg]=rx,ry[deg]=ry,rz[deg]=rz",
                          "t=t,x1=a,y1=b,z1=c,x2=d,y2=e,z2=f"}) {
    generic.column_map = map;
    attempt([&] { return rec::read_generic_csv(text, "fuzz.csv", generic); });
  }
  return 0;
}
