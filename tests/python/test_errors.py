"""Bad input from Python raises ValueError with the command line's one-line message."""
import os

import pytest

import obsgain
from conftest import SOURCE_DIR, run_app

# (command-line arguments, the same request from Python)
CASES = [
    (["--gamma", "-1"], lambda r: obsgain.design_gains(r, gamma=-1)),
    (["--theta", "5", "--gamma", "1"], lambda r: obsgain.design_gains(r, theta=5, gamma=1)),
    (["--gamma", "1", "--vmax", "1,2,3"], lambda r: obsgain.design_gains(r, gamma=1, vmax=[1, 2, 3])),
    (["--gamma", "1", "--polytope-cells", "0"], lambda r: obsgain.design_gains(r, gamma=1, polytope_cells=0)),
    (["--gamma", "1", "--bound-budget", "-2"], lambda r: obsgain.design_gains(r, gamma=1, bound_budget=-2)),
    (["--gamma", "1", "--proof-budget", "0"], lambda r: obsgain.design_gains(r, gamma=1, proof_budget=0)),
    (["--gamma", "1", "--sample-period", "2", "--encoder-counts", "4096", "--acceleration-bounds", "200"],
     lambda r: obsgain.design_gains(r, gamma=1, sample_period=2, encoder_counts=4096, acceleration_bounds=200)),
    (["--gamma", "1", "--sample-period", "0.001"], lambda r: obsgain.design_gains(r, gamma=1, sample_period=0.001)),
    (["--gamma", "1", "--objective", "velocity-error"], lambda r: obsgain.design_gains(r, gamma=1, objective="velocity-error")),
    (["--gamma", "1", "--vmax", ""], lambda r: obsgain.design_gains(r, gamma=1, vmax=[])),
    (["--gamma", "1", "--checkpoint", "/no/such/dir/run.checkpoint"],
     lambda r: obsgain.design_gains(r, gamma=1, checkpoint="/no/such/dir/run.checkpoint")),
    (["--gamma", "1", "--optimize-shape", "--alpha", "2"], lambda r: obsgain.design_gains(r, gamma=1, optimize_shape=True, alpha=2)),
]


def cli_message(app, arguments):
    code, _, err = run_app(app, *arguments)
    assert code == 2, err
    prefix = app + ": error: "
    assert err.startswith(prefix) and err.count("\n") == 1, err
    return err[len(prefix):].strip()


@pytest.mark.parametrize("arguments,call", CASES, ids=[" ".join(a) for a, _ in CASES])
def test_design_errors_carry_the_cli_message(pendubot, arguments, call):
    with pytest.raises(ValueError) as error:
        call(pendubot)
    assert str(error.value) == cli_message("design-gains", ["--robot", "pendubot", *arguments])


def test_robot_errors_carry_the_cli_message():
    missing = os.path.join(SOURCE_DIR, "examples", "no_such_arm.urdf")
    with pytest.raises(ValueError) as error:
        obsgain.load_robot(missing)
    assert str(error.value) == cli_message("design-gains", ["--robot", missing, "--gamma", "1"])
    with pytest.raises(ValueError) as error:
        obsgain.load_robot("pendubot", tip_link="link2")
    assert str(error.value) == cli_message("design-gains", ["--tip-link", "link2", "--gamma", "1"])


def test_monte_carlo_errors_carry_the_cli_message(design):
    for keyword, value, option in (("horizon", 0.0, "0"), ("rtol", 1.0, "1"), ("trials", 0, None)):
        with pytest.raises(ValueError) as error:
            obsgain.monte_carlo(design, **{keyword: value})
        if option is not None:
            assert str(error.value) == cli_message("monte-carlo", ["--gamma", "1.27", "--" + keyword, option])


def test_python_level_mistakes_are_named(pendubot, design):
    with pytest.raises(TypeError, match="'gama'"):
        obsgain.design_gains(pendubot, gama=1.27)
    with pytest.raises(ValueError, match="certificate = 'best' must be one of tight, scaled, paper, polytopic"):
        obsgain.design_gains(pendubot, gamma=1, certificate="best")
    with pytest.raises(ValueError, match="gamma = 'fast' has the wrong type"):
        obsgain.design_gains(pendubot, gamma="fast")
    with pytest.raises(ValueError, match="q has 3 values for a robot of 2 joints"):
        pendubot.mass_matrix([0, 0, 0])
    # Finite arguments whose result leaves double's range: an error, not NaNs.
    with pytest.raises(ValueError, match="q'' overflows double precision"):
        pendubot.forward_dynamics([0, 0], [0, 0], [1e308, -1e308])
    with pytest.raises(ValueError, match=r"A\(q, v\) overflows double precision"):
        pendubot.coriolis([0, 1], [1e200, 1e200])
    with pytest.raises(ValueError, match="must be positive"):
        obsgain.tight_rate(-1, 1, 1)
    with pytest.raises(ValueError, match="not valid JSON"):
        obsgain.Design.from_json("{")
    observer = obsgain.Observer(design, pendubot)
    with pytest.raises(ValueError, match="reset"):
        observer.update([0, 0], [0, 0], 1e-3)
