"""Animation of a stored run: agents as dots coloured by sub-swarm, short trails, the scene
and a time stamp; a 3-D run is seen from the camera of its ``plot_run`` figure. GIF is written with Pillow alone; MP4 needs the ffmpeg program.

Frames are drawn by blitting onto one Agg canvas and handed to Pillow or to an ffmpeg pipe
directly; matplotlib's PillowWriter / FFMpegWriter redraw the whole figure for every frame,
which made a 250-frame, 20-agent GIF take ~18 s instead of ~2 s.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Line3DCollection
from PIL import Image

from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.viz import draw3d
from swarmnav.viz.draw import dot_size, draw_scene, fig_size, label_colors, period_of, scenario_of, trajectory_segments

if TYPE_CHECKING:
    from swarmnav.sim.result import RunResult

FORMATS = (".gif", ".mp4")
#: Most positions per agent drawn in one trail (our choice: a smooth tail at any stride).
TRAIL_POINTS = 12


def animate_run(
    result: RunResult,
    out_path: str | Path,
    *,
    fps: int = 20,
    stride: int | None = None,
    max_frames: int = 300,
    trail: float = 3.0,
    dpi: int = 80,
) -> Path:
    """Write an animation of ``result``; the format follows the extension of ``out_path``.

    Args:
        result: the run.
        out_path: ``.gif`` (Pillow) or ``.mp4`` (ffmpeg, must be on PATH).
        fps: frames per second of the output.
        stride: simulation steps per frame; default and any too small value are raised to
            the smallest stride giving at most ``max_frames`` frames. The last step is
            always the last frame.
        max_frames: most frames written (>= 2).
        trail: length of each agent's trail [s].
        dpi: resolution [dots per inch] of the frames (at most 8 inches wide).

    Raises:
        SwarmnavError: unsupported extension, or ``.mp4`` without ffmpeg.
    """
    out = Path(out_path)
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise SwarmnavError(f"{out}: unsupported animation format '{out.suffix}' (use .gif or .mp4)")
    if suffix == ".mp4" and not _ffmpeg_available():
        raise SwarmnavError(f"{out}: writing .mp4 needs ffmpeg on PATH; install ffmpeg or write a .gif")
    if fps <= 0:
        raise ConfigError(f"fps must be > 0, got {fps}")
    if trail < 0:
        raise ConfigError(f"trail must be >= 0 [s], got {trail}")
    scn = scenario_of(result)
    P = result.positions
    K, N, d = P.shape
    K -= 1
    dt = float(result.config.get("dt", 1.0))
    frames = frame_steps(K, stride, max_frames)
    idx, palette = label_colors(result.labels)
    n_sub = result.n_subswarms
    period = period_of(scn)
    trail_steps = int(round(trail / dt)) if dt > 0 else 0

    title = f"{result.config.get('method', '?')} on {scn.name}, seed {result.config.get('seed', '?')}"
    stamp_box = {"facecolor": "white", "alpha": 0.8, "edgecolor": "none", "pad": 2}
    if scn.dim == 3:
        # the camera, solids and box of plot_run; dots keep their colours at any depth
        fig, ax = draw3d.panel_figure(scn, width=8.0, top=0.4, max_height=6.0)
        fig.set_dpi(dpi)
        canvas = FigureCanvasAgg(fig)
        draw_scene(ax, scn, show_spawn=False)
        h = fig.get_figheight()
        fig.suptitle(title, fontsize=10, y=1 - 0.08 / h, va="top")
        trails = Line3DCollection([], linewidths=0.8, alpha=0.5, zorder=3)
        ax.add_collection(trails, autolim=False)
        dots = ax.scatter(*P[0].T, s=2 * dot_size(N), c=palette[idx[0]], edgecolors="black", linewidths=0.3,
                          zorder=5, depthshade=False)
        stamp = fig.text(0.01, 1 - 0.45 / h, "", ha="left", va="top", fontsize=9, zorder=8, bbox=stamp_box)
    else:
        fig = Figure(figsize=fig_size(scn.bounds, 8.0, extra_height=0.6, max_map_height=6.0), dpi=dpi,
                     layout="constrained")
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        draw_scene(ax, scn, show_spawn=False)
        ax.set_title(title, fontsize=10)
        trails = LineCollection([], linewidths=0.8, alpha=0.5, zorder=3)
        ax.add_collection(trails, autolim=False)
        dots = ax.scatter(P[0, :, 0], P[0, :, 1], s=2 * dot_size(N), c=palette[idx[0]], edgecolors="black",
                          linewidths=0.3, zorder=5)
        stamp = ax.text(0.01, 0.98, "", transform=ax.transAxes, ha="left", va="top", fontsize=9, zorder=8,
                        bbox=stamp_box)
    moving = (trails, dots, stamp)

    def set_frame(k: int) -> None:
        dots.set_offsets(P[k, :, :2])
        if d == 3:
            dots.set_3d_properties(P[k, :, 2], "z")
        dots.set_facecolor(palette[idx[k]])
        k0 = max(0, k - trail_steps)
        if k > k0:
            # Trails through at most TRAIL_POINTS positions, always ending at the current one,
            # drawn as one NaN-separated path per colour: a Path per agent or per segment costs
            # 10-100x more per frame for large swarms.
            ts = np.unique(np.r_[np.arange(k, k0 - 1, -max(1, math.ceil((k - k0) / TRAIL_POINTS)))[::-1], k])
            pts = np.full((N, len(ts) + 1, d), np.nan)  # the last column separates agents
            pts[:, :-1] = P[ts].transpose(1, 0, 2)
            if period is not None:  # a wrap-around is not motion: break the line there
                _, valid = trajectory_segments(P[ts], period)
                pts[:, 1:-1][~valid.T] = np.nan
            groups = np.unique(idx[k])
            trails.set_segments([pts[idx[k] == g].reshape(-1, d) for g in groups])
            trails.set_color(palette[groups])
        else:
            trails.set_segments([])
        stamp.set_text(f"t = {k * dt:6.1f} s   sub-swarms: {n_sub[k]}")

    # Blitting: the scene, axes and title are rendered once; each frame restores that image and
    # draws only the moving artists (a full redraw per frame is ~10x slower, mostly tick labels).
    for a in moving:
        a.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)

    def render(k: int) -> np.ndarray:
        set_frame(int(k))
        canvas.restore_region(background)
        for a in moving:
            if d == 3 and hasattr(a, "do_3d_projection"):
                a.do_3d_projection()  # Axes3D.draw does this for a full redraw; blitting must
            ax.draw_artist(a)
        return np.asarray(canvas.buffer_rgba())  # (H, W, 4) view of the canvas

    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.stem}.partial{suffix}")  # a killed run never leaves a half file at `out`
    try:
        if suffix == ".gif":
            _write_gif(tmp, (render(k) for k in frames), fps, palette)
        else:
            _write_mp4(tmp, (render(k) for k in frames), fps)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out


def frame_steps(K: int, stride: int | None, max_frames: int) -> np.ndarray:
    """Steps shown as frames: ``0, s, 2s, ...`` and always ``K``, at most ``max_frames`` of them.

    The smallest admissible stride is ``ceil(K / (max_frames - 1))``: then ``floor(K / s) + 1``
    regular frames plus the final one never exceed ``max_frames``.
    """
    if max_frames < 2:
        raise ConfigError(f"max_frames must be >= 2, got {max_frames}")
    if stride is not None and stride < 1:
        raise ConfigError(f"stride must be >= 1, got {stride}")
    s = max(stride or 1, math.ceil(K / (max_frames - 1)), 1)
    return np.unique(np.r_[np.arange(0, K + 1, s), K])


def _write_gif(path: Path, frames, fps: float, palette: np.ndarray) -> None:
    """GIF with Pillow. Every frame is mapped to one shared 256-colour palette: the sub-swarm
    colours exactly, the rest taken from the first frame, so colours do not flicker between
    frames and a sub-swarm colour is never merged into a shade of the scene (the shaded solids
    of a 3-D scene fill a median-cut palette with greys)."""
    first = next(frames)[..., :3].copy()
    exact = np.unique((palette[:, :3] * 255).round().astype(np.uint8), axis=0)[:128]
    scene = Image.fromarray(first).quantize(256 - len(exact))
    colours = scene.getpalette()[: 3 * (256 - len(exact))] + exact.ravel().tolist()
    ref = Image.new("P", (1, 1))
    ref.putpalette(colours)

    def quantized(rgb: np.ndarray) -> Image.Image:
        return Image.fromarray(rgb).quantize(palette=ref, dither=Image.Dither.NONE)

    head = quantized(first)
    rest = [quantized(f[..., :3]) for f in frames]
    head.save(path, format="GIF", save_all=True, append_images=rest, duration=round(1000 / fps), loop=0)


def _write_mp4(path: Path, frames, fps: float) -> None:
    """H.264 MP4 by piping raw RGBA frames to ffmpeg (frame sides padded to even numbers,
    as yuv420p requires)."""
    first = next(frames)
    h, w = first.shape[:2]
    cmd = [
        _ffmpeg_path() or "ffmpeg", "-y", "-loglevel", "error",
        "-f", "rawvideo", "-pix_fmt", "rgba", "-s", f"{w}x{h}", "-r", str(fps), "-i", "-",
        "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264", "-pix_fmt", "yuv420p",
        "-f", "mp4", str(path),
    ]
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log)
        try:
            proc.stdin.write(first.tobytes())
            for f in frames:
                proc.stdin.write(f.tobytes())
            proc.stdin.close()
        except BrokenPipeError:
            pass  # ffmpeg stopped early; its exit code and log say why
        finally:
            rc = proc.wait()
        if rc != 0:
            log.seek(0)
            lines = log.read().decode(errors="replace").strip().splitlines()
            raise SwarmnavError(f"{path}: ffmpeg failed (exit {rc}): {lines[-1] if lines else 'no message'}")


def _ffmpeg_path() -> str | None:
    """The ffmpeg executable matplotlib is configured to use (``animation.ffmpeg_path``), if found."""
    return shutil.which(matplotlib.rcParams["animation.ffmpeg_path"])


def _ffmpeg_available() -> bool:
    return _ffmpeg_path() is not None
