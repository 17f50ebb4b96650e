"""The folders a request may read and the bearer token (holecli.serve.security)."""

import os

import pytest

from holecli.serve.security import AccessError, confine, is_loopback, is_the_token, read_token, token_matches


@pytest.fixture
def folders(tmp_path):
    allowed = tmp_path / "scans"
    allowed.mkdir()
    (allowed / "a.ply").write_text("ply\n")
    (allowed / "sub").mkdir()
    (allowed / "sub" / "b.ply").write_text("ply\n")
    outside = tmp_path / "private"
    outside.mkdir()
    (outside / "secret.ply").write_text("ply\n")
    return os.path.realpath(allowed), os.path.realpath(outside)


def test_a_file_inside_an_allowed_folder_is_given_by_its_real_path(folders):
    allowed, _ = folders
    assert confine("a.ply", [allowed]) == os.path.join(allowed, "a.ply")
    assert confine("sub/b.ply", [allowed]) == os.path.join(allowed, "sub", "b.ply")
    assert confine(os.path.join(allowed, "sub", "b.ply"), [allowed]) == os.path.join(allowed, "sub", "b.ply")


@pytest.mark.parametrize("path, status", [
    ("", 400), ("a\x00.ply", 400), ("../private/secret.ply", 400), ("sub/../a.ply", 400), ("sub\\..\\a.ply", 400),
    ("missing.ply", 404), ("sub", 404),
])
def test_refused_paths_say_why_with_a_status(folders, path, status):
    allowed, _ = folders
    with pytest.raises(AccessError) as refused:
        confine(path, [allowed])
    assert refused.value.status == status


def test_a_file_outside_the_allowed_folders_is_forbidden(folders):
    allowed, outside = folders
    with pytest.raises(AccessError) as refused:
        confine(os.path.join(outside, "secret.ply"), [allowed])
    assert refused.value.status == 403
    # a folder whose name starts like the allowed one's is not inside it
    twin = allowed + "-twin"
    os.mkdir(twin)
    open(os.path.join(twin, "x.ply"), "w").close()
    with pytest.raises(AccessError) as refused:
        confine(os.path.join(twin, "x.ply"), [allowed])
    assert refused.value.status == 403


def test_a_link_inside_an_allowed_folder_pointing_outside_is_forbidden(folders):
    allowed, outside = folders
    os.symlink(os.path.join(outside, "secret.ply"), os.path.join(allowed, "link.ply"))
    os.symlink(outside, os.path.join(allowed, "door"))
    for path in ("link.ply", "door/secret.ply"):
        with pytest.raises(AccessError) as refused:
            confine(path, [allowed])
        assert refused.value.status == 403


def test_without_an_allowed_folder_no_file_is_read(folders):
    allowed, _ = folders
    with pytest.raises(AccessError) as refused:
        confine(os.path.join(allowed, "a.ply"), [])
    assert refused.value.status == 403 and "--allow-dir" in str(refused.value)


@pytest.mark.parametrize("host, loopback", [("127.0.0.1", True), ("127.0.0.2", True), ("::1", True),
                                            ("localhost", True), ("0.0.0.0", False), ("192.168.1.5", False),
                                            ("::", False), ("cell7.local", False)])
def test_loopback_hosts(host, loopback):
    assert is_loopback(host) is loopback


def test_the_token_file_must_be_private_and_the_token_long(tmp_path):
    path = tmp_path / "token"
    path.write_text("0123456789abcdef0123\nignored\n")
    path.chmod(0o600)
    assert read_token(path) == "0123456789abcdef0123"
    path.chmod(0o644)
    with pytest.raises(ValueError, match="readable by others"):
        read_token(path)
    path.write_text("short\n")
    path.chmod(0o600)
    with pytest.raises(ValueError, match="shorter than 16"):
        read_token(path)


def test_the_bearer_header_must_carry_the_token():
    token = "0123456789abcdef0123"
    assert token_matches(f"Bearer {token}", token)
    assert not token_matches(f"Bearer {token}x", token)
    assert not token_matches(token, token)
    assert not token_matches(None, token)
    assert token_matches(None, None)  # no token asked for


def test_a_token_given_as_text_or_bytes():
    token = "0123456789abcdef0123"
    assert is_the_token(token, token) and is_the_token(token.encode(), token)
    assert not is_the_token(token[:-1], token) and not is_the_token(b"", token)
