"""The Instructions tab: the session steps, every fault banner explained, the tab names."""

from __future__ import annotations

import re

from device.safety.faults import Fault
from ui.tabs import TABS, InstructionsTab


def test_instructions_cover_the_steps_and_every_fault_banner(qtbot):
    tab = InstructionsTab()
    qtbot.addWidget(tab)
    text = tab.plain_text()
    for step in ("Registration", "Parameters", "Build", "Connect", "Start", "Stop", "Save",
                 "Emergency stop", "Reading the report"):
        assert step in text, step
    # Each banner's opening words, with its measured values elided, is in the table.
    openings = [line.split("\t")[0] for line in text.splitlines()]
    for fault in Fault:
        if fault is Fault.NONE:
            continue
        cause = re.sub(r"\{[^}]*\}", "…", fault.text.cause)
        assert any(o and cause.startswith(o.strip()) for o in openings if len(o) > 10), fault


def test_instructions_name_the_tabs_as_they_are_titled(qtbot):
    tab = InstructionsTab()
    qtbot.addWidget(tab)
    text = tab.plain_text()
    for title, _cls in TABS:
        if title != "Instructions":
            assert title in text, title


def test_a_missing_instructions_file_is_said_plainly(qtbot, tmp_path):
    tab = InstructionsTab(tmp_path / "gone.md")
    qtbot.addWidget(tab)
    assert "Instructions missing" in tab.plain_text()
