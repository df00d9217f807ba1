"""The patient's window in the tasks the robot leads, on real trial files (issue 31): in
position sense nothing of the table is painted (no cursor, no target, no layout: the
background's colour where the hand and the target are), only the words; in strength the
push's arrow is painted with its tip where the line is. Screenshots of both go to
REHAB_SCREENSHOTS when it is set (to look at them)."""

import os
from pathlib import Path

import numpy as np
import pytest

from app.trials.headless import simulate_to_file
from app.trials.reader import read_trial
from core.assessment.protocol import protocol
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PHASE_EXERCISE
from device.recording.record import RECORD_DTYPE
from ui.patient.window import BACKGROUND, PatientWindow
from ui.views.patient_screen import TASK_WORDS
from ui.views.trialview import VIEW_CHANNELS, TrialView

STRENGTH = protocol("strength").parameters(THESIS_SUBJECT).replace(n_targets=2)
POSITION = protocol("position").parameters(THESIS_SUBJECT).replace(n_targets=2,
                                                                   repetitions=1)


def run(params, tmp_path):
    path = tmp_path / f"{params.assessment}.h5"
    simulate_to_file(params, path, patient="healthy", seed=3)
    data = read_trial(path)
    dtype = np.dtype([(c, RECORD_DTYPE.fields[c][0]) for c in VIEW_CHANNELS])
    records = np.zeros(data.n_samples, dtype=dtype)
    for name in VIEW_CHANNELS:
        records[name] = data.channels[name]
    first = int(np.flatnonzero(records["phase"] == PHASE_EXERCISE)[0])
    return float(records["time"][first]), records


def shown_at(qtbot, params, records, approach_s, t_exercise_s, name):
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(900, 700)
    window.show()
    view = TrialView(params)
    view.append(records[:round((approach_s + t_exercise_s) / 0.002) + 1])
    window.show_view(view)
    image = window.grab().toImage()
    folder = os.environ.get("REHAB_SCREENSHOTS")
    if folder:
        image.save(str(Path(folder) / f"patient-{name}.png"))
    return window, image


def test_position_sense_paints_nothing_of_the_table(qtbot, tmp_path):
    approach, records = run(POSITION, tmp_path)
    stretches = POSITION.trajectory().stretches
    for phase in ("out", "match"):
        stretch = next(s for s in stretches if s.phase == phase)
        t = 0.5 * (stretch.start_s + stretch.stop_s)
        window, image = shown_at(qtbot, POSITION, records, approach, t, f"position-{phase}")
        assert window.frame.cue == TASK_WORDS[phase]
        assert window.painted["cursor"] is None
        assert window.painted["target"] is None
        where = window.placement()
        i = round((approach + t) / 0.002)
        for point in (records["position"][i], POSITION.centre_m, stretch.end):
            x, y = where.to_px(point)
            assert image.pixelColor(round(x), round(y)) == BACKGROUND


def test_strength_paints_the_push_s_arrow(qtbot, tmp_path):
    approach, records = run(STRENGTH, tmp_path)
    push = next(s for s in STRENGTH.trajectory().stretches if s.phase == "push")
    t = push.start_s + 2.0
    window, _ = shown_at(qtbot, STRENGTH, records, approach, t,
                         "strength-push")
    frame = window.frame
    assert frame.cue == TASK_WORDS["push"]
    angle, line, force = frame.push
    assert force == pytest.approx(line, rel=0.1)  # the healthy push is at the line
    tip = np.asarray(STRENGTH.centre_m) + STRENGTH.radius_m * np.array(
        [np.cos(angle), np.sin(angle)])
    np.testing.assert_allclose(window.painted["target"], window.placement().to_px(tip),
                               atol=1e-9)
    assert window.painted["cursor"] is None
