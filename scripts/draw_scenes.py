"""Write docs/figures/scene_<name>.png for every built-in scene.

Usage: python scripts/draw_scenes.py [OUT_DIR]   (default: docs/figures next to this script)
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

from swarmnav.viz import plot_scene  # noqa: E402
from swarmnav.world.scenario import builtin_names, load_scenario  # noqa: E402


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).resolve().parent.parent / "docs" / "figures"
    for name in builtin_names():
        print(plot_scene(load_scenario(name), out / f"scene_{name}.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
