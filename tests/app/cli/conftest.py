"""What every command-line test shares."""

import pytest


@pytest.fixture
def data(tmp_path, monkeypatch):
    """A data folder and a config folder of the test's own (REHAB_DATA_DIR,
    REHAB_CONFIG_DIR), never the user's; the data folder's path."""
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    return tmp_path / "data"
