"""The vehicle a run flies: the method's point mass (the default), or a quadrotor in wind.

A method commands its own point model (:mod:`swarmnav.dynamics`: an acceleration for the double
integrators, a velocity for the kinematic model). With ``vehicle=quadrotor`` the run keeps that
contract and puts a flight stack between the command and the world, the way a real swarm flies:

1. The method's point model is stepped from the vehicle's actual state with the method's command;
   its velocity change over the step is the acceleration the method asked for,
   ``a_ref = (v_point - v) / dt``.
2. That setpoint is limited as a flight stack limits it: its horizontal part to the acceleration
   reachable at the tilt limit ``vehicle.max_tilt``, ``g tan(max_tilt)`` (PX4's ``MPC_TILTMAX_AIR``,
   45 deg by default), its vertical part to the thrust left above hover.
3. The quadrotor's SE(3) tracking controller follows the reference that starts at the vehicle's
   actual position and velocity and accelerates at ``a_ref`` for the step,
   ``p_r(tau) = p + v tau + a_ref tau^2 / 2``, at its own inner rate ``vehicle.inner_hz``
   (:class:`~swarmnav.dynamics.quadrotor.QuadrotorFleet`), in the air the wind and the downwash
   of the vehicles above set (:mod:`swarmnav.dynamics.wind`, :mod:`swarmnav.dynamics.downwash`).

On a 2-D scene the vehicles fly at one altitude, which the controller holds (the run records the
plane; the altitude error is a metric). The reference restarts from the actual state every step:
the method closes the loop at its own rate, as it does on the point model, and the vehicle's lag
shows as the distance between where the point model would have put it and where it went
(``vehicle_track_err_*``, over the vehicles still flying: not those flipped, grounded or crashed).
A vehicle that flips (tilt beyond 90 deg) or diverges is frozen, finite, and crashed by the
referee with the reason ``"flipped"``: a counted failure, never NaN. In a 3-D world a vehicle that
comes down to the floor (the world's lowest z) stops on it and is crashed with the reason
``"ground"``; a 2-D scene has no ground (its altitude is held, not modelled).

Every vehicle option is the run's, not a method's (``--set vehicle=quadrotor --set wind.speed=6``),
and the point vehicle with its defaults is no vehicle model at all: the rollout calls the method's
own dynamics, bit for bit as before (docs/vehicle.md).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from swarmnav.dynamics.airframes import GRAVITY as G, airframe
from swarmnav.dynamics.downwash import downwash_air
from swarmnav.dynamics.quadrotor import QuadrotorFleet, default_gains
from swarmnav.dynamics.wind import Wind, WindParams, wind_params  # noqa: F401 (WindParams: the CLI lists it)
from swarmnav.errors import ConfigError
from swarmnav.params import as_dict, build, param

#: The run-option names of the vehicle: ``vehicle`` itself, ``vehicle.NAME``, ``wind.NAME`` and ``downwash``.
VEHICLE = "vehicle"
PREFIX = "vehicle."
WIND_PREFIX = "wind."
DOWNWASH = "downwash"


#: [m/s] below this horizontal speed of its velocity reference a vehicle under vehicle.yaw=velocity
#: keeps its heading (ours: the direction of a velocity this small is noise)
YAW_MIN_SPEED = 0.05


def is_vehicle_option(key: str) -> bool:
    """A run option of the vehicle (module docstring)."""
    return key in (VEHICLE, DOWNWASH) or key.startswith((PREFIX, WIND_PREFIX))


@dataclass(frozen=True, slots=True)
class VehicleParams:
    """The vehicle of a run (module docstring). Defaults: the method's own point mass."""

    model: Literal["point", "quadrotor"] = param(
        "point", "", None, "ours",
        "what flies: the method's own point model, or a quadrotor with a flight controller (--set vehicle=...)")
    airframe: str = param("crazyflie", "", None, "ours",
                          "the quadrotor's airframe: crazyflie (30 g), hummingbird (0.5 kg) or x500 (1 kg); docs/vehicle.md")
    mass: float = param(0.0, "kg", "[0, 100]", "ours", "the airframe's mass instead of its own (0: its own)")
    inner_hz: float = param(500.0, "Hz", "[1, 100000]", "ours",
                            "rate of the attitude controller and of the integration of the rigid body; "
                            "at least the method's own rate")
    max_tilt: float = param(45.0, "deg", "(0, 89]", "PX4 MPC_TILTMAX_AIR",
                            "tilt limit of the acceleration setpoint's horizontal part")
    drag_ff: bool = param(True, "", None, "Faessler, Franchi & Scaramuzza, RA-L 2018",
                          "the controller cancels the airframe's own aerodynamic drag (in still air: the wind "
                          "stays unknown to it); false: RotorPy's SE3Control as it is")
    downwash: bool = param(False, "", None, "ours", "the downwash of each quadrotor acts on those below it")
    yaw: Literal["hold", "velocity"] = param(
        "hold", "", None, "ours",
        "the heading the controller flies: held at 0 deg, or turned toward the direction of the vehicle's "
        "horizontal velocity reference (a sensor's field of view is relative to the heading)")
    yaw_rate_max: float = param(45.0, "deg/s", "(0, 3600]", "PX4 MPC_YAWRAUTO_MAX",
                                "how fast vehicle.yaw=velocity turns the heading reference")

    @property
    def point(self) -> bool:
        return self.model == "point"


def vehicle_params(options: dict[str, Any]) -> tuple[VehicleParams, WindParams]:
    """The vehicle and wind of a run from its vehicle options (:func:`is_vehicle_option`);
    unknown or out-of-range values, and wind or downwash on a point vehicle: ConfigError."""
    own, wind = {}, {}
    for k, v in options.items():
        if k == VEHICLE:
            own["model"] = v
        elif k == DOWNWASH:
            own["downwash"] = v
        elif k.startswith(PREFIX):
            if k[len(PREFIX):] in ("model", "downwash"):
                raise ConfigError(f"vehicle: unknown parameter '{k}'; set it as '{VEHICLE if k.endswith('model') else DOWNWASH}'")
            own[k[len(PREFIX):]] = v
        elif k.startswith(WIND_PREFIX):
            wind[k[len(WIND_PREFIX):]] = v
        else:
            raise ConfigError(f"'{k}' is not a vehicle option")
    p = build(VehicleParams, own, context="vehicle")
    w = wind_params(**wind)
    if p.point:
        moved = [f"{PREFIX}{k}" for k in own if k not in ("model", "downwash")]
        if moved:
            raise ConfigError(f"{', '.join(sorted(moved))}: a quadrotor's option; set vehicle=quadrotor")
        if w != WindParams() or p.downwash:
            raise ConfigError("wind and downwash act on a quadrotor's drag and thrust, and the point vehicle has "
                              "neither; set vehicle=quadrotor")
    else:
        airframe(p.airframe, p.mass or None)  # an unknown or non-physical airframe fails here, before the run
        if p.yaw == "hold" and p.yaw_rate_max != VehicleParams().yaw_rate_max:
            raise ConfigError(f"{PREFIX}yaw_rate_max: the rate at which {PREFIX}yaw=velocity turns; "
                              f"with the yaw held it does nothing; set {PREFIX}yaw=velocity")
    return p, w


def record(p: VehicleParams, w: WindParams) -> dict:
    """The vehicle of a run as its config records it (the point vehicle: nothing)."""
    if p.point:
        return {}
    own = as_dict(p)
    if p.yaw == "hold":  # the yaw held, as before the option existed: the record (and a run's key) as then
        del own["yaw"], own["yaw_rate_max"]
    return {"vehicle": own, **({"wind": as_dict(w)} if w != WindParams() else {})}


class Quadrotors:
    """The quadrotor vehicle of one run (module docstring): :meth:`step` in place of the
    method's ``dynamics.step``; :meth:`summary` its metrics.

    Args:
        p, wind: the vehicle and the wind (:func:`vehicle_params`).
        point: the method's own dynamics (what its command means).
        pos, vel: the starting state (N, d) [m], [m/s]; d = 2 flies at one held altitude.
        dt: the method's step [s].
        seed: the run's seed (the wind's gusts draw from a stream of their own).
        period: side of a periodic world [m], or None.
        floor: the ground's height [m] in the vehicles' vertical (on a 2-D state: relative to the
            held altitude), or None for no ground (a 2-D scene). A vehicle that comes down to it
            stops there and is *grounded* (:attr:`new_grounded`).
    """

    def __init__(self, p: VehicleParams, wind: WindParams, point: Any, pos: np.ndarray, vel: np.ndarray,
                 dt: float, seed: int, period: float | None = None, floor: float | None = None):
        n, d = pos.shape
        if dt * p.inner_hz < 1.0 - 1e-9:
            raise ConfigError(f"vehicle.inner_hz = {p.inner_hz:g} Hz is slower than the method's step "
                              f"({1.0 / dt:g} Hz); the controller must run at least as often as the method")
        self.p, self.point, self.d, self.dt, self.period = p, point, d, float(dt), period
        self.frame = airframe(p.airframe, p.mass or None)
        gains = dataclasses.replace(default_gains(self.frame), drag_ff=p.drag_ff)
        self.fleet = QuadrotorFleet(self.frame, n, inner_hz=p.inner_hz, gains=gains,
                                    floor=-math.inf if floor is None else float(floor))
        self.altitude = np.zeros(n)  # [m] the held altitude of a 2-D scene's vehicles (its z is not recorded)
        self.z = np.zeros(n)
        self.vz = np.zeros(n)
        self.fleet.reset(self._lift(pos, self.z), self._lift(vel, self.vz))
        self.wind = Wind(wind, n, dt, seed) if wind != WindParams() else None
        # [m/s^2] the setpoint's limits: horizontal at the tilt limit, upward to the thrust left above hover
        self.a_xy = G * math.tan(math.radians(p.max_tilt))
        self.a_up = self.frame.max_thrust / self.frame.mass - G
        self.t = 0.0
        # [rad] each vehicle's heading reference (vehicle.yaw=velocity), and its turn rate limit [rad/s]
        self.yaw_on = p.yaw == "velocity"
        self.yaw_ref = np.zeros(n)
        self.yaw_rate_max = math.radians(p.yaw_rate_max)
        self.flipped = np.zeros(n, dtype=bool)
        self.new_flips = np.zeros(n, dtype=bool)
        self.grounded = np.zeros(n, dtype=bool)
        self.new_grounded = np.zeros(n, dtype=bool)
        self.err_sum = 0.0
        self.err_max = 0.0
        self.alt_err_max = 0.0
        self.steps = 0

    def _lift(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        return np.column_stack([x, z]) if self.d == 2 else np.array(x, dtype=np.float64)

    def step(self, pos: np.ndarray, vel: np.ndarray, cmd: np.ndarray, dt: float,
             crashed: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One method step of every vehicle: the method's command through the flight stack.
        ``crashed`` (N,) bool: the vehicles the run's referee has crashed before this step; they
        are held where they hit, so their tracking error is not the vehicle's and is not counted."""
        p_pt, v_pt = self.point.step(pos, vel, cmd, dt)
        a = (np.asarray(v_pt, dtype=np.float64) - vel) / dt
        horizontal = a[:, :2]
        norm = np.sqrt(np.einsum("ij,ij->i", horizontal, horizontal))
        over = norm > self.a_xy
        if over.any():
            a[over, :2] *= (self.a_xy / norm[over])[:, None]
        if self.d == 3:
            a[:, 2] = np.clip(a[:, 2], -G, self.a_up)
        P = self._lift(pos, self.z)
        V = self._lift(vel, self.vz)
        if self.d == 2:  # the altitude is held: its reference is the held altitude, at rest
            p_ref = np.column_stack([pos, self.altitude])
            v_ref = np.column_stack([vel, np.zeros(len(pos))])
            a_ref = np.column_stack([a, np.zeros(len(pos))])
        else:
            p_ref, v_ref, a_ref = P, V, a
        air = None
        if self.wind is not None:
            air = self.wind.air(self.t, P)
        if self.p.downwash:  # once per method step (its wakes move slowly against the inner rate)
            carry = (0.0 if air is None else air) - V  # the air past each source carries its wake
            wash = downwash_air(P, self.fleet.thrust, self.frame.rotor_radius, carry=carry)
            air = wash if air is None else air + wash
        heading = {}
        if self.yaw_on:
            heading = self._heading(v_ref[:, :2] + a_ref[:, :2] * dt, dt)
        P1, V1 = self.fleet.fly(P, V, p_ref, v_ref, a_ref, dt, air, **heading)
        self.t += dt
        flipped = np.asarray(self.fleet.flipped, dtype=bool)
        self.new_flips = flipped & ~self.flipped
        self.flipped = flipped
        grounded = np.asarray(self.fleet.grounded, dtype=bool)
        self.new_grounded = grounded & ~self.grounded
        self.grounded = grounded
        if self.d == 2:
            self.z, self.vz = P1[:, 2].copy(), V1[:, 2].copy()
            self.alt_err_max = max(self.alt_err_max, float(np.max(np.abs(self.z - self.altitude), initial=0.0)))
        pos1, vel1 = np.ascontiguousarray(P1[:, : self.d]), np.ascontiguousarray(V1[:, : self.d])
        miss = pos1 - p_pt
        if self.period is not None:  # the point model may have wrapped its position
            miss -= self.period * np.round(miss / self.period)
        down = flipped | grounded
        flying = ~down if crashed is None else ~(down | crashed)
        err = np.sqrt(np.einsum("ij,ij->i", miss, miss))[flying]
        if err.size:  # the step's mean over the vehicles that flew it; the run's mean over such steps
            self.err_sum += float(err.mean())
            self.err_max = max(self.err_max, float(err.max()))
            self.steps += 1
        return pos1, vel1

    def _heading(self, v_end: np.ndarray, dt: float) -> dict[str, np.ndarray]:
        """The heading ramp of this step (vehicle.yaw=velocity): from the current reference toward
        the direction of the horizontal velocity reference at the step's end ``v_end`` (N, 2)
        [m/s], by the shorter way, at most ``yaw_rate_max``; held where that velocity is below
        :data:`YAW_MIN_SPEED` (at rest it has no direction)."""
        speed = np.sqrt(np.einsum("ij,ij->i", v_end, v_end))
        target = np.where(speed > YAW_MIN_SPEED, np.arctan2(v_end[:, 1], v_end[:, 0]), self.yaw_ref)
        turn = np.mod(target - self.yaw_ref + math.pi, 2.0 * math.pi) - math.pi
        rate = np.clip(turn / dt, -self.yaw_rate_max, self.yaw_rate_max)
        out = {"yaw": self.yaw_ref.copy(), "yaw_rate": rate}
        self.yaw_ref = np.mod(self.yaw_ref + rate * dt + math.pi, 2.0 * math.pi) - math.pi
        return out

    @property
    def heading(self) -> np.ndarray:
        """(N,) each vehicle's heading [rad] in (-pi, pi], from world x (its body x axis, projected)."""
        return self.fleet.yaw

    @property
    def thrust_axis(self) -> np.ndarray:
        """(N, 3) each vehicle's body z axis (its thrust direction) in world axes, a unit vector:
        (0, 0, 1) level, tilted by arccos of its z. Always 3-D: on a 2-D scene its x and y are the
        scene's axes and its z the vertical the scene does not record."""
        return self.fleet.attitude[:, :, 2].copy()

    def summary(self) -> dict[str, float]:
        """Run metrics of the vehicle (docs/metrics.md): units in the names' documentation."""
        f = self.fleet
        return {
            "vehicle_tilt_max": float(np.max(f.tilt_max_deg, initial=0.0)),  # [deg]
            "vehicle_thrust_sat_fraction": float(np.mean(f.saturated_fraction)),
            "vehicle_track_err_mean": self.err_sum / max(self.steps, 1),  # [m]
            "vehicle_track_err_max": self.err_max,  # [m]
            **({"vehicle_alt_err_max": self.alt_err_max} if self.d == 2 else {}),  # [m]
            "vehicle_energy_mean": float(np.mean(f.energy_J)),  # [J] per vehicle
            "vehicle_flips": float(self.flipped.sum()),
            "vehicle_grounded": float(self.grounded.sum()),
        }
