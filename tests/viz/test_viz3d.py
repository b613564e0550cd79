"""3-D figures and animations: solids span their obstacles, the box is the scene's, each
trajectory segment is drawn once in its sub-swarm's colour, the GIF has one frame per step."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.colors import to_rgb, to_rgba  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Path3DCollection, Poly3DCollection  # noqa: E402
from PIL import Image  # noqa: E402

from swarmnav.errors import SwarmnavError  # noqa: E402
from swarmnav.sim.result import RunResult  # noqa: E402
from swarmnav.viz import animate_run, draw_scene, plot_run, plot_scene  # noqa: E402
from swarmnav.viz import draw3d  # noqa: E402
from swarmnav.viz.animate import frame_steps  # noqa: E402
from swarmnav.viz.style import END_COLOR, GOAL_FACE, START_COLOR  # noqa: E402
from swarmnav.world.catalog import load_scenario  # noqa: E402
from swarmnav.world.obstacles import Box, Cylinder, Polygon, Sphere  # noqa: E402
from swarmnav.world.scenario import builtin_names, from_dict  # noqa: E402

SCENE = {
    "name": "viz3d_test",
    "description": "one solid of each kind in a closed box",
    "world": {"bounds": [0.0, 0.0, 0.0, 30.0, 16.0, 6.0]},
    "swarm": {"n": 4, "spawn": [1.0, 6.0, 1.0, 4.0, 10.0, 3.0]},
    "goal": {"position": [28.0, 8.0, 2.0]},
    "obstacles": [
        {"type": "box", "min": [8.0, 2.0, 0.0], "max": [10.0, 5.0, 3.0]},
        {"type": "cylinder", "center": [14.0, 11.0], "radius": 1.0, "z": [0.0, 5.0]},
        {"type": "sphere", "center": [19.0, 5.0, 3.0], "radius": 1.5},
        {"type": "polygon", "points": [[22.0, 10.0], [25.0, 14.0], [26.0, 9.0]], "z": [0.5, 4.0]},  # clockwise
        {"type": "box", "min": [0.0, 0.0, 6.0], "max": [30.0, 16.0, 6.5]},  # ceiling: drawn as an outline
    ],
}
K, N = 60, 4
SPLIT, MERGE = 19, 39  # labels[k] -> labels[k + 1] at these steps
TAB_ORANGE = to_rgb("tab:orange")


def make_result(split: bool = True) -> RunResult:
    """4 agents flying from the spawn box to near the goal, climbing; agents 2 and 3 form
    sub-swarm 1 for k in (19, 39]."""
    scn = from_dict(SCENE)
    start = np.array([[2.0, 7.0, 1.5], [2.0, 9.0, 1.5], [3.0, 7.0, 2.5], [3.0, 9.0, 2.5]])
    end = np.array(scn.goal) + np.array([[-1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, -1.0, 1.0], [0.0, 1.0, 1.0]])
    t = np.linspace(0.0, 1.0, K + 1)[:, None, None]
    P = start[None] * (1 - t) + end[None] * t
    P[:, :, 2] += 1.5 * np.sin(np.pi * t[:, :, 0])  # an arc over the obstacles
    labels = np.zeros((K + 1, N), dtype=np.int32)
    events = []
    if split:
        labels[SPLIT + 1:MERGE + 1, 2:] = 1
        events = [{"step": SPLIT, "action": "split"}, {"step": MERGE, "action": "merge"}]
    clearance = 1.0 + 0.5 * np.cos(np.linspace(0, 5, K + 1))[:, None] * np.ones((1, N))
    return RunResult(
        config={"method": "sph", "scenario": scn.to_dict(), "seed": 3, "steps": K, "dt": 0.1},
        positions=P, velocities=np.gradient(P, 0.1, axis=0), clearance=clearance, labels=labels,
        events=events, metrics={"Y": 1.0, "R_goal": 1.0, "E_mean": 0.5, "R_unsafe": 0.0},
    )


def rgb_array(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"), dtype=np.int16)


def count_colour(img: np.ndarray, colour, tol: int = 3) -> int:
    target = np.round(np.asarray(to_rgb(colour)) * 255).astype(np.int16)
    return int(np.all(np.abs(img - target) <= tol, axis=-1).sum())


def saved_figure(monkeypatch) -> list[Figure]:
    """Figures passed to ``Figure.savefig`` from now on (the public functions return paths)."""
    figs: list[Figure] = []
    save = Figure.savefig

    def spy(self, *args, **kwargs):
        figs.append(self)
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", spy)
    return figs


# ----------------------------------------------------------------------------- solids


def test_box_faces_are_its_six_sides_with_outward_normals():
    box = Box((8.0, 2.0, 0.0), (10.0, 5.0, 3.0))
    faces, normals, edged = draw3d.obstacle_faces(box)
    assert len(faces) == 6 and all(f.shape == (4, 3) for f in faces) and edged.all()
    v = np.vstack(faces)
    np.testing.assert_array_equal(v.min(axis=0), box.min)
    np.testing.assert_array_equal(v.max(axis=0), box.max)
    centre = (np.asarray(box.min) + np.asarray(box.max)) / 2
    for f, n in zip(faces, normals):
        # each face is planar with the normal, and the normal points away from the centre
        np.testing.assert_allclose((f - f[0]) @ n, 0.0, atol=1e-12)
        assert (f.mean(axis=0) - centre) @ n > 0
    assert sorted(map(tuple, np.abs(normals))) == sorted([(1, 0, 0)] * 2 + [(0, 1, 0)] * 2 + [(0, 0, 1)] * 2)


def test_prism_of_a_clockwise_footprint_still_faces_outward():
    prism = Polygon(((22.0, 10.0), (25.0, 14.0), (26.0, 9.0)), z=(0.5, 4.0))
    faces, normals, edged = draw3d.obstacle_faces(prism)
    assert len(faces) == 3 + 2 and edged.all()
    v = np.vstack(faces)
    np.testing.assert_array_equal(v.min(axis=0), (22.0, 9.0, 0.5))
    np.testing.assert_array_equal(v.max(axis=0), (26.0, 14.0, 4.0))
    centroid = np.r_[np.mean(prism.points, axis=0), 2.25]
    assert all((f.mean(axis=0) - centroid) @ n > 0 for f, n in zip(faces, normals))


@pytest.mark.parametrize("sides", [8, 24])
def test_cylinder_faces_lie_on_the_cylinder(sides):
    cyl = Cylinder((14.0, 11.0), 1.0, (0.0, 5.0))
    faces, normals, edged = draw3d.obstacle_faces(cyl, sides)
    assert len(faces) == sides + 2
    assert not edged[:sides].any() and edged[sides:].all()  # seams unlined, rims outlined
    v = np.vstack(faces)
    np.testing.assert_allclose(np.hypot(v[:, 0] - 14.0, v[:, 1] - 11.0), 1.0)
    assert (v[:, 2].min(), v[:, 2].max()) == (0.0, 5.0)


def test_sphere_faces_lie_on_the_sphere_and_reach_its_poles():
    sph = Sphere((19.0, 5.0, 3.0), 1.5)
    faces, normals, edged = draw3d.obstacle_faces(sph, 16)
    assert len(faces) == 16 * 8 and not edged.any()
    v = np.vstack(faces)
    np.testing.assert_allclose(np.linalg.norm(v - sph.center, axis=1), 1.5)
    np.testing.assert_allclose((v[:, 2].min(), v[:, 2].max()), (1.5, 4.5))
    assert all((f.mean(axis=0) - sph.center) @ n > 0 for f, n in zip(faces, normals))


def test_a_forest_of_150_trees_stays_within_the_face_budget():
    trees = [Cylinder((float(i), 0.0), 0.3, (0.0, 6.0)) for i in range(150)]
    s = draw3d.curved_sides(trees)
    assert draw3d.MIN_SIDES <= s <= draw3d.MAX_SIDES
    assert 150 * (s + 2) <= draw3d.CURVED_FACE_BUDGET
    assert draw3d.curved_sides(trees[:3]) == draw3d.MAX_SIDES  # a few get the finest mesh


# ----------------------------------------------------------------------------- scene


def test_draw_scene_3d_has_every_solid_face_and_the_scene_box():
    scn = from_dict(SCENE)
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = draw3d.new_axes(fig)
    handles = draw_scene(ax, scn)
    (solids,) = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    sides = draw3d.curved_sides(scn.obstacles)
    # box 6 + cylinder (sides + 2) + sphere sides * sides / 2 + triangle prism 5; the ceiling is no solid
    expected = 6 + (sides + 2) + sides * (sides // 2) + 5
    fig.canvas.draw()
    assert len(solids.get_paths()) == expected
    assert {h.get_label() for h in handles} == {"obstacle", "walls, ground, ceiling", "spawn region", "goal"}
    assert (ax.get_xlim(), ax.get_ylim(), ax.get_zlim()) == ((0.0, 30.0), (0.0, 16.0), (0.0, 6.0))
    aspect = ax.get_box_aspect()
    np.testing.assert_allclose(aspect / aspect[0], np.array([30.0, 16.0, 6.0]) / 30.0)  # true scale
    assert (ax.elev, ax.azim) == draw3d.CAMERA
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()) == ("x [m]", "y [m]", "z [m]")


def test_a_3d_scene_on_a_planar_axes_is_a_clear_error():
    with pytest.raises(SwarmnavError, match="3-D axes"):
        draw_scene(Figure().add_subplot(), from_dict(SCENE))


def test_plot_scene_3d_fills_the_figure_with_the_scene(tmp_path, monkeypatch):
    figs = saved_figure(monkeypatch)
    img = rgb_array(plot_scene(from_dict(SCENE), tmp_path / "scene.png"))
    (fig,) = figs
    (ax,) = [a for a in fig.axes if a.name == "3d"]
    # the scene box spans most of the figure's width (mplot3d alone leaves it a third)
    corners = draw3d.box_on_screen(ax)
    assert np.ptp(corners[:, 0]) > 0.75 * fig.bbox.width
    assert corners[:, 1].min() > 0 and corners[:, 1].max() < fig.bbox.height  # and stays inside it
    assert count_colour(img, GOAL_FACE) > 50
    non_white = np.any(img < 235, axis=-1).mean()
    assert non_white > 0.05  # solids, panes and labels drawn


@pytest.mark.parametrize("name", [n for n in builtin_names() if load_scenario(n).dim == 3])
def test_plot_scene_of_each_builtin_3d_scene(tmp_path, name):
    img = rgb_array(plot_scene(load_scenario(name), tmp_path / f"{name}.png"))
    assert 600 <= img.shape[1] <= 3000
    # the shaded solids: many pixels of the solid grey darkened over white, but not a wall of it
    grey = np.all(np.abs(img - img.mean(axis=-1, keepdims=True)) < 12, axis=-1) & (img.mean(axis=-1) < 215)
    assert 0.02 < grey.mean() < 0.5
    assert count_colour(img, GOAL_FACE) > 50


# ----------------------------------------------------------------------------- runs


def test_plot_run_3d_draws_each_segment_once_in_its_subswarm_colour(tmp_path, monkeypatch):
    r = make_result()
    figs = saved_figure(monkeypatch)
    out = plot_run(r, tmp_path / "run.png")
    (fig,) = figs
    (ax,) = [a for a in fig.axes if a.name == "3d"]
    lines = [c for c in ax.collections if isinstance(c, Line3DCollection) and c.get_zorder() == 3]
    (traj,) = lines
    segs = np.asarray(traj._segments3d)  # the 3-D segments as given (no public getter in mplot3d)
    assert segs.shape == (K * N, 2, 3)
    np.testing.assert_allclose(segs[:, 0], r.positions[:-1].reshape(-1, 3))
    np.testing.assert_allclose(segs[:, 1], r.positions[1:].reshape(-1, 3))
    colours = traj.get_colors()[:, :3].reshape(K, N, 3)
    in_sub1 = np.zeros((K, N), dtype=bool)
    in_sub1[SPLIT + 1:MERGE + 1, 2:] = True
    np.testing.assert_allclose(colours[in_sub1], np.tile(TAB_ORANGE, (in_sub1.sum(), 1)))
    np.testing.assert_allclose(colours[~in_sub1], np.tile(to_rgb("tab:blue"), ((~in_sub1).sum(), 1)))
    # start and end dots at the first and last positions, not depth-dimmed
    dots = {tuple(to_rgba(c.get_facecolor()[0])): c for c in ax.collections if isinstance(c, Path3DCollection)}
    np.testing.assert_allclose(np.column_stack(dots[to_rgba(START_COLOR)]._offsets3d), r.positions[0])
    np.testing.assert_allclose(np.column_stack(dots[to_rgba(END_COLOR)]._offsets3d), r.positions[-1])
    # the time-series panel is there, with one curve of min clearance over the whole run
    ax_t = [a for a in fig.axes if a.get_title(loc="left") == "(b) clearance and structure"]
    assert len(ax_t) == 1 and len(ax_t[0].lines[0].get_xdata()) == K + 1
    img = rgb_array(out)
    assert count_colour(img, TAB_ORANGE) > 100 and count_colour(img, "tab:blue") > 100


def test_plot_run_3d_without_a_split_has_no_second_colour(tmp_path):
    img = rgb_array(plot_run(make_result(split=False), tmp_path / "run.png"))
    assert count_colour(img, TAB_ORANGE) == 0


def test_gif_3d_has_one_frame_per_step_and_shows_the_split(tmp_path):
    out = animate_run(make_result(), tmp_path / "run.gif", fps=10, max_frames=25)
    steps = frame_steps(K, None, 25)
    with Image.open(out) as im:
        assert im.n_frames == len(steps)
        frames = []
        for j in range(im.n_frames):
            im.seek(j)
            frames.append(np.asarray(im.convert("RGB"), dtype=np.int16))
    assert not np.array_equal(frames[0], frames[-1])
    in_sub1 = (steps > SPLIT) & (steps <= MERGE)
    assert [count_colour(f, TAB_ORANGE) >= 10 for f in frames] == in_sub1.tolist()
