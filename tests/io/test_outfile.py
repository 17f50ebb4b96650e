"""Tests of holecli.io.outfile: atomic text writes leave either the old file or the complete new one."""

import os
import stat

import pytest

from holecli.io import outfile
from holecli.io.outfile import write_text_atomic

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


# --- write_bytes: what is at the path decides (issue 8, item 1), stale temporaries (item 15) -------


def test_write_bytes_to_a_fifo_writes_through_it_and_keeps_it(tmp_path, fifo_reader):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    finish = fifo_reader(fifo)
    outfile.write_bytes(fifo, b"record\n")
    assert finish() == b"record\n"
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert os.listdir(tmp_path) == ["pipe"]


def test_write_bytes_to_a_character_device_writes_to_it_and_keeps_it(tmp_path):
    node = tmp_path / "null"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a /dev/null of our own
    except (PermissionError, OSError) as error:
        pytest.skip(f"cannot make a device node here: {error}")
    try:
        with open(node, "wb") as probe:
            probe.write(b"")
    except OSError as error:  # nodev mount
        pytest.skip(f"cannot use a device node here: {error}")
    outfile.write_bytes(node, b"record\n")
    assert stat.S_ISCHR(os.lstat(node).st_mode)
    assert os.lstat(node).st_rdev == os.makedev(1, 3)
    assert os.listdir(tmp_path) == ["null"]


def test_write_bytes_to_dev_full_raises_and_keeps_it():
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    with pytest.raises(OSError, match="No space left"):
        outfile.write_bytes("/dev/full", b"record\n")
    assert stat.S_ISCHR(os.lstat("/dev/full").st_mode)


def test_write_bytes_through_a_symlink_replaces_its_target_and_keeps_the_link(tmp_path):
    target = tmp_path / "real.json"
    target.write_text(OLD)
    os.chmod(target, 0o640)
    link = tmp_path / "latest.json"
    link.symlink_to("real.json")
    outfile.write_text(link, NEW)
    assert os.path.islink(link) and os.readlink(link) == "real.json"
    assert target.read_text() == NEW
    assert stat.S_IMODE(target.stat().st_mode) == 0o640  # the replaced file keeps its permissions
    assert sorted(os.listdir(tmp_path)) == ["latest.json", "real.json"]


def test_write_bytes_through_a_dangling_symlink_creates_its_target(tmp_path):
    (tmp_path / "results").mkdir()
    link = tmp_path / "latest.json"
    link.symlink_to(tmp_path / "results" / "new.json")
    outfile.write_text(link, NEW)
    assert os.path.islink(link)
    assert (tmp_path / "results" / "new.json").read_text() == NEW


def test_write_bytes_refuses_a_folder_and_a_socket(tmp_path):
    import socket

    (tmp_path / "taken").mkdir()
    with pytest.raises(IsADirectoryError):
        outfile.write_bytes(tmp_path / "taken", b"x")
    assert (tmp_path / "taken").is_dir()
    server = socket.socket(socket.AF_UNIX)
    try:
        server.bind(str(tmp_path / "sock"))
        with pytest.raises(OSError, match="not a regular file"):
            outfile.write_bytes(tmp_path / "sock", b"x")
        assert stat.S_ISSOCK(os.lstat(tmp_path / "sock").st_mode)
    finally:
        server.close()


def test_write_bytes_dash_is_stdout(capfdbinary):
    outfile.write_bytes("-", b"to stdout\n")
    assert capfdbinary.readouterr().out == b"to stdout\n"


def test_write_bytes_to_a_new_or_regular_file_is_atomic(tmp_path):
    path = tmp_path / "result.json"
    outfile.write_text(path, OLD)
    outfile.write_text(path, NEW)
    assert path.read_text() == NEW
    assert os.listdir(tmp_path) == ["result.json"]


def _dead_pid():
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_stale_temporaries_of_killed_writers_are_removed_by_the_next_write(tmp_path):
    path = tmp_path / "result.json"
    dead = tmp_path / f".result.json.{_dead_pid()}.0badf00d.tmp"
    alive = tmp_path / f".result.json.{os.getppid()}.0badf00d.tmp"  # a writer still running
    legacy_old = tmp_path / ".result.json.k2j4h5g3.tmp"  # holecli 0.1.0's mkstemp name
    legacy_new = tmp_path / ".result.json.a1b2c3d4.tmp"
    other = tmp_path / f".other.json.{_dead_pid()}.0badf00d.tmp"  # another target's: not ours to touch
    for temporary in (dead, alive, legacy_old, legacy_new, other):
        temporary.write_text("half a recor")
    an_hour_ago = os.stat(legacy_old).st_mtime - 3600
    os.utime(legacy_old, (an_hour_ago, an_hour_ago))
    outfile.write_text(path, NEW)
    assert sorted(os.listdir(tmp_path)) == sorted(p.name for p in (path, alive, legacy_new, other))
    assert path.read_text() == NEW


# --- Outputs: a run's outputs all or none (issue 23, item 3); a FIFO without a reader (item 7) -----


def test_outputs_commit_writes_every_output(tmp_path, capfdbinary):
    first, second = tmp_path / "result.json", tmp_path / "targets.csv"
    first.write_text(OLD)
    with outfile.Outputs() as outputs:
        outputs.add(first, b"new result\n")
        outputs.add(second, b"name,x\n")
        outputs.add("-", b"on stdout\n")
        assert first.read_text() == OLD and not second.exists()  # staged, not yet written
        assert capfdbinary.readouterr().out == b""
        outputs.commit()
    assert first.read_bytes() == b"new result\n" and second.read_bytes() == b"name,x\n"
    assert capfdbinary.readouterr().out == b"on stdout\n"
    assert sorted(os.listdir(tmp_path)) == ["result.json", "targets.csv"]


def test_outputs_one_that_cannot_be_staged_leaves_every_file_and_prints_nothing(tmp_path, capfdbinary):
    first = tmp_path / "result.json"
    first.write_text(OLD)
    with pytest.raises(FileNotFoundError) as raised:
        with outfile.Outputs() as outputs:
            outputs.add("-", b"on stdout\n")
            outputs.add(first, NEW.encode())
            outputs.add(tmp_path / "missing" / "fit.png", b"\x89PNG")
            outputs.commit()
    assert raised.value.filename == str(tmp_path / "missing" / "fit.png")
    assert first.read_text() == OLD
    assert os.listdir(tmp_path) == ["result.json"]  # its temporary removed
    assert capfdbinary.readouterr().out == b""


def test_outputs_left_without_commit_write_nothing(tmp_path):
    with outfile.Outputs() as outputs:
        outputs.add(tmp_path / "result.json", b"x")
    assert os.listdir(tmp_path) == []


def test_outputs_a_failing_rename_puts_the_files_renamed_before_it_back(tmp_path, monkeypatch):
    earlier, new, third = tmp_path / "corrected.csv", tmp_path / "new.json", tmp_path / "result.json"
    earlier.write_text(OLD)
    third.write_text("third, earlier\n")
    real_replace = os.replace

    def replace(source, target):
        if os.fspath(target) == str(third) and ".tmp" in os.fspath(source):
            raise OSError(28, "No space left on device")
        return real_replace(source, target)

    monkeypatch.setattr(outfile.os, "replace", replace)
    with outfile.Outputs() as outputs:
        outputs.add(earlier, b"corrected, new\n")
        outputs.add(new, b"new\n")
        outputs.add(third, b"third, new\n")
        with pytest.raises(OSError, match="No space left") as raised:
            outputs.commit()
    assert raised.value.filename == str(third)
    assert earlier.read_text() == OLD  # renamed, then put back
    assert not new.exists()  # made, then removed
    assert third.read_text() == "third, earlier\n"
    assert sorted(os.listdir(tmp_path)) == ["corrected.csv", "result.json"]  # no temporary, no kept copy


def test_outputs_a_failing_stream_replaces_no_file(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    earlier = tmp_path / "corrected.csv"
    earlier.write_text(OLD)
    with outfile.Outputs() as outputs:
        outputs.add(earlier, b"corrected, new\n")
        outputs.add("/dev/full", b"record\n")
        with pytest.raises(OSError, match="No space left") as raised:
            outputs.commit()
    assert raised.value.filename == "/dev/full"
    assert earlier.read_text() == OLD
    assert os.listdir(tmp_path) == ["corrected.csv"]


def test_write_bytes_to_a_fifo_without_a_reader_is_refused_at_once(tmp_path):
    import subprocess
    import sys

    fifo = tmp_path / "nobody.reads"
    os.mkfifo(fifo)
    # in a process of its own: without the check, the open blocks forever (the timeout fails the test)
    code = ("import sys\nfrom holecli.io import outfile\n"
            "try:\n    outfile.write_bytes(sys.argv[1], b'record')\n"
            "except OSError as error:\n    print(error.errno, error.strerror, error.filename)\n")
    result = subprocess.run([sys.executable, "-c", code, str(fifo)], capture_output=True, text=True, timeout=60,
                            env=dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.dirname(
                                os.path.abspath(__file__))))))
    import errno

    assert result.stdout.split(" ", 1)[0] == str(errno.ENXIO), result.stderr
    assert "no process reads" in result.stdout and str(fifo) in result.stdout
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert os.listdir(tmp_path) == ["nobody.reads"]
