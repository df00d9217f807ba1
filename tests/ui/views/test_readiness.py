"""The robot bar's words never send the therapist to a greyed button."""

from __future__ import annotations

from core.errors import capitalised
from device.loop.states import State
from ui.views.readiness import PLAN_RUNS, STALE, readiness

UNREACHABLE = ("point (-30.0, 18.0) cm is 57.87 cm from the shoulder; move the exercise or "
               "the shoulder closer together")


def test_start_waiting_for_a_build_the_form_refuses_says_what_holds_build():
    """Found trying the window: a level lowered during a trial (the built trial stale),
    then a radius the arm cannot reach; after the trial Build was greyed, yet the line on
    every tab said "Start is greyed: parameters changed since Build: press Build"."""
    ready = readiness(State.CONNECTED, form_problem=UNREACHABLE, registered=True,
                      built=True, stale=True, held="", unsaved=True)
    assert not ready.enabled["build"]
    assert not ready.enabled["start"]
    assert "press Build" not in ready.line
    assert ready.line == f"Build needs the form fixed: {UNREACHABLE}"
    assert "press Build" not in ready.tooltips["start"]
    assert ready.tooltips["start"] == f"Build needs the form fixed: {UNREACHABLE}"


def test_stale_with_a_buildable_form_still_says_press_build():
    ready = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                      stale=True, held="", unsaved=False)
    assert ready.enabled["build"]
    assert ready.line == f"Start is greyed: {STALE}"
    assert ready.tooltips["start"] == f"Start is greyed: {STALE}"


def test_an_unregistered_patient_is_said_before_the_form():
    """Start's first need is the patient; the form's problem is Build's, said on its
    tooltip."""
    ready = readiness(State.CONNECTED, form_problem=UNREACHABLE, registered=False,
                      built=True, stale=True, held="", unsaved=False)
    assert ready.line.startswith("Start needs a registered patient")
    assert ready.tooltips["build"].startswith("Build needs the form fixed")


OUTSIDE = ("handle outside the exercise area: guide it inside (now at 8.1, 48 cm; the area is "
           "x -40 to -10 cm, y 10 to 50 cm)")


def test_a_handle_outside_the_area_between_trials_greys_start_and_says_where_it_is():
    """The real robot connects at its homing pose, outside most exercises' areas: a state
    (docs/safety.md, H8), said on every tab with where the handle is, not a fault."""
    ready = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                      stale=False, held="", unsaved=False, outside=OUTSIDE)
    assert not ready.enabled["start"]
    assert ready.enabled["build"]
    assert ready.enabled["disconnect"]
    assert ready.line == "H" + OUTSIDE[1:]
    assert ready.tooltips["start"] == "H" + OUTSIDE[1:]
    inside = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                       stale=False, held="", unsaved=False, outside="")
    assert inside.enabled["start"]
    assert inside.line == ""


def test_what_holds_the_session_before_the_handle_is_said_first():
    """A latch (the e-stop) and a missing patient come first; the handle is the last
    thing before Start."""
    held = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                     stale=False, held="the e-stop is held", unsaved=False, outside=OUTSIDE)
    assert held.line == "The e-stop is held"
    unregistered = readiness(State.CONNECTED, form_problem="", registered=False, built=True,
                             stale=False, held="", unsaved=False, outside=OUTSIDE)
    assert unregistered.line.startswith("Start needs a registered patient")


def test_a_start_being_registered_greys_start_and_build_and_says_so():
    """The registry answers Start on the job thread (ui.window.start): meanwhile Start
    says so on every tab, and Build waits (the trial registered is the one built);
    Disconnect and the robot's own buttons stay as the state allows."""
    from ui.views.readiness import REGISTERING

    ready = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                      stale=False, held="", unsaved=False, registering=True)
    assert ready.registering
    assert not ready.enabled["start"]
    assert not ready.enabled["build"]
    assert ready.enabled["disconnect"]
    assert ready.line == "Registering the trial: it starts once the registry answers"
    assert ready.tooltips["build"] == f"Build waits for {REGISTERING}"
    done = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                     stale=False, held="", unsaved=False)
    assert not done.registering
    assert done.enabled["start"]
    assert done.enabled["build"]


def test_a_running_plan_holds_build_and_start_and_says_why_on_their_tooltips():
    """In a plan's rest the robot is connected and the last round built: Build and Start
    were green and ran a trial outside the plan (brief hO). The e-stop's hold is said
    first; the line does not send the therapist to Build."""
    ready = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                      stale=True, held="", unsaved=True, plan=True)
    assert not ready.enabled["build"]
    assert not ready.enabled["start"]
    assert ready.enabled["save"]
    assert ready.tooltips["build"] == ready.tooltips["start"] == capitalised(PLAN_RUNS)
    assert ready.line == ""
    held = readiness(State.CONNECTED, form_problem="", registered=True, built=True,
                     stale=False, held="the emergency stop is pressed", unsaved=False,
                     plan=True)
    assert held.tooltips["start"] == "The emergency stop is pressed"


def test_an_unregistered_patient_is_sent_to_the_button_as_it_is_named():
    """Found trying the window (brief hT): after a refused Start the line said "choose the
    patient and press Confirm", a button the Registration tab does not have: it says "Use
    this patient and these numbers"."""
    from ui.tabs.registration import CONFIRM

    ready = readiness(State.CONNECTED, form_problem="", registered=False, built=True,
                      stale=False, held="", unsaved=False)
    assert f"press {CONFIRM}" in ready.line
    assert "Confirm" not in ready.line
