"""What the wind and downwash cost per method step, and how close the gusts are to the standard.

Run: ``python benchmarks/bench_disturbances.py``. Prints, on one core:

* ``Wind.air`` per call for 100 and 1000 vehicles, one shared gust (``coherence=1``) and a gust
  per vehicle (``coherence=0``);
* ``downwash_air`` per call for 100 and 1000 vehicles spread over a 10 m cube, with vertical and
  with carried wakes;
* the largest deviation of the sample gust variance (20,000 independent vehicles, dt = 0.002,
  0.05 and 2 s) from the standard's, and of the correlation at lags 0.5, 1 and 2 T_w from the
  closed forms (the figures docs/vehicle-disturbances.md quotes).
"""

from __future__ import annotations

import math
import time

import numpy as np

from swarmnav.dynamics.downwash import downwash_air
from swarmnav.dynamics.wind import Wind, intensities, scale_lengths, wind_params


def per_call(f, reps: int) -> float:
    f(0)
    t0 = time.perf_counter()
    for k in range(1, reps + 1):
        f(k)
    return (time.perf_counter() - t0) / reps


def main() -> None:
    for n in (100, 1000):
        for c in (1.0, 0.0):
            wind = Wind(wind_params(speed=6.0, gust=1.5, coherence=c), n, 0.05, 1)
            pos = np.zeros((n, 3))
            s = per_call(lambda k: wind.air(k * 0.05, pos), 2000)
            print(f"Wind.air          N={n:5d} coherence={c:.0f}: {s * 1e6:8.1f} us")
    rng = np.random.default_rng(0)
    for n in (100, 1000):
        pos = rng.uniform(0.0, 10.0, (n, 3))
        thrust = np.full(n, 0.030 * 9.81)
        carry = rng.normal(0.0, 2.0, (n, 3))
        for name, kw in (("vertical", {}), ("carried", {"carry": carry})):
            s = per_call(lambda k: downwash_air(pos, thrust, 0.0225, **kw), 50 if n > 100 else 500)
            print(f"downwash_air      N={n:5d} {name:8s}: {s * 1e3:8.3f} ms")
    n, worst_var, worst_cor = 20_000, 0.0, 0.0
    sig = np.array(intensities(1.5, 10.0))
    for dt in (0.002, 0.05, 2.0):
        wind = Wind(wind_params(speed=4.0, gust=1.5, coherence=0.0), n, dt, 1)
        for k in (0, 7):
            g = wind.air(k * dt, np.zeros((n, 3))) - np.array([4.0, 0.0, 0.0])
            worst_var = max(worst_var, float(np.abs((g**2).mean(axis=0) / sig**2 - 1.0).max()))
    speed = 10.0
    Tu, Tv, Tw = (L / speed for L in scale_lengths(10.0))
    for dt in (0.05, 0.5):
        wind = Wind(wind_params(speed=speed, gust=1.5, coherence=0.0), n, dt, 1)
        mean = np.array([speed, 0.0, 0.0])
        g0 = (wind.air(0.0, np.zeros((n, 3))) - mean) / sig
        for f in (0.5, 1.0, 2.0):
            k = round(f * Tw / dt)
            tau = k * dt
            rho = ((wind.air(tau, np.zeros((n, 3))) - mean) / sig * g0).mean(axis=0)
            want = [math.exp(-tau / Tu), math.exp(-tau / Tv) * (1 - tau / (2 * Tv)),
                    math.exp(-tau / Tw) * (1 - tau / (2 * Tw))]
            worst_cor = max(worst_cor, float(np.abs(rho - want).max()))
    print(f"Dryden variance: largest relative deviation {worst_var:.4f} (5 standard errors: "
          f"{5 * math.sqrt(2 / n):.4f})")
    print(f"Dryden correlation: largest deviation {worst_cor:.4f} (5 standard errors: {5 / math.sqrt(n):.4f})")


if __name__ == "__main__":
    main()
