"""The ``swarmnav`` command as a user runs it: a fresh process of this checkout's code."""

import os
import subprocess
import sys
from pathlib import Path

import swarmnav


def run_cli(*args: str) -> subprocess.CompletedProcess:
    """``python -m swarmnav.cli ARGS`` in a fresh process (this checkout's ``src`` first on the
    path), its stdout and stderr captured as text."""
    src = str(Path(swarmnav.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-m", "swarmnav.cli", *map(str, args)], capture_output=True, text=True,
                          env=env)
