"""Ctrl-C at random moments of the module's long calls, each in a process of its own (an
abort must not take pytest with it): the call ends in KeyboardInterrupt within a second of
the signal, never in an abort, and the output folder keeps the previous set, with no
staging folder left beside it.

Run by ctest (python_test) with PYTHONPATH=<build>/python and HAPTICCAL_SOURCE the source
tree; by hand:
    PYTHONPATH=build/python python3 -m pytest -q python/tests/test_interrupt.py
"""

import os
import pathlib
import random
import signal
import subprocess
import sys
import time

import hapticcal

SOURCE = pathlib.Path(os.environ.get("HAPTICCAL_SOURCE", pathlib.Path(__file__).parents[2]))
MECA = str(SOURCE / "examples" / "meca500" / "meca500.yaml")
CAL_LOG = str(SOURCE / "examples" / "meca500" / "cal-norm_dist_data_0deg_160cube.csv")

# The child: says when the call starts, and when KeyboardInterrupt reached it (the
# system-wide monotonic clock, the parent's too).
CHILD = """
import sys, time
import hapticcal
try:
    print("ready", flush=True)
    {call}
except KeyboardInterrupt:
    print("interrupted", time.monotonic(), flush=True)
    sys.exit(130)
print("finished", flush=True)
"""

TRIALS = 20


def files_of(folder):
    return {p.name: p.read_bytes() for p in sorted(pathlib.Path(folder).iterdir()) if p.is_file()}


def interrupt_at_random(call, out, delays, seed):
    """TRIALS runs of `call` (Python text writing to `out`), each sent SIGINT after a delay
    drawn from `delays` once it has started. Returns the delays from the signal to
    KeyboardInterrupt of the runs it interrupted."""
    rng = random.Random(seed)
    env = dict(os.environ)
    latencies = []
    for trial in range(TRIALS):
        before = files_of(out)
        child = subprocess.Popen([sys.executable, "-c", CHILD.format(call=call)], env=env,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert child.stdout.readline().strip() == "ready", child.stderr.read()
        time.sleep(rng.uniform(*delays))
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        stdout, stderr = child.communicate(timeout=60)
        what = f"trial {trial} (seed {seed}): exit {child.returncode}\n{stdout}{stderr[-2000:]}"
        # A signal after the call returned ends Python itself by SIGINT (-2), "finished" said.
        finished_first = child.returncode == -signal.SIGINT and "finished" in stdout
        assert child.returncode in (0, 130) or finished_first, what  # never an abort (134, -6)
        assert "terminate called" not in stderr, what
        staging = [p.name for p in pathlib.Path(out).parent.iterdir() if ".tmp-" in p.name]
        assert staging == [], what
        if child.returncode == 130:
            latencies.append(float(stdout.split()[-1]) - sent)
            assert files_of(out) == before, what  # the previous set, untouched
    return latencies


def check(latencies, name):
    # Most signals land inside the call (the delays are drawn within its usual length).
    assert len(latencies) >= TRIALS // 2, f"{name}: {len(latencies)} of {TRIALS} interrupted"
    assert max(latencies) < 1.0, f"{name}: {max(latencies):.2f} s after the signal"
    print(f"{name}: {len(latencies)} of {TRIALS} interrupted, "
          f"KeyboardInterrupt {1e3 * max(latencies):.0f} ms after the signal at most")


def test_ctrl_c_during_a_parallel_model_search(tmp_path):
    """calibrate's model search on two threads (its rounds run candidates in parallel)."""
    out = tmp_path / "cal"
    assert hapticcal.calibrate(MECA, CAL_LOG, threads=2, out=str(out)).usable
    call = f"hapticcal.calibrate({MECA!r}, {CAL_LOG!r}, threads=2, out={str(out)!r})"
    check(interrupt_at_random(call, out, (0.0, 0.35), seed=58), "calibrate")


def test_ctrl_c_during_a_parallel_study(tmp_path):
    """simulate's trials on two threads, each calibrating with the model search."""
    out = tmp_path / "sim"
    hapticcal.simulate(trials=2, threads=2, out=str(out))
    call = f"hapticcal.simulate(trials=40, threads=2, out={str(out)!r})"
    check(interrupt_at_random(call, out, (0.05, 1.5), seed=59), "simulate")


def write_session_bag(path, messages):
    """A bz2-compressed ROS 1 bag (Debian's python3-rosbag) of a Touch's /joint_states at
    1 kHz, one joint stepping every 0.5 s, and a tracker's /probe at 125 Hz stepping with
    it: still windows for a static import, and chunks to decompress."""
    import rosbag
    import rospy
    from geometry_msgs.msg import PointStamped
    from sensor_msgs.msg import JointState

    js = JointState(name=["waist", "shoulder", "elbow", "yaw", "pitch", "roll"])
    p = PointStamped()
    with rosbag.Bag(str(path), "w", compression="bz2") as b:
        for k in range(messages):
            stamp = rospy.Time(1733390000 + k // 1000, 1000000 * (k % 1000))
            js.position = [0.3, 0.2, 0.01 * (k // 500), 0.4, 0.5, 0.6]
            js.header.stamp = stamp
            b.write("/joint_states", js, t=stamp)
            if k % 8 == 0:
                p.header.stamp = stamp
                p.point.x, p.point.y, p.point.z = 0.001 * (k // 500), 0.2, -0.1
                b.write("/probe", p, t=stamp)


def test_ctrl_c_during_an_import(tmp_path):
    """import_recording of a 100 s session (100,000 readings; about 0.5 s to import), as
    streams and as a static log with the device's model (the clocks' lag searched)."""
    bag = tmp_path / "session.bag"
    write_session_bag(bag, 100000)
    for name, options, seed in [("import", "", 60),
                                ("import --static",
                                 ", model='geomagic-touch', convention='none', static=0.2", 61)]:
        out = tmp_path / name.replace(" ", "")
        call = f"hapticcal.import_recording({str(bag)!r}, out={str(out)!r}{options})"
        exec(call)  # the previous set
        check(interrupt_at_random(call, out, (0.0, 0.4), seed=seed), name)


# The child for a Ctrl-C that comes as the job's result is handed back: json.loads (Python
# code, run once the job has committed its output set) sends the process SIGINT first.
SIGNAL_IN_CONVERSION = """
import json, os, signal, sys, warnings
import hapticcal
loads = json.loads
def loads_after_ctrl_c(text, **keywords):
    json.loads = loads
    os.kill(os.getpid(), signal.SIGINT)
    return loads(text, **keywords)
json.loads = loads_after_ctrl_c
with warnings.catch_warnings(record=True) as said:
    warnings.simplefilter("always")
    try:
        {call}
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(130)
print("finished", *[str(w.message) for w in said], flush=True)
"""


def test_ctrl_c_as_the_result_is_handed_back(tmp_path):
    """A Ctrl-C after the job committed its set, while its results are converted for Python:
    the call returns them with a RuntimeWarning, never KeyboardInterrupt beside a replaced
    set."""
    for name, call in [
            ("simulate", "hapticcal.simulate(trials=2, threads=2, seed=3, out={out!r})"),
            ("calibrate", f"hapticcal.calibrate({MECA!r}, {CAL_LOG!r}, out={{out!r}})")]:
        out = tmp_path / name
        child = subprocess.run(
            [sys.executable, "-c", SIGNAL_IN_CONVERSION.format(call=call.format(out=str(out)))],
            capture_output=True, text=True, timeout=120)
        what = f"{name}: exit {child.returncode}\n{child.stdout}{child.stderr[-2000:]}"
        assert child.returncode == 0, what
        assert "finished" in child.stdout and "Ctrl-C came as the job finished" in child.stdout, what
        assert (out / "results.json").is_file(), what
