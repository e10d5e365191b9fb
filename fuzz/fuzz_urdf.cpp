// libFuzzer target: URDF text (hapticcal::parse_urdf). Each input is read for
// a few chains: tip "tool" (device_to_urdf's tip), no tip (the single leaf),
// and the last <link name="..."> of the text as tip, from the URDF's root and
// from the first <link> named in the text. Bad input must end in
// hapticcal::InputError; any other exception, a crash, a sanitizer report or
// a hang is a finding. A model that parses must pass check_device (parse_urdf
// refuses the others), and device_to_urdf must write a URDF that parses back
// (tip "tool") to a model with the same joints and the same forward kinematics
// (to 1e-9, relative to the chain's lengths) at a few configurations; an
// InputError on the way back is a finding too.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/kinematics/kinematics.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"

namespace {

constexpr std::size_t kMaxInput = 1 << 20;  // 1 MiB: deep nesting and long attributes fit

[[noreturn]] void finding(const std::string& what, const std::string& urdf) {
  std::fprintf(stderr, "fuzz_urdf: %s\n--- URDF written by device_to_urdf:\n%s\n", what.c_str(),
               urdf.c_str());
  std::abort();
}

// The raw value of the <link name="..."> that starts at or after `from` (empty if none).
std::string link_name_at(const std::string& text, std::size_t from) {
  static const std::string kOpen = "<link name=\"";
  if (from == std::string::npos || text.compare(from, kOpen.size(), kOpen) != 0) return {};
  const std::size_t begin = from + kOpen.size();
  const std::size_t close = text.find('"', begin);
  return close == std::string::npos ? std::string() : text.substr(begin, close - begin);
}

// The first and the last <link name="..."> of the text.
std::pair<std::string, std::string> first_and_last_link(const std::string& text) {
  return {link_name_at(text, text.find("<link name=\"")),
          link_name_at(text, text.rfind("<link name=\""))};
}

// A length scale of the chain at q: what a relative error is relative to.
double length_scale(const hapticcal::DeviceModel& model, const std::vector<double>& q) {
  double scale = 1.0;
  for (int i = 0; i < model.dof(); ++i) {
    const hapticcal::Link& l = model.links[i];
    scale += std::abs(l.origin[0]) + std::abs(l.origin[1]) + std::abs(l.origin[2]);
    if (l.prismatic()) scale += std::abs(q[i]);
  }
  return scale + std::abs(model.tool[0]) + std::abs(model.tool[1]) + std::abs(model.tool[2]);
}

bool finite(const hapticcal::Frame<double>& f) { return f.R.allFinite() && f.p.allFinite(); }

// The configurations compared: zero, the limits, their midpoint and a point
// between the limits picked by the input.
std::vector<std::vector<double>> configurations(const hapticcal::DeviceModel& model,
                                                std::uint64_t seed) {
  const int n = model.dof();
  std::vector<std::vector<double>> out(5, std::vector<double>(n, 0.0));
  for (int i = 0; i < n; ++i) {
    const double lo = model.links[i].lower, hi = model.links[i].upper;
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    const double u = static_cast<double>(seed >> 11) * 0x1.0p-53;
    out[1][i] = lo;
    out[2][i] = hi;
    out[3][i] = lo / 2 + hi / 2;
    out[4][i] = lo + u * (hi - lo);
    if (!std::isfinite(out[4][i])) out[4][i] = out[3][i];
  }
  return out;
}

void check_round_trip(const hapticcal::DeviceModel& model, std::uint64_t seed) {
  if (const std::string why = hapticcal::check_device(model); !why.empty()) {
    finding("parse_urdf gave a model that check_device refuses: " + why, "");
  }
  const std::string urdf = hapticcal::device_to_urdf(model);
  hapticcal::DeviceModel back;
  try {
    back = hapticcal::parse_urdf(urdf, "fuzz-roundtrip.urdf", "tool");
  } catch (const hapticcal::InputError& e) {
    finding(std::string("device_to_urdf's URDF does not read back: ") + e.what(), urdf);
  }
  if (back.dof() != model.dof()) {
    finding("device_to_urdf's URDF reads back with " + std::to_string(back.dof()) +
                " joints, not " + std::to_string(model.dof()),
            urdf);
  }
  for (int i = 0; i < model.dof(); ++i) {
    const hapticcal::Link &a = model.links[i], &b = back.links[i];
    if (a.name != b.name || a.type != b.type || a.lower != b.lower || a.upper != b.upper) {
      finding("joint " + std::to_string(i) + " ('" + a.name + "') reads back as '" + b.name +
                  "' with another type or limits",
              urdf);
    }
  }
  const hapticcal::PreparedModel prepared(model), prepared_back(back);
  for (const std::vector<double>& q : configurations(model, seed)) {
    const hapticcal::Frame<double> f = prepared.forward(q.data());
    const double scale = length_scale(model, q);
    if (!finite(f) || !std::isfinite(scale)) continue;  // overflow: nothing to compare
    const hapticcal::Frame<double> g = prepared_back.forward(q.data());
    const double dR = finite(g) ? (f.R - g.R).cwiseAbs().maxCoeff() : INFINITY;
    const double dp = finite(g) ? (f.p - g.p).cwiseAbs().maxCoeff() : INFINITY;
    if (!(dR <= 1e-9) || !(dp <= 1e-9 * scale)) {
      char what[200];
      std::snprintf(what, sizeof what,
                    "forward kinematics differ after device_to_urdf: |dR| %g, |dp| %g (scale %g)",
                    dR, dp, scale);
      finding(what, urdf);
    }
  }
}

}  // namespace

// urdfdom 3.0 leaks the links of a URDF whose joints form a loop (shared_ptr
// cycles through Link::child_links), whether it accepts the file or not:
// leaks allocated inside liburdfdom_model are urdfdom's, not findings here.
extern "C" const char* __lsan_default_suppressions() { return "leak:liburdfdom_model\n"; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > kMaxInput) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::uint64_t seed = 1469598103934665603ULL;  // FNV-1a of the input
  for (const char c : text) seed = (seed ^ static_cast<unsigned char>(c)) * 1099511628211ULL;

  const auto [first, last] = first_and_last_link(text);
  std::vector<std::pair<std::string, std::string>> chains{{"tool", ""}, {"", ""}};
  if (!last.empty()) {
    chains.emplace_back(last, "");
    if (!first.empty() && first != last) chains.emplace_back(last, first);
  }
  std::sort(chains.begin(), chains.end());
  chains.erase(std::unique(chains.begin(), chains.end()), chains.end());

  for (const auto& [tip, root] : chains) {
    hapticcal::DeviceModel model;
    try {
      model = hapticcal::parse_urdf(text, "fuzz.urdf", tip, root);
    } catch (const hapticcal::InputError&) {
      continue;  // the expected outcome of bad input
    }
    check_round_trip(model, seed);
  }
  return 0;
}
