"""The named specs and registrations of a cell (holecli.serve.specs)."""

import shutil
from pathlib import Path

import pytest

from holecli.serve.specs import SpecLibrary, SpecLookupError

SAMPLES = Path(__file__).resolve().parents[2] / "sample_clouds"


@pytest.fixture
def spec_dir(tmp_path):
    shutil.copy(SAMPLES / "panel_tolerances.toml", tmp_path / "wing-7.toml")
    (tmp_path / "broken.toml").write_text("[[holes]\n")
    (tmp_path / "notes.txt").write_text("not a spec")
    return tmp_path


def test_names_are_the_files_stems(spec_dir):
    assert SpecLibrary(str(spec_dir)).names() == {"specs": ["broken", "wing-7"], "registrations": []}
    assert SpecLibrary(None).names() == {"specs": [], "registrations": []}


def test_a_named_spec_is_read_with_its_provenance(spec_dir):
    inspection = SpecLibrary(str(spec_dir)).inspection("wing-7")
    assert [hole.name for hole in inspection.spec.holes][:1] == ["T1"]
    assert inspection.spec.sha256 and inspection.registration is None
    assert SpecLibrary(str(spec_dir)).inspection() is None


@pytest.mark.parametrize("name, status", [("../wing-7", 400), ("a/b", 400), (".hidden", 400), ("", 400),
                                          ("x" * 101, 400), ("missing", 404), ("broken", 422)])
def test_names_that_cannot_be_had(spec_dir, name, status):
    with pytest.raises(SpecLookupError) as refused:
        SpecLibrary(str(spec_dir)).inspection(name)
    assert refused.value.status == status


def test_without_a_spec_folder_every_name_is_unknown():
    with pytest.raises(SpecLookupError) as refused:
        SpecLibrary(None).inspection("wing-7")
    assert refused.value.status == 404 and "--spec-dir" in str(refused.value)


def test_a_registration_needs_a_spec(spec_dir):
    with pytest.raises(SpecLookupError) as refused:
        SpecLibrary(str(spec_dir)).inspection(None, "frame")
    assert refused.value.status == 400
