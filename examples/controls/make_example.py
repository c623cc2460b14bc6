"""Write mr_damper_voltage.csv: a magnetorheological damper under random displacement and random coil voltage.

numpy and scipy only (no hybridhyst code): the example data of docs/controls.md. The device: the coil's
field u follows the commanded voltage v with a first-order lag (du/dt = -eta (u - v), eta = 50 1/s); the force is

    F = (c_a + c_b u) dx/dt + (alpha_a + alpha_b u) z + k x,
    dz/dt = dx/dt - beta |dx/dt| z |z| - gamma dx/dt z^2        (Bouc-Wen, n = 2)

with c = 0.6 + 1.5 u [N s/mm], alpha = 25 + 50 u [N/mm], k = 0.4 N/mm, beta = 0.5 and gamma = 0.3 [1/mm^2];
x [mm] is a sum of four sines between 0.5 and 3 Hz (peak 8 mm), v [V] a random staircase between 0 and 2 V held
0.3 to 0.8 s. Integrated by scipy's LSODA (steps of at most 0.1 ms, the velocity exact), sampled at 400 Hz,
with AR(1) coloured noise (coefficient 0.7, 2 N standard deviation) on the force. Six records of 5 s: four to fit
(set = fit), two to hold out (set = held_out).

    python examples/controls/make_example.py     # rewrites examples/controls/mr_damper_voltage.csv
"""

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ETA, C_A, C_B, ALPHA_A, ALPHA_B, K, BETA, GAMMA = 50.0, 0.6, 1.5, 25.0, 50.0, 0.4, 0.5, 0.3
FS, DURATION, NOISE_SD, NOISE_AR = 400.0, 5.0, 2.0, 0.7


def excitation(rng):
    f = rng.uniform(0.5, 3.0, 4)
    a = rng.uniform(0.5, 1.0, 4)
    phase = rng.uniform(0, 2 * np.pi, 4)
    t = np.linspace(0, DURATION, 20001)
    peak = np.abs((a[:, None] * np.sin(2 * np.pi * f[:, None] * t + phase[:, None])).sum(0)).max()
    a = 8.0 * a / peak
    x = lambda t: np.sum(a[:, None] * np.sin(2 * np.pi * f[:, None] * np.atleast_1d(t) + phase[:, None]), 0)  # noqa
    dx = lambda t: np.sum(a[:, None] * 2 * np.pi * f[:, None] * np.cos(2 * np.pi * f[:, None] * np.atleast_1d(t)  # noqa
                                                                       + phase[:, None]), 0)
    return x, dx


def staircase(rng):
    edges, levels, now = [0.0], [rng.uniform(0, 2)], 0.0
    while now < DURATION:
        now += rng.uniform(0.3, 0.8)
        edges.append(now)
        levels.append(rng.uniform(0, 2))
    edges, levels = np.array(edges), np.array(levels)
    return lambda t: levels[np.searchsorted(edges, np.atleast_1d(t), side="right") - 1]


def record(rng):
    x, dx = excitation(rng)
    v = staircase(rng)

    def field(t, s):
        z, u = s
        vel = dx(t)[0]
        return [vel - BETA * abs(vel) * z * abs(z) - GAMMA * vel * z * z, -ETA * (u - v(t)[0])]

    t = np.arange(int(DURATION * FS) + 1) / FS
    sol = solve_ivp(field, (0, t[-1]), [0.0, v(0.0)[0]], method="LSODA", t_eval=t, max_step=1e-4, rtol=1e-9,
                    atol=1e-11)
    z, u = sol.y
    force = (C_A + C_B * u) * dx(t) + (ALPHA_A + ALPHA_B * u) * z + K * x(t)
    e = rng.normal(0, NOISE_SD * np.sqrt(1 - NOISE_AR**2), len(t))
    noise = np.zeros(len(t))
    noise[0] = rng.normal(0, NOISE_SD)
    for i in range(1, len(t)):
        noise[i] = NOISE_AR * noise[i - 1] + e[i]
    return t, x(t), force + noise, v(t)


def main(out: Path | None = None) -> Path:
    rng = np.random.default_rng(2026)
    lines = ["record,set,t,x_mm,force_n,voltage_v"]
    for i in range(6):
        t, x, f, v = record(rng)
        part = "fit" if i < 4 else "held_out"
        lines += [f"r{i + 1},{part},{a:.4f},{b:.5f},{c:.3f},{d:.4f}" for a, b, c, d in zip(t, x, f, v)]
    out = Path(__file__).with_name("mr_damper_voltage.csv") if out is None else Path(out)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out} ({len(lines) - 1} rows)")
    return out


if __name__ == "__main__":
    main()
