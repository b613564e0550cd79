"""Shared by the browser tests of the replay viewer: one headless Chromium per test module."""

import pytest

from swarmnav.viz.headless import Browser


@pytest.fixture(scope="module")
def browser():
    with Browser(1100, 700) as b:
        yield b
