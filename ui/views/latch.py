"""The emergency stop and the fault latch as one state: what the banner shows, what the
robot buttons allow and what the loop holds are read from here, so they cannot disagree.

The loop holds two things (device.loop.client, device.safety): the e-stop, a flag it reads
every tick while a robot is connected, and a latched fault, which puts it in FAULTED until
it is cleared. The window sets the flag and hears the state. Before this model each was
shown on its own: an e-stop pressed with nothing connected showed its banner, Clear fault
released the flag, the loop refused the clear ("not possible while idle") and the banner
stayed up over a trial that then ran in full (issue 27 #3).

Here the latch is `estop_held or state is FAULTED or the loop is lost`, and the banner is
that, in words:

* the e-stop pressed with no robot connected (Idle, Built) stays held: nothing reads it,
  so Build, Connect and Start wait, and Clear fault releases it (nothing else to clear);
* pressed while connected, the loop faults on its next tick; Clear fault releases it and
  then asks the loop to clear (`release()` says when the loop must be asked);
* a fault the loop latched is the banner until the loop leaves FAULTED: cleared, or
  disconnected (the fault goes with the robot's connection; an e-stop still held stays);
* a lost loop is the banner for good: nothing can be cleared, restart the console.
"""

from __future__ import annotations

from dataclasses import dataclass

from device.loop.states import State
from device.safety.faults import Fault

ESTOP_WORDS = Fault.ESTOP.banner()
"""The supervisor's own words for the e-stop (one wording, before and after the loop
reports it)."""


@dataclass
class Latch:
    """The e-stop held, the loop's state and its latched fault, the loop lost."""

    estop_held: bool = False
    state: State = State.IDLE
    fault_code: int = 0
    fault_text: str = ""
    lost_text: str = ""

    # -- what the therapist and the loop do -------------------------------------------
    def press(self) -> None:
        """The e-stop pressed (its flag is set at once)."""
        self.estop_held = True

    def release(self) -> bool:
        """Clear fault pressed: the e-stop is released. True when the loop must be asked
        to clear too (a robot is connected: it may have latched the e-stop or a fault);
        False when releasing is the whole clear (nothing connected reads the flag)."""
        self.estop_held = False
        return self.state.ticking and not self.lost_text

    def on_state(self, state: State, reason: str = "") -> None:
        """The loop entered `state`; leaving FAULTED (cleared, or disconnected) ends its
        fault."""
        self.state = state
        if state == State.FAULTED:
            if not self.fault_text:
                self.fault_text = reason
        else:
            self.fault_code, self.fault_text = 0, ""

    def on_fault(self, code: int, message: str) -> None:
        self.fault_code, self.fault_text = int(code), message

    def on_lost(self, message: str) -> None:
        self.lost_text = message

    # -- what the window shows ------------------------------------------------------
    @property
    def latched(self) -> bool:
        return self.estop_held or self.state == State.FAULTED or bool(self.lost_text)

    @property
    def banner(self) -> str:
        """The banner's text, '' when nothing is latched."""
        if self.lost_text:
            return self.lost_text
        if self.state == State.FAULTED:
            return self.fault_text or ESTOP_WORDS
        if self.estop_held:
            return ESTOP_WORDS
        return ""

    @property
    def clearable(self) -> bool:
        """Clear fault can do something: a latch that is not a lost loop."""
        return self.latched and not self.lost_text

    def holds_robot(self) -> str:
        """Why Build, Connect and Start wait for the latch, in words ('' when they need
        not)."""
        if self.lost_text:
            return "the control loop stopped: restart the console"
        if self.state == State.FAULTED:
            return "a fault is latched: make sure the patient is safe, then press Clear fault"
        if self.estop_held:
            return ("the emergency stop is pressed: make sure the patient is safe, then "
                    "press Clear fault")
        return ""
