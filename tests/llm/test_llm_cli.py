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


def _closed_port() -> int:
    import socket

    with socket.socket() as sock:  # bound, never listening: a connection is refused
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _llm_run(out, *flags):
    return main(["run", "--method", "hes", "--scenario", "default_corridor", "--steps", "200", "--out", str(out),
                 "--quiet", "--llm-timeout", "2", *flags])


@pytest.mark.parametrize("server", ["closed port", "http500", "drop"])
def test_an_unusable_back_end_warns_once_per_run_and_counts_its_fallbacks(fake_server, tmp_path, capsys, server):
    import json

    url = f"http://127.0.0.1:{_closed_port()}" if server == "closed port" else fake_server(server).url
    assert _llm_run(tmp_path / "r", "--decision", "ollama", "--llm-url", url) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if "warning" in ln]  # (not a compile notice)
    assert len(err) == 1 and err[0].startswith("swarmnav: warning: the LLM back end (ollama) failed at step 0: ")
    assert "the rule decides wherever a call fails" in err[0]
    m = json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert m["llm_calls"] == 4 and m["llm_fallback_used"] == 4  # k = 0, 50, 100, 150: all answered by the rule
    # replaying that run re-enacts its failures on purpose: no warning
    assert _llm_run(tmp_path / "p", "--decision", "replay", "--llm-replay", str(tmp_path / "r")) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("mode", ["rules", "garbage"])
def test_a_back_end_that_answers_gives_no_warning(fake_server, tmp_path, capsys, mode):
    import json

    assert _llm_run(tmp_path / "r", "--decision", "openai", "--llm-url", fake_server(mode).url + "/v1") == 0
    assert "warning" not in capsys.readouterr().err
    m = json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert m["llm_fallback_used"] == (4 if mode == "garbage" else 0)  # unparsable answers still count
