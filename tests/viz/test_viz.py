"""Figures and animations: files are real images showing the scene, the run and its structure."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from PIL import Image  # noqa: E402

from swarmnav.errors import SwarmnavError  # noqa: E402
from swarmnav.sim.result import RunResult  # noqa: E402
import swarmnav.viz.animate as animate_mod  # noqa: E402
from swarmnav.viz import animate_run, draw_scene, plot_run, plot_scene  # noqa: E402
from swarmnav.viz.animate import frame_steps  # noqa: E402
from swarmnav.viz.draw import event_points, trajectory_segments  # noqa: E402
from swarmnav.viz.style import GOAL_FACE, OBSTACLE_FACE  # noqa: E402
from swarmnav.world.catalog import load_scenario  # noqa: E402
from swarmnav.world.scenario import builtin_names, from_dict  # noqa: E402

SCENE = {
    "name": "viz_test",
    "description": "one obstacle of each kind",
    "world": {"bounds": [-5.0, -5.0, 25.0, 10.0]},
    "swarm": {"n": 3, "spawn": [-4.0, -4.0, -1.0, -1.0]},
    "goal": {"position": [20.0, 2.0], "path": [[-2.0, -2.0], [10.0, 8.0], [20.0, 2.0]]},
    "obstacles": [
        {"type": "box", "min": [4.0, -3.0], "max": [6.0, 1.0]},
        {"type": "circle", "center": [12.0, 5.0], "radius": 1.5},
        {"type": "polygon", "points": [[15.0, -4.0], [18.0, -4.0], [16.5, -1.0]]},
    ],
}
K, N = 50, 3
SPLIT_STEP, MERGE_STEP = 19, 39  # events logged at k change labels[k] -> labels[k + 1]
TAB_ORANGE = to_rgb("tab:orange")  # colour of the second sub-swarm id (tab10)


def make_result(split: bool = True) -> RunResult:
    """3 agents moving straight from spawn to near the goal; agent 2 forms sub-swarm 1 for
    k in (19, 39]."""
    scn = from_dict(SCENE)
    start = np.array([[-3.0, -3.0], [-2.0, -2.0], [-3.0, -1.5]])
    end = np.array(scn.goal) + np.array([[-2.0, 0.0], [0.0, -2.0], [-2.0, 2.0]])
    t = np.linspace(0.0, 1.0, K + 1)[:, None, None]
    P = start[None] * (1 - t) + end[None] * t
    labels = np.zeros((K + 1, N), dtype=np.int32)
    events = []
    if split:
        labels[SPLIT_STEP + 1:MERGE_STEP + 1, 2] = 1
        events = [
            {"step": SPLIT_STEP, "action": "split", "source": "rule", "reason": "gap"},
            {"step": MERGE_STEP, "action": "merge", "source": "rule", "reason": "open"},
        ]
    clearance = 1.0 + np.sin(np.linspace(0, 6, K + 1))[:, None] * np.ones((1, N))
    return RunResult(
        config={"method": "hes", "scenario": scn.to_dict(), "seed": 7, "steps": K, "dt": 0.1},
        positions=P, velocities=np.gradient(P, 0.1, axis=0), clearance=clearance, labels=labels,
        events=events, metrics={"Y": 1.0, "R_goal": 1.0, "E_mean": 0.5, "R_unsafe": 0.2},
    )


def rgb_array(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"), dtype=np.int16)


def has_colour(img: np.ndarray, colour, min_pixels: int = 5, tol: int = 3) -> bool:
    """At least ``min_pixels`` pixels within ``tol`` (0-255 per channel) of ``colour``."""
    target = np.round(np.asarray(to_rgb(colour)) * 255).astype(np.int16)
    return int(np.all(np.abs(img - target) <= tol, axis=-1).sum()) >= min_pixels


def map_panel(img: np.ndarray) -> np.ndarray:
    """The trajectory panel of a plot_run image without its legend: upper half, left 76 %
    (the legend sits right of the panel, the time series below it)."""
    h, w = img.shape[:2]
    return img[: h // 2, : int(0.76 * w)]


def test_plot_run_draws_scene_trajectories_and_labels(tmp_path):
    out = plot_run(make_result(), tmp_path / "sub" / "trajectory.png")
    assert out == tmp_path / "sub" / "trajectory.png" and out.stat().st_size > 10_000
    with Image.open(out) as im:
        assert im.format == "PNG"
        w, h = im.size
    assert 800 <= w <= 3000 and 600 <= h <= 3000
    img = rgb_array(out)
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20  # not blank
    panel = map_panel(img)
    # obstacles, goal, start dots, end dots, sub-swarm 0 curves
    for colour, n in ((OBSTACLE_FACE, 1000), (GOAL_FACE, 50), ("tab:green", 30), ("tab:red", 30), ("tab:blue", 300)):
        assert has_colour(panel, colour, min_pixels=n), colour
    # agent 2 in sub-swarm 1 for 20 of 50 steps: a long orange stretch of its curve
    assert has_colour(panel, TAB_ORANGE, min_pixels=100)


def test_plot_run_without_second_subswarm_has_no_second_colour(tmp_path):
    img = rgb_array(plot_run(make_result(split=False), tmp_path / "t.png"))
    assert not has_colour(img, TAB_ORANGE, min_pixels=1)


def test_event_centroid_is_that_of_the_affected_subswarms():
    r = make_result()
    pts = event_points(r.positions, r.labels, r.events)
    assert [(k, a) for k, a, _ in pts] == [(SPLIT_STEP, "split"), (MERGE_STEP, "merge")]
    # the split divides the whole swarm (label 0 before) and the merge joins it again: all agents
    np.testing.assert_allclose(pts[0][2], r.positions[SPLIT_STEP + 1].mean(axis=0))
    np.testing.assert_allclose(pts[1][2], r.positions[MERGE_STEP + 1].mean(axis=0))
    # a split of sub-swarm 1 only: the centroid is that of its members, not of the swarm
    labels = np.zeros((K + 1, 4), dtype=np.int32)
    labels[:, 2:] = 1
    labels[11:, 3] = 2
    P = np.arange((K + 1) * 4 * 2, dtype=float).reshape(K + 1, 4, 2)
    (_, _, c), = event_points(P, labels, [{"step": 10, "action": "split"}])
    np.testing.assert_allclose(c, P[11, 2:].mean(axis=0))


def test_draw_scene_sets_bounds_aspect_and_one_patch_per_obstacle():
    scn = from_dict(SCENE)
    ax = Figure().add_subplot()
    handles = draw_scene(ax, scn)
    assert ax.get_xlim() == (-5.0, 25.0) and ax.get_ylim() == (-5.0, 10.0)
    assert ax.get_aspect() == 1.0
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")
    (obstacles,) = [c for c in ax.collections if isinstance(c, PatchCollection)]
    assert len(obstacles.get_paths()) == 3
    assert {h.get_label() for h in handles} == {"obstacle", "spawn region", "path", "goal", "world wall"}
    (frame,) = [h for h in handles if h.get_label() == "world wall"]  # the closed world's walls, on the bounds
    assert frame.get_xy() == (-5.0, -5.0) and (frame.get_width(), frame.get_height()) == (30.0, 15.0)
    opened = draw_scene(Figure().add_subplot(), from_dict({**SCENE, "world": {**SCENE["world"], "boundary": "open"}}))
    assert "world wall" not in {h.get_label() for h in opened}


def test_spawn_rectangle_is_the_region_agents_are_drawn_from():
    # with a spawn density the swarm is drawn from a square sized to n, not the declared box
    scn = from_dict({**SCENE, "swarm": {"n": 4, "spawn": [-4.0, -4.0, -1.0, -1.0], "density": 1.0}})
    ax = Figure().add_subplot()
    (rect,) = [h for h in draw_scene(ax, scn) if h.get_label() == "spawn region"]
    x0, y0, x1, y1 = scn.swarm.region
    assert (x1 - x0, y1 - y0) == (2.0, 2.0)  # sqrt(4 / 1) m, not the 3 m box
    assert rect.get_xy() == (x0, y0) and (rect.get_width(), rect.get_height()) == (x1 - x0, y1 - y0)


def test_periodic_wraps_are_not_drawn_as_motion():
    P = np.array([[[9.5, 1.0]], [[9.9, 1.0]], [[0.2, 1.0]], [[0.6, 1.0]]])  # crosses x = 10 -> 0
    _, valid = trajectory_segments(P, period=10.0)
    assert valid[:, 0].tolist() == [True, False, True]


@pytest.mark.parametrize("K_, stride, max_frames", [(1000, None, 300), (50, None, 300), (999, 2, 100), (7, 3, 300)])
def test_frame_steps_cover_run_within_budget(K_, stride, max_frames):
    f = frame_steps(K_, stride, max_frames)
    assert f[0] == 0 and f[-1] == K_ and len(f) <= max_frames
    assert np.all(np.diff(f) >= 1)
    if stride is not None:
        assert np.all(np.diff(f)[:-1] >= stride)
    if K_ < max_frames and stride is None:
        assert len(f) == K_ + 1  # no frame dropped when the budget allows all


def test_gif_has_one_frame_per_selected_step_and_shows_motion_and_labels(tmp_path):
    out = animate_run(make_result(), tmp_path / "run.gif", fps=10, max_frames=20)
    steps = frame_steps(K, None, 20)
    with Image.open(out) as im:
        assert im.format == "GIF"
        assert im.n_frames == len(steps)
        frames = []
        for j in range(im.n_frames):
            im.seek(j)
            frames.append(np.asarray(im.convert("RGB"), dtype=np.int16))
    assert not np.array_equal(frames[0], frames[-1])  # the dots moved
    # agent 2 is drawn in the colour of sub-swarm 1 exactly while it belongs to it
    in_sub1 = (steps > SPLIT_STEP) & (steps <= MERGE_STEP)
    assert [has_colour(f, TAB_ORANGE, min_pixels=10) for f in frames] == in_sub1.tolist()
    assert list(tmp_path.iterdir()) == [out]  # no partial file left behind


def test_unsupported_animation_format_is_a_user_error(tmp_path):
    with pytest.raises(SwarmnavError, match="unsupported animation format"):
        animate_run(make_result(), tmp_path / "run.avi")
    assert not any(tmp_path.iterdir())


def test_mp4_without_ffmpeg_is_a_user_error(tmp_path, monkeypatch):
    monkeypatch.setattr(animate_mod, "_ffmpeg_available", lambda: False)
    with pytest.raises(SwarmnavError, match="ffmpeg"):
        animate_run(make_result(), tmp_path / "run.mp4")


@pytest.mark.skipif(not animate_mod._ffmpeg_available(), reason="ffmpeg not installed")
def test_mp4_with_ffmpeg_is_an_mp4_file(tmp_path):
    out = animate_run(make_result(), tmp_path / "run.mp4", max_frames=10)
    assert out.read_bytes()[4:8] == b"ftyp"


@pytest.mark.parametrize("name", [n for n in builtin_names() if load_scenario(n).dim == 2])
def test_plot_scene_of_each_builtin_scene(tmp_path, name):
    # 3-D built-in scenes: tests/viz/test_viz3d.py
    out = plot_scene(load_scenario(name), tmp_path / f"scene_{name}.png")
    img = rgb_array(out)
    assert 600 <= img.shape[1] <= 3000
    assert has_colour(img, OBSTACLE_FACE, min_pixels=200) and has_colour(img, GOAL_FACE)
