"""What the registry accepts as text (app.records.registry.values.checked_text), the same
on SQLite and PostgreSQL."""

from __future__ import annotations

import pytest

from app.errors import InvalidRecordError
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.values import checked_text


@pytest.mark.parametrize("text", ["Ada\0", "\0", "Ad\0a Lovelace"])
def test_a_nul_character_is_refused_in_one_line_naming_the_field(text):
    with pytest.raises(InvalidRecordError) as refused:
        checked_text("therapist", text, 100)
    message = str(refused.value)
    assert message.startswith("therapist holds a NUL character")
    assert "type it again without it" in message
    assert "\n" not in message
    assert "\0" not in message


def test_sqlite_registry_refuses_a_nul_it_could_store(tmp_path):
    """SQLite would keep the NUL; the registry refuses it there too, so a record stays
    storable on the server."""
    registry = Registry(DataDir(tmp_path / "data"))
    with pytest.raises(InvalidRecordError, match="first_name holds a NUL character"):
        registry.create_patient("Ada\0", "Lovelace")
    patient = registry.create_patient("Ada", "Lovelace")
    with pytest.raises(InvalidRecordError, match="notes holds a NUL character"):
        registry.open_session(patient.code, notes="came\0late")

