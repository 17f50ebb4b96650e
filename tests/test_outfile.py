"""Tests of holecli.outfile: atomic text writes leave either the old file or the complete new one."""

import os
import stat

import pytest

from holecli import outfile
from holecli.outfile import write_text_atomic

OLD = '{"old": true}\n'
NEW = '{"holes": [], "note": "µm, ø 8.3"}\n' * 1000


def _umask():
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_writes_the_text(tmp_path):
    path = tmp_path / "result.json"
    write_text_atomic(path, NEW)
    assert path.read_bytes() == NEW.encode("utf-8")
    assert os.listdir(tmp_path) == ["result.json"]


def test_replaces_an_existing_file(tmp_path):
    path = tmp_path / "result.json"
    path.write_text(OLD)
    write_text_atomic(str(path), "x\r\ny\n")
    # newline="" : the text is written as given, no newline translation
    assert path.read_bytes() == b"x\r\ny\n"
    assert os.listdir(tmp_path) == ["result.json"]


def test_relative_path_in_the_current_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_text_atomic("out.csv", "a,b\n")
    assert (tmp_path / "out.csv").read_text() == "a,b\n"


def test_failing_rename_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "result.json"
    path.write_text(OLD)

    def broken_replace(source, target):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(outfile.os, "replace", broken_replace)
    with pytest.raises(OSError, match="No space left"):
        write_text_atomic(path, NEW)
    assert path.read_text() == OLD
    assert os.listdir(tmp_path) == ["result.json"]


def test_write_failing_half_way_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "result.json"
    path.write_text(OLD)
    real_fdopen = os.fdopen

    class HalfWriter:
        """A stream that writes half the text, then fails like a full disk."""

        def __init__(self, stream):
            self.stream = stream

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.stream.close()
            return False

        def write(self, text):
            self.stream.write(text[: len(text) // 2])
            self.stream.flush()
            raise OSError(28, "No space left on device")

        def __getattr__(self, name):
            return getattr(self.stream, name)

    monkeypatch.setattr(outfile.os, "fdopen", lambda *args, **kwargs: HalfWriter(real_fdopen(*args, **kwargs)))
    with pytest.raises(OSError, match="No space left"):
        write_text_atomic(path, NEW)
    assert path.read_text() == OLD
    assert os.listdir(tmp_path) == ["result.json"]


def test_interrupt_while_syncing_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "result.json"
    path.write_text(OLD)

    def interrupted(descriptor):
        raise KeyboardInterrupt

    monkeypatch.setattr(outfile.os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_text_atomic(path, NEW)
    assert path.read_text() == OLD
    assert os.listdir(tmp_path) == ["result.json"]


def test_missing_folder_raises_oserror(tmp_path):
    with pytest.raises(OSError):
        write_text_atomic(tmp_path / "missing" / "result.json", NEW)
    assert os.listdir(tmp_path) == []


def test_a_folder_as_the_target_raises_oserror_and_is_kept(tmp_path):
    (tmp_path / "taken").mkdir()
    with pytest.raises(OSError):
        write_text_atomic(tmp_path / "taken", NEW)
    assert (tmp_path / "taken").is_dir()
    assert os.listdir(tmp_path) == ["taken"]


def test_the_file_gets_the_mode_of_a_plain_open(tmp_path):
    # not mkstemp's owner-only 0600: a result file is as readable as one written by open()
    path = tmp_path / "result.json"
    write_text_atomic(path, NEW)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~_umask()


def test_write_bytes_atomic_writes_the_bytes(tmp_path):
    path = tmp_path / "cloud.ply"
    payload = bytes(range(256)) * 10
    outfile.write_bytes_atomic(path, payload)
    assert path.read_bytes() == payload
    assert os.listdir(tmp_path) == ["cloud.ply"]
