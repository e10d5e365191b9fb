#!/usr/bin/python3
"""Writes trackers' CSV exports of one seeded trajectory, and its truth.

An independent writer for tests/tracker_export_test.cpp: the layouts follow the
trackers' documentation (OptiTrack Motive's CSV export,
https://docs.optitrack.com/motive/data-export/data-export-csv, Euler angles
relative (intrinsic) in the order named by Rotation Type; Vicon Nexus's CSV
export: sections titled Devices / Segments / Trajectories, each with its frame
rate, names, "Frame,Sub Frame,..." labels and units), and the rotations are
computed here, in Python, from the truth.

Usage: write_tracker_exports.py OUT_DIR [SEED]
Writes into OUT_DIR: truth.csv (frame, t, x, y, z, qw, qx, qy, qz and the three
markers m1x..m3z, metres and seconds, repr() precision, an empty field where the
tracker lost the sample), motive_quat_mm.csv, motive_quat_m.csv,
motive_euler_xyz.csv, motive_euler_zyx.csv, vicon_nexus.csv, generic.csv,
generic_plain.csv.
"""

import math
import os
import random
import sys

RATE_HZ = 120.0
FRAMES = 300
FIRST_FRAME = 1
MARKER_OFFSETS_M = [(0.03, 0.0, 0.01), (-0.02, 0.04, 0.0), (0.0, -0.035, 0.05)]
MARKER_NAMES = ["Marker1", "Marker2", "Marker3"]


def quat_from_rotvec(r):
    angle = math.sqrt(sum(v * v for v in r))
    if angle < 1e-12:
        return (1.0, 0.5 * r[0], 0.5 * r[1], 0.5 * r[2])
    s = math.sin(angle / 2) / angle
    return (math.cos(angle / 2), s * r[0], s * r[1], s * r[2])


def rotvec_from_quat(q):
    w, x, y, z = q
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-15:
        return (2 * x, 2 * y, 2 * z)
    angle = 2 * math.atan2(n, w)
    return (angle * x / n, angle * y / n, angle * z / n)


def matrix(q):
    w, x, y, z = q
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]


def clamp(v):
    return max(-1.0, min(1.0, v))


def euler_xyz_deg(q):
    """Angles (about X, Y, Z) with R = Rx(a) Ry(b) Rz(c)."""
    m = matrix(q)
    a = math.atan2(-m[1][2], m[2][2])
    b = math.asin(clamp(m[0][2]))
    c = math.atan2(-m[0][1], m[0][0])
    return tuple(math.degrees(v) for v in (a, b, c))


def euler_zyx_deg(q):
    """Angles (about X, Y, Z) with R = Rz(c) Ry(b) Rx(a)."""
    m = matrix(q)
    a = math.atan2(m[2][1], m[2][2])
    b = math.asin(clamp(-m[2][0]))
    c = math.atan2(m[1][0], m[0][0])
    return tuple(math.degrees(v) for v in (a, b, c))


def trajectory(seed):
    rng = random.Random(seed)
    amp = [rng.uniform(0.05, 0.2) for _ in range(3)]
    freq = [rng.uniform(0.2, 0.9) for _ in range(3)]
    phase = [rng.uniform(0, 2 * math.pi) for _ in range(6)]
    centre = [rng.uniform(-0.5, 0.5) for _ in range(3)]
    rot_amp = [rng.uniform(0.3, 0.8) for _ in range(3)]
    lost_body = set(rng.sample(range(FRAMES), 7))
    lost_marker2 = set(rng.sample(sorted(set(range(FRAMES)) - lost_body), 5))
    samples = []
    for i in range(FRAMES):
        frame = FIRST_FRAME + i
        t = frame / RATE_HZ
        p = [centre[k] + amp[k] * math.sin(2 * math.pi * freq[k] * t + phase[k]) for k in range(3)]
        r = [rot_amp[k] * math.sin(2 * math.pi * freq[2 - k] * t + phase[3 + k]) for k in range(3)]
        q = quat_from_rotvec(r)
        m = matrix(q)
        markers = []
        for off in MARKER_OFFSETS_M:
            markers.append([p[k] + sum(m[k][j] * off[j] for j in range(3)) for k in range(3)])
        samples.append({
            "frame": frame, "t": t, "p": p, "q": q, "markers": markers,
            "body_lost": i in lost_body,
            "marker_lost": [i in lost_body, i in lost_body or i in lost_marker2, i in lost_body],
        })
    return samples


def fmt(v):
    return repr(float(v))


def cells(values, lost):
    return [""] * len(values) if lost else [fmt(v) for v in values]


def write(path, lines):
    with open(path, "w", newline="") as f:
        for line in lines:
            f.write(",".join(line) + "\n")


def write_truth(path, samples):
    head = ["frame", "t", "x", "y", "z", "qw", "qx", "qy", "qz"]
    for k in range(1, 4):
        head += ["m%dx" % k, "m%dy" % k, "m%dz" % k]
    rows = [head]
    for s in samples:
        row = [str(s["frame"]), fmt(s["t"])]
        row += cells(s["p"], s["body_lost"]) + cells(s["q"], s["body_lost"])
        for k in range(3):
            row += cells(s["markers"][k], s["marker_lost"][k])
        rows.append(row)
    write(path, rows)


def write_motive(path, samples, rotation_type, units, scale):
    info = ["Format Version", "1.23", "Take Name", "stylus_take", "Take Notes", "",
            "Capture Frame Rate", "120.000000", "Export Frame Rate", "120.000000",
            "Capture Start Time", "2024-03-01 10.15.00.000 AM", "Capture Start Frame", "0",
            "Total Frames in Take", str(FRAMES), "Total Exported Frames", str(FRAMES),
            "Rotation Type", rotation_type, "Length Units", units, "Coordinate Space", "Global"]
    rot_labels = ["X", "Y", "Z", "W"] if rotation_type == "Quaternion" else ["X", "Y", "Z"]
    types, names, ids, kinds, comps = [], [], [], [], []

    def add(type_, name, id_, kind, labels):
        for lab in labels:
            types.append(type_)
            names.append(name)
            ids.append(id_)
            kinds.append(kind)
            comps.append(lab)

    # Two rigid bodies: the stylus (the trajectory) and a resting base.
    for body, id_ in (("base", "2"), ("stylus", "1")):
        add("Rigid Body", body, id_, "Rotation", rot_labels)
        add("Rigid Body", body, id_, "Position", ["X", "Y", "Z"])
        add("Rigid Body", body, id_, "Mean Marker Error", [""])
    # Expected (solved) marker positions, deliberately 2 mm off: not what is read.
    for k, mname in enumerate(MARKER_NAMES):
        add("Rigid Body Marker", "stylus:" + mname, "1", "Position", ["X", "Y", "Z"])
        add("Rigid Body Marker", "stylus:" + mname, "1", "Marker Quality", [""])
    for k, mname in enumerate(MARKER_NAMES):
        add("Marker", "stylus:" + mname, "Marker%d" % (k + 1), "Position", ["X", "Y", "Z"])
    rows = [info, [],
            ["", "Type"] + types, ["", "Name"] + names, ["", "ID"] + ids,
            ["", ""] + kinds, ["Frame", "Time (Seconds)"] + comps]
    base_q = (0.9238795325112867, 0.0, 0.3826834323650898, 0.0)
    base_p = [0.25, 0.0, -0.125]
    for s in samples:
        lost = s["body_lost"]
        row = [str(s["frame"]), fmt(s["t"])]
        for q, p, body_lost in ((base_q, base_p, False), (s["q"], s["p"], lost)):
            if rotation_type == "Quaternion":
                rot = [q[1], q[2], q[3], q[0]]
            elif rotation_type == "XYZ":
                rot = euler_xyz_deg(q)
            else:
                rot = euler_zyx_deg(q)
            row += cells(rot, body_lost) + cells([v * scale for v in p], body_lost)
            row += cells([0.00012 * scale], body_lost)
        for k in range(3):
            off = [v + 0.002 for v in s["markers"][k]]
            row += cells([v * scale for v in off], lost) + cells([0.98], lost)
        for k in range(3):
            row += cells([v * scale for v in s["markers"][k]], s["marker_lost"][k])
        rows.append(row)
    write(path, rows)


def section_head(title, rate, groups, width_per_group):
    names = ["", ""]
    for g in groups:
        names += [g] + [""] * (width_per_group - 1)
    return [[title], [fmt(rate) if rate != int(rate) else str(int(rate))], names]


def write_vicon(path, samples):
    rows = []
    # Devices: a force plate at 10 sub frames a frame; never read.
    rows += section_head("Devices", 1200, ["Force Plate 1 - Force"], 3)
    rows += [["Frame", "Sub Frame", "Fx", "Fy", "Fz"], ["", "", "N", "N", "N"]]
    for s in samples[:20]:
        for sub in range(10):
            rows.append([str(s["frame"]), str(sub), "0.5", "-1.25", fmt(700 + sub)])
    rows.append([])
    # Segments: the stylus and a resting base, helical angles in degrees.
    rows += section_head("Segments", RATE_HZ, ["Subject:base", "Subject:stylus"], 6)
    labels = ["Frame", "Sub Frame"] + ["RX", "RY", "RZ", "TX", "TY", "TZ"] * 2
    rows += [labels, ["", ""] + ["deg", "deg", "deg", "mm", "mm", "mm"] * 2]
    for s in samples:
        row = [str(s["frame"]), "0", "0", "45", "0", "250", "0", "-125"]
        rv = [math.degrees(v) for v in rotvec_from_quat(s["q"])]
        row += cells(rv, s["body_lost"]) + cells([v * 1000 for v in s["p"]], s["body_lost"])
        rows.append(row)
    rows.append([])
    # Trajectories: the three markers, millimetres.
    rows += section_head("Trajectories", RATE_HZ, ["Subject:" + m for m in MARKER_NAMES], 3)
    rows += [["Frame", "Sub Frame"] + ["X", "Y", "Z"] * 3, ["", ""] + ["mm"] * 9]
    for s in samples:
        row = [str(s["frame"]), "0"]
        for k in range(3):
            row += cells([v * 1000 for v in s["markers"][k]], s["marker_lost"][k])
        rows.append(row)
    rows.append([])
    write(path, rows)


def write_generic(path, samples, units):
    if units:
        head = ["Frame", "Time [ms]", "PosX [mm]", "PosY [mm]", "PosZ [mm]", "QX", "QY", "QZ", "QW"]
    else:
        head = ["Frame", "time", "px", "py", "pz", "rx", "ry", "rz"]
    for k in range(3):
        head += ["M%d%s%s" % (k + 1, a, " [mm]" if units else "") for a in "XYZ"]
    rows = [["# a tracker's own CSV, read with a column map"], head]
    for s in samples:
        lost = s["body_lost"]
        if units:
            row = [str(s["frame"]), fmt(s["t"] * 1000)] + cells([v * 1000 for v in s["p"]], lost)
            row += cells([s["q"][1], s["q"][2], s["q"][3], s["q"][0]], lost)
        else:
            row = [str(s["frame"]), fmt(s["t"])] + cells(s["p"], lost)
            row += cells(rotvec_from_quat(s["q"]), lost)
        for k in range(3):
            scale = 1000 if units else 1
            row += cells([v * scale for v in s["markers"][k]], s["marker_lost"][k])
        rows.append(row)
    write(path, rows)


def main():
    out = sys.argv[1]
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 20240301
    os.makedirs(out, exist_ok=True)
    samples = trajectory(seed)
    write_truth(os.path.join(out, "truth.csv"), samples)
    write_motive(os.path.join(out, "motive_quat_mm.csv"), samples, "Quaternion", "Millimeters", 1000)
    write_motive(os.path.join(out, "motive_quat_m.csv"), samples, "Quaternion", "Meters", 1)
    write_motive(os.path.join(out, "motive_euler_xyz.csv"), samples, "XYZ", "Millimeters", 1000)
    write_motive(os.path.join(out, "motive_euler_zyx.csv"), samples, "ZYX", "Millimeters", 1000)
    write_vicon(os.path.join(out, "vicon_nexus.csv"), samples)
    write_generic(os.path.join(out, "generic.csv"), samples, True)
    write_generic(os.path.join(out, "generic_plain.csv"), samples, False)


if __name__ == "__main__":
    main()
