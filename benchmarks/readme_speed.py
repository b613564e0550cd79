"""The README's speed table against its copies in the docs, and (``--check``) against the benchmarks.

One number per fact: a speed figure the README quotes and a docs page repeats must be the same
number in both. ``FACTS`` names each such fact: the README row it is in (a phrase of the row's
*what* cell), the numbers of its *figure* cell, and where the docs state it. The script prints
every fact with both copies and exits 1 if any differs, if a row or a docs copy cannot be found
(a fact whose text moved is a failure, not a skip), or if the README's speed table is gone.

    python benchmarks/readme_speed.py              # README vs docs, no benchmark run (instant)
    PYTHONPATH=src python benchmarks/readme_speed.py --check   # + re-measure the cheap rows

``--check`` re-runs the rows that take seconds (``bench_hes.py``: HES, 1000 steps, on
default_corridor and on narrow_alternating_gates, and the step at N = 20 / 100 / 500; CPU time, one
core, best of 3; about 20 s) and compares each
with the README's figure within ``TOLERANCE`` (a factor of 2 either way: on this shared 2-core
machine the same benchmark moved by up to 2x with the load, docs/env.md). Rows whose benchmark takes
minutes (sweeps, N = 1e5 steps, VMAS) are checked against the docs only.
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 2.0  # [x] --check: a measured figure within this factor of the README's passes


@dataclass(frozen=True)
class Fact:
    """One speed figure the README's table quotes and a docs page repeats."""

    name: str
    row: str  # a phrase of the README row's first cell
    figure: str  # regex on the README row's figure cell; its groups are the fact's numbers
    page: str  # the docs page that repeats it
    copy: str  # regex on that page (whitespace-tolerant, across lines); its groups are the same numbers


def _ws(pattern: str) -> str:
    """A pattern whose spaces match any run of whitespace (docs text wraps lines anywhere)."""
    return pattern.replace(" ", r"\s+")


FACTS = (
    Fact("hes, 1000 steps, default_corridor [s CPU]", "`hes`, N = 20, 1000 steps (`default_corridor`)",
         r"^([\d.]+) s$", "docs/methods/hes.md", _ws(r"default_corridor, N = 20, 1000 steps: ([\d.]+) s")),
    Fact("hes, 1000 steps, narrow_alternating_gates [s CPU]", "`hes` on `narrow_alternating_gates`",
         r"^([\d.]+) s$", "docs/methods/hes.md", _ws(r"narrow_alternating_gates \(passages, stall planner\): ([\d.]+) s")),
    Fact("hes step at N = 20 / 100 / 500 [ms CPU]", "`hes` step at N = 20 / 100 / 500",
         r"^([\d.]+) / ([\d.]+) / ([\d.]+) ms$", "docs/methods/hes.md",
         _ws(r"([\d.]+), ([\d.]+) and ([\d.]+) ms per step")),
    Fact("SPH planning per replan, guard: median and p95 ranges [ms]", "SPH planning, per robot per replan (`guard`",
         r"^median ([\d.]+)–([\d.]+) ms, p95 ([\d.]+)–([\d.]+) ms$", "docs/reproduction/table2.md",
         r"\| SPH \(`guard`\) \| ([\d.]+)–([\d.]+) ms \| ([\d.]+)–([\d.]+) ms \|"),
    Fact("vem step at N = 1e5, ours / NumPy + cKDTree [ms] and ratio", "`vem` step, N = 1e5",
         r"^([\d.]+) ms; ([\d.]+)x faster than the usual NumPy \+ cKDTree Vicsek step measured beside it \(([\d.]+) ms\)$",
         "docs/methods/vicsek.md", r"\| 10\^5 \| ([\d.]+) ms \([\d.]+ steps/s\) \| ([\d.]+) ms \| ([\d.]+)× \|"),
    Fact("LiDAR per ray on 512 x 512 maps, rooms / random [ns] and ratios to the corridor",
         "LiDAR ring on 512 x 512 MovingAI-style maps",
         r"^([\d.]+) / ([\d.]+) ns \(([\d.]+)x / ([\d.]+)x the corridor's", "docs/maps.md",
         r"\| room512-32 style map [^|]*\| [\d ]+ \| ([\d.]+) \| ([\d.]+)× \|.*?"
         r"\| random512-25 style map [^|]*\| [\d ]+ \| ([\d.]+) \| ([\d.]+)× \|"),
    Fact("portable / native wall time: range and geometric mean", "portable numerics (the default) against native",
         r"^([\d.]+)-([\d.]+)x wall time, geometric mean ([\d.]+)$", "docs/determinism.md", ""),
    Fact("swarmnav.env vs VMAS: env steps/s (1 env, 64 copies) and ratio ranges", "`swarmnav.env`, 20 agents",
         r"^([\d,]+)-([\d,]+) / ([\d,]+)-([\d,]+) env steps/s \(([\d]+)-([\d]+)x VMAS", "docs/env.md", ""),
)


def _order(fact: Fact, readme: list[str]) -> list[str]:
    """The README's numbers in the order the docs copy states them (vem: the ratio comes last there)."""
    if fact.name.startswith("vem"):
        ours, ratio, plain = readme
        return [ours, plain, ratio]
    if fact.name.startswith("LiDAR per ray on 512"):
        rooms, scattered, rooms_x, scattered_x = readme
        return [rooms, rooms_x, scattered, scattered_x]
    return readme


def _derived(fact: Fact, page: str) -> list[str] | None:
    """The numbers of a fact the docs state as a table rather than a sentence: the ranges over its rows."""
    if fact.page == "docs/determinism.md":
        ratios = [float(m) for m in re.findall(r"^\| `\w+` .*\| ([\d.]+) \|$", page, flags=re.M)]
        mean = re.search(r"Geometric mean ([\d.]+)", page)
        if not ratios or not mean:
            return None
        return [f"{min(ratios):.2f}", f"{max(ratios):.2f}", mean.group(1)]
    if fact.page == "docs/env.md":
        rows = re.findall(r"^\| \d+ \(load [\d.]+\) \| (\d+) \| ([\d,]+) \| [\d.]+ \| (\d+)x \|$", page, flags=re.M)
        if not rows:
            return None
        one = [int(r[1].replace(",", "")) for r in rows if r[0] == "1"]
        many = [int(r[1].replace(",", "")) for r in rows if r[0] != "1"]
        ratio = [int(r[2]) for r in rows]
        return [str(v) for v in (min(one), max(one), min(many), max(many), min(ratio), max(ratio))]
    return None


def speed_rows(readme: str) -> dict[str, str]:
    """The README's ``## Speed`` tables: first cell -> second cell (the figure), header rows dropped."""
    m = re.search(r"^## Speed\n(.*?)(?=^## )", readme, flags=re.S | re.M)
    if not m:
        return {}
    rows = {}
    for line in m.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")] if line.startswith("|") else []
        if len(cells) >= 2 and cells[0] not in ("what",) and not set(cells[0]) <= set("-: "):
            rows[cells[0]] = cells[1]
    return rows


def compare(readme: str, pages: dict[str, str]) -> list[tuple[Fact, list[str] | None, list[str] | None, str]]:
    """Each fact with its README numbers, its docs numbers and "" if they agree, else what is wrong."""
    rows = speed_rows(readme)
    out = []
    for fact in FACTS:
        cell = next((fig for what, fig in rows.items() if fact.row in what), None)
        m = re.search(fact.figure, cell) if cell is not None else None
        ours = _order(fact, [g.replace(",", "") for g in m.groups()]) if m else None
        page = pages.get(fact.page)
        if page is None:
            theirs = None
        elif fact.copy:
            c = re.search(fact.copy, page, flags=re.S)
            theirs = list(c.groups()) if c else None
        else:
            theirs = _derived(fact, page)
        if cell is None:
            why = f"no README speed row contains {fact.row!r}"
        elif ours is None:
            why = f"the README figure {cell!r} does not read as {fact.figure!r}"
        elif theirs is None:
            why = f"{fact.page} no longer states this figure where the script looks for it"
        elif ours != theirs:
            why = f"README {', '.join(ours)} but {fact.page} {', '.join(theirs)}"
        else:
            why = ""
        out.append((fact, ours, theirs, why))
    return out


def read_pages() -> tuple[str, dict[str, str]]:
    return (ROOT / "README.md").read_text(encoding="utf-8"), {
        f.page: (ROOT / f.page).read_text(encoding="utf-8") for f in FACTS if (ROOT / f.page).exists()}


def check_benchmarks(readme: str) -> list[str]:
    """Re-measure the cheap rows; a figure more than TOLERANCE x off the README's is a problem."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_hes

    rows = speed_rows(readme)
    problems = []
    for fact, scene in ((FACTS[0], "default_corridor"), (FACTS[1], "narrow_alternating_gates")):
        cell = next(fig for what, fig in rows.items() if fact.row in what)
        quoted = float(re.search(fact.figure, cell).group(1))
        got = bench_hes.measure(ROOT / "src", scene, 1000, 3)["cpu"]
        ok = quoted / TOLERANCE <= got <= quoted * TOLERANCE
        print(f"  measured: {fact.name}: {got:.3f} s, README {quoted:g} s ({got / quoted:.2f}x) "
              f"{'ok' if ok else f'OUTSIDE {TOLERANCE:g}x'}")
        if not ok:
            problems.append(f"{fact.name}: measured {got:.3f} s, README {quoted:g} s")
    fact = FACTS[2]  # the step at N = 20 / 100 / 500, first 200 steps of the scaling field
    cell = next(fig for what, fig in rows.items() if fact.row in what)
    scene = str(ROOT / "benchmarks" / "scenes" / "hes_scaling.toml")
    for n, quoted in zip((20, 100, 500), (float(v) for v in re.search(fact.figure, cell).groups())):
        got = bench_hes.measure(ROOT / "src", scene, 200, 3, n)["cpu"] / 200 * 1e3
        ok = quoted / TOLERANCE <= got <= quoted * TOLERANCE
        print(f"  measured: hes step at N = {n}: {got:.3f} ms, README {quoted:g} ms ({got / quoted:.2f}x) "
              f"{'ok' if ok else f'OUTSIDE {TOLERANCE:g}x'}")
        if not ok:
            problems.append(f"hes step at N = {n}: measured {got:.3f} ms, README {quoted:g} ms")
    return problems


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help=f"also re-run the cheap benchmarks (within {TOLERANCE:g}x)")
    a = ap.parse_args(argv)
    readme, pages = read_pages()
    if not speed_rows(readme):
        print("README.md has no '## Speed' table")
        return 1
    bad = 0
    for fact, ours, theirs, why in compare(readme, pages):
        bad += bool(why)
        print(f"{'DIFFERS' if why else 'same':8s} {fact.name}: README {', '.join(ours or ['?'])}; "
              f"{fact.page} {', '.join(theirs or ['?'])}" + (f"  <- {why}" if why else ""))
    problems = check_benchmarks(readme) if a.check else []
    print(f"{len(FACTS) - bad} of {len(FACTS)} facts the same in README and docs"
          + (f"; {len(problems)} benchmark figure(s) outside {TOLERANCE:g}x" if a.check else ""))
    return 1 if bad or problems else 0


if __name__ == "__main__":
    sys.exit(main())
