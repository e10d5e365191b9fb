// Trackers' own CSV exports: OptiTrack Motive (rigid bodies and markers), Vicon
// (Nexus / Tracker exports: trajectories of markers, a segment's or object's
// pose), and any CSV with a column map. Each becomes a tracker stream: times in
// seconds, positions in metres, orientations as unit quaternions (w, x, y, z),
// or several markers. Units are read from the file where it states them (Motive's
// "Length Units", Vicon's units row); otherwise the user gives them and a file
// without them is refused. Every problem is an InputError naming the file, the
// line and the column; nothing is guessed.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace hapticcal::recording {

// A tracker's samples: t[i] with either one position (p), one position and
// orientation (p, q) or several markers (markers[i][k], k < marker_names.size()).
// A sample the tracker lost (an empty field: an occluded marker) is left out, and
// counted in `lost`.
struct TrackerStream {
  std::string source;                     // "Motive CSV 1.23, rigid body 'stylus'", ...
  std::vector<double> t;                  // s
  std::vector<std::array<double, 3>> p;   // m, one a sample (empty with markers)
  std::vector<std::array<double, 4>> q;   // w, x, y, z; empty without orientations
  std::vector<std::string> marker_names;  // several markers: their names, in order
  std::vector<std::vector<std::array<double, 3>>> markers;  // [sample][marker], m
  std::size_t lost = 0;
};

// What to take from an export. `body` names the rigid body, segment or object
// (empty: the only one in the file; several is an error listing them);
// `markers` the markers to take (empty with `body` empty: the only marker, or
// the body's pose). `length_unit` / `time_unit` are needed when the file does not
// say ("m", "mm", "um", "cm"; "s", "ms"), and refused when it does and they differ.
struct TrackerExportOptions {
  std::string body;
  std::vector<std::string> markers;
  std::string length_unit;
  std::string time_unit;
  // A generic CSV: the columns to read, "t=Time,x=PosX,y=PosY,z=PosZ" (and qw,
  // qx, qy, qz or rx, ry, rz [rad|deg]; or x1, y1, z1, x2, ... for markers).
  std::string column_map;
};

// "Motive", "Vicon" or "CSV" from the file's first lines (a generic CSV needs a
// column map).
std::string tracker_export_format(const std::string& text);

TrackerStream read_motive_csv(const std::string& text, const std::string& name,
                              const TrackerExportOptions& options);
TrackerStream read_vicon_csv(const std::string& text, const std::string& name,
                             const TrackerExportOptions& options);
TrackerStream read_generic_csv(const std::string& text, const std::string& name,
                               const TrackerExportOptions& options);
// Reads a file (at most the log's size bound) and dispatches on its format.
TrackerStream read_tracker_export(const std::string& path, const TrackerExportOptions& options);

}  // namespace hapticcal::recording
