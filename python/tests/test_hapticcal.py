"""The Python module against the command line and against numerical derivatives.

Run by ctest (python_test) with PYTHONPATH=<build>/python, HAPTICCAL_CLI the
built command line and HAPTICCAL_SOURCE the source tree; by hand:
    PYTHONPATH=build/python HAPTICCAL_CLI=build/hapticcal python3 -m pytest -q python/tests
"""

import html
import json
import math
import os
import pathlib
import re
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import hapticcal

SOURCE = pathlib.Path(os.environ.get("HAPTICCAL_SOURCE", pathlib.Path(__file__).parents[2]))
CLI = os.environ.get("HAPTICCAL_CLI", str(SOURCE / "build" / "hapticcal"))
MECA = str(SOURCE / "examples" / "meca500" / "meca500.yaml")
CAL_LOG = str(SOURCE / "examples" / "meca500" / "cal-norm_dist_data_0deg_160cube.csv")
VAL_LOG = str(SOURCE / "examples" / "meca500" / "val-norm_dist_data_0deg_160cube.csv")
BUILTIN = str(SOURCE / "data" / "devices" / "baser-7dof.yaml")


def cli(*args):
    """The command line with a list of arguments (no shell): (exit code, stdout, stderr)."""
    run = subprocess.run([CLI, *args], capture_output=True, text=True, timeout=120)
    return run.returncode, run.stdout, run.stderr


def assert_same(a, b, path="", tol=1e-12):
    """JSON-like values equal; numbers to `tol` relative (absolute below 1)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), path
        for k in a:
            assert_same(a[k], b[k], f"{path}.{k}", tol)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{path}[{i}]", tol)
    elif isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            assert a == b, path
        else:
            assert abs(a - b) <= tol * max(1.0, abs(a)), f"{path}: {a} != {b}"
    else:
        assert a == b, path


@pytest.fixture(scope="module")
def cli_calibration(tmp_path_factory):
    """The README's Meca500 calibration by the command line, and its validation."""
    out = tmp_path_factory.mktemp("cli") / "cal"
    code, stdout, stderr = cli("calibrate", "--model", MECA, "--log", CAL_LOG, "--out", str(out))
    assert code == 0, stderr
    results = json.loads((out / "results.json").read_text())
    code, stdout, stderr = cli(
        "evaluate", "--model", str(out / "calibrated.yaml"), "--log", VAL_LOG, "--json"
    )
    assert code == 0, stderr
    return results, json.loads(stdout), out


@pytest.fixture(scope="module")
def py_calibration():
    return hapticcal.calibrate(MECA, CAL_LOG)


def test_calibration_reproduces_the_cli_results_json(cli_calibration, py_calibration):
    results, _, _ = cli_calibration
    r = py_calibration
    assert r.usable and r.status == "converged" == results["status"]
    assert_same(r.results, results)
    assert r.rms_before == pytest.approx(results["rms_before"], rel=1e-12)
    assert r.rms_after == pytest.approx(results["rms_after"], rel=1e-12)
    assert r.rms_after * 1e3 == pytest.approx(0.0353, abs=5e-5)
    assert r.cv_rms * 1e3 == pytest.approx(0.0409, abs=5e-5)  # README: held out
    assert list(r.parameters) == list(results["parameters"])
    for name, p in results["parameters"].items():
        mine = r.parameters[name]
        assert abs(mine["value"] - p["value"]) <= 1e-12 * max(1.0, abs(p["value"]))
        assert mine["identifiable"] == p["identifiable"]
    assert r.model.parameters()["j2.a"] == pytest.approx(r.parameters["j2.a"]["value"], rel=1e-15)


def test_validation_rms_matches_the_cli(cli_calibration, py_calibration):
    _, validation, out = cli_calibration
    mine = hapticcal.evaluate(py_calibration.model, VAL_LOG)
    assert list(mine) == list(validation)
    assert mine["n"] == validation["n"]
    assert abs(mine["rms_position"] - validation["rms_position"]) < 1e-12
    assert abs(mine["max_position"] - validation["max_position"]) < 1e-12
    # The README's figure: 0.0403 mm on the validation log.
    assert mine["rms_position"] * 1e3 == pytest.approx(0.0403, abs=5e-5)
    # The CLI's calibrated.yaml read back gives the same figures.
    assert_same(hapticcal.evaluate(str(out / "calibrated.yaml"), VAL_LOG), validation)


def test_device_model_is_the_cli_device_yaml_in_the_devices_frame(cli_calibration, py_calibration):
    """device_model: calibrate's device.yaml; its tool pose is device_frame^-1 times the
    calibrated model's at every reading (the tool point moved by tool_point)."""
    _, _, out = cli_calibration
    r = py_calibration
    from_file = hapticcal.load_model(str(out / "device.yaml"))
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.uniform(-1.0, 1.0, r.model.dof)
        assert np.abs(r.device_model.forward(q) - from_file.forward(q)).max() < 1e-12
        expected = np.linalg.inv(r.device_frame) @ r.model.forward(q)
        assert np.abs(r.device_model.forward(q) - expected).max() < 1e-12
    tipped = hapticcal.calibrate(MECA, CAL_LOG, tool_point=[0.0, 0.0, 0.07])
    assert tipped.device_model.parameters()["tool.z"] == pytest.approx(0.07, abs=1e-15)
    with pytest.raises(ValueError, match="--tool-point"):
        hapticcal.calibrate(MECA, CAL_LOG, tool_point=[0.0, 0.07])


def test_evaluation_with_reference_matches_the_cli(cli_calibration):
    _, _, out = cli_calibration
    calibrated = str(out / "calibrated.yaml")
    code, stdout, stderr = cli(
        "evaluate", "--model", calibrated, "--log", VAL_LOG, "--reference", MECA,
        "--register", "frame", "--json"
    )
    assert code == 0, stderr
    mine = hapticcal.evaluate(calibrated, VAL_LOG, reference=MECA, register="frame")
    assert_same(mine, json.loads(stdout))
    # The README's figures: the nominal model (in the robot's frame) with the
    # tracker's placement fitted on the validation log, 0.1990 mm; the
    # calibrated model with its placement fitted there too, 0.0369 mm.
    assert mine["reference_rms_position"] * 1e3 == pytest.approx(0.1990, abs=5e-5)
    assert mine["rms_position"] * 1e3 == pytest.approx(0.0369, abs=5e-5)


def rotation_vector(R):
    """The rotation vector of a small rotation R (vee of its skew part)."""
    return 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])


@pytest.fixture(scope="module")
def eccentric(tmp_path_factory):
    """The built-in device with eccentric capstans: q + dtheta(q) is not q."""
    text = pathlib.Path(BUILTIN).read_text()
    ideal = "transmission: {type: capstan, ratio: 10, drum_distance: 0.005}"
    assert ideal in text
    text = text.replace(
        ideal,
        "transmission: {type: capstan, ratio: 10, drum_distance: 0.005, r_out: 0.0002, "
        "beta_out: 0.3, r_in: 0.0001, beta_in: -0.7}",
    )
    path = tmp_path_factory.mktemp("device") / "eccentric.yaml"
    path.write_text(text)
    return str(path)


def numeric_jacobian(m, q, h):
    """The tool's velocity Jacobian w.r.t. the readings q by central differences of forward."""
    numeric = np.zeros((6, m.dof))
    for i in range(m.dof):
        dq = np.zeros(m.dof)
        dq[i] = h
        Tp, Tm = m.forward(q + dq), m.forward(q - dq)
        numeric[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        numeric[3:, i] = rotation_vector(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
    return numeric


@pytest.mark.parametrize("which", ["meca500", "builtin", "eccentric"])
def test_jacobian_matches_central_differences(which, eccentric):
    m = hapticcal.load_model({"meca500": MECA, "builtin": BUILTIN, "eccentric": eccentric}[which])
    rng = np.random.default_rng(7)
    h = 1e-6
    for _ in range(5):
        q = rng.uniform(-1.0, 1.0, m.dof)
        T = m.forward(q)
        assert T.shape == (4, 4) and np.allclose(T[3], [0, 0, 0, 1])
        J = m.jacobian(q)
        J_tool = m.jacobian(q, frame="tool")
        assert J.shape == (6, m.dof)
        # The Jacobian is w.r.t. the joint values: through the transmissions'
        # compensation, d theta / d q by central differences too.
        numeric = numeric_jacobian(m, q, h)
        dtheta = np.array(
            [
                (m.compensate(q + h * e)[i] - m.compensate(q - h * e)[i]) / (2 * h)
                for i, e in enumerate(np.eye(m.dof))
            ]
        )
        assert np.max(np.abs(numeric - J * dtheta)) < 1e-7
        R = T[:3, :3]
        assert np.allclose(J_tool[:3], R.T @ J[:3], atol=1e-12)
        assert np.allclose(J_tool[3:], R.T @ J[3:], atol=1e-12)


def test_coupled_model_jacobian_through_the_readings():
    """A coupled model (examples/coupled: joint 4 passive, theta4 = -(u2 + u3)):
    coupling as written, jacobian @ reading_jacobian against central differences
    of forward in the readings."""
    m = hapticcal.load_model(str(SOURCE / "examples" / "coupled" / "level-arm.yaml"))
    C = m.coupling
    assert C.shape == (7, 7) and C[3, 1] == -1 and C[3, 2] == -1 and C[3, 3] == 0
    rng = np.random.default_rng(3)
    h = 1e-6
    for _ in range(5):
        q = rng.uniform(-1.0, 1.0, m.dof)
        theta = m.compensate(q)
        assert abs(theta[3] + theta[1] + theta[2]) < 1e-15
        Jq = m.jacobian(q) @ m.reading_jacobian(q)
        numeric = numeric_jacobian(m, q, h)
        assert np.max(np.abs(numeric - Jq)) < 1e-7
        assert np.all(Jq[:, 3] == 0)  # the passive joint's reading moves nothing
    assert np.array_equal(hapticcal.load_model(MECA).coupling, np.eye(6))


def test_transmissions_make_compensate_differ_from_q(eccentric):
    m = hapticcal.load_model(eccentric)
    q = np.full(m.dof, 0.3)
    assert np.max(np.abs(m.compensate(q) - q)) > 1e-6
    meca = hapticcal.load_model(MECA)
    assert np.array_equal(meca.compensate(q[:6]), q[:6])


def test_parameters_round_trip(tmp_path):
    m = hapticcal.load_model(MECA)
    assert m.dof == 6 and m.path == MECA and m.name
    p = m.parameters()
    assert "j2.a" in p and "tool.x" in p
    T0 = m.forward(np.zeros(6))
    p["j2.a"] += 1e-3
    m.set_parameters(p)
    assert m.parameters() == p and m.path == ""
    assert not np.allclose(m.forward(np.zeros(6)), T0)
    m.save(str(tmp_path / "changed.yaml"))
    back = hapticcal.load_model(str(tmp_path / "changed.yaml"))
    assert back.parameters() == p
    with pytest.raises(ValueError, match="not a kinematic parameter"):
        m.set_parameters({"j9.a": 1.0})
    with pytest.raises(ValueError, match="q has 5 values"):
        m.forward(np.zeros(5))


def test_bad_input_raises_value_error_with_the_cli_message(tmp_path):
    bad = tmp_path / "bad.csv"
    lines = pathlib.Path(CAL_LOG).read_text().splitlines()[:4]
    lines[2] = lines[2].replace(lines[2].split(",")[1], "abc", 1)
    bad.write_text("\n".join(lines) + "\n")
    for command, call in [
        ("evaluate", lambda: hapticcal.evaluate(MECA, str(bad))),
        ("calibrate", lambda: hapticcal.calibrate(MECA, str(bad))),
    ]:
        args = [command, "--model", MECA, "--log", str(bad)]
        if command == "calibrate":
            args += ["--out", str(tmp_path / "out")]
        code, _, stderr = cli(*args)
        assert code == 2
        assert stderr.startswith("hapticcal: ")
        with pytest.raises(ValueError) as e:
            call()
        assert "hapticcal: " + str(e.value) + "\n" == stderr
        assert "bad.csv:3" in str(e.value)
    code, _, stderr = cli(
        "calibrate", "--model", MECA, "--log", CAL_LOG, "--point-distance", "A:B",
        "--out", str(tmp_path / "out"),
    )
    assert code == 2
    with pytest.raises(ValueError) as e:
        hapticcal.calibrate(MECA, CAL_LOG, point_distance=["A:B"])
    assert "hapticcal: " + str(e.value) + "\n" == stderr


def test_options_reach_the_calibration():
    r = hapticcal.calibrate(
        MECA, CAL_LOG, samples=20, seed=3, keep_all=True, folds=0, fix=["j2.a"], sigma=2e-5
    )
    assert r.usable
    assert not r.parameters["j2.a"]["identifiable"]
    assert r.parameters["j2.a"]["value"] == r.parameters["j2.a"]["nominal"]
    assert r.results["poses"] == 20 and r.results["seed"] == 3
    assert math.isnan(r.cv_rms)


def test_the_model_search_is_returned_and_can_be_turned_off(py_calibration):
    s = py_calibration.search
    assert s["ran"] and s == py_calibration.results["model_search"]
    kept = s["candidates"][s["kept"]]
    assert kept["cv_rms"] == pytest.approx(py_calibration.cv_rms, rel=1e-12)
    assert kept["usable"] and kept["allowed"]
    assert {c["estimator"] for c in s["candidates"]} == {
        "tolerance prior", "significance cut", "least squares"}
    assert s["nominal_rms"] > 3 * kept["cv_rms"]
    one = hapticcal.calibrate(MECA, CAL_LOG, search=False, prior=True)
    assert one.usable and not one.search["ran"] and one.search["candidates"] == []
    with pytest.raises(ValueError, match="exclude each other"):
        hapticcal.calibrate(MECA, CAL_LOG, keep_all=True, prior=True)
    with pytest.raises(ValueError, match="threads"):
        hapticcal.calibrate(MECA, CAL_LOG, threads=-1)


def test_joint_error_options_reach_the_calibration():
    # The harmonic joint errors: their coefficients are parameters, and the
    # comparison without them is in the results.
    r = hapticcal.calibrate(MECA, CAL_LOG, samples=40, joint_errors=["harmonic"])
    assert "j2.sin1" in r.parameters and "j6.cos2" in r.parameters
    assert r.results["joint_errors"]["families"] == ["harmonic"]
    assert r.results["joint_errors"]["cv_rms_without"] > 0
    with pytest.raises(ValueError, match="not a joint-error family"):
        hapticcal.calibrate(MECA, CAL_LOG, joint_errors=["gear-play"])
    # Compliance on a model without masses: each link a lumped 1 kg, said so.
    c = hapticcal.calibrate(MECA, CAL_LOG, joint_errors=["compliance"])
    assert "j2.k" in c.parameters
    assert any("lumped 1 kg" in n for n in c.notes)
    with pytest.raises(ValueError, match="encoder-resolution"):
        hapticcal.calibrate(MECA, CAL_LOG, encoder_resolution=-1.0)


def test_plan_smoke(tmp_path):
    out = tmp_path / "plan"
    r = hapticcal.plan(MECA, "position", 12, pool=200, refine_passes=0, seed=2, out=str(out))
    assert set(r) == {"plan", "readings", "out", "files"}
    assert r["readings"].shape == (12, 6)
    plan = r["plan"]
    for key in ["format", "measurement", "criterion", "poses", "chosen_candidates",
                "predicted_rms_sd", "parameter_sd", "observability", "path_length"]:
        assert key in plan
    assert plan["poses"] == 12 and plan["pool"] == 200
    assert json.loads((out / "plan.json").read_text()) == plan
    assert (out / "plan.csv").exists()
    with pytest.raises(ValueError, match="--measurement 'speed'"):
        hapticcal.plan(MECA, "speed", 12, out=str(out))


def test_simulate_smoke(tmp_path):
    scenario = tmp_path / "small.yaml"
    scenario.write_text(
        "format: hapticcal-scenario/1\n"
        f"device: {MECA}\n"
        "measurement: position\n"
        "poses: {identification: 40, validation: 10}\n"
        "trajectory: {seconds: 1, rate_hz: 10}\n"
    )
    out = tmp_path / "sim"
    r = hapticcal.simulate(str(scenario), seed=4, threads=1, out=str(out))
    assert set(r) == {"results", "out", "files"}
    assert (out / "results.json").exists() and (out / "calibrated.yaml").exists()
    assert json.loads((out / "results.json").read_text()) == r["results"]
    assert r["results"]["seed"] == 4


def moved_log(path, log, seed):
    """`log` as a tracker moved by 0.5 m and 30 deg (a random axis) would have measured it."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    angle = math.radians(30)
    R = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    direction = rng.normal(size=3)
    t = 0.5 * direction / np.linalg.norm(direction)
    lines = pathlib.Path(log).read_text().splitlines()
    header = lines[0].split(",")
    ix = header.index("x")
    out = [lines[0]]
    for line in lines[1:]:
        f = line.split(",")
        p = R @ np.array([float(v) for v in f[ix : ix + 3]]) + t
        f[ix : ix + 3] = [repr(float(v)) for v in p]
        out.append(",".join(f))
    pathlib.Path(path).write_text("\n".join(out) + "\n")
    return str(path)


@pytest.mark.parametrize("what", ["frame", "frame,tool"])
def test_evaluate_register_matches_the_cli(tmp_path, what):
    log = moved_log(tmp_path / "moved.csv", VAL_LOG, 3)
    code, stdout, stderr = cli("evaluate", "--model", MECA, "--log", log, "--register", what,
                               "--json")
    assert code == 0, stderr
    mine = hapticcal.evaluate(MECA, log, register=what)
    assert_same(mine, json.loads(stdout))
    assert mine["registered"]["what"] == what
    # Moved or not, the registered error is the same (the tracker's place does not matter).
    unmoved = hapticcal.evaluate(MECA, VAL_LOG, register=what)
    assert abs(mine["rms_position"] - unmoved["rms_position"]) < 1e-9
    assert mine["registered"]["rms_position_before_registration"] > 0.1
    code, stdout, stderr = cli("evaluate", "--model", MECA, "--log", log, "--register", what,
                               "--reference", MECA, "--json")
    assert code == 0, stderr
    assert_same(hapticcal.evaluate(MECA, log, register=what, reference=MECA),
                json.loads(stdout))


def test_evaluate_register_refuses_an_unknown_word():
    with pytest.raises(ValueError, match="expected frame"):
        hapticcal.evaluate(MECA, VAL_LOG, register="base")


ARM = str(SOURCE / "tests" / "data" / "urdf" / "arm.urdf")


def arm_log(path, rows, seed, held=None):
    """A position log of the test arm with its joint origins moved ~1 mm / 1 mrad, 10 um noise;
    joint `held` (0-based) kept at 0."""
    rng = np.random.default_rng(seed)
    truth = hapticcal.load_model(ARM, tip="tcp")
    moved = {n: v + rng.uniform(-1e-3, 1e-3) for n, v in truth.parameters().items()}
    truth.set_parameters(moved)
    low = np.array([-2.0, -1.2, 0.02, -3.0, -2.5])
    high = np.array([2.0, 1.0, 0.23, 3.0, 2.5])
    lines = ["q1,q2,q3[m],q4,q5,x,y,z"]
    for _ in range(rows):
        q = rng.uniform(low, high)
        if held is not None:
            q[held] = 0.0
        p = truth.forward(q)[:3, 3] + rng.normal(0, 1e-5, 3)
        lines.append(",".join(repr(float(v)) for v in [*q, *p]))
    pathlib.Path(path).write_text("\n".join(lines) + "\n")
    return str(path)


def output_files(folder):
    """The set's files relative to it (the marker left out)."""
    root = pathlib.Path(folder)
    files = (p for p in root.rglob("*") if p.is_file() and p.name != ".hapticcal-output")
    return sorted(str(p.relative_to(root)) for p in files)


def test_calibrate_out_writes_the_cli_files_for_a_urdf_model(tmp_path):
    """calibrate(out=) writes what the command line writes (calibrated.urdf too); on an unusable
    rerun into the same folder both keep the previous calibrated.yaml and calibrated.urdf."""
    good = arm_log(tmp_path / "good.csv", 150, 5)
    poor = arm_log(tmp_path / "poor.csv", 150, 6, held=3)  # the wrist still: not excited
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    for log, usable in ((good, True), (poor, False)):
        # --keep-all: plain least squares refuses what the poses leave unexcited
        # (the default's tolerance prior would hold it).
        code, _, stderr = cli("calibrate", "--model", ARM, "--tip", "tcp", "--log", log,
                              "--keep-all", "--out", str(cli_out))
        assert code == (0 if usable else 3), stderr
        r = hapticcal.calibrate(ARM, log, tip="tcp", keep_all=True, out=str(py_out))
        assert r.usable == usable, r.status_reason
        files = output_files(cli_out)
        assert "calibrated.urdf" in files and "calibrated.yaml" in files
        assert output_files(py_out) == files
        results = json.loads((cli_out / "results.json").read_text())
        assert_same(json.loads((py_out / "results.json").read_text()), results)
        assert_same(r.results, results)
        for name in ("calibrated.yaml", "calibrated.urdf"):
            assert (py_out / name).read_text() == (cli_out / name).read_text(), name
    assert any("previous run's model" in n for n in results["notes"])


def test_calibrate_job_gives_the_cli_output_folder_byte_for_byte(tmp_path):
    """The command line and the module run one job (jobs/calibrate_job.hpp): for the same inputs
    their output folders are equal file by file, byte for byte (figures included), and the module's
    summary lines are the lines the command line prints before its report line."""
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    code, stdout, stderr = cli("calibrate", "--model", MECA, "--log", CAL_LOG, "--folds", "3",
                               "--out", str(cli_out))
    assert code == 0, stderr
    r = hapticcal.calibrate(MECA, CAL_LOG, folds=3, out=str(py_out))
    files = output_files(cli_out)
    assert "results.json" in files and "report.html" in files and "calibrated.yaml" in files
    assert output_files(py_out) == files
    for name in files:
        a, b = (cli_out / name).read_bytes(), (py_out / name).read_bytes()
        if name == "report.html":  # it names its own folder
            a = a.replace(str(cli_out).encode(), b"OUT")
            b = b.replace(str(py_out).encode(), b"OUT")
        assert a == b, name
    printed = stdout.splitlines()
    assert printed[: len(r.lines)] == list(r.lines)
    assert printed[len(r.lines)].startswith("report: ")
    # The report carries the same summary (one calibration_lines for both).
    report = (cli_out / "report.html").read_text()
    # (core's markup_escaped: & < > and ", not ')
    summary = "\n".join(html.escape(line, quote=False).replace('"', "&quot;") for line in r.lines)
    assert summary in report


def same_folders(cli_out, py_out):
    """Two output sets equal file by file, byte for byte (a report names its own folder)."""
    files = output_files(cli_out)
    assert files and output_files(py_out) == files
    for name in files:
        a, b = (cli_out / name).read_bytes(), (py_out / name).read_bytes()
        if name == "report.html":
            a = a.replace(str(cli_out).encode(), b"OUT")
            b = b.replace(str(py_out).encode(), b"OUT")
        assert a == b, name
    return files


def test_evaluate_job_gives_the_cli_output_folder_byte_for_byte(tmp_path):
    """evaluate runs one job (jobs/evaluate_job.hpp) for both front ends: with a reference and a
    registration, the two output folders are equal byte for byte and the module's dict is the
    command line's --json."""
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    args = ["--model", MECA, "--log", VAL_LOG, "--reference", MECA, "--register", "frame"]
    code, stdout, stderr = cli("evaluate", *args, "--json", "--out", str(cli_out))
    assert code == 0, stderr
    ev = hapticcal.evaluate(MECA, VAL_LOG, reference=MECA, register="frame", out=str(py_out))
    files = same_folders(cli_out, py_out)
    assert "results.json" in files and "report.html" in files
    assert_same(ev, json.loads(stdout))


def test_plan_job_gives_the_cli_output_folder_byte_for_byte(tmp_path):
    """plan runs one job (jobs/plan_job.hpp) for both front ends: the same folders, byte for
    byte, and the module's plan is plan.json."""
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    code, _, stderr = cli("plan", "--model", MECA, "--measurement", "position", "--poses", "12",
                          "--pool", "200", "--refine-passes", "0", "--seed", "2",
                          "--distance-range", "0.25,0.35", "--fix", "j1.a", "--out", str(cli_out))
    assert code == 0, stderr
    r = hapticcal.plan(MECA, "position", 12, pool=200, refine_passes=0, seed=2,
                       distance_range=[0.25, 0.35], fix=["j1.a"], out=str(py_out))
    files = same_folders(cli_out, py_out)
    assert "plan.csv" in files and "plan.json" in files
    assert json.loads((cli_out / "plan.json").read_text()) == r["plan"]
    with pytest.raises(ValueError, match="--distance-range .0.2.: expected 2 comma-separated numbers"):
        hapticcal.plan(MECA, "position", 12, distance_range=[0.2], out=str(py_out))


def test_iso_plan_and_its_test_are_the_cli_s(tmp_path):
    """plan(iso9283=True) runs the command line's ISO 9283 job (jobs/iso_plan_job.hpp): the same
    folders byte for byte, the cube the terminal prints; evaluate(iso9283=...) scores a log that
    follows its plan.csv as evaluate --iso9283 does."""
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    code, stdout, stderr = cli("plan", "--model", MECA, "--iso9283", "--cycles", "3",
                               "--out", str(cli_out))
    assert code == 0, stderr
    r = hapticcal.plan(MECA, iso9283=True, cycles=3, out=str(py_out))
    files = same_folders(cli_out, py_out)
    assert "plan.csv" in files and "iso9283.json" in files
    assert r["plan"] == json.loads((cli_out / "iso9283.json").read_text())
    assert f"test cube: edge {r['plan']['size'] * 1e3:.1f} mm" in stdout
    assert r["readings"].shape == (5, 6)
    with pytest.raises(ValueError, match="apply to an ISO 9283 plan"):
        hapticcal.plan(MECA, "position", 12, cycles=5, out=str(py_out))
    with pytest.raises(ValueError, match="no --measurement, --poses or --candidates"):
        hapticcal.plan(MECA, "position", 12, iso9283=True, out=str(py_out))
    # The test measured: the model's own tool points, 20 um off at P1.
    m = hapticcal.load_model(MECA)
    rows = (cli_out / "plan.csv").read_text().splitlines()
    log = tmp_path / "test.csv"
    with open(log, "w") as f:
        f.write(rows[0] + ",x,y,z\n")
        for line in rows[1:]:
            cells = line.split(",")
            p = m.forward(np.array([float(c) for c in cells[:6]]))[:3, 3]
            if cells[6] == "P1":
                p = p + np.array([2e-5, 0, 0])
            f.write(line + "," + ",".join(repr(float(v)) for v in p) + "\n")
    code, stdout, stderr = cli("evaluate", "--model", MECA, "--log", str(log), "--iso9283",
                               str(cli_out / "plan.csv"), "--json")
    assert code == 0, stderr
    ev = hapticcal.evaluate(MECA, str(log), iso9283=str(cli_out / "plan.csv"))
    assert_same(ev, json.loads(stdout))
    assert "iso9283" in ev


def test_every_command_option_is_a_keyword_and_back():
    """Each command's options (its --help) and its Python function's keywords name the same
    things: a difference is an option one front end lacks. The differences that are not:
    --no-search is search=False, --json is the command line's way to print what Python
    returns, and the positional inputs (convert's input and output, import's recording)."""
    commands = {"calibrate": "calibrate", "evaluate": "evaluate", "plan": "plan",
                "simulate": "simulate", "force": "force", "convert": "convert",
                "import": "import_recording", "compensate": "compensate"}
    same = {"no_search": "search"}
    cli_only = {"json"}
    python_only = {"input", "output", "recording"}
    for command, function in commands.items():
        signature = getattr(hapticcal, function).__doc__.split("\n")[0]
        keywords = set(re.findall(r"(\w+):", signature.split("(", 1)[1]))
        code, stdout, stderr = cli(command, "--help")
        assert code == 0, stderr
        options = {same.get(o.replace("-", "_"), o.replace("-", "_"))
                   for o in re.findall(r"^\s+(?:-\w, )?--([a-z0-9-]+)", stdout, re.M)}
        options.discard("help")
        assert options - keywords - cli_only == set(), command
        assert keywords - options - python_only == set(), command


def test_a_commands_keywords_are_read_as_its_options(tmp_path):
    """calibrate's and evaluate's keywords are their options' table (the command line's):
    Python's errors for a keyword unknown, given twice, missing or of the wrong type; each
    keyword's help in the doc, as the command line's --help gives it; a list as a list or as
    the command line's comma-separated text; a point as numbers or as text."""
    with pytest.raises(TypeError, match="unexpected keyword argument 'fold'"):
        hapticcal.calibrate(MECA, CAL_LOG, fold=3)
    with pytest.raises(TypeError, match="multiple values for argument 'log'"):
        hapticcal.calibrate(MECA, CAL_LOG, log=CAL_LOG)
    with pytest.raises(TypeError, match="missing required argument: 'log'"):
        hapticcal.evaluate(MECA)
    with pytest.raises(TypeError, match="takes 2 positional arguments but 3"):
        hapticcal.evaluate(MECA, CAL_LOG, "x")
    for keywords in (dict(folds=2.5), dict(folds=True), dict(keep_all=1), dict(fix=3),
                     dict(sigma="0.001"), dict(fix=["j1.a", 2])):
        with pytest.raises(TypeError, match="takes"):
            hapticcal.calibrate(MECA, CAL_LOG, **keywords)
    with pytest.raises(ValueError, match="--clock-search: needs --tracker"):
        hapticcal.calibrate(MECA, CAL_LOG, clock_search=5.0)
    with pytest.raises(ValueError, match="--loss tukey: not one of cauchy, huber, none"):
        hapticcal.calibrate(MECA, CAL_LOG, loss="tukey")
    code, stdout, _ = cli("calibrate", "--help")
    assert code == 0
    for keyword, help_line in re.findall(r"^(\w+): (.+)$", hapticcal.calibrate.__doc__, re.M):
        flag = "--no-search" if keyword == "search" else "--" + keyword.replace("_", "-")
        assert flag in stdout, keyword
        assert help_line[:60] in " ".join(stdout.split()), keyword
    as_list = hapticcal.calibrate(MECA, CAL_LOG, fix=["j1.a", "j2.d"], no_transmission=True,
                                  folds=0, search=False, tool_point=[0.0, 0.0, 0.07])
    as_text = hapticcal.calibrate(MECA, CAL_LOG, fix="j1.a,j2.d", no_transmission=True,
                                  folds=0, search=False, tool_point="0,0,0.07",
                                  clock_drift=False)  # a flag's default: no tracker needed
    as_array = hapticcal.calibrate(MECA, CAL_LOG, fix=("j1.a", "j2.d"), no_transmission=True,
                                   folds=np.int64(0), search=np.bool_(False),
                                   tool_point=np.array([0.0, 0.0, 0.07]))
    assert as_array.device_model.parameters() == as_text.device_model.parameters()
    with pytest.raises(TypeError, match="markers takes"):
        hapticcal.evaluate(MECA, CAL_LOG, markers=hapticcal.load_model(MECA))
    with pytest.raises(TypeError, match="log takes"):
        hapticcal.evaluate(MECA, [1.0, 2.0])
    assert as_list.parameters["j1.a"]["value"] == as_list.parameters["j1.a"]["nominal"]
    assert ({k: p["value"] for k, p in as_list.parameters.items()}
            == {k: p["value"] for k, p in as_text.parameters.items()})
    assert as_list.device_model.parameters() == as_text.device_model.parameters()


def test_the_command_lines_defaults_are_the_keywords_defaults():
    """A default the command line shows (`--folds INT:in [0, 1000]=5` in its --help) is the
    default of the Python keyword of that name: both are the library's (CalibrationOptions,
    StreamOptions), not a number written twice."""
    checked = 0
    for command, function in {"calibrate": "calibrate", "evaluate": "evaluate",
                              "simulate": "simulate", "force": "force",
                              "compensate": "compensate", "import": "import_recording",
                              "plan": "plan", "convert": "convert"}.items():
        signature = getattr(hapticcal, function).__doc__.split("\n")[0]
        code, stdout, stderr = cli(command, "--help")
        assert code == 0, stderr
        # An option's own column: its name, type, check and default, up to two spaces.
        for option, column in re.findall(r"^\s+--([a-z0-9-]+) ((?:(?!  ).)*)", stdout, re.M):
            shown = re.search(r"=(\S+)", column)
            if not shown:
                continue
            keyword = option.replace("-", "_")
            match = re.search(r"\b" + keyword + r": [^=]+? = ([^,)]+)", signature)
            assert match, (command, option)
            default = match.group(1).strip().strip("'")
            try:
                assert float(default) == float(shown.group(1)), (command, option, default, shown)
            except ValueError:
                assert default == shown.group(1), (command, option, default, shown)
            checked += 1
    # calibrate's seven shown defaults, evaluate's clock search, simulate's threads and out,
    # force's out, gain, noise, three of the wall and seed, compensate's load and out,
    # import's time and clock offset, plan's cycles, criterion, seed and out
    assert checked >= 25


def test_simulate_job_gives_the_cli_output_folder_byte_for_byte(tmp_path):
    """simulate runs one job (jobs/simulate_job.hpp) for both front ends: the same folders, byte
    for byte (trial logs, results.json, the report and its figures)."""
    scenario = tmp_path / "small.yaml"
    scenario.write_text(
        "format: hapticcal-scenario/1\n"
        f"device: {MECA}\n"
        "measurement: position\n"
        "poses: {identification: 40, validation: 10}\n"
        "trajectory: {seconds: 1, rate_hz: 10}\n"
    )
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    code, _, stderr = cli("simulate", "--scenario", str(scenario), "--seed", "4", "--threads",
                          "1", "--out", str(cli_out))
    assert code == 0, stderr
    r = hapticcal.simulate(str(scenario), seed=4, threads=1, out=str(py_out))
    files = same_folders(cli_out, py_out)
    assert "results.json" in files and "report.html" in files
    assert json.loads((cli_out / "results.json").read_text()) == r["results"]


def test_force_and_convert_jobs_give_the_cli_outputs_byte_for_byte(tmp_path):
    """force and convert run one job each (jobs/force_job.hpp) for both front ends: force's
    folders are equal byte for byte; convert writes the same file; both refuse the same input."""
    m = hapticcal.load_model(MECA)
    p = m.parameters()
    p["j2.a"] += 1e-3
    p["j3.alpha"] += 2e-3
    m.set_parameters(p)
    actual = str(tmp_path / "actual.yaml")
    m.save(actual)
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    posture = [0.1, 0.3, 0.2, 0.1, 0.5, 0.2]  # (home is a wrist singularity of the Meca500)
    code, _, stderr = cli("force", "--actual", actual, "--nominal", MECA, "--calibrated", actual,
                          "--noise", "0.01", "--seed", "3", "--posture",
                          ",".join(str(v) for v in posture), "--out", str(cli_out))
    assert code == 0, stderr
    r = hapticcal.force(actual, MECA, actual, noise=0.01, seed=3, posture=posture,
                        out=str(py_out))
    files = same_folders(cli_out, py_out)
    assert "force_nominal.csv" in files and "results.json" in files
    assert json.loads((cli_out / "results.json").read_text()) == r["results"]
    assert r["results"]["transverse_rms_calibrated"] < r["results"]["transverse_rms_nominal"]
    for name in ("cli.urdf", "py.urdf"):
        assert not (tmp_path / name).exists()
    code, _, stderr = cli("convert", MECA, str(tmp_path / "cli.urdf"))
    assert code == 0, stderr
    c = hapticcal.convert(MECA, str(tmp_path / "py.urdf"))
    assert c["dof"] == 6
    assert (tmp_path / "py.urdf").read_bytes() == (tmp_path / "cli.urdf").read_bytes()
    code, _, stderr = cli("convert", MECA, str(tmp_path / "x.yaml"))
    assert code == 2
    with pytest.raises(ValueError) as refused:
        hapticcal.convert(MECA, str(tmp_path / "x.yaml"))
    assert stderr.strip() == "hapticcal: " + str(refused.value)


def test_the_library_refuses_what_the_command_line_refuses(tmp_path):
    """Issue 23 (C3, E8): bounds checked by the library, for Python as for the CLI."""
    with pytest.raises(ValueError, match="--dependency-tolerance"):
        hapticcal.calibrate(MECA, CAL_LOG, dependency_tolerance=1.0)
    with pytest.raises(ValueError, match="--dependency-tolerance"):
        hapticcal.calibrate(MECA, CAL_LOG, dependency_tolerance=math.inf)
    with pytest.raises(ValueError, match="--trials 100001"):
        hapticcal.simulate(trials=100001, out=str(tmp_path / "sim"))
    with pytest.raises(ValueError, match="--pool 1000000000"):
        hapticcal.plan(MECA, "position", 12, pool=10**9, out=str(tmp_path / "plan"))
    with pytest.raises(ValueError, match="NUL byte"):
        hapticcal.load_model(MECA + "\x00junk")
    # Every number in the command line's range, nan and inf included: never
    # converted out of range (a clock search of 1e20 s once reported -9.2e16 s).
    for bad in (math.nan, math.inf, -math.inf, 1e20, 0.0):
        with pytest.raises(ValueError, match=r"--clock-search .*: not in \[0.001, 3600\] s"):
            hapticcal.calibrate("geomagic-touch", CAL_LOG, tracker=CAL_LOG, clock_search=bad)
    refusals = [
        (dict(sigma=0.0), "--sigma"), (dict(sigma=math.nan), "--sigma"),
        (dict(folds=-1), "--folds"), (dict(samples=-3), "--samples"),
        (dict(polynomial_order=0), "--polynomial-order"), (dict(prior_scale=math.inf), "--prior-scale"),
        (dict(encoder_resolution=math.nan), "--encoder-resolution"),
    ]
    for keywords, option in refusals:
        with pytest.raises(ValueError, match=option):
            hapticcal.calibrate(MECA, CAL_LOG, **keywords)
    with pytest.raises(ValueError, match="--sigma-e"):
        hapticcal.plan(MECA, "position", 12, sigma_e=math.nan, out=str(tmp_path / "plan"))
    with pytest.raises(ValueError, match="--refine-passes"):
        hapticcal.plan(MECA, "position", 12, refine_passes=5000, out=str(tmp_path / "plan"))
    with pytest.raises(ValueError, match="--threads"):
        hapticcal.simulate(threads=1000, out=str(tmp_path / "sim"))
    with pytest.raises(ValueError, match="--stiffness"):
        hapticcal.force(MECA, MECA, MECA, stiffness=math.nan, out=str(tmp_path / "force"))
    assert not (tmp_path / "plan").exists() and not (tmp_path / "sim").exists()


def simulated_session(tmp_path, seconds, validation):
    """A simulated hand-guided Touch session (the command line's simulate) in tmp_path/sim."""
    scenario = tmp_path / "session.yaml"
    scenario.write_text(
        "format: hapticcal-scenario/1\n"
        f"device: {SOURCE / 'data' / 'devices' / 'geomagic-touch.yaml'}\n"
        f"measurement: position\nposes: {{validation: {validation}}}\nnoise: {{sigma_m: 1.0e-4}}\n"
        "random_deviations: {lengths: 5.0e-4, angles: 5.0e-3}\n"
        f"session: {{seconds: {seconds}, clock_offset: 0.0373, clock_drift_ppm: 20}}\n"
    )
    code, _, stderr = cli("simulate", "--scenario", str(scenario), "--out", str(tmp_path / "sim"))
    assert code == 0, stderr


def test_calibrate_two_streams_and_markers(tmp_path):
    """Issue 26: calibrate(tracker=...) estimates the clocks as --tracker does."""
    simulated_session(tmp_path, seconds=40, validation=50)
    r = hapticcal.calibrate(
        "geomagic-touch",
        str(tmp_path / "sim" / "device.csv"),
        tracker=str(tmp_path / "sim" / "tracker.csv"),
        clock_drift=True,
    )
    assert r.usable, r.status_reason
    assert abs(r.results["clock"]["offset"] - 0.0373) < 2e-4
    assert r.results["clock"]["drift_fitted"] is True
    with pytest.raises(ValueError):
        hapticcal.calibrate("geomagic-touch", str(tmp_path / "sim" / "device.csv"), markers="1,2")


def test_evaluate_a_second_session(tmp_path):
    """evaluate(tracker=...) aligns a session's clocks with the model held, as --tracker does."""
    simulated_session(tmp_path, seconds=40, validation=50)
    device, tracker = str(tmp_path / "sim" / "device.csv"), str(tmp_path / "sim" / "tracker.csv")
    fit = hapticcal.calibrate("geomagic-touch", device, tracker=tracker, clock_drift=True)
    assert fit.usable, fit.status_reason
    r = hapticcal.evaluate(fit.model, device, tracker=tracker, clock_drift=True)
    assert abs(r["clock"]["offset"] - fit.results["clock"]["offset"]) < 3 * r["clock"]["offset_sd"]
    assert r["rms_position"] < 2e-4  # the session's noise: 0.1 mm a coordinate
    with pytest.raises(ValueError, match="--clock-search"):
        hapticcal.evaluate(fit.model, device, tracker=tracker, clock_search=0)


def test_import_a_ros1_bag(tmp_path):
    """import_recording reads a bag written by Debian's python3-rosbag, as `hapticcal import`."""
    import rosbag  # Debian's python3-rosbag (the Makefile installs it)
    import rospy
    from geometry_msgs.msg import PointStamped
    from sensor_msgs.msg import JointState

    bag = tmp_path / "session.bag"
    with rosbag.Bag(str(bag), "w") as b:
        for k in range(50):
            stamp = rospy.Time(1733390000, 1000000 * k)
            js = JointState(name=["elbow", "shoulder", "waist", "yaw", "pitch", "roll"],
                            position=[0.3, 0.2, 0.1 * k, 0.4, 0.5, 0.6])
            js.header.stamp = stamp
            b.write("/joint_states", js, t=stamp)
            if k % 5 == 0:
                p = PointStamped()
                p.header.stamp = stamp
                p.point.x, p.point.y, p.point.z = 0.001 * k, 0.2, -0.1
                b.write("/probe", p, t=stamp)
    out = tmp_path / "imported"
    r = hapticcal.import_recording(str(bag), model="geomagic-touch", convention="none", out=str(out))
    assert r["format"] == "ROS 1 bag"
    assert r["joints"] == ["waist", "shoulder", "elbow", "yaw", "pitch", "roll"]
    assert (r["device_rows"], r["tracker_rows"]) == (50, 10)
    roles = {t["topic"]: t["role"] for t in r["topics"]}
    assert roles == {"/joint_states": "device", "/probe": "tracker"}
    rows = [line.split(",") for line in (out / "device.csv").read_text().splitlines()
            if not line.startswith("#")]
    assert rows[0] == ["t", "q1", "q2", "q3", "q4", "q5", "q6"]
    assert [float(v) for v in rows[3][1:]] == [0.1 * 2, 0.2, 0.3, 0.4, 0.5, 0.6]
    assert rows[3][0] == "0.002000000"
    listed = hapticcal.import_recording(str(bag), list=True)
    assert len(listed["topics"]) == 2
    # Options that would have no effect are refused, with the command line's words.
    for kwargs, args, says in [
            (dict(list=True, out=str(tmp_path / "listed")), ["--list", "--out", str(tmp_path / "listed")],
             "--out would have no effect"),
            (dict(list=True, model="geomagic-touch"), ["--list", "--model", "geomagic-touch"],
             "--model would have no effect"),
            (dict(still_tolerance=1e-3, out=str(tmp_path / "x")),
             ["--still-tolerance", "0.001", "--out", str(tmp_path / "x")],
             "--still-tolerance: applies to the still windows of a static log"),
            (dict(tracker_still=1e-3, out=str(tmp_path / "x")),
             ["--tracker-still", "0.001", "--out", str(tmp_path / "x")], "--tracker-still: applies")]:
        with pytest.raises(ValueError, match=says) as refused:
            hapticcal.import_recording(str(bag), **kwargs)
        code, stdout, stderr = cli("import", str(bag), *args)
        assert code == 2 and stderr == f"hapticcal: {refused.value}\n", (stderr, str(refused.value))
    assert not (tmp_path / "listed").exists() and not (tmp_path / "x").exists()
    # Two publishers of one topic (two connections of the bag) are one stream in
    # stamp order; a second JointState topic makes the choice the user's, and
    # list=True still lists.
    two = tmp_path / "two.bag"
    with rosbag.Bag(str(two), "w") as b:
        for k in range(40):
            stamp = rospy.Time(1733390000, 1000000 * k)
            js = JointState(name=["a"], position=[0.01 * k])
            js.header.stamp = stamp
            header = {"callerid": "/pub%d" % (k % 2), "topic": "/joint_states", "type": js._type,
                      "md5sum": js._md5sum, "message_definition": js._full_text}
            b.write("/joint_states", js, t=stamp, connection_header=header)
            other = JointState(name=["b"], position=[1.0])
            other.header.stamp = stamp
            b.write("/gripper_states", other, t=stamp)
    r = hapticcal.import_recording(str(two), joints="/joint_states", out=str(tmp_path / "two"))
    assert r["device_rows"] == 40
    assert hapticcal.import_recording(str(two), list=True)["topics"][0]["messages"] == 40
    with pytest.raises(ValueError, match="several JointState topics"):
        hapticcal.import_recording(str(two), out=str(tmp_path / "x"))
    with pytest.raises(ValueError, match="no topic /nothing"):
        hapticcal.import_recording(str(bag), joints="/nothing", out=str(tmp_path / "x"))


TWO_ARM = str(SOURCE / "examples" / "two-arm" / "two_arm.urdf")


def test_calibrate_a_tree_of_two_tips(tmp_path):
    """calibrate(tip="A,B") on a URDF fits both hands at once: points from the nominal chains
    (Model.forward) in a frame moved by a known pose are fitted to rounding (the frame
    registered); the shared torso joints are one parameter each, on both tips' paths; the
    calibrated tree comes back as a Model whose forward(q, tip=k) is tip k's pose."""
    left = hapticcal.load_model(TWO_ARM, tip="left_hand")
    right = hapticcal.load_model(TWO_ARM, tip="right_hand")
    rng = np.random.default_rng(5)
    frame = np.eye(4)
    frame[:3, 3] = [0.4, -0.2, 0.9]
    rows = []
    for _ in range(120):
        q = rng.uniform(-1.3, 1.3, 11)
        pl = (frame @ left.forward(q[[0, 1, 2, 3, 4, 5, 6]]))[:3, 3]
        pr = (frame @ right.forward(q[[0, 1, 2, 7, 8, 9, 10]]))[:3, 3]
        rows.append(",".join(f"{v:.17g}" for v in [*q, *pl, *pr]))
    header = ",".join([f"q{i}" for i in range(1, 12)] + ["x1", "y1", "z1", "x2", "y2", "z2"])
    (tmp_path / "tree.csv").write_text(header + "\n" + "\n".join(rows) + "\n")
    c = hapticcal.calibrate(TWO_ARM, str(tmp_path / "tree.csv"), tip="left_hand,right_hand",
                            out=str(tmp_path / "out"))
    assert c.usable, c.status_reason
    assert c.model is not None and c.model.tips == ["left_hand", "right_hand"]
    assert c.results["frame_registered"] and c.rms_after < 1e-9
    tips = c.results["tips"]
    assert list(tips) == ["left_hand", "right_hand"]
    assert tips["left_hand"]["joints"][:3] == tips["right_hand"]["joints"][:3]
    assert tips["right_hand"]["rms_after"] < 1e-9
    assert "torso_pitch.x" in c.parameters
    assert c.parameters["base.x"]["value"] == pytest.approx(0.4, abs=1e-9)
    q = rng.uniform(-1.3, 1.3, 11)
    want = (frame @ right.forward(q[[0, 1, 2, 7, 8, 9, 10]]))[:3, 3]
    assert np.abs(c.model.forward(q, tip=1)[:3, 3] - want).max() < 1e-9
    assert not c.model.jacobian(q, tip=1)[:, 3:7].any()  # the left arm moves no right hand
    with pytest.raises(ValueError):
        c.model.forward(q, tip=2)
    again = hapticcal.calibrate(c.model, str(tmp_path / "tree.csv"))  # its URDF and tips kept
    assert again.usable and again.model.tips == ["left_hand", "right_hand"]
    assert (tmp_path / "out" / "calibrated.urdf").exists()
    # The whole tree in one device file, loaded back as the calibrated Model.
    whole = hapticcal.load_model(str(tmp_path / "out" / "calibrated.yaml"))
    assert whole.tips == ["left_hand", "right_hand"]
    for tip in (0, 1):
        assert np.abs(whole.forward(q, tip=tip) - c.model.forward(q, tip=tip)).max() < 1e-12


def test_every_xml_file_of_the_repository_is_well_formed():
    """Every XML file the repository holds (URDF, xacro, SVG, launch, SDF) parses by Python's own
    parser (independent of urdfdom, which forgives what ROS tools do not, such as "--" inside a
    comment); the two files that are malformed on purpose (parser tests) are refused by it."""
    import xml.dom.minidom
    import xml.parsers.expat

    malformed = {SOURCE / "tests" / "data" / "urdf" / "bad-xml.urdf",
                 SOURCE / "fuzz" / "seeds" / "urdf" / "cut-utf8.urdf"}
    kinds = {".xml", ".urdf", ".xacro", ".svg", ".launch", ".sdf"}
    files = [p for p in SOURCE.rglob("*")
             if p.suffix.lower() in kinds and p.is_file()
             and not any(part.startswith(("build", ".git")) for part in p.relative_to(SOURCE).parts)]
    assert len(files) >= 10 and malformed <= set(files)
    for path in sorted(files):
        if path in malformed:
            with pytest.raises(xml.parsers.expat.ExpatError):
                xml.dom.minidom.parse(str(path))
        else:
            xml.dom.minidom.parse(str(path))


def interrupted_after(seconds, job):
    """Runs job() with a SIGINT `seconds` in; the time from the signal to its end [s]."""
    sent = []
    timer = threading.Timer(seconds, lambda: (sent.append(time.monotonic()),
                                              os.kill(os.getpid(), signal.SIGINT)))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            job()
    finally:
        timer.cancel()
    assert sent, "the job ended before the signal"
    return time.monotonic() - sent[0]


def test_ctrl_c_interrupts_a_running_job_and_keeps_the_previous_set(tmp_path):
    """Ctrl-C 1 s into a calibration (or a 20 s study) ends it within a second,
    KeyboardInterrupt raised, and the output folder keeps the previous set."""
    simulated_session(tmp_path, seconds=120, validation=20)
    out = tmp_path / "out"
    assert hapticcal.calibrate(MECA, CAL_LOG, out=str(out)).usable
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    jobs = {
        # About 5 s on one thread.
        "calibrate": lambda: hapticcal.calibrate(
            "geomagic-touch", str(tmp_path / "sim" / "device.csv"),
            tracker=str(tmp_path / "sim" / "tracker.csv"), threads=1, out=str(out)),
        # 200 trials of the paper's study: about 20 s on one thread.
        "simulate": lambda: hapticcal.simulate(trials=200, threads=1, out=str(out)),
    }
    for name, job in jobs.items():
        took = interrupted_after(1.0, job)
        assert took < 1.0, f"{name}: {took:.2f} s after the signal"
        after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
        assert after == before, name
        assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out")] == [], name
    # The next run is not cancelled.
    assert hapticcal.calibrate(MECA, CAL_LOG, out=str(out)).usable



def write_bz2_bag(path, chunks, messages_per_chunk, message_bytes):
    """A ROS 1 bag (format 2.0) of bz2 chunks, each of `messages_per_chunk` messages of
    `message_bytes` zeros on /camera/image: a few kilobytes that take a reader seconds to
    decompress. Every chunk the same (compressed once), the index as rosbag writes it."""
    import bz2
    import struct

    u32 = lambda v: struct.pack("<I", v)
    field = lambda name, value: u32(len(name) + 1 + len(value)) + name + b"=" + value
    record = lambda header, data: u32(len(header)) + header + u32(len(data)) + data
    op = lambda code: field(b"op", bytes([code]))
    time = u32(1733390000) + u32(0)
    connection = record(op(7) + field(b"conn", u32(0)) + field(b"topic", b"/camera/image"),
                        field(b"topic", b"/camera/image") + field(b"type", b"sensor_msgs/Image") +
                        field(b"md5sum", b"0" * 32) + field(b"message_definition", b"uint8[] data\n"))
    contents, offsets = connection, []
    for _ in range(messages_per_chunk):
        offsets.append(len(contents))
        contents += record(op(2) + field(b"conn", u32(0)) + field(b"time", time), bytes(message_bytes))
    packed = bz2.compress(contents, 1)
    chunk = record(op(5) + field(b"compression", b"bz2") + field(b"size", u32(len(contents))), packed)
    index = record(op(4) + field(b"ver", u32(1)) + field(b"conn", u32(0)) +
                   field(b"count", u32(len(offsets))), b"".join(time + u32(o) for o in offsets))
    header_bytes = 13 + 4096
    body = (chunk + index) * chunks
    infos = b"".join(
        record(op(6) + field(b"ver", u32(1)) +
               field(b"chunk_pos", struct.pack("<Q", header_bytes + k * len(chunk + index))) +
               field(b"start_time", time) + field(b"end_time", time) + field(b"count", u32(1)),
               u32(0) + u32(len(offsets))) for k in range(chunks))
    fields = (op(3) + field(b"index_pos", struct.pack("<Q", header_bytes + len(body))) +
              field(b"conn_count", u32(1)) + field(b"chunk_count", u32(chunks)))
    bag_header = record(fields, b" " * (4096 - len(fields) - 8))
    pathlib.Path(path).write_bytes(b"#ROSBAG V2.0\n" + bag_header + body + connection + infos)


def test_ctrl_c_interrupts_an_import_and_keeps_the_previous_set(tmp_path):
    """Ctrl-C 1 s into an import that decompresses for seconds (eight bz2 chunks of 128 MB of
    zeros, a few kilobytes on disk) ends it within a second, KeyboardInterrupt raised; the output
    folder keeps the previous set and no staging folder is left."""
    small, large = tmp_path / "small.bag", tmp_path / "large.bag"
    write_bz2_bag(small, 1, 2, 1000)
    write_bz2_bag(large, 8, 4, 32 << 20)
    assert large.stat().st_size < 100000
    out = tmp_path / "out"
    listed = hapticcal.import_recording(str(small), list=True)
    assert listed["topics"][0]["messages"] == 2
    # The previous set: an import of a JointState bag.
    import rosbag
    import rospy
    from sensor_msgs.msg import JointState
    with rosbag.Bag(str(tmp_path / "joints.bag"), "w") as b:
        for k in range(20):
            js = JointState(name=["a"], position=[0.01 * k])
            js.header.stamp = rospy.Time(1733390000, 1000000 * k)
            b.write("/joint_states", js, t=js.header.stamp)
    hapticcal.import_recording(str(tmp_path / "joints.bag"), out=str(out))
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    took = interrupted_after(1.0, lambda: hapticcal.import_recording(str(large), out=str(out)))
    assert took < 1.0, f"{took:.2f} s after the signal"
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["joints.bag", "large.bag", "out", "small.bag"]
    # The next run is not cancelled.
    assert hapticcal.import_recording(str(small), list=True)["topics"][0]["messages"] == 2


def test_inverse_and_compensate_match_the_cli(cli_calibration, tmp_path):
    """Model.inverse puts the calibrated Meca500's tool on a pose (every effect of the model in
    it, checked by its own forward kinematics), says when it cannot; compensate gives the
    command line's compensated.csv."""
    _, _, out = cli_calibration
    device = hapticcal.load_model(str(out / "device.yaml"))
    nominal = hapticcal.load_model(MECA)
    rng = np.random.default_rng(57)
    q = np.array([rng.uniform(0.8 * lo, 0.8 * hi) for lo, hi in
                  [(-2.9, 2.9), (-0.6, 1.5), (-2.2, 1.2), (-2.9, 2.9), (-1.7, -0.3), (-3, 3)]])
    target = nominal.forward(q)
    found = device.inverse(target, q)
    assert found["converged"], found
    assert found["position_error"] <= 1e-9 and found["rotation_error"] <= 1e-9
    reached = device.forward(found["q"])
    assert np.abs(reached - target).max() < 1e-8
    far = target.copy()
    far[0, 3] += 5.0
    assert not device.inverse(far, q)["converged"]
    program = tmp_path / "program.csv"
    program.write_text("q1,q2,q3,q4,q5,q6\n" + ",".join(f"{v:.17g}" for v in q) + "\n")
    code, stdout, stderr = cli("compensate", "--model", str(out / "device.yaml"), "--nominal", MECA,
                               "--targets", str(program), "--out", str(tmp_path / "cli"))
    assert code == 0, stderr
    mine = hapticcal.compensate(str(out / "device.yaml"), MECA, str(program),
                                out=str(tmp_path / "py"))
    assert mine["results"]["usable"] == 1
    assert (tmp_path / "py" / "compensated.csv").read_text() == \
        (tmp_path / "cli" / "compensated.csv").read_text()
    row = (tmp_path / "py" / "compensated.csv").read_text().splitlines()[1].split(",")
    assert np.abs(np.array([float(v) for v in row[1:7]]) - found["q"]).max() < 1e-7
