"""The Instructions tab: the session steps, every fault banner explained, the tab names."""

from __future__ import annotations

import re

from device.safety.faults import Fault
from ui.tabs import TABS, InstructionsTab
from ui.tabs.instructions import INSTRUCTIONS_PATH


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


def test_the_connect_step_says_hands_off_in_the_windows_words(qtbot):
    """Issue 27 #9: the steps had the patient hold the handle before Connect, while the
    force sensor takes its zero in Connect's first quarter second. Nobody may touch the
    handle until the window says the zero is taken, in the words the window uses."""
    from ui.window.trial import HANDS_OFF, ZERO_TAKEN

    tab = InstructionsTab()
    qtbot.addWidget(tab)
    text = tab.plain_text()
    steps = text[text.index("\n3. Build, Connect, Start\n"):text.index("\n4. Stop and Save\n")]
    connect = steps.index("Press Connect")
    before = steps[:connect]
    assert not re.search(r"holds? the handle", before), before  # nobody holds it yet
    assert "Nobody touches the handle" in before
    after = steps[connect:]
    for words in (HANDS_OFF, ZERO_TAKEN):
        assert words.split(":")[0] in after, words  # "Hands off the handle", "Zero taken"
    assert "refused in one line" in after  # a zero under load
    # the patient takes the handle only once the zero is taken
    assert after.index("Zero taken") < after.index("the patient holds the handle")


def test_every_tab_the_window_shows_is_explained(qtbot, tmp_path, monkeypatch):
    """Seen going through a clinical day guided by the Instructions tab: it said nothing of
    the Plan and Assessments tabs (the window adds them beside Parameters, outside TABS), nor
    of the clinical record (a Fugl-Meyer, a note) or the scales on Progress. Each tab the
    window shows, and those two parts, is named in bold where the text explains it."""
    from tests.ui.session import open_window

    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        titles = [win.tabs.tabText(i) for i in range(win.tabs.count())]
    finally:
        win.close()
    source = INSTRUCTIONS_PATH.read_text(encoding="utf-8")
    explained = [*titles[1:], "Clinical record", "Clinical scales"]
    assert [name for name in explained if f"**{name}**" not in source] == []
