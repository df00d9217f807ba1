"""Which robot buttons the therapist may press now, and why a greyed one is greyed, in
words shown on every tab (the robot bar's line and each button's tooltip).

A button is enabled only when the loop's state allows its command and nothing the window
knows stands in the way:

* Build needs a form without a problem (the reason is the form's own words, shown on
  every tab, not only under the field on the Parameters tab);
* Start needs a registered patient and a built trial that is what the form shows now:
  any change to the form after Build (a field, the robot, the patient's force, the
  proposal taken) makes the built trial stale, and Start says "parameters changed since
  Build: press Build" (issue 27 #1: Start ran the circle built before the form was
  changed to a figure eight);
* the e-stop or a latched fault holds Build, Connect and Start (ui.views.latch);
* between trials, a handle outside the exercise area holds Start until someone guides it
  inside: the robot at zero torque cannot have put it there, so it is a state the line
  says, with where the handle is, not a fault (docs/safety.md, H8);
* while a Start's trial is being registered (the registry answers on the job thread, a
  shared one on a silent network only after its bounded wait: ui.window.start), Start
  says "Registering…" and Build waits: what the registry is given is what was built;
* while a session plan runs (any phase: its rests and a pause too) Build and Start are
  the plan's (ui.window.plan): pressed in a rest they ran a trial the plan's record does
  not hold while the patient's screen said rest, and the plan's next Build then met a
  running robot (brief hO). They are greyed with PLAN_RUNS.
"""

from __future__ import annotations

from dataclasses import dataclass

from core.errors import capitalised
from device.loop.states import State

STALE = "parameters changed since Build: press Build"
SAVING = "the last trial to be saved: a moment"
# the button as ui.tabs.registration names it, in one line under the buttons at 1366 px
NOT_REGISTERED = "a registered patient: press Use this patient and these numbers (Registration tab)"
NOT_BUILT = "a built trial: press Build"
REGISTERING = "the trial being registered"
PLAN_RUNS = ("the session plan builds and starts its own trials: press Stop plan (Plan tab) "
             "to run one of your own")

KEYS = {"build": "F2", "connect": "F3", "disconnect": "F4", "start": "F5", "stop": "F6",
        "save": "F7"}


@dataclass(frozen=True, slots=True)
class Readiness:
    """What the robot bar shows: the buttons enabled, a tooltip each, and one line."""

    enabled: dict[str, bool]
    tooltips: dict[str, str]
    line: str
    """Why the next button of the session is greyed ('' when nothing waits)."""
    registering: bool = False
    """A Start's trial is being registered: the Start button says so."""


def start_needs(*, registered: bool, built: bool, stale: bool, saving: bool = False,
                registering: bool = False) -> str:
    """What Start waits for beyond the robot's state ('' when nothing). `saving`: the last
    trial's file is not closed yet, or its trial not yet finished into the registry
    from it (its row, its analysis and the next proposal), or the registry's numbers and
    proposal after it not yet read (ui.window.after_trial); `registering`: the trial of
    the Start pressed is being registered."""
    if registering:
        return REGISTERING
    if saving:
        return SAVING
    if not registered:
        return NOT_REGISTERED
    if not built:
        return NOT_BUILT
    if stale:
        return STALE
    return ""


def start_why(needs: str) -> str:
    """What Start waits for (start_needs) as a sentence: "Start needs a built trial: press
    Build"; a stale trial is said as what happened ("Start needs parameters changed since
    Build" read as if Start wanted the form changed)."""
    if needs == STALE:
        return f"Start is greyed: {STALE}"
    if needs == REGISTERING:
        return "Registering the trial: it starts once the registry answers"
    return f"Start needs {needs}"


def readiness(state: State, *, form_problem: str, registered: bool, built: bool,
              stale: bool, held: str, unsaved: bool, saving: bool = False,
              connecting: bool = False, outside: str = "",
              registering: bool = False, plan: bool = False) -> Readiness:
    """The buttons for `state`. `form_problem`: why the form cannot be built ('' when it
    can); `built`: a trial was built; `stale`: the form changed since; `held`: why the latch
    holds the robot ('' when it does not, ui.views.latch.Latch.holds_robot); `unsaved`: a
    finished trial's report is not yet saved; `saving`: the last trial's file is not closed
    yet; `connecting`: a Connect was sent and is not answered yet (the sensor's zero);
    `outside`: the loop's line for a handle outside the exercise area ('' when inside);
    `registering`: a Start's trial is being registered (Build waits for it); `plan`: a
    session plan runs (Build and Start are its own: PLAN_RUNS)."""
    needs = start_needs(registered=registered, built=built, stale=stale, saving=saving,
                        registering=registering)
    build_why = f"Build needs the form fixed: {form_problem}" if form_problem else \
        f"Build waits for {REGISTERING}" if registering else ""
    # Start waits for a Build the form does not allow: "press Build" would send the
    # therapist to a greyed button, so both say what holds Build (a level lowered during
    # a trial, then a radius the arm cannot reach: the line said "press Build")
    blocked_build = needs in (STALE, NOT_BUILT) and bool(form_problem)
    free = not held
    mine = not plan  # Build and Start are the therapist's, not a running plan's
    enabled = {
        "build": free and mine and not build_why and state in (State.IDLE, State.BUILT,
                                                         State.CONNECTED),
        "connect": free and state == State.BUILT and not connecting,
        "disconnect": state in (State.CONNECTED, State.FAULTED),
        "start": free and mine and not needs and not outside and state == State.CONNECTED,
        "stop": state == State.RUNNING,
        "save": unsaved and state not in (State.RUNNING, State.STOPPING),
    }
    why = {
        "build": held or (PLAN_RUNS if plan else build_why),
        "connect": held,
        "start": held or (PLAN_RUNS if plan else build_why if blocked_build
                          else start_why(needs) if needs else outside),
    }
    tooltips = {}
    for name, on in enabled.items():
        words = why.get(name, "")
        tooltips[name] = capitalised(words) if not on else ""
    # the line names what holds the next step of the session, on every tab
    if held:
        line = capitalised(held)
    elif plan:  # the next step is the plan's (its status on the Plan tab), not a Build
        line = ""
    elif state == State.CONNECTED and needs and not blocked_build:
        line = start_why(needs)
    elif state in (State.IDLE, State.BUILT, State.CONNECTED) and form_problem:
        line = build_why
    elif state in (State.BUILT, State.CONNECTED) and stale:
        line = start_why(STALE)
    elif state == State.CONNECTED and outside:
        line = capitalised(outside)
    else:
        line = ""
    return Readiness(enabled, tooltips, line, registering)
