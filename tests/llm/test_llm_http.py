"""The HTTP back ends against a loopback server speaking the Ollama and OpenAI wire formats:
the requests carry the paper's decoding settings, and every fault becomes an LlmError of the
right kind within the timeout."""

import socket
import time

import pytest

from swarmnav.llm import LlmError, build_prompt, parse_answer
from swarmnav.llm.backends import OllamaBackend, OpenAIBackend
from swarmnav.llm.check import SAMPLE_STATE

PROMPT = build_prompt(SAMPLE_STATE)
BACKENDS = {
    "ollama": lambda url, **kw: OllamaBackend(url, **kw),
    "openai": lambda url, **kw: OpenAIBackend(url + "/v1", **kw),
}


@pytest.mark.parametrize("kind", BACKENDS)
def test_good_answer_and_faithful_request(fake_server, kind):
    s = fake_server("rules")
    reply = BACKENDS[kind](s.url, model="qwen2.5:3b", timeout=5).complete(PROMPT, 0)
    assert parse_answer(reply.text).action == "split"  # SAMPLE_STATE: can_split, two corridors
    assert 0 <= reply.latency < 5
    assert s.violations == []
    path, body = s.requests[0]
    assert path == {"ollama": "/api/chat", "openai": "/v1/chat/completions"}[kind]
    # the prompt's fixed part as the system turn, z(k) as the user turn; together the whole prompt
    assert [m["role"] for m in body["messages"]] == ["system", "user"]
    assert body["messages"][0]["content"] + "\n\n" + body["messages"][1]["content"] == PROMPT
    assert body["messages"][1]["content"].startswith("Current state: {")


@pytest.mark.parametrize("kind", BACKENDS)
@pytest.mark.parametrize("mode, error", [("empty", "empty"), ("http500", "http"), ("drop", "connection"),
                                         ("late", "timeout")])
def test_faults_raise_the_right_error_within_the_timeout(fake_server, kind, mode, error):
    s = fake_server(mode, delay=3.0)
    b = BACKENDS[kind](s.url, model="qwen2.5:3b", timeout=0.5)
    t0 = time.perf_counter()
    with pytest.raises(LlmError) as e:
        b.complete(PROMPT, 0)
    assert e.value.kind == error, e.value
    assert time.perf_counter() - t0 < 1.5  # bounded by the timeout, not by the server's 3 s
    assert s.violations == []


@pytest.mark.parametrize("kind", BACKENDS)
def test_garbage_is_returned_for_the_parser_to_reject(fake_server, kind):
    s = fake_server("garbage")
    reply = BACKENDS[kind](s.url, model="qwen2.5:3b", timeout=5).complete(PROMPT, 0)
    assert parse_answer(reply.text).action is None


@pytest.mark.parametrize("kind", BACKENDS)
def test_unknown_model_is_an_http_error_naming_it(fake_server, kind):
    s = fake_server("rules")
    with pytest.raises(LlmError, match="nosuchmodel") as e:
        BACKENDS[kind](s.url, model="nosuchmodel", timeout=5).complete(PROMPT, 0)
    assert e.value.kind == "http" and "404" in str(e.value)


@pytest.mark.parametrize("kind", BACKENDS)
def test_connection_refused(kind):
    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    with pytest.raises(LlmError) as e:
        BACKENDS[kind](f"http://127.0.0.1:{port}", model="m", timeout=2).complete(PROMPT, 0)
    assert e.value.kind == "connection" and "refused" in str(e.value)


@pytest.mark.parametrize("kind", BACKENDS)
def test_a_trickling_server_cannot_stretch_the_timeout(kind):
    """Bytes every 0.2 s keep each socket read alive; the call still ends at the deadline."""
    import threading

    srv = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve():
        conn, _ = srv.accept()
        with conn:
            conn.recv(65536)
            conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 1000\r\n\r\n")
            for _ in range(50):  # at most 10 s
                if stop.wait(0.2):
                    break
                try:
                    conn.sendall(b" ")
                except OSError:
                    break

    t = threading.Thread(target=serve, daemon=True)
    t.start()
    try:
        t0 = time.perf_counter()
        with pytest.raises(LlmError) as e:
            BACKENDS[kind](f"http://127.0.0.1:{srv.getsockname()[1]}", model="m", timeout=0.7).complete(PROMPT, 0)
        assert e.value.kind == "timeout" and time.perf_counter() - t0 < 1.5
    finally:
        stop.set()
        srv.close()
        t.join(5)


def test_url_forms():
    assert OllamaBackend("http://h:1").url == "http://h:1/api/chat"
    assert OllamaBackend("http://h:1/api/chat").url == "http://h:1/api/chat"
    assert OpenAIBackend("http://h:1/v1/").url == "http://h:1/v1/chat/completions"
    assert OpenAIBackend("").url == "http://127.0.0.1:8000/v1/chat/completions"
    assert OpenAIBackend("x", response_format="json_schema").request("p")["response_format"]["type"] == "json_schema"
    assert "response_format" not in OpenAIBackend("x", response_format="none").request("p")
