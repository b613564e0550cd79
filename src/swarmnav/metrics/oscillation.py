"""Oscillation of a flight: the high-frequency part of the robots' velocities.

The SPH paper raised its viscosity gain "to reduce oscillations under network latency" (Section
IV-B) without defining them. Here an oscillation is velocity that changes faster than navigation
does: a robot that swerves around a 1-2 m trunk at ~1 m/s turns over a second or more, while a
robot that keeps correcting against delayed pictures of its neighbours shakes back and forth
several times a second. So, per robot and axis, the velocity ``v(t)`` (finite differences of the
recorded positions) is split into its centred moving average over ``1 / f_c`` seconds (the slow
part, navigation) and the rest (the fast part)::

    osc_hf_speed = sqrt( mean over robots, steps and axes summed of |v(t) - <v>_{1/f_c}(t)|^2 )   [m/s]

the RMS speed of the fast part. A moving average over exactly one period removes a sinusoid of that
frequency or any multiple of it entirely, so a sinusoidal oscillation ``A sin(2 pi f t)`` at
f = k f_c (k = 1, 2, ...) gives exactly ``A / sqrt(2)``; a steady flight gives 0; a slow turn at
0.1 f_c passes almost wholly into the average (1.6 % of its amplitude remains). Only the steps with
a full window on either side are counted (no edge effect). Units: m/s, the scale of the shaking.

Why this and not a count of heading reversals: a reversal count needs a speed floor (a hovering
robot's heading is noise) and is blind to the amplitude, while the energy of the fast part is
zero for a robot at rest, grows with the amplitude and is defined for every robot at every step.
"""

from __future__ import annotations

import numpy as np

#: Cut-off [Hz] between navigation and oscillation (our choice, module docstring): a turn around a
#: 1-2 m obstacle at ~1 m/s takes a second or more.
CUTOFF_HZ = 1.0


def hf_speed(positions: np.ndarray, dt: float, cutoff_hz: float = CUTOFF_HZ) -> float:
    """RMS speed [m/s] of the velocity above ``cutoff_hz`` (module docstring).

    Args:
        positions: (K + 1, N, d) recorded positions [m] at every step.
        dt: the step between recorded positions [s].
        cutoff_hz: f_c [Hz]; the moving average spans round(1 / (f_c dt)) velocity samples.

    Returns nan when the run is shorter than one window on each side of one sample.
    """
    if dt <= 0 or cutoff_hz <= 0:
        raise ValueError(f"dt and cutoff_hz must be positive, got dt={dt}, cutoff_hz={cutoff_hz}")
    p = np.asarray(positions, dtype=float)
    v = np.diff(p, axis=0) / dt  # (K, N, d) [m/s]
    w = max(1, int(round(1.0 / (cutoff_hz * dt))))  # samples per window
    if v.shape[0] < w + 1:
        return float("nan")
    c = np.concatenate([np.zeros((1, *v.shape[1:])), np.cumsum(v, axis=0)])
    slow = (c[w:] - c[:-w]) / w  # (K - w + 1, N, d): mean of v[k .. k + w - 1]
    # the window starting at k is centred on sample k + (w - 1) / 2; compare with the sample there
    # (for even w the two middle samples' mean, so the window stays centred)
    lo, hi = (w - 1) // 2, w // 2
    centre = 0.5 * (v[lo: lo + slow.shape[0]] + v[hi: hi + slow.shape[0]])
    fast = centre - slow
    return float(np.sqrt(np.mean(np.sum(fast * fast, axis=-1))))


#: Metrics a report can compute from a stored trajectory (``[report] trajectory_metrics``): name ->
#: function of (positions (K + 1, N, d) [m], dt [s]).
FROM_TRAJECTORY = {"osc_hf_speed": hf_speed}
