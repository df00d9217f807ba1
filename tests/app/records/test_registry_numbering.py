"""Numbers without gaps or repeats, held by the database itself on both engines (schema v9,
app.records.registry.numbering; the server's own tests: postgres/test_postgres_numbering.py).
"""

from __future__ import annotations

import datetime

import pytest

from app.errors import DuplicateNumberError, RegistryError
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import TrialParameters
from tests.app.records.history import registry_at

T0 = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)


def begin(registry, code, **kwargs):
    return registry.begin_trial(code, TrialParameters(), backend="simulator", **kwargs)


def test_the_database_refuses_a_gap_a_repeat_a_renumbering_and_a_middle_withdrawal(
        open_registry):
    """What the console's own connection writes past its code (a program with the console's
    seals, a station's login on the server) is refused by the database."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    for _ in range(2):
        begin(registry, code, session_number=1)
    with registry._read() as conn:
        session, patient = conn.exec_driver_sql(
            "SELECT id, patient_id FROM sessions").one()
    insert = ("INSERT INTO trials (session_id, number, parameters, file, metrics, status, "
              f"started_at) VALUES ({session}, {{}}, '{{{{}}}}', 'f{{}}', '{{{{}}}}', "
              "'recording', '2024-05-02T09:30:00+00:00')")
    refused = (
        insert.format(5, 5),  # a gap
        insert.format(2, 2),  # a repeat
        f"INSERT INTO sessions (patient_id, number, date) VALUES ({patient}, 3, '2024-05-02')",
        "UPDATE trials SET number = 7 WHERE number = 2",
        f"UPDATE sessions SET number = 4 WHERE id = {session}",
        "DELETE FROM trials WHERE number = 1",  # not the last: would leave a gap
    )
    for statement in refused:
        with pytest.raises(RegistryError, match="refused a change"), registry._write() as conn:
            conn.exec_driver_sql(statement)
    with registry._write() as conn:  # the next number is taken
        conn.exec_driver_sql(insert.format(3, 3))
    assert [t.number for t in registry.trials(code, 1)] == [1, 2, 3]
    with registry._write() as conn:  # and the last one may go
        conn.exec_driver_sql("DELETE FROM trials WHERE number = 3")
    assert [t.number for t in registry.trials(code, 1)] == [1, 2]
    assert registry.integrity_check() == []


def _v8_registry_with_gaps(folder) -> DataDir:
    """A registry as a console before v9 left it, numbers typed with gaps: sessions 1 and
    3, trials 2 and 5 of session 3."""
    with registry_at(folder, 8) as conn:
        conn.execute("INSERT INTO patients (code, first_name, last_name, created_at) "
                     "VALUES ('PABC234', 'Ada', 'Example', '2024-01-01T00:00:00+00:00')")
        for number in (1, 3):
            conn.execute("INSERT INTO sessions (patient_id, number, date) "
                         "VALUES (1, ?, '2024-01-0' || ?)", (number, number))
        for number in (2, 5):
            conn.execute("INSERT INTO trials (session_id, number, parameters, file, metrics, "
                         "status, started_at) VALUES (2, ?, '{}', ?, '{}', 'complete', "
                         "'2024-01-03T10:00:00+00:00')", (number, f"f{number}"))
    return DataDir(folder)


def test_a_registry_with_gaps_is_migrated_keeping_them_and_numbers_go_on_after_the_last(
        tmp_path):
    data = _v8_registry_with_gaps(tmp_path / "data")
    registry = Registry(data)
    assert [s.number for s in registry.sessions("PABC234")] == [1, 3]
    assert [t.number for t in registry.trials("PABC234", 3)] == [2, 5]
    suggestion = registry.suggest_registration("PABC234", today=datetime.date(2024, 1, 3))
    assert (suggestion.session_number, suggestion.trial_number) == (3, 6)
    with pytest.raises(DuplicateNumberError,
                       match=r"patient PABC234 session 3's trials go up to 5: a new trial "
                             "takes the next number, not 3; use 6, the next free number"):
        begin(registry, "PABC234", session_number=3, trial_number=3)
    with pytest.raises(DuplicateNumberError, match=r"go up to 3: .* not 2; use 4"):
        begin(registry, "PABC234", session_number=2)
    assert begin(registry, "PABC234", session_number=3, started_at=T0).trial_number == 6
    assert begin(registry, "PABC234", session_number=4, started_at=T0).trial_number == 1
    assert registry.integrity_check() == []
