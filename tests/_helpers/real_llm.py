"""The real-model LLM tests' guard: skip when the model packages are missing (with the reason
scripts/test.sh reported), but fail under CI, which must install them."""

from __future__ import annotations

import importlib.util
import os

import pytest


def require(*modules: str) -> None:
    """Skip (or, under CI, fail) unless every one of ``modules`` can be imported."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if not missing:
        return
    msg = f"{', '.join(missing)} not installed"
    if reported := os.environ.get("SWARMNAV_REAL_LLM_SKIP"):
        pytest.skip(f"{msg}: {reported}")
    msg += ": pip install -e '.[llm-test]' (CMAKE_ARGS=-DGGML_NATIVE=OFF)"
    if os.environ.get("CI"):
        pytest.fail(f"CI must install the real-model test dependencies: {msg}", pytrace=False)
    pytest.skip(msg)
