"""Monte Carlo, verify_bounds and the Observer from Python against the apps and the C++ class; long calls stop on
Ctrl-C; the examples run headless."""
import json
import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

import obsgain
from conftest import SOURCE_DIR, app_json


def test_monte_carlo_equals_the_command_line(design):
    report = obsgain.monte_carlo(design, trials=24, seed=5, threads=2)
    cli = app_json("monte-carlo", "--robot", "pendubot", "--gamma", "1.27", "--trials", "24", "--seed", "5")
    mine = json.loads(report.to_json())
    for key in ("trials", "passed", "envelope_violations", "lyapunov_violations", "worst_envelope_ratio", "decay_rate"):
        assert mine[key] == cli[key], key
    assert report.passed == 24 and report.certificate_held
    rates = report.per_trial["fitted_rate"]
    assert rates.shape == (24,) and np.nanmin(rates) >= design.gamma  # the certified rate is a lower bound
    assert report.decay_rate["min"] == np.nanmin(rates)


def test_trajectory_stays_inside_its_envelope(design):
    trajectory = obsgain.monte_carlo(design, trials=1, seed=2).trajectory(0)
    t, error = trajectory["t"], trajectory["error_norm"]
    assert t.ndim == 1 and trajectory["q_hat"].shape == (t.size, 2)
    assert np.all(error <= trajectory["envelope"] * (1 + 1e-4))
    e0 = np.linalg.norm(np.concatenate([trajectory["q_hat"][0] - trajectory["q"][0], trajectory["v_hat"][0] - trajectory["v"][0]]))
    assert error[0] == pytest.approx(e0, rel=1e-12)


def test_observer_is_the_cpp_class_to_the_last_bit(deployed, pendubot, tmp_path):
    # A recorded trajectory: the Pendubot swinging, read by a 4096-count encoder at 1 kHz with some jitter.
    rng = np.random.default_rng(7)
    dt = 1e-3 * (1 + 0.05 * rng.uniform(-1, 1, 400))
    t = np.cumsum(dt)
    counts = 2 * np.pi / 4096
    q = np.round(np.stack([0.8 * np.sin(3 * t), 1.2 * np.sin(2 * t + 0.4)], axis=1) / counts) * counts
    u = np.stack([0.2 * np.cos(5 * t), np.zeros_like(t)], axis=1)
    q0 = np.array([0.0, np.round(1.2 * np.sin(0.4) / counts) * counts])
    samples = tmp_path / "samples.txt"
    samples.write_text(" ".join(repr(x) for x in q0) + "\n" +
                       "".join(" ".join(repr(x) for x in [dt[k], *q[k], *u[k]]) + "\n" for k in range(t.size)))
    exported = tmp_path / "observer.txt"
    exported.write_text(deployed.export_observer())
    replay = subprocess.run([os.environ["OBSGAIN_REPLAY"], str(exported), str(samples)], capture_output=True, text=True, check=True)
    reference = np.array([[float(x) for x in line.split()] for line in replay.stdout.splitlines()])

    observer = obsgain.Observer(deployed, pendubot)
    observer.reset(q0)
    estimates = np.array([np.concatenate(observer.update(q[k], u[k], dt[k])) for k in range(t.size)])
    assert estimates.shape == reference.shape == (400, 4)
    assert np.array_equal(estimates, reference)
    assert np.all(np.std(estimates[:, 2:], axis=0) > 0.1)  # the estimates move: the comparison is not of constants


def test_verify_bounds_writes_the_report(pendubot, design, tmp_path):
    result = obsgain.verify_bounds(pendubot, str(tmp_path / "report"), gamma=1.27, trials=8)
    assert os.path.isfile(result["html"]) and os.path.isfile(result["json"])
    assert result["design"].theta == design.theta and result["monte_carlo"].trials == 8
    assert "obsgain.verify_bounds(load_robot('pendubot')" in open(result["html"], encoding="utf-8").read()


def test_verify_bounds_refuses_a_file_as_its_directory_before_any_work(pendubot, tmp_path):
    # The app's message for --out, named out; found before the design, which would report progress.
    path = tmp_path / "a_file"
    path.write_text("not a directory")
    calls = []
    with pytest.raises(ValueError) as error:
        obsgain.verify_bounds(pendubot, str(path), gamma=1.27, trials=8, progress=calls.append)
    assert str(error.value) == f"out = '{path}' is not a directory"
    assert calls == []


def interrupt_after(seconds):
    timer = threading.Timer(seconds, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_stops_a_long_search():
    # arm3's bounds to 1e-6 take seconds; Ctrl-C half a second in stops them at the next progress report.
    arm = obsgain.load_robot(os.path.join(SOURCE_DIR, "examples", "arm3.urdf"))
    lines = []
    interrupt_after(0.5)
    with pytest.raises(KeyboardInterrupt):
        obsgain.design_gains(arm, gamma=5, bound_budget=0, progress=lines.append)
    assert lines[0].startswith("bounds:")


def test_ctrl_c_stops_monte_carlo(design):
    interrupt_after(0.5)
    with pytest.raises(KeyboardInterrupt):
        obsgain.monte_carlo(design, trials=1_000_000, threads=1, step_budget=1e12)  # hours: stopped by Ctrl-C


def test_a_run_past_the_step_budget_says_what_would_help(pendubot):
    stiff = obsgain.design_gains(pendubot, theta=20000, bounds="numeric")
    refused = obsgain.monte_carlo(stiff)
    assert refused.trials == 0 and not refused.certificate_held
    assert "--horizon" in refused.not_run and json.loads(refused.to_json())["not_run"] == refused.not_run
    short = obsgain.monte_carlo(stiff, trials=2, horizon=0.005)
    assert short.not_run == "" and short.passed + short.assumption_violations == 2


@pytest.mark.parametrize("example,arguments", [("design_pendubot.py", ["--trials", "12"]),
                                               ("theta_sweep.py", ["--bound-budget", "1"])])
def test_examples_run_headless(example, arguments, tmp_path):
    script = os.path.join(SOURCE_DIR, "examples", "python", example)
    done = subprocess.run([sys.executable, script, *arguments, "--out", str(tmp_path)], capture_output=True, text=True,
                          env={**os.environ, "MPLBACKEND": "Agg"}, check=False)
    assert done.returncode == 0, done.stderr
    pictures = list(tmp_path.glob("*.png"))
    assert len(pictures) == 1 and pictures[0].stat().st_size > 10_000
