"""Fixtures of the results store's tests: real records (measured from the sample clouds) and a store
of each engine."""

import pytest


@pytest.fixture(scope="session")
def panel_record(repo_root):
    """The record of sample_clouds/panel.ply checked against panel_tolerances.toml (4 holes, all pass),
    with ``path`` as ``holecli batch`` gives it."""
    from holecli import measure_scan
    from holecli.cli.files import read_spec

    spec = read_spec(str(repo_root / "sample_clouds" / "panel_tolerances.toml"))
    return measure_scan(str(repo_root / "sample_clouds" / "panel.ply"), spec=spec, resolve_path=True).record


@pytest.fixture(scope="session")
def table1_record(repo_root):
    """The record of sample_clouds/table1.ply without tolerances (one hole, unchecked)."""
    from holecli import measure_scan

    return measure_scan(str(repo_root / "sample_clouds" / "table1.ply")).record


@pytest.fixture(scope="session")
def error_record(repo_root):
    """A batch error record (a file that could not be measured)."""
    from holecli.batch.record import error_record

    return error_record(repo_root / "sample_clouds" / "missing.ply", "sample_clouds/missing.ply: no such file")


@pytest.fixture(params=["sqlite", "postgres"])
def store_location(request, tmp_path):
    """The location of a new, empty store of each engine: an SQLite file, a fresh PostgreSQL database
    (of the throwaway server of :mod:`tests.pgserver`)."""
    if request.param == "sqlite":
        return str(tmp_path / "results.sqlite")
    return request.getfixturevalue("postgres_store_url")
