"""The one rollout loop: scene + method + seed + steps -> RunResult."""

from __future__ import annotations

import contextlib
import time
from typing import Any

import numpy as np
from numba import njit

from swarmnav._version import __version__
from swarmnav.dynamics.vehicle import Quadrotors, is_vehicle_option, record as vehicle_record, vehicle_params
from swarmnav.errors import ConfigError, DivergedError, ScenarioError
from swarmnav.methods import registry
from swarmnav.methods.base import Method, Observation
from swarmnav.metrics.flight import FlightParams, flight_metrics
from swarmnav.metrics.navigation import MetricParams, goal_reached, navigation_metrics
from swarmnav.params import as_dict, coerce
from swarmnav.portable import numerics
from swarmnav.sensing import PreparedGeometry
from swarmnav.sensing.perception import PREFIX as SENSE_PREFIX, Perception, record as sense_record, sense_params
from swarmnav.sim.network import PREFIX as NET_PREFIX, Network, net_params, record as net_record
from swarmnav.sim.flight import Lookahead, inside_walls, world_of
from swarmnav.sim.referee import Referee
from swarmnav.sim.result import Plans, RunResult
from swarmnav.world.catalog import load_scenario
from swarmnav.world.scenario import Scenario


#: The run options that override the scene's referee settings (``world.boundary``, ``[rules]``).
SCENE_OPTIONS = ("boundary", "contact", "goal_radius", "d_safe", "body_radius")
#: Options of the run itself, accepted by :func:`run` beside the method's parameters (and by
#: ``--set`` on the command line and in experiment specs).
RUN_OPTIONS = ("z_fly", *SCENE_OPTIONS, "plans")


def is_run_option(key: str) -> bool:
    """A ``--set`` key of the run rather than of its method: :data:`RUN_OPTIONS`, the
    network's ``net.*`` (docs/network.md), perception's ``sense.*`` (docs/sensing.md) and the
    vehicle's ``vehicle``, ``vehicle.*``, ``wind.*``, ``downwash`` (docs/vehicle.md)."""
    return key in RUN_OPTIONS or key.startswith(NET_PREFIX) or key.startswith(SENSE_PREFIX) or is_vehicle_option(key)


def run(
    method: str | Method,
    scenario: str | Scenario,
    *,
    seed: int,
    steps: int | None = None,
    horizon: float | None = None,
    progress: bool | Any = False,
    z_fly: float | str | None = None,
    boundary: str | None = None,
    contact: str | None = None,
    goal_radius: float | None = None,
    d_safe: float | None = None,
    body_radius: float | None = None,
    plans: bool | str = True,
    **params: Any,
) -> RunResult:
    """Simulate ``method`` on ``scenario`` for ``steps`` steps from a seeded start.

    Positions, velocities and commands are (N, d) arrays, d the scene's dimension. A planar
    method (``dims = (2,)``: HES, the Vicsek family) keeps its paper's plane on
    a 3-D scene: it flies the scene's horizontal slice at altitude ``z_fly`` (spawned, sensing
    and acting in that slice), while the run is recorded in 3-D at that altitude and its
    clearance and metrics are measured against the 3-D world; ``config["plane"]`` says so.

    Args:
        method: a registered method name or a Method instance.
        scenario: a Scenario, a built-in scene name, generator spec or scene-file path.
        seed: seed of the run's ``numpy.random.Generator`` (spawn positions, method noise).
        steps: number of integration steps K (K + 1 states are recorded); at most K if the
            method ends the run early with ``info["done"] = True``.
        horizon: instead of ``steps``, the simulated time [s]: K = round(horizon / dt) steps of
            the method's own dt (at least one). Give exactly one of the two; the config
            records both (``horizon`` = K dt when given ``steps``).
        progress: True for a tqdm bar, or a callable ``f(done_steps)``.
        z_fly: altitude [m] of a planar method on a 3-D scene (default: the middle of the
            spawn box's z range); an error anywhere else.
        boundary, contact, goal_radius, d_safe, body_radius: override the scene's
            ``world.boundary`` and ``[rules]`` (docs/scenarios.md); None keeps the scene's.
        plans: keep the trajectories a planner committed (its optional ``plans()`` hook,
            docs/methods/contract.md) in ``RunResult.plans``; False (or ``"false"``) keeps
            none. Either way the run flies the same.
        **params: method parameters (unknown names raise ConfigError), and the network's
            ``net.*`` options (pass them as ``**{"net.latency": 0.15}``; docs/network.md),
            perception's ``sense.*`` (``**{"sense.pos_noise": 0.05}``; docs/sensing.md) and the
            vehicle's (``vehicle="quadrotor"``, ``**{"wind.speed": 6}``; docs/vehicle.md).

    The same (method, params, scene, seed, steps) always gives identical arrays.
    """
    scn = load_scenario(scenario) if not isinstance(scenario, Scenario) else scenario
    scn = with_rules(scn, boundary=boundary, contact=contact, goal_radius=goal_radius, d_safe=d_safe,
                     body_radius=body_radius)
    keep_plans = coerce(plans, bool, "plans")
    net = net_params({k: params.pop(k) for k in [k for k in params if k.startswith(NET_PREFIX)]})
    sense = sense_params({k: params.pop(k) for k in [k for k in params if k.startswith(SENSE_PREFIX)]})
    vehicle, wind = vehicle_params({k: params.pop(k) for k in [k for k in params if is_vehicle_option(k)]})
    m = registry.make(method, **params) if isinstance(method, str) else method
    scans = sense.map == "scans"
    if scans and not getattr(m, "map_sensor", False):
        raise ConfigError(f"{m.name} cannot build its map from scans (it reads the obstacles from the world), so "
                          f"sense.map=scans cannot apply; methods that can: {', '.join(_mapping()) or 'none'}")
    if sense.ranged and not getattr(m, "range_sensor", False) and not scans:
        raise ConfigError(f"{m.name} has no range sensor (it reads the obstacles from the world), so "
                          f"{', '.join('sense.' + k for k in sense.ranged)} cannot apply; methods with one: "
                          f"{', '.join(_ranged()) or 'none'}")
    if not net.ideal and not getattr(m, "networked", False):
        raise ConfigError(f"{m.name} does not read the other agents through the network yet, so it cannot fly "
                          f"a non-ideal one (net.*); methods that can: {', '.join(_networked()) or 'none'}")
    if not net.ideal and getattr(m, "network_refusal", None):  # a build whose switched-on parts read true states
        raise ConfigError(m.network_refusal)
    if (steps is None) == (horizon is None):
        raise ConfigError("give exactly one of steps or horizon")
    if steps is None:
        steps = steps_for_horizon(horizon, float(m.dt))
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ConfigError(f"steps must be an integer >= 1, got {steps!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"seed must be an integer >= 0, got {seed!r}")
    world, plane_z = world_of(scn, m.dims, z_fly, m.name)
    if world.periodic and not getattr(m, "periodic", True):
        raise ConfigError(f"{m.name} cannot fly a periodic world ({scn.name}): its plans cross the world's "
                          "edge, where a periodic box wraps; fly it in a walled or open world")
    rng = np.random.default_rng(seed)
    pos = world.spawn_positions(rng)
    vel = np.zeros_like(pos)
    m.reset(world, pos.copy(), vel.copy(), rng)
    dt = float(m.dt)
    network = None
    if not net.ideal:  # the agents send at net.rate, else at the method's own broadcast rate, else every step
        own_rate = float(getattr(m.params, "broadcast_hz", 0.0) or 0.0)
        network = Network(net, scn.n, pos.shape[1], dt, seed, rate=net.rate or own_rate)
    perception = None  # perfect perception: the method reads the true state and exact ranges
    if not sense.perfect:
        perception = Perception(sense, pos, seed, world.goal_array if world.has_goal else None)
    step = m.dynamics.step  # the point vehicle: the method's own model, untouched
    quads = None
    if not vehicle.point:
        quads = Quadrotors(vehicle, wind, m.dynamics, pos, vel, dt, seed,
                           period=world.bounds[2] - world.bounds[0] if world.periodic else None,
                           floor=_floor(scn, plane_z))
    N = scn.n
    d = scn.dim
    P = np.empty((steps + 1, N, d))
    V = np.empty((steps + 1, N, d))
    C = np.empty((steps + 1, N))
    lab = np.zeros((steps + 1, N), dtype=np.int32)
    axis = None  # (K + 1, N, 3) the quadrotors' thrust axes; none on the point vehicle
    if quads is not None:
        axis = np.empty((steps + 1, N, 3), dtype=np.float32)
        axis[0] = quads.thrust_axis
    roles = None  # (K + 1, N) role codes, recorded only for a method whose info gives "roles"
    geom = scn.geometry
    no_obstacles = geom.is_empty
    if no_obstacles:
        clear = lambda x: np.full(len(x), np.inf)  # noqa: E731
    else:  # the geometry converted once: the same kernel as signed_distance, without per-step packing
        prepared = PreparedGeometry(geom)
        distance_into = prepared.distance_into  # a row of P is a C-contiguous float64 (N, d) array
        clear = lambda x: distance_into(np.ascontiguousarray(x, dtype=np.float64), np.empty(len(x)))  # noqa: E731
    lift = vlift = _identity
    if plane_z is not None:  # the slice's (N, 2) state at altitude plane_z, no vertical velocity
        lift = lambda x, z=plane_z: np.column_stack([x, np.full(len(x), z)])  # noqa: E731
        vlift = lambda x: np.column_stack([x, np.zeros(len(x))])  # noqa: E731
    P[0], V[0] = lift(pos), vlift(vel)
    C[0] = clear(P[0])  # against the scene's own (3-D) obstacles
    walled = scn.boundary == "wall"  # beyond the walls' far side an agent is still outside the world
    w_lo, w_hi = scn.lower, scn.upper
    if walled:
        inside_walls(P[0], w_lo, w_hi, C[0])
    events: list[dict] = []
    bar = _progress(progress, steps)
    t0 = time.perf_counter()
    lo = np.array(world.bounds[:2])
    period = world.bounds[2] - world.bounds[0] if world.periodic else None
    # the usual case -- the state is (N, d) float64 arrays recorded as they are -- checks finiteness
    # and copies the new state into its rows of P and V in one compiled pass
    direct = plane_z is None and period is None
    rules = scn.rules
    referee = Referee(N, rules.body_radius, period, bounds=world.bounds if scn.boundary == "wall" else None) \
        if scn.contact == "crash" else None
    if referee is not None:
        events += referee.judge(0, P[0], C[0], pos)
    look = _lookahead(m, scn, steps, plane_z, network, perception, period, quads)
    # a diverging state is reported in one line (DivergedError below), not by NumPy's floating-point
    # warnings on the way there (an overflow in a power, inf - inf): they only repeat it
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"), _closing(m):
        for k in range(steps):
            if look is not None:  # a copy of the run at the start of this step, for the method's oracle
                look.mark(m, k, pos, vel, rng, referee)
            if perception is None:
                view = None if network is None else network.step(k * dt, pos, vel)
                cmd, info = m.act(Observation(k, k * dt, pos, vel, view), rng)
            else:  # each agent acts on, and sends, what it believes of itself
                opos, ovel = perception.observe(k * dt, pos, vel)
                view = None if network is None else network.step(k * dt, opos, ovel)
                cmd, info = m.act(Observation(k, k * dt, opos, ovel, view, perception), rng)
            if network is not None and "publish" in info:  # what the agents send from now on
                network.publish(info["publish"])
            if quads is None:
                pos, vel = step(pos, vel, cmd, dt)
            else:  # the referee's wrecks are held, not flown: no tracking error of theirs counts
                pos, vel = quads.step(pos, vel, cmd, dt, None if referee is None else referee.crashed)
            if referee is not None:
                if quads is not None and quads.new_flips.any():  # a flipped quadrotor has crashed
                    events += referee.fail(k + 1, quads.new_flips, pos, "flipped")
                if quads is not None and quads.new_grounded.any():  # so has one that came down to the floor
                    events += referee.fail(k + 1, quads.new_grounded, pos, "ground")
                referee.hold(pos, vel)
            if direct and _plain(pos, vel, d):
                finite = _finite_into(pos, vel, P[k + 1], V[k + 1])
            else:
                finite = _all_finite(pos, vel)
                if finite:
                    if period is not None:  # the world is a torus whatever the method's dynamics
                        pos = lo + np.mod(pos - lo, period)
                    P[k + 1], V[k + 1] = lift(pos), vlift(vel)
            if not finite:
                raise DivergedError(f"{m.name} diverged at step {k + 1} (t = {(k + 1) * dt:g} s): non-finite "
                                    f"positions or velocities; check the parameters ({_changed(m.params)})")
            if no_obstacles:
                C[k + 1] = clear(P[k + 1])
            else:  # written in place (a row of C is a contiguous float64 buffer): the same values
                distance_into(P[k + 1], C[k + 1])
            if walled:
                inside_walls(P[k + 1], w_lo, w_hi, C[k + 1])
            labels = info.get("labels")
            lab[k + 1] = lab[k] if labels is None else labels
            r = info.get("roles")
            if r is not None:
                if roles is None:
                    roles = np.zeros((steps + 1, N), dtype=np.uint8)
                roles[k + 1] = r
            elif roles is not None:
                roles[k + 1] = roles[k]
            evs = info.get("events")
            if evs:
                for ev in evs:
                    events.append({"step": k, **ev})
            if axis is not None:
                axis[k + 1] = quads.thrust_axis
            if referee is not None:
                events += referee.judge(k + 1, P[k + 1], C[k + 1], pos)
            if bar is not None and (k % 10 == 9 or k == steps - 1):
                bar(k + 1)
            if info.get("done") or (referee is not None and referee.crashed.all()):  # the method's task is complete: record this state and stop
                P, V, C, lab = P[: k + 2].copy(), V[: k + 2].copy(), C[: k + 2].copy(), lab[: k + 2].copy()
                roles = None if roles is None else roles[: k + 2].copy()
                axis = None if axis is None else axis[: k + 2].copy()
                if bar is not None:
                    bar(steps)
                break
    wall = time.perf_counter() - t0
    lab[0] = lab[1]  # the structure in force at k = 0 is the one decided at the first step
    if roles is not None:
        roles[0] = roles[1]
    result = RunResult(
        config={
            "swarmnav_version": __version__,
            "numerics": numerics(),  # "portable": identical on any x86-64 machine (docs/determinism.md)
            "method": m.name,
            "params": as_dict(m.params),
            "scenario": scn.to_dict(),
            "seed": int(seed),
            "rules": {"boundary": scn.boundary, "contact": scn.contact, "goal_radius": rules.goal_radius,
                      "d_safe": rules.d_safe, "body_radius": rules.body_radius},
            "steps": int(steps),
            "dt": dt,
            "horizon": int(steps) * dt,  # [s] simulated time asked for (a method may end the run early)
            **({"plane": {"z_fly": plane_z, "reason": f"{m.name} is planar: it flew the scene's "
                          f"horizontal slice at z = {plane_z:g} m"}} if plane_z is not None else {}),
            **({"net": net_record(net)} if network is not None else {}),
            **({"sense": sense_record(sense)} if perception is not None else {}),
            **vehicle_record(vehicle, wind),
        },
        positions=P, velocities=V, clearance=C, labels=lab, roles=roles, thrust_axis=axis, events=events,
        wall_time=wall,
    )
    n_struct = sum(1 for e in events if e.get("action") in ("split", "merge"))
    crashed = referee.crashed if referee is not None else np.zeros(N, dtype=bool)
    goal = scn.goal_array if scn.has_goal else None
    metrics = navigation_metrics(
        P, C, goal, result.n_subswarms, n_struct,
        MetricParams(r_succ=rules.goal_radius, d_safe=rules.d_safe, r_s=rules.d_safe, body_radius=rules.body_radius),
        periodic_box=period,
        reached=None if goal is None else goal_reached(scn, P[-1], crashed),
    )
    metrics["crashes"] = float(crashed.sum())
    if period is None:  # the SPH flight metrics cross an open world to a goal; on a torus the wrap
        # jumps would count as path and jerk, and there is no goal to arrive at (docs/metrics.md).
        # Same pairs, same contact distance: the minimum is reused, not searched again.
        metrics.update(flight_metrics(P, V, C, scn.goal_array, dt, FlightParams(body_radius=rules.body_radius),
                                      min_pair=metrics["min_inter_agent_distance"], crashed=crashed))
    metrics.update(m.summary())
    if network is not None:
        metrics.update(network.summary())
    if perception is not None:
        metrics.update(perception.summary())
    if quads is not None:
        metrics.update(quads.summary())
    result.metrics = metrics
    timings = getattr(m, "timings", None)  # optional hook: wall-clock figures, never metrics
    if callable(timings):
        result.timings = dict(timings())
    artifacts = getattr(m, "artifacts", None)  # optional hook: extra files of the run directory
    if callable(artifacts):
        result.artifacts = dict(artifacts())
    hook = getattr(m, "plans", None)  # optional hook: the trajectories the method committed
    if keep_plans and callable(hook):
        try:
            result.plans = Plans.from_arrays(hook(), n=N, dim=d, lift=plane_z)
        except ValueError as e:  # a method's defect, not the user's input
            raise ValueError(f"{m.name}.plans() broke its contract (docs/methods/contract.md): {e}") from None
    return result


def _floor(scn: Scenario, plane_z: float | None) -> float | None:
    """The ground under a quadrotor run, in its vehicles' vertical: a 3-D world's lowest z [m]
    (``bounds``; relative to the slice's altitude for a planar method), None in a 2-D scene."""
    if scn.dim != 3 or scn.periodic:
        return None
    return scn.bounds[2] - (plane_z if plane_z is not None else 0.0)


def _lookahead(m: Method, scn: Scenario, steps: int, plane_z: float | None, network: Any, perception: Any,
               period: float | None, quads: Any) -> Lookahead | None:
    """The :class:`Lookahead` handed to the method's optional ``oracle`` hook (None: the method
    has none, or it is switched off); an oracle flies copies of the run, which need the ideal
    network, perfect perception, the point vehicle and a walled or open world with a goal
    (docs/oracle.md)."""
    oracle = getattr(m, "oracle", None)
    if oracle is None:
        return None
    if network is not None or perception is not None or quads is not None:
        raise ConfigError("decision=oracle flies copies of the run on the ideal network with perfect perception "
                          "and the point vehicle; drop the net.*, sense.* and vehicle options")
    if period is not None or not scn.has_goal:
        raise ConfigError(f"decision=oracle scores progress to a goal; {scn.name} has none")
    look = Lookahead(scn, steps, plane_z)
    oracle.attach(look)
    return look


def with_rules(scn: Scenario, *, boundary: Any = None, contact: Any = None, goal_radius: Any = None,
               d_safe: Any = None, body_radius: Any = None) -> Scenario:
    """``scn`` with its boundary and referee settings overridden where given (None: the scene's).
    A bad value raises ConfigError naming the option."""
    from dataclasses import replace

    given = {k: v for k, v in (("goal_radius", goal_radius), ("d_safe", d_safe), ("body_radius", body_radius))
             if v is not None}
    for k, v in given.items():
        try:
            given[k] = float(v)
        except (TypeError, ValueError):
            raise ConfigError(f"{k} must be a number [m], got {v!r}") from None
    if contact is not None:
        given["contact"] = str(contact)
    if boundary is not None and str(boundary) != scn.boundary:
        b = str(boundary)
        if b == "periodic" or scn.periodic:
            raise ConfigError(f"boundary={b}: a scene is periodic or not by its own geometry "
                              f"({scn.name} is {scn.boundary}); only wall and open are interchangeable")
        try:
            scn = replace(scn, boundary=b)
        except ScenarioError as e:
            raise ConfigError(str(e).split(": ", 1)[-1]) from None
    if given:
        try:
            scn = replace(scn, rules=replace(scn.rules, **given))
        except ScenarioError as e:
            raise ConfigError(str(e)) from None
    return scn


def _all_finite(pos: np.ndarray, vel: np.ndarray) -> bool:
    """Every position and velocity is finite (compiled for the usual float64 arrays)."""
    if type(pos) is np.ndarray and type(vel) is np.ndarray and pos.dtype == vel.dtype == np.float64:
        return _finite_kernel(pos.reshape(-1), vel.reshape(-1))
    return bool(np.isfinite(pos).all() and np.isfinite(vel).all())


def _plain(pos, vel, d: int) -> bool:
    """``pos`` and ``vel`` are (N, d) float64 numpy arrays (what :func:`_finite_into` takes)."""
    return (type(pos) is np.ndarray and type(vel) is np.ndarray and pos.dtype == vel.dtype == np.float64
            and pos.ndim == 2 and pos.shape == vel.shape and pos.shape[1] == d)


@njit(cache=True)
def _finite_into(pos, vel, p_row, v_row):
    """Whether every position and velocity is finite; if so, ``p_row[:] = pos``, ``v_row[:] = vel``."""
    n, d = pos.shape
    for i in range(n):
        for c in range(d):
            if not (np.isfinite(pos[i, c]) and np.isfinite(vel[i, c])):
                return False
    for i in range(n):
        for c in range(d):
            p_row[i, c] = pos[i, c]
            v_row[i, c] = vel[i, c]
    return True


@njit(cache=True)
def _finite_kernel(a, b):
    for i in range(a.shape[0]):
        if not np.isfinite(a[i]):
            return False
    for i in range(b.shape[0]):
        if not np.isfinite(b[i]):
            return False
    return True


def _changed(params: Any) -> str:
    """The parameters that differ from their defaults, ``k=v, ...`` (or "all defaults")."""
    base = as_dict(type(params)())
    diff = [f"{k}={v}" for k, v in as_dict(params).items() if v != base[k]]
    return ", ".join(diff) if diff else "all defaults"


def steps_for_horizon(horizon: Any, dt: float) -> int:
    """Steps of ``dt`` that cover ``horizon`` seconds: round(horizon / dt), at least one."""
    try:
        h = float(horizon)
    except (TypeError, ValueError):
        raise ConfigError(f"horizon must be a number of seconds, got {horizon!r}") from None
    if not (h > 0 and np.isfinite(h)):
        raise ConfigError(f"horizon must be finite and > 0 s, got {horizon!r}")
    steps = round(h / dt)
    if steps > 100_000_000:
        raise ConfigError(f"horizon {h:g} s is {steps:.3g} steps of dt = {dt:g} s; at most 1e8")
    return max(1, int(steps))


@contextlib.contextmanager
def _closing(m: Method):
    """Call the method's optional ``close()`` hook (its threads, docs/methods/contract.md) when the
    steps end, however they end."""
    try:
        yield
    finally:
        close = getattr(m, "close", None)
        if callable(close):
            close()


def _identity(x: np.ndarray) -> np.ndarray:
    return x


def _progress(progress, steps):
    if progress is False or progress is None:
        return None
    if callable(progress) and progress is not True:
        return progress
    from tqdm import tqdm

    bar = tqdm(total=steps, unit="step", leave=False, dynamic_ncols=True)

    def update(done: int) -> None:
        bar.update(done - bar.n)
        if done >= steps:
            bar.close()

    return update


def _ranged() -> list[str]:
    """Registered methods that read a range sensor through ``Observation.scan`` (a class attribute)."""
    return [n for n in registry.names() if getattr(registry.spec(n).factory, "range_sensor", False)]


def _mapping() -> list[str]:
    """Registered methods that can build their maps from their own scans (``sense.map = scans``)."""
    return [n for n in registry.names() if getattr(registry.spec(n).factory, "map_sensor", False)]


def _networked() -> list[str]:
    """Registered methods that read the other agents only through the network (a class attribute)."""
    return [n for n in registry.names() if registry.spec(n).networked]
