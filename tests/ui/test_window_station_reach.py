"""The status bar's words for a station recording on its own (ui/window/station.py) say why:
the server not reached, this login refused, or the records made offline refused. They said
'Shared registry unreachable' for all three, and a therapist whose sync the server refused
(another station recorded for the same patient meanwhile) was sent to check a network that
worked; the tooltip says the whole of it."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from PySide6.QtWidgets import QLabel

from app.records import station
from ui.window.station import LOGIN_REFUSED, SYNC_REFUSED, UNREACHABLE, StationStatus

REASON = "the shared registry 127.0.0.1:5432/rehab cannot be reached: …"
PROBLEM = "the records this station made offline were not sent: … trial number 3 …"


def _shown(cause: str, qtbot, said: list[str] | None = None) -> QLabel:
    label = QLabel("")
    qtbot.addWidget(label)
    said = [] if said is None else said
    win = SimpleNamespace(registry_label=label, _was_offline=False,
                          _say=lambda text, problem=False: said.append(text),
                          registry=SimpleNamespace(offline_cause=cause, sync_problem=PROBLEM,
                                                   offline_reason=REASON))
    StationStatus._show_reach(win, True)
    return label


@pytest.mark.parametrize(("cause", "words", "tip"), [
    (station.UNREACHABLE, UNREACHABLE, REASON),
    (station.LOGIN_REFUSED, LOGIN_REFUSED, REASON),
    (station.SYNC_REFUSED, SYNC_REFUSED, PROBLEM),
])
def test_the_status_bar_says_why_the_station_records_on_its_own(qtbot, cause, words, tip):
    label = _shown(cause, qtbot)
    assert label.text().endswith(words)
    assert label.toolTip() == tip


def test_only_an_unreached_server_is_called_unreachable():
    assert "unreachable" not in LOGIN_REFUSED + SYNC_REFUSED
    assert len({UNREACHABLE, LOGIN_REFUSED, SYNC_REFUSED}) == 3


@pytest.mark.parametrize(("cause", "says"), [
    (station.UNREACHABLE, [REASON]), (station.LOGIN_REFUSED, [REASON]),
    (station.SYNC_REFUSED, [])])
def test_going_offline_says_why_once_and_never_after_a_refusal(qtbot, cause, says):
    """A station opened with records waiting whose sync the server refuses: the window says
    the refusal as the station opens; the message line then read 'Records made while the
    shared registry was unreachable are waiting to be sent' over it (a sync that could not
    come)."""
    said: list[str] = []
    _shown(cause, qtbot, said)
    assert [text.lower() for text in said] == [text.lower() for text in says]
