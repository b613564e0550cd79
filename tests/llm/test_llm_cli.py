"""``swarmnav llm check`` and the run flags that are sugar for ``--set``."""

import pytest

from swarmnav.cli import main


@pytest.mark.parametrize("decision, suffix", [("ollama", ""), ("openai", "/v1")])
def test_llm_check_ok_and_fail(fake_server, capsys, decision, suffix):
    good = fake_server("rules")
    assert main(["llm", "check", "--decision", decision, "--llm-url", good.url + suffix, "--llm-timeout", "5"]) == 0
    out = capsys.readouterr().out
    assert "OK: decision split" in out and "latency" in out
    bad = fake_server("garbage")
    assert main(["llm", "check", "--decision", decision, "--llm-url", bad.url + suffix, "--llm-timeout", "5"]) == 1
    assert "FAIL: unparsable answer" in capsys.readouterr().out
    down = fake_server("http500")
    assert main(["llm", "check", "--decision", decision, "--llm-url", down.url + suffix, "--llm-timeout", "5"]) == 1
    assert "FAIL: http: HTTP 500" in capsys.readouterr().out


@pytest.mark.parametrize("args, fragment", [
    (["llm", "check", "--decision", "chatgpt"], "decision: expected one of"),
    (["llm", "check", "--decision", "llamacpp", "--llm-gguf", "/nonexistent.gguf"], "no such model file"),
    (["llm", "check", "--decision", "replay", "--llm-replay", "/nonexistent"], "no transcript"),
    (["llm", "check", "--llm-latency", "soon"], "llm_latency"),
    (["llm", "check", "--llm-timeout", "0"], "llm_timeout"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--decision", "ollama"],
     "unknown parameter 'decision'"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--decision", "ollama",
      "--set", "decision=openai"], "contradicts --set decision=openai"),
])
def test_bad_llm_input_is_one_line_exit_2(args, fragment, tmp_path, capsys):
    assert main([a.replace("X", str(tmp_path / "x")) for a in args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0], err


def test_sim1_llm_report_sets_the_papers_qwen_row_beside_the_llm_variant(fake_server, tmp_path):
    # The spec's variant_map names the paper's "qwen2.5:3b" row, whose key has a dot: the report
    # must find it (the paper's qwen E_mean 6.206, N_event 38.60 and L_mean 228.33 appear).
    server = fake_server("rules")
    out = tmp_path / "sim1"
    assert main(["experiment", "hes-sim1-llm", "--seeds", "1", "--workers", "1", "--quiet", "--no-trajectories",
                 "--set", "decision=ollama", "--set", f"llm_url={server.url}", "--set", "llm_timeout=5",
                 "--out", str(out)]) == 0
    assert main(["report", str(out), "--no-viewers"]) == 0
    llm_rows = [ln for ln in (out / "report.md").read_text().splitlines() if ln.startswith("| llm |")]
    assert llm_rows and any("6.206" in ln for ln in llm_rows) and any("228.33" in ln for ln in llm_rows), llm_rows
