"""What the processes of a live trial say to each other: typed, picklable messages.

    console (client) ──commands──▶ loop ──trial messages──▶ recorder
           ◀────────events─────────┘                           │
           ◀──────────────────────recorder notices─────────────┘

The loop's messages to the recorder, and the recorder's notices to the console, are in
device.recording.messages. E-stop and the heartbeat do not travel as messages: they are
shared counters the loop reads every tick (device.loop.client), so neither waits behind
anything.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from core.trial import TrialParameters
from device.recording.trialfile import SubjectInfo
from device.safety.limits import SafetyLimits

# ------------------------------------------------------------------ backends
BACKEND_KINDS = ("simulator", "quanser")


@dataclass(frozen=True, slots=True)
class BackendConfig:
    """Which robot the loop drives. Built inside the loop process at Connect.

    simulator: `patient` is a virtual patient kind (device.sim.patient_parameters.PATIENT_KINDS).
    quanser: `hardware_settings` is the TOML file of docs/hardware.md.
    `fault_scenario` wraps the backend in device.sim.faultinjection.FaultInjectingBackend
    (commissioning and tests), with `fault_options` as keyword arguments.
    `timing` (device.backend): None for the backend's own (the simulator is stepped
    by the nominal period, hardware runs on the wall clock); "real" runs the simulator
    on the wall clock with the hardware's late-tick watchdog, to rehearse on a PC how
    the real robot's loop would be timed there.
    `seed`: None (the default) draws a new seed for every trial (device.sim.simulator.
    draw_seed: at Connect, and again at a Start after a trial ran on that one), so a
    course of simulated trials varies as a person's would; a whole number fixes one, for
    every trial. The seed each trial ran is in its file (`backend`, the start event).
    """

    kind: str = "simulator"
    patient: str = "healthy"
    seed: int | None = None
    hardware_settings: str | None = None
    fault_scenario: str | None = None
    fault_at_s: float = 1.0
    fault_options: tuple[tuple[str, object], ...] = ()
    timing: str | None = None
    plant: str = "realistic"
    """The simulated robot (device.sim.plant.PLANTS): its own parameters drawn around the
    controller's model by `robot_seed`, or the model itself."""
    robot_seed: int = 0
    """The draw of a realistic plant's robot (device.sim.seeds.ROBOT_SEED): the same
    simulated robot for every trial, whatever `seed` draws for the patient."""
    push_at_connect_N: tuple[float, float] = (0.0, 0.0)
    """A simulated hand pushing the handle while the force sensor takes its zero at
    Connect (global frame, N; device.sim.simulator): to see the zero refused."""
    robot_name: str = ""
    """The real robot's name (its settings file's `[robot] name`), set by the loop from the
    file as it opened it, never by the window: the trial records the robot it ran on."""

    @property
    def label(self) -> str:
        if self.kind == "simulator":
            clock = ", on the wall clock" if self.timing == "real" else ""
            seed = "a new seed each trial" if self.seed is None else f"seed {self.seed}"
            return f"simulator ({self.patient}, {seed}{clock})"
        if self.robot_name:
            return f"quanser (robot {self.robot_name}, {self.hardware_settings})"
        return f"quanser ({self.hardware_settings})"


# ------------------------------------------------------------------ commands
@dataclass(frozen=True, slots=True)
class Build:
    """Build a trial. `model` is the learned model the trial's parameters name
    (`learned_model`, its hash `learned_model_sha256`): a core.learning.tick.
    LearnedInverseDynamics the console read and checked (app.learning.library), None for
    the analytic model."""

    id: int
    parameters: TrialParameters
    backend: BackendConfig = field(default_factory=BackendConfig)
    limits: SafetyLimits | None = None
    model: object | None = None


@dataclass(frozen=True, slots=True)
class Connect:
    id: int


@dataclass(frozen=True, slots=True)
class Disconnect:
    id: int


@dataclass(frozen=True, slots=True)
class Start:
    """Start a trial recorded to `path` (chosen by the app from the registry)."""

    id: int
    path: str
    subject: SubjectInfo
    display: ShownToPatient | None = None
    """What the patient's screen shows as the trial starts (the window's; None where the
    console has no patient's screen, as `rehab run`): the file's events hold it."""
    answer_by_s: float | None = None
    """The console's time.monotonic() (the same clock in every process of this computer)
    after which it no longer waits for the answer and takes the trial back: a Start the
    loop comes to later is refused, never run (it ran a trial the registry had withdrawn);
    None: no limit. Set by DeviceClient.request."""


@dataclass(frozen=True, slots=True)
class Stop:
    id: int


@dataclass(frozen=True, slots=True)
class ClearFault:
    id: int


@dataclass(frozen=True, slots=True)
class SetAssistance:
    id: int
    level: float


@dataclass(frozen=True, slots=True)
class Shutdown:
    id: int
    signal: str = ""
    """The stop signal the console was given (SIGINT, SIGTERM, SIGHUP), '' when closed by
    hand: a running trial then stops as at a fault naming it (docs/safety.md)."""


COMMAND_TYPES = (Build, Connect, Disconnect, Start, Stop, ClearFault, SetAssistance, Shutdown)


@dataclass(frozen=True, slots=True)
class ShownToPatient:
    """What the patient's screen shows: whether it is open and the therapist's options
    for it (ui.views.patient_screen.PatientOptions.to_dict), with `message` saying so in
    words. Feedback is part of what a trial was (knowledge of performance and of results
    change how a patient learns), so the trial file records it as the event
    "patient_screen" at the trial's start and at the tick of every change the therapist
    makes while the trial runs (docs/data-format.md). Data, not a command: neither
    answered nor bound to a state; the loop drops it when no trial runs."""

    message: str
    values: dict


@dataclass(frozen=True, slots=True)
class TrialNote:
    """Something the console saw while a trial ran that the trial's own samples do not
    say (a live EMG source whose numbers reach volts: its unit is wrong), for the trial
    file: the event `kind` with `message` and `values` at the tick the loop takes it
    (docs/data-format.md). Data, not a command, as ShownToPatient: the loop drops it
    when no trial runs."""

    kind: str
    message: str
    values: dict


@dataclass(frozen=True, slots=True)
class ForceEstimate:
    """The console's latest estimate of the patient's force on the handle (global frame,
    N; NaN when it has none), made from EMG for the trial's tick `tick`: data, not a
    command, so neither answered nor bound to a state. The loop hands it to the
    assistance of a trial that names a force estimate (TickPipeline.set_force_estimate)
    and drops it otherwise."""

    fx_N: float
    fy_N: float
    tick: int


# ------------------------------------------------------------------ events to the console
@dataclass(frozen=True, slots=True)
class Reply:
    """The answer to one command: done, or refused with the reason."""

    id: int
    ok: bool
    message: str = ""


@dataclass(frozen=True, slots=True)
class StateChanged:
    state: int  # device.loop.states.State
    reason: str = ""


@dataclass(frozen=True, slots=True)
class FaultRaised:
    code: int  # device.safety.faults.Fault
    message: str
    detail: dict
    time_s: float
    monotonic_s: float  # time.monotonic() in the loop when it was detected


@dataclass(frozen=True, slots=True)
class TrialStarted:
    path: str
    approach_ticks: int
    total_ticks: int
    # monotonic time of wall_time 0 (the loop's clock origin): what puts live records on
    # other instruments' clocks (the LSL outlet, device.lsl)
    wall_time_origin_monotonic_s: float = float("nan")
    first_seq: int = -1
    """The ring sequence number of the trial's first record (its tick 0)."""


@dataclass(frozen=True, slots=True)
class ClockStarted:
    """The loop began ticking (at Connect): every record it pushes from ring sequence number
    `first_seq` on has its `wall_time` counted from `origin_monotonic_s`. Sent before that
    record is pushed, so a reader that reads the ring and then its messages always knows
    the clock of what it read (the LSL outlet's stamps, device.lsl.timeline)."""

    origin_monotonic_s: float
    first_seq: int


@dataclass(frozen=True, slots=True)
class TrialMarker:
    """An event the loop writes into the trial file (start with the trial's settings,
    stop, fault, a live assistance change), for the console's other instruments: it
    happened at the tick whose record has ring sequence number `seq`; `monotonic_s` is
    when the loop sent it (the stamp when that record is no longer at hand)."""

    kind: str
    message: str
    values: dict
    tick: int
    seq: int
    monotonic_s: float


@dataclass(frozen=True, slots=True)
class TrialEnded:
    path: str
    status: str  # complete | stopped_early | faulted | recording_lost
    summary: dict
    end_seq: int = -1
    """The trial's records end before this ring sequence number."""


@dataclass(frozen=True, slots=True)
class SensorZeroed:
    """The handle's force sensor took its zero at Connect with nothing on the handle (a
    zero under load refuses the Connect instead, in one line): sent before the Connect's
    reply, so the window can say "zero taken" (device.backend.Tare)."""

    duration_s: float
    spread_N: float
    """How much the force in the plane moved during the zero (RMS about its mean, N)."""
    limit_N: float

    @property
    def message(self) -> str:
        return (f"zero taken: the force sensor's zero at Connect ({self.duration_s:g} s, "
                f"the force moved {self.spread_N:.2f} N, within the sensor's noise)")


@dataclass(frozen=True, slots=True)
class HandleArea:
    """Between trials, where the handle is against the exercise area: `line` says it is
    outside and where ('' once it is inside). Sent when it changes, checked ten times a
    second while connected with no trial: outside the area is a state then, and Start is
    refused until the handle is inside (docs/safety.md, H8)."""

    line: str


@dataclass(frozen=True, slots=True)
class Notice:
    """Something the therapist or technician should know (real-time setup, a warning)."""

    level: str  # "info" | "warning" | "error"
    message: str
