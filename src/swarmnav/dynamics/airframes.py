"""Quadrotor airframes: immutable parameter records in SI units, each with its source.

Frames and signs (used by :mod:`swarmnav.dynamics.quadrotor`): the world frame is x-y horizontal,
z up, gravity along -z; the body frame is x forward, y left, z along the rotor axes. The four rotors
sit in an "X" at ``arm_length`` from the centre of mass, 45 deg off the body axes:
rotor 1 front-left (+x, +y), 2 front-right (+x, -y), 3 rear-right (-x, -y), 4 rear-left (-x, +y).
Rotors 1 and 3 have a yaw moment of ``+k_m w^2`` about body z, rotors 2 and 4 ``-k_m w^2``
(:data:`ROTOR_DIRECTIONS`). This is RotorPy's layout (Folk et al. 2023, arXiv 2306.04485), so
its parameter files and ours describe the same vehicle.

The aerodynamic terms follow RotorPy's model (its paper, Section III): parasitic body drag
quadratic in the air-relative speed, ``c_D``; rotor drag ("H-force"), linear in each rotor's speed
and its hub's air-relative velocity, ``k_d`` in the rotor plane and ``k_z`` along its axis;
translational lift ``k_h``; blade-flapping moment ``k_flap``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from swarmnav.errors import ConfigError

GRAVITY = 9.81  # g [m/s^2], the value RotorPy uses (its oracle tests compare against ours)

#: Sign of each rotor's yaw moment about body z (rotors 1..4 as in the module docstring).
ROTOR_DIRECTIONS = (1.0, -1.0, 1.0, -1.0)


@dataclass(frozen=True, slots=True)
class Airframe:
    """One quadrotor's physical parameters. Build a checked one with :func:`airframe`."""

    name: str
    mass: float  # m [kg]
    inertia: tuple[float, float, float]  # (Ixx, Iyy, Izz) [kg m^2], principal axes = body axes
    arm_length: float  # distance from the centre of mass to each rotor hub [m]
    k_eta: float  # rotor thrust coefficient, T = k_eta w^2 [N/(rad/s)^2]
    k_m: float  # rotor yaw-moment coefficient, Q = k_m w^2 [N m/(rad/s)^2]
    rotor_speed_min: float  # w_min [rad/s]
    rotor_speed_max: float  # w_max [rad/s]
    tau_m: float  # motor time constant of the first-order lag w' = (w_cmd - w) / tau_m [s]
    c_D: tuple[float, float, float]  # parasitic drag (c_Dx, c_Dy, c_Dz), D = -|v_a| c_D v_a [N/(m/s)^2]
    k_d: float  # rotor drag in the rotor plane, H = -w k_d v_hub [N/((rad/s)(m/s))] = [kg/rad]
    k_z: float  # rotor drag (induced inflow) along the rotor axis [kg/rad]
    k_h: float  # translational lift, dT = k_h (v_hub,x^2 + v_hub,y^2) [N/(m/s)^2]
    k_flap: float  # blade-flapping moment, M = -k_flap w (v_hub x e3) [N m/((rad/s)(m/s))]
    rotor_radius: float  # [m] (the downwash model's disc radius)
    source: str  # where the values come from

    @property
    def max_thrust(self) -> float:
        """Collective thrust at full rotor speed, 4 k_eta w_max^2 [N]."""
        return 4.0 * self.k_eta * self.rotor_speed_max**2

    @property
    def hover_speed(self) -> float:
        """Rotor speed that holds the weight in still air, sqrt(m g / (4 k_eta)) [rad/s]."""
        return math.sqrt(self.mass * GRAVITY / (4.0 * self.k_eta))

    def rotor_positions(self) -> np.ndarray:
        """Hub positions in the body frame, (4, 3) [m], rotors 1..4 as in the module docstring."""
        d = self.arm_length / math.sqrt(2.0)
        return np.array([[d, d, 0.0], [d, -d, 0.0], [-d, -d, 0.0], [-d, d, 0.0]])


AIRFRAMES: dict[str, Airframe] = {
    # Bitcraze Crazyflie 2.0 (27-30 g). Inertia, k_eta, k_m, k_d, k_z as compiled in RotorPy's
    # crazyflie_params (Folk et al. 2023), which cites Forster 2015 ("System identification of the
    # Crazyflie 2.0 nano quadrocopter", ETH Zurich) and Bitcraze's thrust measurements (14.5 g of
    # thrust per rotor at 2500 rad/s); tau_m from the same file (Eschmann et al. 2024,
    # arXiv 2404.07837, motor delay). Body drag is neglected there (c_D = 0); so here.
    "crazyflie": Airframe(
        name="crazyflie",
        mass=0.030,
        inertia=(1.43e-5, 1.43e-5, 2.89e-5),
        arm_length=0.043,
        k_eta=2.3e-8,
        k_m=7.8e-10,
        rotor_speed_min=0.0,
        rotor_speed_max=2500.0,
        tau_m=0.072,
        c_D=(0.0, 0.0, 0.0),
        k_d=10.2506e-7,
        k_z=7.553e-7,
        k_h=0.0,
        k_flap=0.0,
        rotor_radius=0.0225,  # 45 mm propellers (Bitcraze Crazyflie 2.x datasheet)
        source="Forster 2015 (Crazyflie 2.0 system identification) as compiled in RotorPy "
        "crazyflie_params (Folk et al. 2023, arXiv 2306.04485)",
    ),
    # AscTec Hummingbird (0.5 kg). Values of RotorPy's hummingbird_params, which cite Svacha,
    # Mohta, Kumar, "Improving quadrotor trajectory tracking by compensating for aerodynamic
    # effects", ICUAS 2017 (aerodynamic coefficients) and a UNM thesis (inertia, rotors).
    "hummingbird": Airframe(
        name="hummingbird",
        mass=0.500,
        inertia=(3.65e-3, 3.68e-3, 7.03e-3),
        arm_length=0.17,
        k_eta=5.57e-6,
        k_m=1.36e-7,
        rotor_speed_min=0.0,
        rotor_speed_max=1500.0,
        tau_m=0.005,
        c_D=(0.5e-2, 0.5e-2, 1e-2),
        k_d=1.19e-4,
        k_z=2.32e-4,
        k_h=3.39e-3,
        k_flap=0.0,
        rotor_radius=0.10,
        source="AscTec Hummingbird: RotorPy hummingbird_params (Folk et al. 2023), citing Svacha, "
        "Mohta, Kumar, ICUAS 2017",
    ),
    # 1 kg-class quadrotor: PX4's simulation-in-hardware (SIH) default quad-X airframe, the size of
    # a Holybro X500. PX4 parameters SIH_MASS = 1.0 kg, SIH_IXX/IYY/IZZ = 0.025/0.025/0.030 kg m^2,
    # SIH_L_ROLL = SIH_L_PITCH = 0.2 m (rotor offset from each axis: arm 0.2 sqrt(2) m),
    # SIH_T_MAX = 5 N and SIH_Q_MAX = 0.1 N m per rotor at w_max, SIH_T_TAU = 0.05 s.
    # w_max = 1000 rad/s is RotorPy's choice in px4_sihsim_quadx_params (k_eta = T_MAX / w_max^2,
    # k_m = Q_MAX / w_max^2), and so is the quadratic body drag c_D = 0.01 N/(m/s)^2 (SIH's own
    # drag is linear). Rotor radius: the X500's 10-inch propellers.
    "x500": Airframe(
        name="x500",
        mass=1.0,
        inertia=(0.025, 0.025, 0.030),
        arm_length=0.2 * math.sqrt(2.0),
        k_eta=5.0e-6,
        k_m=1.0e-7,
        rotor_speed_min=0.0,
        rotor_speed_max=1000.0,
        tau_m=0.05,
        c_D=(1e-2, 1e-2, 1e-2),
        k_d=0.0,
        k_z=0.0,
        k_h=0.0,
        k_flap=0.0,
        rotor_radius=0.127,
        source="PX4 SIH default quad-X parameters (docs.px4.io, SIH_*) with RotorPy "
        "px4_sihsim_quadx_params' w_max and body drag",
    ),
}


def check(af: Airframe) -> Airframe:
    """``af`` if it is physical, else a one-line :class:`ConfigError` naming the bad value."""
    bad = None
    finite = all(math.isfinite(float(x)) for x in (af.mass, *af.inertia, af.arm_length, af.k_eta, af.k_m,
                                                    af.rotor_speed_min, af.rotor_speed_max, af.tau_m,
                                                    *af.c_D, af.k_d, af.k_z, af.k_h, af.k_flap,
                                                    af.rotor_radius))
    if not finite:
        bad = "every value must be finite"
    elif af.mass <= 0:
        bad = f"mass must be > 0 kg, got {af.mass:g}"
    elif min(af.inertia) <= 0:
        bad = f"inertia must be > 0 kg m^2, got {af.inertia}"
    elif af.arm_length <= 0 or af.rotor_radius <= 0:
        bad = "arm_length and rotor_radius must be > 0 m"
    elif af.k_eta <= 0 or af.k_m < 0:
        bad = "k_eta must be > 0 and k_m >= 0"
    elif af.tau_m < 0:
        bad = f"tau_m must be >= 0 s, got {af.tau_m:g}"
    elif not 0 <= af.rotor_speed_min < af.rotor_speed_max:
        bad = f"rotor speeds need 0 <= min < max, got [{af.rotor_speed_min:g}, {af.rotor_speed_max:g}] rad/s"
    elif min(af.c_D) < 0 or min(af.k_d, af.k_z, af.k_flap) < 0:
        bad = "drag coefficients must be >= 0"
    elif af.max_thrust <= af.mass * GRAVITY:
        bad = (f"cannot hover: maximum thrust {af.max_thrust:.4g} N <= weight {af.mass * GRAVITY:.4g} N "
               f"(mass {af.mass:g} kg)")
    elif 4.0 * af.k_eta * af.rotor_speed_min**2 >= af.mass * GRAVITY:
        bad = f"cannot descend: thrust at rotor_speed_min >= weight {af.mass * GRAVITY:.4g} N"
    if bad:
        raise ConfigError(f"airframe {af.name!r}: {bad}")
    return af


def airframe(name: str, mass: float | None = None) -> Airframe:
    """The checked airframe ``name`` from :data:`AIRFRAMES`, optionally with another ``mass`` [kg].

    A mass override models the same frame carrying more or less load spread like its own mass:
    the inertia scales by the same ratio; rotors, motors, geometry and drag stay. The result is
    checked again, so a mass the rotors cannot hold up (4 k_eta w_max^2 <= m g) is a ConfigError.
    """
    if name not in AIRFRAMES:
        raise ConfigError(f"unknown airframe {name!r}; known: {', '.join(sorted(AIRFRAMES))}")
    af = AIRFRAMES[name]
    if mass is not None:
        m = float(mass)
        if not math.isfinite(m) or m <= 0:
            raise ConfigError(f"airframe {name!r}: mass must be > 0 kg, got {mass!r}")
        s = m / af.mass
        af = dataclasses.replace(af, mass=m, inertia=tuple(i * s for i in af.inertia))
    return check(af)
