#!/usr/bin/python3
"""The paper-scenario trajectory of bench_simulation (Pendubot, θ = 200, α = β = 1, observer started at
(-π/2, 0, 2, 2), u = 1.5 sin(100 t), horizon 1 s) with SciPy's solve_ivp RK45 at rtol 1e-8, atol 1e-10, in
two formulations:
  same   the system obsgain integrates: (q, v, u, ρ) with e = exp(ρ) u, so e keeps 1e-8 relative accuracy
         as it decays (same work, same step count: the like-for-like comparison);
  plain  (q, v, e) directly: once ||e|| < atol the integrator stops resolving it (far fewer steps, and an
         error trajectory that is only accurate to 1e-10 absolute).
Reference for a benchmark only (Debian's python3-scipy). Prints, per line: name, median microseconds, steps."""
import math
import statistics
import time

import numpy as np
from scipy.integrate import solve_ivp

P1, P2, P3, P4, P5, G0 = 0.0308, 0.0106, 0.0095, 0.2086, 0.0630, 9.81
V = np.array([10.0, 10.0])
K1, K2 = 200.0, 40000.0


def coriolis(q2, v):
    h = P3 * math.sin(q2)
    return np.array([-h * (2 * v[0] * v[1] + v[1] ** 2), h * v[0] ** 2])


def rhs(t, x):
    q, v, eq, ev = x[0:2], x[2:4], x[4:6], x[6:8]
    c2 = math.cos(q[1])
    M = np.array([[P1 + P2 + 2 * P3 * c2, P2 + P3 * c2], [P2 + P3 * c2, P2]])
    g = np.array([P4 * G0 * math.cos(q[0]) + P5 * G0 * math.cos(q[0] + q[1]), P5 * G0 * math.cos(q[0] + q[1])])
    u = np.array([1.5 * math.sin(100 * t), 0.0])
    a = coriolis(q[1], v)
    dv = np.linalg.solve(M, u - a - g)
    vhat = np.clip(v + ev, -V, V)
    dev = -np.linalg.solve(M, coriolis(q[1], vhat) - a) - K2 * eq
    return np.concatenate([v, dv, -K1 * eq + ev, dev])


def rhs_scaled(t, x):
    q, v, uq, uv, rho = x[0:2], x[2:4], x[4:6], x[6:8], x[8]
    scale = math.exp(rho)
    e = np.concatenate([uq, uv]) * scale
    d = rhs(t, np.concatenate([q, v, e]))
    g = d[4:8] / scale
    u = x[4:8]
    growth = u.dot(g) / u.dot(u)
    return np.concatenate([d[0:4], g - growth * u, [growth]])


def median_run(f, x0, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        sol = solve_ivp(f, (0.0, 1.0), x0, method="RK45", rtol=1e-8, atol=1e-10)
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6, sol.t.size - 1


e0 = math.sqrt(8.0)
print("same %.1f %d" % median_run(rhs_scaled, np.array([-math.pi / 2, 0, 0, 0, 0, 0, 2 / e0, 2 / e0, math.log(e0)]), 3))
print("plain %.1f %d" % median_run(rhs, np.array([-math.pi / 2, 0, 0, 0, 0, 0, 2, 2]), 5))
