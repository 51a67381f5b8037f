"""Certified gains for the Pendubot, validated by Monte Carlo, and one trial's error against its envelope.

    PYTHONPATH=build/python python3 examples/python/design_pendubot.py [--trials N] [--out DIR]
"""
import argparse
import os

import matplotlib.pyplot as plt

import obsgain

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--trials", type=int, default=200)
parser.add_argument("--out", default=".")
arguments = parser.parse_args()

robot = obsgain.load_robot("pendubot")
design = obsgain.design_gains(robot, gamma=1.27)
print(design.summary())

report = obsgain.monte_carlo(design, trials=arguments.trials, seed=1)
print(report.summary())

trial = report.trajectory(0)
figure, axes = plt.subplots(figsize=(7, 4))
axes.semilogy(trial["t"], trial["error_norm"], label="||e(t)||, simulated")
axes.semilogy(trial["t"], trial["envelope"], "--", label=f"k ||e(0)|| exp(-{design.gamma:g} t), certified")
axes.set_xlabel("t [s]")
axes.set_ylabel("observer error")
axes.set_title(f"Pendubot, theta = {design.theta:.2f} ({design.certificate} certificate)")
axes.legend()
figure.tight_layout()
path = os.path.join(arguments.out, "pendubot_envelope.png")
figure.savefig(path, dpi=120)
print("plot:", path)
