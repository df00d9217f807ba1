"""A trial's start and end in the loop process, as the recorder and the console hear of
them (a part of device.loop.process.DeviceLoop): the pipeline begun at the handle, the
trial file begun with its settings and its first record, the events of the patient's
screen and of a task the robot leads, and at the end the stop event, the summary (the
robot's own clock, the simulated robot) and the assistance group. A virtual patient is
cued and rested with the trial.
"""

from __future__ import annotations

import dataclasses

from device.backend import Backend
from device.loop.messages import ShownToPatient, Start, TrialEnded, TrialStarted
from device.loop.pipeline import assistance_group
from device.recording.messages import BeginTrial, EndTrial, TrialEvent


class TrialRun:
    """Starting and ending a trial (a part of DeviceLoop)."""

    def _start_trial(self, command: Start) -> str:
        self.paused = True
        # the exercise waits at its start while the drives' torque ramps up (H3)
        self.pipeline.begin(self.reading.q1_rad, self.reading.q2_rad,
                            still_s=self.supervisor.limits.restart_ramp_s)
        # every trial starts from its own settings: a live change belonged to the trial it
        # was made in (issue 27: one made between trials ran every later trial at it)
        self.pipeline.set_assistance_level(self.plan.parameters.assistance_level)
        self.supervisor.restart_ramp()
        self.trial_path = command.path
        self.trial_tick = 0
        self.trial_start_sample_s = self.reading.time_s
        if self.pipeline.approach_ticks == 0:
            cue_patient(self.backend)
        plan = self.plan
        self.seed_used = True
        first_seq = self.ring.write_count
        self.trial_first_seq = first_seq
        self.recorder_pulse.reset()
        self._to_recorder(BeginTrial(
            command.path, first_seq, plan.parameters, command.subject,
            dataclasses.asdict(plan.robot), self.opened.label, plan.period_s,
        ))
        started = {"approach_ticks": self.pipeline.approach_ticks}
        if self.opened.kind == "simulator":
            started["seed"] = self.opened.seed  # the file runs again with it
            started["robot_seed"] = self.opened.robot_seed  # on the same simulated robot
        elif self.opened.robot_name:
            started["robot"] = self.opened.robot_name  # which robot (app.learning.library)
        self._to_recorder(TrialEvent(0.0, 0, "start", "trial started", started))
        if command.display is not None:
            self._tell_shown(command.display, 0)
        # a task the robot leads: each phase's start, told as the tick comes (core.holdtasks)
        self.task_events = list(reversed(self.pipeline.task_events()))
        self._tell_task_events()
        self._send(TrialStarted(command.path, self.pipeline.approach_ticks,
                                self.pipeline.total_ticks, self.t0, first_seq))
        return ""

    def _tell_shown(self, shown: ShownToPatient, tick: int) -> None:
        """What the patient's screen shows from `tick` on, into the trial file."""
        self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, "patient_screen",
                                     shown.message, dict(shown.values)))

    def _tell_task_events(self) -> None:
        """The task's events whose tick has come, to the recorder and the console."""
        while self.task_events and self.task_events[-1][0] <= self.trial_tick:
            tick, kind, message, values = self.task_events.pop()
            event = TrialEvent(tick * self.plan.period_s, tick, kind, message, values)
            self._to_recorder(event)

    def _end_trial(self, status: str, message: str, values: dict | None = None) -> None:
        tick = self.trial_tick
        time_s = tick * self.plan.period_s
        self._to_recorder(TrialEvent(time_s, tick, "stop", message, values or {}))
        summary = {"approach_s": self.pipeline.approach_ticks * self.plan.period_s,
                   "ticks": float(tick),
                   # wall_time is perf_counter() − this; on Linux both perf_counter and
                   # time.monotonic read CLOCK_MONOTONIC, so camera frames stamped with
                   # time.monotonic() line up with the samples (device.camera.capture).
                   "wall_time_origin_monotonic_s": self.t0,
                   # the robot's own clock over the trial: ticks × period on the
                   # simulator however late the ticks, monotonic seconds on hardware
                   "robot_clock_s": self.reading.time_s - self.trial_start_sample_s,
                   "timing": self.backend.timing,
                   # the simulated robot, as a headless trial's file names it
                   **_plant_of(self.backend)}
        # a virtual patient stops its exercise with the trial: a person lets go of the
        # push and rests their hand while the robot is at zero torque between trials
        _rest_patient(self.backend)
        self.end_seq = self.ring.write_count
        pipeline = self.pipeline
        self._to_recorder(EndTrial(self.end_seq, status, summary, assistance_group(
            self.plan.parameters, pipeline.guidance, pipeline.feedforward_history)))
        self._send(TrialEnded(self.trial_path, status, summary, self.end_seq))


def cue_patient(backend: Backend) -> None:
    """A virtual patient starts the exercise together with the reference."""
    cue = getattr(backend, "cue_patient", None)
    if cue is not None:
        cue()


def _plant_of(backend: Backend) -> dict:
    """The simulated robot a backend runs (through a fault injector), as the trial file's
    summary names it (device.sim.plant.plant_summary); {} for the real robot."""
    from device.sim.plant import plant_summary

    backend = getattr(backend, "inner", backend)
    plant = getattr(backend, "plant", None)
    return plant_summary(plant.describe() if plant is not None else None)


def _rest_patient(backend: Backend) -> None:
    """A virtual patient stops the exercise together with the trial."""
    rest = getattr(backend, "rest_patient", None)
    if rest is not None:
        rest()
