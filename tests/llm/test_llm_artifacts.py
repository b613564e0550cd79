"""The run-directory hook the transcript relies on: a method's ``artifacts()`` files are kept in
RunResult.artifacts and written by save()."""

import pytest

import swarmnav
from swarmnav.errors import SwarmnavError
from swarmnav.methods.apf import Apf


class WithArtifacts(Apf):
    def artifacts(self):
        return {"llm_transcript.jsonl": '{"step": 0}\n', "blob.bin": b"\x00\x01"}


def test_method_artifacts_are_saved_in_the_run_directory(tmp_path):
    res = swarmnav.run(WithArtifacts(), "default_corridor", seed=1, steps=3)
    assert set(res.artifacts) == {"llm_transcript.jsonl", "blob.bin"}
    out = res.save(tmp_path / "r")
    assert (out / "llm_transcript.jsonl").read_text() == '{"step": 0}\n'
    assert (out / "blob.bin").read_bytes() == b"\x00\x01"
    assert swarmnav.run("apf", "default_corridor", seed=1, steps=3).artifacts == {}


@pytest.mark.parametrize("name", ["../x", "sub/x", ".hidden", "metrics.json"])
def test_artifact_names_cannot_escape_or_overwrite(tmp_path, name):
    res = swarmnav.run("apf", "default_corridor", seed=1, steps=2)
    res.artifacts = {name: "x"}
    with pytest.raises(SwarmnavError, match="artifact name"):
        res.save(tmp_path / "r")
