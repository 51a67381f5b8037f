#!/usr/bin/python3
"""The paper-scenario trajectory of bench_simulation (Pendubot, θ = 200, α = β = 1, observer started at
(-π/2, 0, 2, 2), u = 1.5 sin(100 t), horizon 1 s) with SciPy's solve_ivp RK45 at rtol 1e-8, atol 1e-10.
Reference for a benchmark only (Debian's python3-scipy); prints the median wall time in microseconds."""
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


x0 = np.array([-math.pi / 2, 0, 0, 0, 0, 0, 2, 2])
times = []
for _ in range(5):
    start = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, 1.0), x0, method="RK45", rtol=1e-8, atol=1e-10)
    times.append(time.perf_counter() - start)
print(f"{statistics.median(times) * 1e6:.1f} {sol.t.size - 1}")
