"""The records' interface: the registry implements every call of RecordStore with the same
signature, so code typed with the interface can be given the registry (or a later store)."""

from __future__ import annotations

import inspect

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.store import RecordStore, StationStore

PROPERTIES = ("data_dir", "station")
"""What the interface reads of a store besides its calls."""


def interface_members() -> list[str]:
    return sorted(name for name in vars(RecordStore)
                  if not name.startswith("_") and name not in PROPERTIES)


def station_members() -> list[str]:
    """What the window asks of a station's store only (ui.window.station), besides."""
    return sorted({*vars(StationStore).get("__annotations__", {}),
                   *(name for name in vars(StationStore) if not name.startswith("_"))})


def test_the_registry_is_a_record_store(open_registry):
    registry = open_registry()
    assert isinstance(registry, RecordStore)
    assert isinstance(registry.data_dir, DataDir)
    assert open_registry(station="robot-2").station == "robot-2"


def test_every_call_of_the_interface_has_the_registrys_signature():
    names = interface_members()
    assert "begin_trial" in names
    assert "trial_summaries" in names
    for name in names:
        wanted = inspect.signature(getattr(RecordStore, name))
        actual = inspect.signature(getattr(Registry, name))
        assert actual == wanted, name


def test_the_interface_lists_only_what_the_registry_offers_publicly():
    public = {name for name in dir(Registry) if not name.startswith("_")}
    assert set(interface_members()) <= public
    # Maintenance calls stay the registry's own (see app.records.store).
    assert {"backup", "integrity_check", "update_patient", "open_session"} <= public
    assert not {"backup", "integrity_check", "update_patient", "open_session"} & set(
        interface_members())


def test_app_and_ui_ask_a_registry_only_what_the_interface_lists():
    """Every `registry.<name>` in app (outside the records) and ui is a RecordStore member,
    so a store that implements the interface serves the whole console."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    allowed = set(interface_members()) | set(station_members()) | set(PROPERTIES)
    asked: dict[str, set[str]] = {}
    for folder in ("app", "ui"):
        for path in (root / folder).rglob("*.py"):
            if path.is_relative_to(root / "app" / "records"):
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if not isinstance(node, ast.Attribute):
                    continue
                owner = node.value
                named = (isinstance(owner, ast.Name) and owner.id == "registry") or (
                    isinstance(owner, ast.Attribute) and owner.attr == "registry")
                if named:
                    asked.setdefault(node.attr, set()).add(str(path.relative_to(root)))
    assert {"begin_trial", "trial_path", "search_patients"} <= set(asked)
    assert {name: files for name, files in asked.items() if name not in allowed} == {}
