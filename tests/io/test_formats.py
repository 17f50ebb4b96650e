"""holecli.io.formats: the one table of formats, and what is derived from it (issue 26)."""

import subprocess
import sys

import numpy as np
import pytest

from holecli.cli import options
from holecli.errors import LoadError
from holecli.io import SUPPORTED_EXTENSIONS, WRITE_EXTENSIONS, read_cloud, save_points
from holecli.io.formats import FORMATS, INPUT_FORMATS, expected, reader, writer


def test_every_format_has_a_reader_that_exists_and_every_written_one_a_writer():
    for fmt in FORMATS:
        assert callable(reader(fmt))
        assert (fmt.write is None) == (fmt.name in ("e57", "las", "laz")) and (fmt.write is None or callable(writer(fmt)))


def test_every_extension_of_the_table_is_read_and_any_other_is_refused_naming_them(tmp_path):
    # what the table declares is what read_cloud does: a format added to FORMATS is read by its
    # extension (any case), and the refusal of an unknown one lists it
    points = np.random.default_rng(2).normal(size=(20, 3))
    known = expected(SUPPORTED_EXTENSIONS)
    for fmt in FORMATS:
        for extension in fmt.extensions:
            if fmt.write is not None:
                save_points(tmp_path / f"cloud{extension}", points)
                (tmp_path / f"cloud{extension}").rename(tmp_path / f"upper{extension.upper()}")
                np.testing.assert_array_equal(read_cloud(tmp_path / f"upper{extension.upper()}").points, points)
            else:  # not written here: a reader is tried (or its extra asked for), never the unknown's refusal
                (tmp_path / f"bad{extension}").write_bytes(b"not a point cloud\n")
                with pytest.raises(LoadError) as error:
                    read_cloud(tmp_path / f"bad{extension}")
                assert known not in str(error.value)
    (tmp_path / "a.obj").write_text("v 1 2 3\n")
    with pytest.raises(LoadError) as error:
        read_cloud(tmp_path / "a.obj")
    assert f"expected {known};" in str(error.value)


def test_the_input_format_choices_are_the_table_s_names():
    option = options.input_format_option("help")(lambda input_format: None).__click_params__[0]
    assert tuple(option.type.choices) == INPUT_FORMATS


@pytest.mark.parametrize("extensions, text", [
    ((".ply",), ".ply"), ((".ply", ".pcd"), ".ply or .pcd"), ((".a", ".b", ".c"), ".a, .b or .c")])
def test_expected_lists_as_the_messages_do(extensions, text):
    assert expected(extensions) == text


def test_an_unknown_extension_is_refused_with_the_table_s_list(tmp_path):
    path = tmp_path / "a.obj"
    path.write_text("v 1 2 3\n")
    with pytest.raises(LoadError, match=r"expected \.ply, \.pcd, \.csv, \.txt, \.xyz, \.e57, \.las or \.laz;"):
        read_cloud(path)
    with pytest.raises(ValueError, match=r"\(expected \.ply, \.pcd, \.csv, \.txt or \.xyz\)"):
        save_points(path, np.zeros((3, 3)))


@pytest.mark.parametrize("extension", WRITE_EXTENSIONS)
def test_every_written_format_reads_back_through_the_table(tmp_path, extension):
    points = np.random.default_rng(1).normal(size=(20, 3))
    path = tmp_path / f"cloud{extension}"
    save_points(path, points)
    np.testing.assert_array_equal(read_cloud(path).points, points)


def test_the_table_and_the_package_face_import_no_numpy(repo_root):
    code = "import sys, holecli.io, holecli.io.formats, holecli.vocabulary; print('numpy' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=repo_root, timeout=60)
    assert result.stdout.strip() == "False", result.stderr


@pytest.mark.parametrize("extension, extra", [(".e57", "e57"), (".las", "las"), (".laz", "las")])
def test_the_missing_extra_message_names_the_table_s_extra(extension, extra):
    from holecli.io._common import _need_extra

    assert str(_need_extra(extension)) == f"reading {extension} needs the optional extra: pip install 'holecli[{extra}]'"
