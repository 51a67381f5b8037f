"""The rate each certificate proves against the gain θ, for a URDF arm, on its proven bounds.

The bounds are computed once (design_gains); the sweep then evaluates the certificates' closed forms, which is
what design-gains does for one θ.

    PYTHONPATH=build/python python3 examples/python/theta_sweep.py [--robot FILE] [--bound-budget S] [--out DIR]
"""
import argparse
import os

import matplotlib.pyplot as plt
import numpy as np

import obsgain

here = os.path.dirname(os.path.abspath(__file__))
parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--robot", default=os.path.join(here, "..", "arm3.urdf"))
parser.add_argument("--bound-budget", type=float, default=15)
parser.add_argument("--out", default=".")
arguments = parser.parse_args()

robot = obsgain.load_robot(arguments.robot)
design = obsgain.design_gains(robot, gamma=5, bound_budget=arguments.bound_budget)
print(design.summary())
L, S_norm = design.L, obsgain.observer_lyapunov(1.0, 1.0, robot.dof)["S_norm"]

thetas = np.geomspace(design.theta / 4, design.theta * 8, 60)
tight = [obsgain.tight_rate(theta, theta**2, L) for theta in thetas]
paper = [obsgain.paper_rate(S_norm, theta, L) for theta in thetas]

figure, axes = plt.subplots(figsize=(7, 4))
axes.semilogx(thetas, tight, label="tight (bounded-real lemma)")
axes.semilogx(thetas, paper, label="paper (Theorem 1)")
axes.axhline(0, color="grey", linewidth=0.5)
axes.axvline(design.theta, linestyle=":", color="black", label=f"design for gamma = 5: theta = {design.theta:.1f}")
axes.set_xlabel("theta")
axes.set_ylabel("certified rate gamma [1/s]")
axes.set_title(f"{robot.name}: L = {L:.4g} ({'proven' if design.proven else 'estimate'})")
axes.legend()
figure.tight_layout()
path = os.path.join(arguments.out, "theta_sweep.png")
figure.savefig(path, dpi=120)
print("plot:", path)
