"""The order in which the loop tells of a fault that ends a trial: the console first, the
recorder after. The recorder's word on the trial's file ("closed", "lost") follows the
trial's end; told before the fault, that word could reach the window first and the registry
kept the trial's end without its cause (a CI run: a trial whose file could not be made,
listed as lost with no "The trial file could not be written"). In this process, no ticks
timed: each tick is called by hand."""

from types import SimpleNamespace

from core.trial import THESIS_SUBJECT
from device.loop.messages import BackendConfig, Build, Connect, FaultRaised, Start
from device.loop.states import State
from device.recording.messages import EndTrial
from device.recording.trialfile.layout import SubjectInfo
from tests.device.bare_loop import bare_loop


def test_the_console_hears_the_fault_before_the_recorder_hears_the_trials_end():
    recording_failed = SimpleNamespace(value=0)
    with bare_loop(4096, recording_failed=recording_failed) as (loop, _console):
        said: list = []
        loop._send = lambda message: said.append(("console", message))
        loop._to_recorder = lambda message: said.append(("recorder", message))
        loop._command(Build(1, THESIS_SUBJECT.replace(repetitions=1), BackendConfig()))
        loop._command(Connect(2))
        loop.t0 = loop.clock.now()
        loop._beat = (0, loop.t0)
        loop._tick(0, loop.clock.now(), 0.0)  # the sensors' first reading
        loop._command(Start(3, "/tmp/trial.h5", SubjectInfo("P1", 70.0, 0.3, 0.3, "right")))
        for k in range(1, 5):
            loop._tick(k, loop.clock.now(), 0.0)
        assert loop.state == State.RUNNING
        said.clear()
        recording_failed.value = 1  # the recorder could not make the trial's file
        loop._tick(5, loop.clock.now(), 0.0)
        assert loop.state == State.FAULTED
        order = [(to, type(message)) for to, message in said]
        assert order.index(("console", FaultRaised)) < order.index(("recorder", EndTrial))
