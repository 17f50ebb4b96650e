"""holecli.batch.manifest: what a cluster batch has done, by path and content, for --resume."""

import hashlib
import json

from holecli.batch.manifest import Manifest, file_fingerprint, manifest_path
from holecli.measure import resolved_path


def test_fingerprint_is_the_size_and_sha256_of_the_bytes(tmp_path):
    path = tmp_path / "a.xyz"
    path.write_bytes(b"0 0 0\n1 1 1\n")
    assert file_fingerprint(path) == {"size": 12, "sha256": hashlib.sha256(b"0 0 0\n1 1 1\n").hexdigest()}
    assert file_fingerprint(tmp_path / "missing.xyz") == {"size": None, "sha256": None}
    assert manifest_path("out.jsonl") == "out.jsonl.manifest"


def test_resume_keeps_whole_entries_and_finds_the_files_changed(tmp_path):
    same, edited, resized, unknown = (tmp_path / f"{name}.xyz" for name in ("same", "edited", "resized", "unknown"))
    for path in (same, edited, resized, unknown):
        path.write_bytes(b"0 0 0\n")
    manifest_file = tmp_path / "out.jsonl.manifest"
    location = str(manifest_file)
    with Manifest(location) as manifest:
        for path in (same, edited, resized):
            manifest.add(str(path), file_fingerprint(path))
    with open(location, "ab") as stream:
        stream.write(b'{"path": "/cut/short')  # a run killed mid-write: its partial line
    edited.write_bytes(b"9 9 9\n")  # same size, other bytes
    resized.write_bytes(b"0 0 0\n1 1 1\n")
    with Manifest(location, resume=True) as manifest:
        assert set(manifest.entries) == {resolved_path(str(path)) for path in (same, edited, resized)}
        # unknown has no entry: done by its path, as a local batch's --resume has it
        assert manifest.changed(map(str, (same, edited, resized, unknown))) == {resolved_path(str(edited)),
                                                                                resolved_path(str(resized))}
        manifest.add(str(edited), file_fingerprint(edited))  # measured again: its later entry counts
    lines = manifest_file.read_text().splitlines()
    assert len(lines) == 4 and all(json.loads(line)["path"] for line in lines)  # the partial line cut off
    with Manifest(location, resume=True) as manifest:
        assert manifest.changed([str(edited)]) == set()
    with Manifest(location) as manifest:  # a new run: emptied
        assert manifest.entries == {}
    assert manifest_file.read_text() == ""
