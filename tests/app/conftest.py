"""What the app's tests share: a data folder of the test's own, its registry, a registered
patient, and a data folder without the console's shipped norms."""

from __future__ import annotations

import pytest

from app.norms import in_use
from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run


@pytest.fixture
def data(tmp_path, monkeypatch):
    """A data folder and a config folder of the test's own (REHAB_DATA_DIR,
    REHAB_CONFIG_DIR), never the user's; the data folder's path."""
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    return tmp_path / "data"


@pytest.fixture
def no_shipped_norms(tmp_path, monkeypatch):
    """No shipped normative model (app.norms.in_use.SHIPPED a file that is not there): a data
    folder scores only with the norms the test puts in use, never resources/norms'."""
    monkeypatch.setattr(in_use, "SHIPPED", tmp_path / "no-shipped-norms.json")


@pytest.fixture
def registry(data) -> Registry:
    """The registry of the test's data folder, created."""
    return Registry(DataDir(data), create=True)


@pytest.fixture
def patient(data, capsys) -> str:
    """The code of a right-sided patient added with `rehab patients add` to the test's data
    folder, with the body sizes of the thesis' subject."""
    code, out, _ = run(["patients", "add", "--first-name", "Ada", "--last-name", "Example",
                        "--body-mass", "80", "--upper-arm", "0.30", "--forearm", "0.29",
                        "--side", "right", "--shoulder", "-0.12", "0.73"], capsys)
    assert code == 0
    return out.strip()
