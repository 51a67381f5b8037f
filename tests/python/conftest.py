"""Shared fixtures of the Python module's tests: the apps to compare with, and one Pendubot design."""
import json
import os
import subprocess

import pytest

import obsgain

APP_DIR = os.environ["OBSGAIN_APP_DIR"]
SOURCE_DIR = os.environ["OBSGAIN_SOURCE_DIR"]


def run_app(app, *arguments):
    """Runs one of the apps; returns (exit code, stdout, stderr)."""
    done = subprocess.run([os.path.join(APP_DIR, app), *arguments], capture_output=True, text=True, check=False)
    return done.returncode, done.stdout, done.stderr


def app_json(app, *arguments):
    code, out, err = run_app(app, *arguments, "--json", "--quiet")
    assert code == 0, err
    return json.loads(out)


DEPLOYMENT = dict(sample_period=0.001, encoder_counts=4096, acceleration_bounds=200, objective="velocity-error")
DEPLOYMENT_ARGUMENTS = ["--sample-period", "0.001", "--encoder-counts", "4096", "--acceleration-bounds", "200",
                        "--objective", "velocity-error"]


@pytest.fixture(scope="session")
def pendubot():
    return obsgain.load_robot("pendubot")


@pytest.fixture(scope="session")
def design(pendubot):
    return obsgain.design_gains(pendubot, gamma=1.27)


@pytest.fixture(scope="session")
def deployed(pendubot):
    return obsgain.design_gains(pendubot, gamma=1.27, **DEPLOYMENT)
