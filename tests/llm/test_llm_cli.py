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
