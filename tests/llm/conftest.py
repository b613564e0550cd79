"""Fixtures of the LLM tests: loopback fake servers (closed at teardown) and a scripted back end."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from llm_fakeserver import FakeLlmServer  # noqa: E402

from swarmnav.llm.backends import LlmError, Reply  # noqa: E402


@pytest.fixture
def fake_server():
    """``fake_server(mode, **kw)`` starts a FakeLlmServer on 127.0.0.1; all are closed after the test."""
    servers: list[FakeLlmServer] = []

    def start(mode: str = "rules", **kw) -> FakeLlmServer:
        s = FakeLlmServer(mode, **kw)
        servers.append(s)
        return s

    yield start
    for s in servers:
        s.close()


class ScriptedBackend:
    """A back end answering from a list: a string is the raw answer, an LlmError is raised."""

    name = "scripted"
    model = "script"

    def __init__(self, answers, latency: float = 0.0):
        self.answers = list(answers)
        self.latency = latency
        self.asked: list[tuple[int, str]] = []

    def complete(self, prompt: str, step: int) -> Reply:
        self.asked.append((step, prompt))
        a = self.answers[min(len(self.asked) - 1, len(self.answers) - 1)]
        if isinstance(a, Exception):
            raise a
        return Reply(a, self.latency)


@pytest.fixture
def scripted():
    return ScriptedBackend


__all__ = ["LlmError"]
