"""The session plan in the window (issue 30, the plan #4): a template copied to the patient
and a block changed in the Plan tab's table; Start plan runs each round through the
window's own Build and Start (the robot buttons' path, so the state machine's one truth
holds), times the rest, and the E-STOP ends it at once. The real loop and recorder run
behind the window; trials of one 1.5 s lap, rests of 1 s."""

import pytest
from PySide6.QtCore import Qt

from app.reports.build import content_for_registry_trial
from core.plan import Block, Plan, check_plan
from device.loop.states import State
from tests.ui.session import click, enabled, open_window, register_patient, short_trial

pytestmark = pytest.mark.slow

PLAN = Plan("Two short blocks", (
    Block(shape="d", repetitions=1, duration_s=1.5, rest_s=1.0, name="D"),
    Block(shape="circle", repetitions=1, duration_s=1.5, rest_s=0.0, radius_m=0.08,
          name="Circle"),
))
LONG_REST = Plan("A long rest", (
    Block(shape="d", repetitions=1, duration_s=1.5, rest_s=600.0, name="D"),
    Block(shape="circle", repetitions=1, duration_s=1.5, rest_s=0.0, radius_m=0.08,
          name="Circle"),
))
"""A rest no loaded machine can miss by polling (a 1 s one was missed in a whole check
under load); the emergency stop ends it at once."""


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    yield win
    win.close()


def shown(qtbot, win) -> None:
    """The plan's registry call answered and shown (ui.window.plan: on the job thread)."""
    qtbot.waitUntil(lambda: not win.plan_waiting(), timeout=20000)


def start_plan(qtbot, win) -> None:
    """Start plan pressed, and the run begun in the registry (on the job thread)."""
    click(qtbot, win.plan_tab.start_button)
    shown(qtbot, win)


def connected_with_plan(qtbot, win, plan=PLAN):
    register_patient(qtbot, win)
    code = win.patient.code
    win.registry.save_plan(code, plan)
    win.show_plan_of(code)
    shown(qtbot, win)
    short_trial(win)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
    return code


def in_the_rest(qtbot, win) -> str:
    """A plan whose second block is long (ten laps, so that a Stop lands in it however
    slow the machine) started, and waited for in its 3 s rest after block 1 (which polling
    finds on a loaded machine; one of 1 s was missed); the patient's code."""
    long_second = Plan(PLAN.name, (PLAN.blocks[0].replace(rest_s=3.0),
                                   PLAN.blocks[1].replace(repetitions=10)))
    code = connected_with_plan(qtbot, win, long_second)
    start_plan(qtbot, win)
    qtbot.waitUntil(lambda: win.plan_runner is not None and win.plan_runner.phase
                    == "resting", timeout=120000)
    return code


def test_a_template_copied_and_a_block_changed_in_the_plan_tab(qtbot, window):
    win = window
    tab = win.plan_tab
    click(qtbot, tab.copy_button)
    assert "Choose the patient first" in tab.refusal.text()
    register_patient(qtbot, win)
    shown(qtbot, win)
    # the list shows the plans' titles, the copy takes the template (clinic exploration
    # 2 #5: the list showed the files' names, "first-session")
    titles = [tab.templates.itemText(k) for k in range(tab.templates.count())]
    assert titles == ["Endurance", "First session", "Games", "Reaching"]
    assert "five minutes" in tab.templates.itemData(0, Qt.ItemDataRole.ToolTipRole)
    tab.templates.setCurrentText("First session")
    click(qtbot, tab.copy_button)
    shown(qtbot, win)
    first = win.registry.current_plan(win.patient.code)
    assert first.template == "first-session"
    assert tab.table.rowCount() == 3
    # the blocks in the words of the Parameters and Progress tabs, not the plan's codes
    # (the cells read "d", "none", "as-needed")
    assert [tab.table.item(0, col).text() for col in (1, 2, 6)] == [
        "D shape", "none", "As needed"]
    assert tab.table.item(2, 1).text() == "Reach out and back"
    tab.table.item(1, 9).setText("30")  # the circle's rest, s
    shown(qtbot, win)
    today = win.registry.current_plan(win.patient.code)
    assert today.based_on == first.id
    assert today.plan.blocks[1].rest_s == 30.0
    tab.table.item(0, 7).setText("140")  # a level of 140 %
    assert "block 1.assistance_level = 1.4 is not allowed" in tab.refusal.text()
    assert win.registry.current_plan(win.patient.code) == today
    assert tab.table.item(0, 7).text() == "100"  # the cell shows the plan again
    # a block made a game: the reaching game needs the targets or a reach
    tab.table.item(0, 2).setText("reach")
    assert "block 1.shape = 'd' is not allowed" in tab.refusal.text()
    tab.table.item(0, 1).setText("Targets (centre-out)")  # a cell takes the name it shows
    shown(qtbot, win)
    tab.table.item(0, 2).setText("Reaching game")
    shown(qtbot, win)
    tab.table.item(0, 3).setText("3")
    shown(qtbot, win)
    game = win.registry.current_plan(win.patient.code).plan.blocks[0]
    assert (game.shape, game.game, game.rounds) == ("targets", "reach", 3)
    assert tab.table.item(0, 2).text() == "Reaching game"


def test_start_plan_runs_each_block_through_build_and_start_with_its_rest(qtbot, window):
    win = window
    code = connected_with_plan(qtbot, win)
    # every line the plan's status showed: the 1 s rest is over before a poll of a loaded
    # machine may look (a wait for the resting phase itself timed out in whole checks)
    shown: list[str] = []
    set_text = win.plan_tab.status.setText
    win.plan_tab.status.setText = lambda text: (shown.append(text), set_text(text))[-1]
    # the therapist watches the plan on its tab: its trials' start and end took them to
    # Trajectory, then Report, away from Pause and Stop plan (brief hZ)
    win.tabs.setCurrentWidget(win.plan_tab)
    visited: list[str] = []
    win.tabs.currentChanged.connect(lambda k: visited.append(win.tabs.tabText(k)))
    before = win.parameters_tab.parameters()
    start_plan(qtbot, win)
    assert win.plan_runner is not None
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=120000)
    assert visited == [], visited
    assert any(line.startswith("Rest 0:01 after block 1 of 2") for line in shown), shown
    # the form shows the trial the plan built: what ran is what the tab showed
    assert win.plan_tab.status.text().startswith("Plan complete (Block 2 of 2; 2 of 2 "
                                                 "movements)")
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "complete"
    assert [(s.kind, s.block) for s in run.steps] == [("trial", 1), ("rest", 1), ("trial", 2)]
    trials = [win.registry.trial(s.trial_id) for s in run.trial_steps()]
    assert [t.status for t in trials] == ["complete", "complete"]
    assert [t.parameters["shape"] for t in trials] == ["d", "circle"]
    assert win.built.shape == "circle"
    # the form back to the trial before the plan, and said: the therapist's next trial
    # of their own ran the plan's last block (its 5 minutes) when the form kept it
    assert win.parameters_tab.parameters() == before
    assert "The Parameters tab is back to the trial it showed before the plan: press " \
        "Build" in "\n".join(win.messages.history())
    assert win.stale()  # Start waits for Build: the form is not the circle built
    assert "start" not in enabled(win)
    assert win.state == State.CONNECTED
    # the dose on the Progress tab and in the trial's report, from the files
    qtbot.waitUntil(lambda: "Two short blocks (run 1): complete, 2 of 2 movements" in
                    win.progress.dose.text(), timeout=30000)
    header = dict((h.label, h.value) for h in
                  content_for_registry_trial(win.registry, trials[1].id).therapist_header)
    assert header["Plan"] == "Two short blocks (run 1), block 2 of 2: Circle"
    assert header["Plan's dose"].startswith("2 of 2 movements, 0:0")


def test_the_patient_s_bar_moves_during_a_block_and_is_whole_at_the_end(qtbot, window):
    """The bar of the session under the patient's top band counted finished trials only:
    through a block's trial it stood still. A one-block plan of two 2 s laps: the bar
    takes values between nothing and whole while the trial runs, never goes back, and is
    whole at the plan's end."""
    win = window
    connected_with_plan(qtbot, win, Plan("One block", (
        Block(shape="d", repetitions=2, duration_s=2.0, rest_s=0.0, name="D"),)))
    patient = win.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    bars: list[float] = []

    def seen() -> bool:
        if patient.plan is not None:
            bars.append(patient.plan.progress)
        return win.plan_runner is None

    start_plan(qtbot, win)
    qtbot.waitUntil(seen, timeout=120000)
    win._feed_patient_screen()
    bars.append(patient.plan.progress)
    assert bars == sorted(bars)  # never back
    assert bars[-1] == 1.0
    within = {round(b, 2) for b in bars if 0.0 < b < 1.0}
    assert len(within) >= 3, bars  # it moved through the block, not in one step


def test_the_emergency_stop_in_a_rest_ends_the_plan_at_once(qtbot, window):
    win = window
    code = connected_with_plan(qtbot, win, LONG_REST)
    start_plan(qtbot, win)
    qtbot.waitUntil(lambda: win.plan_runner is not None and win.plan_runner.phase
                    == "resting", timeout=120000)
    win.emergency_stop()
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=20000)
    assert win.plan_tab.status.text().startswith("Plan ended by the emergency stop")
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "emergency_stop"
    assert [(s.kind, s.block) for s in run.steps] == [("trial", 1), ("rest", 1)]
    qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=20000)
    assert len(win.registry.trials_for_patient(code)) == 1  # nothing ran after


def test_build_and_start_are_the_plan_s_while_it_rests(qtbot, window):
    """Found driving the window (brief hO): in the rest between blocks ("Rest 0:57 after
    block 1 of 2") Build and Start (F5) were green; Start ran the last built round as a
    trial of its own, registered but not in the plan's record, while the patient's screen
    said rest, and when it overlapped the rest's end the plan never ended. While the plan
    runs they are greyed with why; Stop plan gives them back."""
    from PySide6.QtTest import QTest

    from core.errors import capitalised
    from ui.views.readiness import PLAN_RUNS

    win = window
    code = connected_with_plan(qtbot, win, LONG_REST)
    start_plan(qtbot, win)
    qtbot.waitUntil(lambda: win.plan_runner is not None and win.plan_runner.phase
                    == "resting" and not win.saving(), timeout=120000)
    for name in ("build", "start"):
        button = win.robot.buttons[name]
        assert not button.isEnabled(), name
        assert button.toolTip() == capitalised(PLAN_RUNS)
    QTest.keyClick(win, Qt.Key.Key_F5)  # the shortcut of a greyed button runs nothing
    QTest.keyClick(win, Qt.Key.Key_F2)
    qtbot.wait(500)
    assert not win.registering()
    assert win.state == State.CONNECTED
    assert len(win.registry.trials_for_patient(code)) == 1
    click(qtbot, win.plan_tab.stop_button)
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=20000)
    # the therapist's again: Build, and Start once the form (back to the trial before
    # the plan, not the block built) is built
    assert "build" in enabled(win)
    assert win.robot.buttons["start"].toolTip() != capitalised(PLAN_RUNS)
    assert win.stale()
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: not win.stale() and "start" in enabled(win), timeout=20000)
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "stopped"


def test_a_plan_this_console_cannot_run_is_said_on_the_tab_not_raised(qtbot, tmp_path,
                                                                       monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        code = win.patient.code
        win.registry.save_plan(code, PLAN)
        with win.registry._write() as conn:  # as a newer console might have written it
            conn.exec_driver_sql(
                "UPDATE plans SET plan = replace(plan, '\"circle\"', '\"spiral\"')")
        win.show_plan_of(code)
        shown(qtbot, win)
        assert "plan cannot be shown" in win.plan_tab.title.text()
        assert "block 2.shape = 'spiral'" in win.plan_tab.title.text()
        assert not win.plan_tab.start_button.isEnabled()
    finally:
        win.close()


def test_pause_holds_the_plan_resume_goes_on_and_the_robot_bar_s_stop_ends_it(qtbot, window):
    """Pause in a rest holds the plan (nothing is built or started however long it is
    held), Resume goes on to the next block, and the robot bar's Stop (F6's button) in that
    block ends the plan as stopped, the trial stopped early and nothing after it."""
    win = window
    code = in_the_rest(qtbot, win)
    click(qtbot, win.plan_tab.pause_button)
    assert win.plan_tab.status.text().startswith("Plan paused at")
    assert win.plan_tab.resume_button.isEnabled()
    assert not win.plan_tab.pause_button.isEnabled()
    qtbot.wait(4000)  # more than the 3 s rest: a paused plan starts nothing
    assert win.plan_runner.phase == "paused"
    assert len(win.registry.trials_for_patient(code)) == 1
    assert win.state == State.CONNECTED
    click(qtbot, win.plan_tab.resume_button)
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=120000)
    click(qtbot, win.robot.buttons["stop"])
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=60000)
    assert win.plan_tab.status.text().startswith("Plan stopped")
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "stopped"
    assert [(s.kind, s.block) for s in run.steps] == [("trial", 1), ("rest", 1), ("trial", 2)]
    trials = [win.registry.trial(s.trial_id) for s in run.trial_steps()]
    assert [t.status for t in trials] == ["complete", "stopped_early"]
    assert len(win.registry.trials_for_patient(code)) == 2


def test_the_plan_s_records_wait_on_the_registry_off_the_window_s_thread(qtbot, window):
    """A trial's record in the plan is made as the trial starts, the robot running: on a
    shared registry whose network drops everything it waited its bounded wait on the
    window's thread (app.records.registry.postgres.deadline), the window frozen and the
    loop's heartbeat missed. Here the registry's record answers only once the window has
    handled an event after it was asked (a timer's tick): it never can while the window
    waits for it (the wait gives up after 30 s)."""
    import threading

    from PySide6.QtCore import QTimer

    win = window
    code = connected_with_plan(qtbot, win, Plan("One block", (
        Block(shape="d", repetitions=1, duration_s=1.5, rest_s=0.0, name="D"),)))
    ticked = threading.Event()
    timer = QTimer(win)
    timer.timeout.connect(ticked.set)
    timer.start(10)
    handled_first: list[bool] = []
    record = win.registry.record_plan_trial

    def record_after_a_tick(*args):
        ticked.clear()
        handled_first.append(ticked.wait(30))
        return record(*args)

    win.registry.record_plan_trial = record_after_a_tick
    start_plan(qtbot, win)
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=120000)
    timer.stop()
    assert handled_first == [True], "the window waited for the plan's record"
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "complete"
    assert [(s.kind, s.block) for s in run.steps] == [("trial", 1)]


def test_a_template_is_copied_fitted_to_the_patient_s_arm(qtbot, tmp_path, monkeypatch):
    """Trying a session: the First session template, copied for a patient of 57 cm of arm,
    was refused at Start plan (block 3's reach 57.9 cm from the shoulder). Copied, it is
    fitted to the arm on the Parameters tab, the line says what was made smaller, and
    Start plan no longer refuses it for reach."""
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        shown(qtbot, win)
        p = win.parameters_tab
        p.forearm.setValue(27.0)
        p.refresh()
        tab = win.plan_tab
        tab.templates.setCurrentText("First session")
        click(qtbot, tab.copy_button)
        shown(qtbot, win)
        assert tab.refusal.text().startswith("Fitted to this patient: block 3 (Forward "
                                             "reach): radius "), tab.refusal.text()
        assert not check_plan(win.stored_plan.plan, p.parameters(), p.robot)
        click(qtbot, tab.start_button)
        assert "Forward reach" not in tab.refusal.text(), tab.refusal.text()
    finally:
        win.close()


def test_a_block_out_of_reach_is_said_before_build_and_connect(qtbot, tmp_path, monkeypatch):
    """A therapist's first plan (brief hI): the First session template for a patient of
    57 cm of arm; Start plan, pressed before Build and Connect, said "connect the robot
    first", and only after Build and Connect that block 3 was out of reach, with "move the
    exercise" but not where (the table has no centre). Now the block is named at once with
    where to move it; nothing is registered or run."""
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        shown(qtbot, win)
        code = win.patient.code
        p = win.parameters_tab
        tab = win.plan_tab
        tab.templates.setCurrentText("First session")
        click(qtbot, tab.copy_button)
        shown(qtbot, win)
        # copied for this arm; then a shorter arm on the form: the forward reach's far end
        # is out of it (a plan copied is not fitted again behind the therapist's back)
        p.forearm.setValue(27.0)
        p.refresh()
        click(qtbot, tab.start_button)
        said = tab.refusal.text()
        assert said.startswith("Start plan refused: block 3 (Forward reach): "), said
        # in the form's own units: its refusals say cm (brief hO: the plan's said metres)
        assert " cm from the shoulder" in said, said
        assert ") m " not in said, said
        assert "Parameters tab's centre" in said
        assert win.plan_runner is None
        assert win.registry.plan_runs_for_patient(code) == []
        # moved nearer the shoulder on the Parameters tab, the plan waits for the robot only
        p.centre_y.setValue(34.0)
        p.refresh()
        click(qtbot, tab.start_button)
        # on the simulator nobody holds a handle (brief hO): no "hands off" said
        assert tab.refusal.text() == ("Start plan refused: connect the robot first (Build, "
                                      "then Connect).")
        # the robot chosen, the Connect's zero asks the handle free of hands
        p.robot_choice.hardware.setChecked(True)
        click(qtbot, tab.start_button)
        assert tab.refusal.text() == ("Start plan refused: connect the robot first (Build, "
                                      "then Connect, hands off the handle).")
    finally:
        win.close()


def test_the_chosen_template_says_what_it_holds_before_it_is_copied(qtbot):
    """The Plan tab showed a bare "Endurance" over an empty table: what a template holds
    was only its tooltip, so the therapist copied it to the patient to find out. The
    chosen template's own words are in view under the list, and follow the choice."""
    from app.plans.templates import load_template, template_titles
    from ui.tabs.plan import PlanTab

    titles = template_titles()
    tab = PlanTab(titles)
    qtbot.addWidget(tab)
    tab.show()
    for index, (name, title, _about) in enumerate(titles):
        tab.templates.setCurrentIndex(index)
        assert tab.about.isVisible()
        assert tab.about.text() == f"{title}: {load_template(name).about}"


@pytest.mark.parametrize("name", ["first-session", "reaching", "endurance", "games"])
def test_the_plan_table_shows_every_cell_and_heading_whole_at_1366(qtbot, name):
    """The Plan tab on a 1366 px laptop (brief hI): the table kept Qt's 100 px columns and
    cut "1. Warm-up on the D" to "1. Warm-…" and the headings "Pace (s a lap)" and
    "Tolerance (°)", with a third of the table's width empty beside them."""
    from PySide6.QtWidgets import QApplication

    from app.plans.templates import load_template, template_titles
    from ui.tabs.plan import PlanTab

    tab = PlanTab(template_titles())
    qtbot.addWidget(tab)
    tab.resize(1366, 600)
    tab.show()
    tab.set_plan(load_template(name).plan, "a template")
    QApplication.processEvents()
    table, header = tab.table, tab.table.horizontalHeader()
    for col in range(table.columnCount()):
        heading = header.fontMetrics().horizontalAdvance(
            table.horizontalHeaderItem(col).text())
        needed = max(table.sizeHintForColumn(col), heading)
        assert table.columnWidth(col) >= needed, (
            f"column {table.horizontalHeaderItem(col).text()!r}: {table.columnWidth(col)} "
            f"px for {needed}")
    # the blocks are numbered once, in the first column: Qt's row numbers beside it read
    # "1 | 1. Reaching game" (brief hX)
    assert table.item(0, 0).text().startswith("1")
    assert not table.verticalHeader().isVisible()


def test_a_disconnect_in_a_rest_pauses_the_plan_and_resume_goes_on_once_connected(
        qtbot, window):
    """Disconnect pressed in a rest (brief hU): the plan pauses saying why and what to do,
    the run's record notes it with its time, nothing is built however long it is held,
    Resume waits for Connect, and then the plan goes on to its next block. Before, the next
    round was built at the rest's end, its Start refused (not connected), and the plan
    ended 'faulted'."""
    import threading

    from ui.window.plan import RESUME_WAITS, ROBOT_GONE

    win = window
    # the first trial's saved line held back until after the Disconnect (its reads run
    # after the plan has moved on to the rest, ui.window.after_trial)
    verify, read_back = win.registry.verify_trial_file, threading.Event()
    win.registry.verify_trial_file = lambda trial: read_back.wait(60) and verify(trial)
    code = in_the_rest(qtbot, win)
    click(qtbot, win.robot.buttons["disconnect"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
    assert win.plan_runner.phase == "paused"
    assert win.plan_tab.status.text() == f"Plan paused at block 1 of 2: {ROBOT_GONE}"
    assert win.message.text().endswith(f"Plan paused: {ROBOT_GONE}.")
    read_back.set()
    qtbot.waitUntil(lambda: not win.saving(), timeout=60000)
    saved = [line for line in win.messages.history() if "Trial 1 of session 1 saved" in line]
    assert len(saved) == 1
    # the saved line came after the pause: the event line says what holds the plan again
    assert win.message.text().endswith(f"Plan paused: {ROBOT_GONE}.")
    qtbot.wait(4000)  # more than the 3 s rest: a paused plan starts nothing
    assert win.plan_runner.phase == "paused"
    assert len(win.registry.trials_for_patient(code)) == 1
    click(qtbot, win.plan_tab.resume_button)  # not connected: Resume waits
    assert win.plan_runner.phase == "paused"
    assert win.message.text().endswith(RESUME_WAITS)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
    click(qtbot, win.plan_tab.resume_button)
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=120000)  # block 2
    click(qtbot, win.plan_tab.stop_button)
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=60000)
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "stopped"
    assert [(s.kind, s.block) for s in run.steps] == [("trial", 1), ("rest", 1), ("trial", 2)]
    notes = [n.text for n in win.registry.notes(code)]
    assert notes == [f"Plan run {run.id}, block 1: paused: {ROBOT_GONE}",
                     f"Plan run {run.id}, block 1: resumed"]


def test_a_round_built_before_the_last_trial_s_reads_waits_for_them_to_start(
        qtbot, window, monkeypatch):
    """A plan's next round (a game block's, or a block after no rest) was built while the
    registry's reads after the last trial were still on the job thread: its Start was
    refused ("the last trial to be saved: a moment") and the plan ended as faulted after
    one round (seen under Xvfb, a game block of two rounds on a loaded machine). Here the
    reads answer only once the next round is built: its Start waits for them, then runs."""
    from app.plans.runner import STARTING
    from tests.ui.held import Held

    win = window
    no_rest = Plan("No rest", (PLAN.blocks[0].replace(rest_s=0.0), PLAN.blocks[1]))
    code = connected_with_plan(qtbot, win, no_rest)
    reads = Held(monkeypatch, win.registry, "verify_trial_file")  # one of the reads after
    start_plan(qtbot, win)
    def next_round_started_or_ended() -> bool:
        runner = win.plan_runner
        return reads.asked.is_set() and (runner is None or (
            runner.index == 1 and runner.phase in (STARTING, "ended")))

    qtbot.waitUntil(next_round_started_or_ended, timeout=120000)
    assert win.plan_runner is not None
    assert win.plan_runner.phase == STARTING  # built, its Start waiting
    assert win.plan_start_waits == (2, 1)
    reads.release()
    qtbot.waitUntil(lambda: win.plan_runner is None, timeout=120000)
    assert reads.waited[0]
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.status == "complete", run.reason
    assert [(s.kind, s.block) for s in run.steps] == [("trial", 1), ("trial", 2)]
