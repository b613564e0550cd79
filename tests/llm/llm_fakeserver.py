"""A loopback stand-in for an Ollama or OpenAI-compatible model server, with faults on demand.

It speaks both wire formats as the real servers do:

- Ollama ``POST /api/chat``: checks ``model``, ``messages``, ``stream: false`` (without it
  the real server streams NDJSON, and so does this one), ``format`` (a JSON schema or
  "json"), ``options.temperature`` and ``options.num_predict``; answers
  ``{"model", "created_at", "message": {"role", "content"}, "done": true, ...}``, and
  ``404 {"error": "model ... not found"}`` for an unknown model.
- OpenAI ``POST /v1/chat/completions``: checks ``model``, ``messages``, ``temperature``,
  ``max_tokens`` and ``response_format``; answers a ``chat.completion`` object, or
  ``404 {"error": {"message", "type", "code"}}`` for an unknown model.

Request fields that differ from what swarmnav must send (temperature 0, 64 tokens, a schema)
are recorded in ``violations``; tests assert there are none.

Modes (``mode`` for every request, or ``script``: one mode per request in order):

- ``rules``: a well-behaved model that follows the prompt's three rules on the state it
  reads from the prompt;
- ``answer``: always the fixed text ``answer`` (e.g. an infeasible suggestion);
- ``garbage``: text with no JSON and no action keyword;
- ``empty``: an empty content string;
- ``http500``: HTTP 500 with an error body;
- ``drop``: the connection is closed without any response;
- ``late``: a good answer after ``delay`` seconds (interrupted when the server closes).

Bounded: only 127.0.0.1, at most ``max_requests`` requests (then 503), sleeps capped at
``max_delay`` seconds and cut short by :meth:`close`.
"""

from __future__ import annotations

import json
import re
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

MODES = ("rules", "answer", "garbage", "empty", "http500", "drop", "late")
GARBAGE = "lorem ipsum dolor sit amet, <<< 4 8 15 16 23 42 >>> {{ not json"


def rule_answer(prompt: str) -> str:
    """What a model that obeys the prompt's three rules answers (JSON)."""
    m = re.search(r"Current state: (\{.*\})", prompt)
    z = json.loads(m.group(1)) if m else {}
    if z.get("can_split") and z.get("path_count", 0) >= 2:
        d = "split"
    elif z.get("can_merge") and z.get("near_goal_subswarms", 0) >= 2:
        d = "merge"
    else:
        d = "keep"
    return json.dumps({"decision": d, "reason": f"rule {d} from the state"})


class FakeLlmServer:
    def __init__(self, mode: str = "rules", *, answer: str = "", script: list[str] | None = None,
                 delay: float = 2.0, models: tuple[str, ...] = ("qwen2.5:3b",), max_requests: int = 400,
                 max_delay: float = 10.0):
        assert mode in MODES and all(s in MODES for s in script or ())
        self.mode, self.answer, self.script = mode, answer, list(script or ())
        self.delay, self.models = min(delay, max_delay), models
        self.max_requests = max_requests
        self.requests: list[tuple[str, dict]] = []
        self.modes_served: list[str] = []
        self.violations: list[str] = []
        self._closed = threading.Event()
        self._lock = threading.Lock()
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), self._handler())
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self._thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._closed.set()
        self.httpd.shutdown()
        self.httpd.server_close()
        self._thread.join(5)

    # -- request handling ----------------------------------------------------------------

    def _next_mode(self) -> str | None:
        with self._lock:
            n = len(self.modes_served)
            if n >= self.max_requests:
                return None
            mode = self.script[n] if n < len(self.script) else self.mode
            self.modes_served.append(mode)
            return mode

    def _violate(self, msg: str) -> None:
        with self._lock:
            self.violations.append(msg)

    def _text(self, mode: str, prompt: str) -> str:
        if mode == "answer":
            return self.answer
        if mode == "garbage":
            return GARBAGE
        if mode == "empty":
            return ""
        return rule_answer(prompt)

    def _check_common(self, body: dict) -> str:
        msgs = body.get("messages")
        ok = isinstance(msgs, list) and msgs and all(isinstance(m, dict) and {"role", "content"} <= set(m)
                                                     for m in msgs)
        if not ok:
            self._violate(f"messages malformed: {msgs!r}")
            return ""
        return "\n".join(str(m["content"]) for m in msgs)

    def _check_ollama(self, body: dict) -> None:
        if body.get("stream") is not False:
            self._violate(f"ollama: stream must be false, got {body.get('stream')!r}")
        fmt = body.get("format")
        if not (fmt == "json" or (isinstance(fmt, dict) and "decision" in fmt.get("properties", {}))):
            self._violate(f"ollama: format must be a JSON schema with 'decision', got {fmt!r}")
        opts = body.get("options") or {}
        if opts.get("temperature") != 0:
            self._violate(f"ollama: options.temperature must be 0, got {opts.get('temperature')!r}")
        if opts.get("num_predict") != 64:
            self._violate(f"ollama: options.num_predict must be 64, got {opts.get('num_predict')!r}")
        for k in ("temperature", "max_tokens", "num_predict"):
            if k in body:
                self._violate(f"ollama: {k} belongs in options, not at top level")

    def _check_openai(self, body: dict) -> None:
        if body.get("temperature") != 0:
            self._violate(f"openai: temperature must be 0, got {body.get('temperature')!r}")
        if body.get("max_tokens") != 64:
            self._violate(f"openai: max_tokens must be 64, got {body.get('max_tokens')!r}")
        rf = body.get("response_format") or {}
        if rf.get("type") not in ("json_object", "json_schema"):
            self._violate(f"openai: response_format must ask for JSON, got {rf!r}")
        if body.get("stream"):
            self._violate("openai: stream must be off")

    def _handler(self):
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args):  # quiet
                pass

            def _send(self, status: int, obj=None, raw: bytes | None = None, ctype="application/json"):
                data = raw if raw is not None else json.dumps(obj).encode()
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", ctype)
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):  # the client gave up (timeout): expected
                    self.close_connection = True

            def do_GET(self):
                if self.path == "/api/tags":
                    return self._send(200, {"models": [{"name": m, "model": m} for m in server.models]})
                if self.path == "/v1/models":
                    data = [{"id": m, "object": "model"} for m in server.models]
                    return self._send(200, {"object": "list", "data": data})
                return self._send(404, raw=b"404 page not found", ctype="text/plain")

            def do_POST(self):
                n = int(self.headers.get("Content-Length") or 0)
                try:
                    body = json.loads(self.rfile.read(n))
                except ValueError:
                    server._violate(f"{self.path}: body is not JSON")
                    return self._send(400, {"error": "invalid JSON"})
                with server._lock:
                    server.requests.append((self.path, body))
                if self.path == "/api/chat":
                    return self._ollama(body)
                if self.path == "/v1/chat/completions":
                    return self._openai(body)
                return self._send(404, raw=b"404 page not found", ctype="text/plain")

            def _fault(self, mode: str | None, err) -> bool:
                """Serve a fault mode; True if the request is done."""
                if mode is None:
                    self._send(503, err("too many requests for this test server"))
                    return True
                if mode == "drop":
                    self.close_connection = True
                    return True
                if mode == "http500":
                    self._send(500, err("llama runner process has terminated: signal: killed"))
                    return True
                if mode == "late":
                    server._closed.wait(server.delay)
                return False

            def _ollama(self, body: dict):
                server._check_ollama(body)
                prompt = server._check_common(body)
                model = body.get("model")
                if model not in server.models:
                    return self._send(404, {"error": f"model \"{model}\" not found, try pulling it first"})
                mode = server._next_mode()
                if self._fault(mode, lambda m: {"error": m}):
                    return
                text = server._text(mode, prompt)
                now = time.strftime("%Y-%m-%dT%H:%M:%S.000000000Z", time.gmtime())
                msg = {"model": model, "created_at": now, "message": {"role": "assistant", "content": text},
                       "done_reason": "stop", "done": True, "total_duration": 1_000_000, "load_duration": 1000,
                       "prompt_eval_count": len(prompt) // 4, "prompt_eval_duration": 1000,
                       "eval_count": len(text) // 4, "eval_duration": 1000}
                if body.get("stream") is not False:  # the real default: NDJSON chunks
                    chunks = [dict(msg, done=False, message={"role": "assistant", "content": text}), msg]
                    raw = "".join(json.dumps(c) + "\n" for c in chunks).encode()
                    return self._send(200, raw=raw, ctype="application/x-ndjson")
                return self._send(200, msg)

            def _openai(self, body: dict):
                server._check_openai(body)
                prompt = server._check_common(body)
                model = body.get("model")
                err = lambda m, t="server_error", c=None: {"error": {"message": m, "type": t, "code": c}}  # noqa: E731
                if model not in server.models:
                    return self._send(404, err(f"The model `{model}` does not exist.", "invalid_request_error",
                                               "model_not_found"))
                mode = server._next_mode()
                if self._fault(mode, err):
                    return
                text = server._text(mode, prompt)
                return self._send(200, {
                    "id": f"chatcmpl-{len(server.requests)}", "object": "chat.completion", "created": int(time.time()),
                    "model": model,
                    "choices": [{"index": 0, "message": {"role": "assistant", "content": text},
                                 "finish_reason": "stop"}],
                    "usage": {"prompt_tokens": len(prompt) // 4, "completion_tokens": len(text) // 4,
                              "total_tokens": (len(prompt) + len(text)) // 4},
                })

        return Handler
