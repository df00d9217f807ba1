"""The registry's rows are sealed (schema v6, app.records.registry.seals): a byte changed on
the disk is refused in one line, never read as if it had been written (issue 28, item 12
and the corruption test's registry: a flipped bit read a different name, or raised
UnicodeDecodeError)."""

import os
import sqlite3

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.errors import RegistryError
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.seals import SEALED
from core.trial import THESIS_SUBJECT


def make_registry(folder):
    registry = Registry(DataDir(folder))
    for first, last in (("Ada", "Example"), ("Bo", "Sample")):
        patient = registry.create_patient(first, last, body_mass_kg=70.0, upper_arm_m=0.3,
                                          forearm_m=0.28, side="right",
                                          shoulder_m=(-0.12, 0.73))
        begun = registry.begin_trial(patient.code, THESIS_SUBJECT, backend="simulator")
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_mm": 1.5})
    return registry.path


def everything(folder):
    """What a console reads of the registry: every patient with every trial."""
    registry = Registry(DataDir(folder))
    patients = registry.patients()
    return [(p, registry.trials_for_patient(p.code)) for p in patients]


def refused_in_one_line(folder, *words) -> None:
    """Reading the registry in `folder` is refused: a RegistryError in one line that says
    every one of `words`."""
    with pytest.raises(RegistryError) as caught:
        everything(folder)
    text = str(caught.value)
    assert "\n" not in text
    for word in words:
        assert word in text, text


def test_every_sealed_table_seals_every_column_it_has(tmp_path):
    """A migration that adds a column must seal it too (seals.SEALED and the triggers)."""
    path = make_registry(tmp_path / "data")
    with sqlite3.connect(path) as conn:
        for table, columns in SEALED.items():
            found = tuple(r[1] for r in conn.execute(f"PRAGMA table_info({table})"))
            # a column a later schema added comes after the seal (ALTER TABLE appends it)
            assert tuple(c for c in found if c != "seal") == columns, table
            assert "seal" in found, table
        tables = {r[0] for r in conn.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table'")}
    assert tables == set(SEALED)


def flip(path, offset, bit):
    with open(path, "r+b") as f:
        f.seek(offset)
        byte = f.read(1)[0]
        f.seek(offset)
        f.write(bytes([byte ^ (1 << bit)]))


@pytest.mark.parametrize("bit", [0, 7])  # a different letter; bytes that are not UTF-8
def test_a_flipped_bit_in_a_name_is_refused_in_one_line(tmp_path, bit):
    path = make_registry(tmp_path / "data")
    offset = path.read_bytes().index(b"Example")
    flip(path, offset + 2, bit)  # 'a' → '`' or a byte that is not UTF-8
    refused_in_one_line(tmp_path / "data", "damaged", "patients row", "backup")


def test_a_flipped_bit_in_a_column_name_of_the_schema_is_refused_in_one_line(tmp_path):
    """The schema's own text (a table's CREATE statement) is outside the integrity check:
    a column renamed by one bit leaves the seal naming a column the table no longer has
    (found by the bit-flip fuzz test below: it raised SQLite's error, not one line)."""
    path = make_registry(tmp_path / "data")
    flip(path, path.read_bytes().index(b"decided_at"), 0)  # 'd' -> 'e'
    refused_in_one_line(tmp_path / "data", "damaged", "no longer has the columns", "backup")


def test_a_flipped_bit_in_a_pages_type_is_refused_in_one_line(tmp_path):
    """A page whose header no longer says what kind of page it is: SQLite's integrity check
    itself fails ("database disk image is malformed"), which escaped as SQLite's own error
    (found by the bit-flip fuzz test below: offset 4096, bit 0)."""
    path = make_registry(tmp_path / "data")
    flip(path, 4096, 0)  # the second page's first byte: its type
    refused_in_one_line(tmp_path / "data", "malformed", "backup")


def test_a_row_edited_outside_the_console_is_refused(tmp_path):
    """A database browser cannot change a row without the console's seal function; one
    that removes the triggers to do it leaves a row its seal refuses."""
    path = make_registry(tmp_path / "data")
    with sqlite3.connect(path) as conn, pytest.raises(sqlite3.OperationalError,
                                                      match="registry_seal"):
        conn.execute("UPDATE trials SET status = 'faulted' WHERE id = 1")
    with sqlite3.connect(path) as conn:
        conn.execute("DROP TRIGGER trials_sealed_on_update")
        conn.execute("UPDATE trials SET status = 'faulted' WHERE id = 1")
    with pytest.raises(RegistryError, match="trials row 1 does not match its seal"):
        everything(tmp_path / "data")


def test_the_console_reseals_what_it_changes(tmp_path):
    """Every write of the console keeps its rows sealed: proposals, decisions, notes."""
    folder = tmp_path / "data"
    make_registry(folder)
    registry = Registry(DataDir(folder))
    code = registry.patients()[0].code
    begun = registry.begin_trial(code, THESIS_SUBJECT.replace(radius_m=0.09),
                                 backend="simulator")
    registry.finish_trial(begun.trial_id, "faulted", {}, reason="emergency stop")
    assert everything(folder) == everything(folder)
    assert Registry(DataDir(folder)).integrity_check() == []


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_flipped_bit_anywhere_is_refused_or_changes_nothing(tmp_path_factory, data):
    """Any one bit of the file flipped: the registry reads as it was, or is refused in one
    line; it never reads different patients or trials."""
    folder = tmp_path_factory.mktemp("data")
    path = make_registry(folder)
    original = everything(folder)
    size = os.path.getsize(path)
    # most of the file is empty page space: aim half the flips near the rows' values
    content = path.read_bytes()
    near = [content.index(word) for word in (b"Example", b"Sample", b"complete",
                                             b'"shape"', b"rmse_x_mm", b"simulator")]
    offset = data.draw(st.one_of(
        st.integers(0, size - 1),
        st.builds(lambda at, delta: min(max(at + delta, 0), size - 1),
                  st.sampled_from(near), st.integers(-48, 48))), label="offset")
    flip(path, offset, data.draw(st.integers(0, 7), label="bit"))
    try:
        seen = everything(folder)
    except RegistryError as exc:
        refusal = str(exc)
        seen = None
    if seen is None:
        assert "\n" not in refusal
    else:
        assert seen == original
