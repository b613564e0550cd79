"""The README's speed table and its copies in the docs state the same numbers (issue 34: one number
per fact), as ``benchmarks/readme_speed.py`` checks them, and that check fails when they do not: every
fact is shown to fail when one of its numbers changes, on either side, or when its text is gone."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "readme_speed.py"
_spec = importlib.util.spec_from_file_location("readme_speed", SCRIPT)
speed = importlib.util.module_from_spec(_spec)
sys.modules["readme_speed"] = speed  # dataclasses resolve the module by name
_spec.loader.exec_module(speed)

README, PAGES = speed.read_pages()
IDS = [f.name.split(":")[0].split(" [")[0] for f in speed.FACTS]


def _bump(number: str) -> str:
    """``number`` with its last digit changed (0.14 -> 0.15, 538 -> 539, 9 -> 8)."""
    d = int(number[-1])
    return number[:-1] + str(d + 1 if d < 9 else d - 1)


def test_every_fact_is_found_on_both_sides_and_agrees():
    result = speed.compare(README, PAGES)
    assert len(result) == len(speed.FACTS) >= 7
    for fact, ours, theirs, why in result:
        assert ours and theirs and len(ours) == len(theirs), fact.name  # found, not skipped
        assert why == "", why


def test_the_script_exits_0_on_the_repository_and_prints_every_fact():
    p = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stdout + p.stderr
    assert f"{len(speed.FACTS)} of {len(speed.FACTS)} facts the same" in p.stdout


@pytest.mark.parametrize("fact", speed.FACTS, ids=IDS)
def test_a_changed_readme_number_fails_its_fact(fact):
    line = next(ln for ln in README.splitlines() if ln.startswith("|") and fact.row in ln.split("|")[1])
    cell = line.split("|")[2].strip()
    m = re.search(fact.figure, cell)
    start, end = m.span(1)
    changed_cell = cell[:start] + _bump(cell[start:end]) + cell[end:]
    readme = README.replace(line, line.replace(cell, changed_cell, 1), 1)
    assert readme != README
    failed = [f.name for f, _, _, why in speed.compare(readme, PAGES) if why]
    assert failed == [fact.name]


@pytest.mark.parametrize("fact", speed.FACTS, ids=IDS)
def test_a_changed_docs_number_fails_its_fact(fact):
    page = PAGES[fact.page]
    if fact.copy:
        m = re.search(fact.copy, page, flags=re.S)
        start, end = m.span(1)
    else:  # a table the fact is derived from: change the row that gives its first number (the minimum)
        first = speed.compare(README, PAGES)[speed.FACTS.index(fact)][2][0]
        written = f"{int(first):,}" if first.isdigit() else first
        m = re.search(rf"\| {re.escape(written)} \|", page)
        start, end = m.start() + 2, m.end() - 2
    changed = page[:start] + _bump(page[start:end]) + page[end:]
    assert changed != page
    failed = [f.name for f, _, _, why in speed.compare(README, {**PAGES, fact.page: changed}) if why]
    assert failed == [fact.name]


def test_a_missing_row_or_table_fails_rather_than_passes():
    no_table = README.replace("## Speed", "## Timings")
    result = speed.compare(no_table, PAGES)
    assert all("no README speed row" in why for _, _, _, why in result)
    gone = {**PAGES, "docs/methods/hes.md": PAGES["docs/methods/hes.md"].replace("1000 steps: 0.14 s", "1000 steps took 0.14 s")}
    why = {f.name: w for f, _, _, w in speed.compare(README, gone)}
    assert "no longer states this figure" in why[speed.FACTS[0].name]
