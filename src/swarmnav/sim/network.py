"""The network between the agents: what one agent knows of another is what reached it.

Each agent broadcasts its state (position, velocity) at ``net.rate``; each copy of a message to
each other agent is lost (independently, or in bursts: a Gilbert-Elliott channel per link), not
sent beyond ``net.range`` of the sender, and otherwise arrives ``net.latency`` plus a uniform
``[0, net.jitter]`` later. A receiver keeps the newest state it has received from each sender
and the time it was sent, so a method sees every other agent as it was when its last message
left, with that message's age. An agent knows its own state exactly.

The ideal network (every parameter at its default) delivers every state at once: the rollout
then passes no view at all and every method reads the true state, exactly as before the network
existed (bit-identical runs). A network is seeded from the run's seed through its own stream, so
a method's random draws are the same with or without it, and the same seed loses the same
messages.

Bandwidth. With ``net.bandwidth`` [bit/s] each sender's radio sends one message at a time: a
message of B bytes occupies it 8 B / bandwidth seconds (a broadcast is sent once, whatever the
number of receivers), starting when it is due or when the sender's previous message has left,
whichever is later. A message that would have to wait longer than the sender's send period is
dropped before it is sent (its sender has a newer state to send by then); the others arrive their
queueing and sending time later than without the limit. A message's size is its UDP/IPv4
headers (28 B), sender id (4 B), time stamp (8 B), position and velocity (6 floats, 48 B), plus
what the method published with it: 8 B a float of a float row, and an object's ``nbytes`` (a
planner's trajectory: its size in planning/messages.py; an object without one counts nothing).

Parameters are the run's, not a method's: ``--set net.latency=0.15`` (docs/network.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.params import as_dict, build, param

#: The run-option names of the network parameters (``net.NAME``).
PREFIX = "net."
#: [B] a state message's size (module docstring): UDP (8) + IPv4 (20) headers, sender id (4), time stamp
#: (8), position and velocity (6 x 8), whatever the world's dimension (the robots fly in 3-D)
STATE_BYTES = 28 + 4 + 8 + 6 * 8


@dataclass(frozen=True, slots=True)
class NetParams:
    """The network between the agents (module docstring). Defaults: the ideal network."""

    rate: float = param(0.0, "Hz", "[0, 10000]", "ours",
                        "broadcast rate of each agent's state; 0: the method's own broadcast_hz if it has "
                        "one (SPH, the flocking pair), else every control step")
    latency: float = param(0.0, "s", "[0, 60]", "ours", "fixed delay of every message")
    jitter: float = param(0.0, "s", "[0, 60]", "ours", "extra delay, uniform in [0, jitter], per message")
    loss: float = param(0.0, "", "[0, 1]", "ours", "fraction of messages lost, per link")
    burst: float = param(0.0, "", "[0, 1000000]", "ours",
                         "mean length of a run of lost messages on a link (Gilbert-Elliott channel); "
                         "0: losses independent")
    range: float = param(0.0, "m", "[0, 1000000]", "ours", "no message reaches an agent farther than this "
                         "from its sender; 0: no limit")
    bandwidth: float = param(0.0, "bit/s", "[0, 1e12]", "ours",
                             "each sender's radio sends at most this many bits a second, one message at a time; a "
                             "message that would wait longer than the send period is dropped (docs/network.md); "
                             "0: no limit")

    @property
    def ideal(self) -> bool:
        return self == NetParams()


def net_params(options: dict) -> NetParams:
    """The network of a run from its ``net.*`` options (unknown or out-of-range: ConfigError)."""
    p = build(NetParams, {k[len(PREFIX):]: v for k, v in options.items()}, context="net")
    if p.burst and p.loss < 1.0 and p.burst < p.loss / (1.0 - p.loss):
        raise ConfigError(f"net: burst = {p.burst:g} is shorter than loss = {p.loss:g} allows: a channel that "
                          f"loses {p.loss:g} of its messages has loss bursts of {p.loss / (1 - p.loss):.3g} messages "
                          f"or more on average (or set burst = 0: independent losses)")
    if p.burst and 0.0 < p.loss and p.burst < 1.0:
        raise ConfigError(f"net: burst = {p.burst:g} must be 0 (independent losses) or at least 1 message")
    return p


@dataclass(frozen=True, slots=True)
class View:
    """What each agent has received of every other: ``positions[i, j]`` [m] and
    ``velocities[i, j]`` [m/s] are agent j's state as agent i last heard it, ``age[i, j]`` [s]
    how old that is (``inf``: never heard; row i, column i: its own state, age 0).
    ``data[name]`` is what a method published under ``name`` (:meth:`Network.publish`) as agent i
    last received it from agent j, in the same message as the state: an (N, N, ...) array (NaN
    where none arrived yet) or an (N, N) object array (None where none arrived yet); row i, column
    i is agent i's own last publication."""

    positions: np.ndarray  # (N, N, d)
    velocities: np.ndarray  # (N, N, d)
    age: np.ndarray  # (N, N)
    data: dict = field(default_factory=dict)

    @property
    def heard(self) -> np.ndarray:
        """(N, N) bool: agent i has a state of agent j."""
        return np.isfinite(self.age)

    def payload(self, name: str) -> np.ndarray | None:
        """The (N, N, ...) picture of publication ``name`` (class docstring); None: never published."""
        return self.data.get(name)


class Network:
    """The messages of one run (module docstring). ``step`` is called once per control step with
    the true state; ``view`` is what every agent has received by then."""

    def __init__(self, p: NetParams, n: int, dim: int, dt: float, seed: int, rate: float | None = None):
        self.p = p
        self.n, self.dt = n, dt
        # a stream of its own, so the method's draws do not depend on the network
        self.rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x6E6574]))
        rate = p.rate if rate is None else rate
        self.rate = rate
        self.period = max(1.0 / rate, dt) if rate > 0 else dt
        # each agent's first send at a random phase of its period (agents are not synchronised)
        self.phase = self.rng.uniform(0.0, self.period, n) if rate > 0 else np.zeros(n)
        self.next_send = self.phase.copy()
        self.pos = np.zeros((n, n, dim))
        self.vel = np.zeros((n, n, dim))
        self.stamp = np.full((n, n), -np.inf)  # send time of the state held
        self.bad = np.zeros((n, n), dtype=bool)  # Gilbert-Elliott channel state per link (receiver, sender)
        self.pending: list[tuple] = []  # (sent at, receivers, senders, positions, velocities, delays, payloads)
        self.latest: dict[str, np.ndarray] = {}  # each name's last publication, one row per agent
        self.data: dict[str, np.ndarray] = {}  # each name's (receiver, sender) picture
        self.sent = 0
        self.delivered = 0
        self.lost = 0
        self.out_of_range = 0
        self.busy = np.full(n, -np.inf)  # [s] when each sender's radio is free (net.bandwidth)
        self.dropped = 0  # copies dropped at their sender's queue (net.bandwidth)
        self.queued = 0.0  # [s] summed queueing + sending time of the messages sent (net.bandwidth)
        self.queued_messages = 0
        eye = np.eye(n, dtype=bool)
        self._others = ~eye

    def step(self, t: float, pos: np.ndarray, vel: np.ndarray) -> View:
        """Send the messages due by time ``t`` [s], deliver those that arrived, return the view."""
        p, n = self.p, self.n
        senders = np.flatnonzero(self.next_send <= t + 1e-9)
        if senders.size:
            self.next_send[senders] += self.period * np.ceil((t + 1e-9 - self.next_send[senders]) / self.period + 1e-12)
            wait = None
            if p.bandwidth > 0:  # each sender's radio: queue, send, or drop (module docstring)
                senders, wait = self._radio(t, senders)
            recv, send = np.nonzero(self._others[:, senders])  # every other agent, each sender
            if wait is not None:
                wait = wait[send]
            send = senders[send]
            self.sent += recv.size
            keep = np.ones(recv.size, dtype=bool)
            if p.range > 0:
                far = np.linalg.norm(pos[recv] - pos[send], axis=1) > p.range
                self.out_of_range += int(far.sum())
                keep &= ~far
            if p.loss > 0:
                u = self.rng.random(recv.size)
                if p.burst:  # Gilbert-Elliott: bad state loses every message, good none
                    leave_bad = 1.0 / p.burst
                    enter_bad = min(1.0, p.loss * leave_bad / (1.0 - p.loss)) if p.loss < 1 else 1.0
                    was = self.bad[recv, send]
                    now = np.where(was, u >= leave_bad, u < enter_bad)
                    self.bad[recv, send] = now
                    lost = now
                else:
                    lost = u < p.loss
                lost &= keep
                self.lost += int(lost.sum())
                keep &= ~lost
            delay = np.full(recv.size, p.latency)
            if p.jitter > 0:
                delay = delay + self.rng.uniform(0.0, p.jitter, recv.size)
            if wait is not None:
                delay = delay + wait
            recv, send, delay = recv[keep], send[keep], delay[keep]
            if recv.size:
                # fancy indexing copies: the message keeps the payload rows as they are when it leaves
                data = {k: v[send] for k, v in self.latest.items()}
                self.pending.append((t, recv, send, pos[send].copy(), vel[send].copy(), delay, data))
        self._deliver(t)
        own = np.arange(n)
        self.pos[own, own], self.vel[own, own], self.stamp[own, own] = pos, vel, t
        for k, v in self.latest.items():
            self.data[k][own, own] = v
        return View(self.pos.copy(), self.vel.copy(), t - self.stamp, {k: v.copy() for k, v in self.data.items()})

    def message_bytes(self, senders: np.ndarray) -> np.ndarray:
        """Size [B] of the message each of ``senders`` sends now (module docstring)."""
        size = np.full(len(senders), float(STATE_BYTES))
        for rows in self.latest.values():
            if rows.dtype == object:
                size += [float(getattr(rows[s], "nbytes", 0) or 0) for s in senders]
            else:
                size += 8.0 * (rows[0].size if rows.ndim > 1 else 1)
        return size

    def _radio(self, t: float, senders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The bandwidth limit at time ``t`` [s] (module docstring): the senders whose message
        goes out, and its queueing + sending time [s] each; the rest are dropped."""
        airtime = 8.0 * self.message_bytes(senders) / self.p.bandwidth  # [s]
        start = np.maximum(t, self.busy[senders])
        go = start - t <= self.period + 1e-12
        self.dropped += int((~go).sum()) * (self.n - 1)  # every copy of a dropped message
        senders, start, airtime = senders[go], start[go], airtime[go]
        self.busy[senders] = start + airtime
        wait = start - t + airtime
        self.queued += float(wait.sum())
        self.queued_messages += len(senders)
        return senders, wait

    def publish(self, payloads: dict) -> None:
        """A method's publications of this step, ``{name: values}`` with one row per agent (an
        (N, ...) array, or a length-N sequence of any objects). Each message an agent sends from
        now on carries its row of each name until it publishes that name again; a receiver holds
        the row of the newest message it received (``View.data``). Objects travel by reference:
        a method must not change one after publishing it."""
        for name, values in payloads.items():
            if isinstance(values, np.ndarray) and values.dtype != object:
                rows = np.array(values, dtype=np.float64)
                if name not in self.data:
                    self.data[name] = np.full((self.n, *rows.shape), np.nan)
            else:
                rows = np.empty(self.n, dtype=object)
                rows[:] = list(values)
                if name not in self.data:
                    self.data[name] = np.full((self.n, self.n), None, dtype=object)
            if len(rows) != self.n:
                raise ValueError(f"publish: {name!r} has {len(rows)} rows for {self.n} agents")
            self.latest[name] = rows

    def _deliver(self, t: float) -> None:
        keep = []
        for sent_at, recv, send, pos, vel, delay, data in self.pending:
            due = sent_at + delay <= t + 1e-9
            if due.any():
                r, s = recv[due], send[due]
                newer = sent_at > self.stamp[r, s]
                r, s = r[newer], s[newer]
                self.pos[r, s] = pos[due][newer]
                self.vel[r, s] = vel[due][newer]
                self.stamp[r, s] = sent_at
                for k, v in data.items():
                    self.data[k][r, s] = v[due][newer]
                self.delivered += int(due.sum())
            if not due.all():
                rest = ~due
                keep.append((sent_at, recv[rest], send[rest], pos[rest], vel[rest], delay[rest],
                             {k: v[rest] for k, v in data.items()}))
        self.pending = keep

    def summary(self) -> dict[str, float]:
        """Run metrics of the network: messages sent (one per receiver), the fractions delivered,
        lost and out of range."""
        sent = max(self.sent, 1)
        out = {"net_rate_hz": self.rate if self.rate > 0 else 1.0 / self.dt,
               "net_messages": float(self.sent), "net_delivered_fraction": self.delivered / sent,
               "net_lost_fraction": self.lost / sent, "net_out_of_range_fraction": self.out_of_range / sent}
        if self.p.bandwidth > 0:  # the copies dropped at the senders' queues, of those due
            out["net_dropped_fraction"] = self.dropped / max(self.sent + self.dropped, 1)
            out["net_queue_delay_mean"] = self.queued / max(self.queued_messages, 1)
        return out


def record(p: NetParams) -> dict:
    """The network of a run as its config records it."""
    return {k: (None if isinstance(v, float) and math.isinf(v) else v) for k, v in as_dict(p).items()}
