"""Shared test setup: Qt offscreen before anything imports it, a fixed hypothesis profile, and
the options that run the hardware tests on a real robot (docs/hardware.md, "Checking the
fakes against your robot").

Rig tests are ordinary tests whose backend fixture has two variants: `[fake]` (the vendor
fakes, always) and `[rig]` (the real card and sensor, marked `rig`). Without the options the
`[rig]` variants are deselected at collection, never skipped: a test of a real component does
not skip in CI. With an option given but its vendor package, settings or device missing, the
run stops with one line saying what is missing (a `pytest.UsageError`).
"""

from __future__ import annotations

import atexit
import contextlib
import os
import re
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, replace

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
# Model files are signed with the installation's key in the config folder
# (app.records.signing): the suite has a config folder of its own, never the user's.
if not os.environ.get("REHAB_CONFIG_DIR"):
    os.environ["REHAB_CONFIG_DIR"] = tempfile.mkdtemp(prefix="rehab-tests-config-")
# Nor the user's data folder: a test that leaves out --data-dir and REHAB_DATA_DIR (or
# undoes them: a monkeypatch.undo() inside a test) gets the default data folder, which is
# platformdirs' under XDG_DATA_HOME: a folder of the run's own, never the user's registry
# (a whole check once migrated ~/.local/share/rehab-console/registry.sqlite3).
os.environ["XDG_DATA_HOME"] = tempfile.mkdtemp(prefix="rehab-tests-data-home-")
# XLA compiles a network's training step for each train() call, the same program again
# whenever the shapes and options are the same: 5-10 s of a small model's 6-20 s (fnn
# 6.7 s -> 1.6 s, delan 14.9 s -> 5.9 s for 100 epochs from a warm cache). The run keeps
# what it compiled in a folder of its own, empty at its start (nothing carried from an
# earlier run or another checkout), which the CLI processes it starts read too (they
# inherit the environment). The compiled program is the same either way: only its
# compiling is saved.
if not os.environ.get("JAX_COMPILATION_CACHE_DIR"):
    os.environ["JAX_COMPILATION_CACHE_DIR"] = tempfile.mkdtemp(prefix="rehab-tests-xla-")
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"

    def _remove_xla_cache(folder: str = os.environ["JAX_COMPILATION_CACHE_DIR"],
                          owner: int = os.getpid()) -> None:
        """At the run's end; not by a child forked from it that exits through Python."""
        if os.getpid() == owner:
            shutil.rmtree(folder, ignore_errors=True)

    atexit.register(_remove_xla_cache)

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from device.lsl.library import use_loopback
from tests.patience import be_patient

# Nothing leaves this machine in tests: liblsl reads LSLAPICFG once, when pylsl is first
# used, so the suite confines it to loopback before any test module imports pylsl (and
# whatever the environment pointed it at; child processes inherit it).
use_loopback(Path(tempfile.mkdtemp(prefix="rehab-tests-lsl-")))

settings.register_profile(
    "project", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("project")

# Every wait on a live process waits for its event, with a deadline only a hang reaches
# (tests/patience.py): the CI host can stall a process for 20 s and more.
be_patient()


# -- the rig options -----------------------------------------------------------------------------

DESELECTED = "Without it the [rig] tests are deselected (reported as deselected, never skipped)."

RIG_PARTS = {
    # marker argument: (the option(s) that enable it, whether the options given enable it)
    "quanser": ("--quanser-board", lambda rig: rig.quanser),
    "nidaq": ("--nidaq-device or --quanser-board", lambda rig: rig.nidaq),
    "move_by_hand": ("--rig-move-by-hand", lambda rig: rig.move_by_hand),
    "watchdog_expiry": ("--rig-allow-watchdog-expiry", lambda rig: rig.watchdog_expiry),
}
"""What a `[rig]` test may need. The `rig(part)` marker sits on the real variant of a backend
fixture; `rig_needs(*parts)` on a test adds parts its real variant needs (ignored by `[fake]`)."""


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup(
        "rig", "tests on the real robot (docs/hardware.md, 'Checking the fakes against your robot')"
    )
    group.addoption(
        "--quanser-board", metavar="ID", default=None,
        help="Also run the [rig] tests on the real Quanser card: board identifier ID ('0' is the "
             "first board of [quanser] board_type), replacing board_identifier of "
             "--hardware-settings, which it needs. Includes the force sensor of the settings "
             f"file. Commands zero torque only. {DESELECTED}",
    )
    group.addoption(
        "--nidaq-device", metavar="NAME", default=None,
        help="The NI-DAQmx device of the force sensor as NI MAX names it (e.g. Dev1), replacing "
             "the device of [force_sensor] physical_channels. Alone (without --quanser-board) "
             f"runs the force-sensor [rig] tests only. Needs --hardware-settings. {DESELECTED}",
    )
    group.addoption(
        "--hardware-settings", metavar="PATH", default=None,
        help="The robot's hardware settings file (resources/hardware.example.toml filled in for "
             "this robot): channels, signs, homing pose, watchdog, calibration file.",
    )
    group.addoption(
        "--rig-move-by-hand", action="store_true", default=False,
        help="Also run the [rig] test that asks you to turn each link by hand (amplifiers "
             "OFF) and checks the angle grows counter-clockwise. Needs --quanser-board.",
    )
    group.addoption(
        "--rig-allow-watchdog-expiry", action="store_true", default=False,
        help="Also run the [rig] test that lets the Q8 watchdog expire. Only with the "
             "amplifiers' enable OFF (or the motor leads disconnected) and zero torque "
             "commanded. Needs --quanser-board.",
    )


@dataclass(frozen=True)
class RigConfig:
    """What the rig options asked for: the robot's settings with --quanser-board and
    --nidaq-device applied, and which of the optional checks the operator allowed."""

    settings: object  # device.hardware.settings.HardwareSettings
    quanser: bool
    nidaq: bool
    move_by_hand: bool
    watchdog_expiry: bool
    pytest_config: pytest.Config
    period_s: float = 0.002  # the control loop's period: rig tests read at its pace

    def say(self, text: str) -> None:
        """Print to the operator's terminal now, whatever pytest captures."""
        capture = self.pytest_config.pluginmanager.getplugin("capturemanager")
        with capture.global_and_fixture_disabled() if capture else contextlib.nullcontext():
            print(f"\n[rig] {text}", flush=True)

    def ticker(self) -> Ticker:
        return Ticker(self.period_s)


class Ticker:
    """Waits for the next loop deadline on the monotonic clock (absolute deadlines, as the
    loop keeps them; a deadline missed by more than a period starts afresh from now)."""

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self._next: float | None = None

    def wait(self) -> float:
        now = time.monotonic()
        if self._next is None or now - self._next > self.period_s:
            self._next = now
        while (remaining := self._next - time.monotonic()) > 0.0:
            time.sleep(remaining)
        self._next += self.period_s
        return time.monotonic()


_RIG = pytest.StashKey[RigConfig]()


def _with_device(spec: str, device: str) -> str:
    """NI physical channels `spec` with every item's device replaced: Dev1/ai0:5 -> Dev3/ai0:5."""
    return ",".join(re.sub(r"^\s*[^/]+/", f"{device}/", item) for item in spec.split(","))


def _rig_from_options(config: pytest.Config) -> RigConfig | None:
    """The RigConfig the options ask for, or None without rig options. Raises UsageError with
    one line when an option lacks another, a vendor package or the settings file."""
    board = config.getoption("quanser_board")
    device = config.getoption("nidaq_device")
    path = config.getoption("hardware_settings")
    by_hand = config.getoption("rig_move_by_hand")
    expiry = config.getoption("rig_allow_watchdog_expiry")
    if board is None and device is None:
        if path or by_hand or expiry:
            given = "--hardware-settings" if path else (
                "--rig-move-by-hand" if by_hand else "--rig-allow-watchdog-expiry")
            raise pytest.UsageError(
                f"{given} runs nothing by itself: add --quanser-board ID (the Q8 card and the "
                "force sensor) or --nidaq-device NAME (the force sensor only)."
            )
        return None
    if board is None and (by_hand or expiry):
        raise pytest.UsageError(
            f"{'--rig-move-by-hand' if by_hand else '--rig-allow-watchdog-expiry'} checks the "
            "Q8 card: add --quanser-board ID."
        )
    # The vendor packages first: without them nothing else matters.
    from device.errors import BackendUnavailable
    from device.hardware.forcesensor import import_nidaqmx
    from device.hardware.hil import import_hil

    asked = f"--quanser-board {board}" if board is not None else f"--nidaq-device {device}"
    try:
        if board is not None:
            import_hil()
        import_nidaqmx()
    except BackendUnavailable as exc:
        raise pytest.UsageError(f"{asked}: {exc} (this Python: {sys.executable})") from None
    if not path:
        raise pytest.UsageError(
            f"{asked} needs --hardware-settings PATH: this robot's settings file (copy "
            "resources/hardware.example.toml and fill it in, docs/hardware.md)."
        )
    from device.hardware.settings import HardwareSettingsError, load_hardware_settings

    try:
        hardware = load_hardware_settings(path)
        if board is not None:
            hardware = replace(hardware, quanser=replace(hardware.quanser,
                                                         board_identifier=str(board)))
        if device is not None:
            channels = _with_device(hardware.force_sensor.physical_channels, device)
            hardware = replace(hardware, force_sensor=replace(hardware.force_sensor,
                                                              physical_channels=channels))
    except HardwareSettingsError as exc:
        raise pytest.UsageError(f"{asked}: {exc}") from None
    return RigConfig(hardware, quanser=board is not None, nidaq=True, move_by_hand=by_hand,
                     watchdog_expiry=expiry, pytest_config=config)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "rig(part): the variant of a backend fixture that runs on the real robot; "
                   "deselected unless its option is given (tests/conftest.py)")
    config.addinivalue_line(
        "markers", "rig_needs(*parts): further options the test's [rig] variant needs "
                   "(move_by_hand, watchdog_expiry)")
    rig = _rig_from_options(config)
    if rig is not None:
        config.stash[_RIG] = rig


def pytest_report_header(config: pytest.Config) -> str:
    rig = config.stash.get(_RIG, None)
    if rig is None:
        return "rig: fakes only; the [rig] tests are deselected (see --quanser-board)"
    q, f = rig.settings.quanser, rig.settings.force_sensor
    parts = [f"Quanser {q.board_type} #{q.board_identifier}"] if rig.quanser else []
    parts.append(f"NI {f.physical_channels}")
    extra = [name for name, on in (("move by hand", rig.move_by_hand),
                                   ("watchdog expiry", rig.watchdog_expiry)) if on]
    return (f"rig: {', '.join(parts)} from {rig.settings.source}"
            + (f"; also {', '.join(extra)}" if extra else ""))


def pytest_terminal_summary(terminalreporter) -> None:
    # the full-disk tests run on a real tmpfs or injected at the write calls: say which,
    # so that neither is ever taken for the other (tests/device/smalldisk.py)
    disk = sys.modules.get("tests.device.smalldisk")
    if disk is not None:
        terminalreporter.write_line(f"full disk in these tests: {disk.DISK_WORDS[disk.DISK_KIND]}")
    # the shared registry's PostgreSQL server: started by initdb or the package's cluster
    # (tests/postgres.py), as each test process's tests reported it
    for path in sorted(_POSTGRES_PATHS):
        terminalreporter.write_line(f"PostgreSQL for the tests: {path}")


def _rig_needs(item: pytest.Item) -> set[str] | None:
    """The parts the item's real variant needs, or None for a test that touches no hardware."""
    marker = item.get_closest_marker("rig")
    if marker is None:
        return None
    needs = set(marker.args)
    for extra in item.iter_markers("rig_needs"):
        needs.update(extra.args)
    unknown = needs - set(RIG_PARTS)
    if unknown:
        raise pytest.UsageError(f"{item.nodeid}: unknown rig part(s) {sorted(unknown)}")
    return needs


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rig = config.stash.get(_RIG, None)
    keep: list[pytest.Item] = []
    drop: list[pytest.Item] = []
    used: set[str] = set()
    for item in items:
        needs = _rig_needs(item)
        if needs is not None and (rig is None or not all(RIG_PARTS[p][1](rig) for p in needs)):
            drop.append(item)
            continue
        keep.append(item)
        used |= needs or set()
    if drop:
        config.hook.pytest_deselected(items=drop)
        items[:] = keep
    items[:] = sorted(items, key=_runs_jax)  # stable: the order is kept otherwise
    if rig is not None and used and not config.option.collectonly:
        _probe(rig)


JAX_TESTS = ("tests/core/learning/", "tests/app/learning/", "tests/app/cli/test_learn.py")
"""Tests that run JAX computations. They run last: once JAX has started its threads, a fork
(multiprocessing's default start on Linux, which several tests of the registry, the ring
and the data folder use) may deadlock, and JAX warns of it, which fails the test."""


def _runs_jax(item: pytest.Item) -> bool:
    path = item.path.as_posix()
    return any(part in path for part in JAX_TESTS)


def _probe(rig: RigConfig) -> None:
    """Connect once before the first [rig] test, so that a card or device that is missing,
    unpowered or held by another program stops the run with one line instead of failing
    every test with the same traceback. Other errors are left to the tests to report."""
    from device.errors import BackendError, BackendUnavailable
    from device.hardware.forcesensor import AtiForceSensor
    from device.hardware.quanser import QuanserBackend

    if rig.quanser:
        device = QuanserBackend(rig.settings)
        option = f"--quanser-board {rig.settings.quanser.board_identifier}"
    else:
        device = AtiForceSensor(rig.settings.force_sensor)
        option = f"--nidaq-device {rig.settings.force_sensor.physical_channels.split('/')[0]}"
    try:
        device.open()
    except BackendUnavailable as exc:
        raise pytest.UsageError(f"{option}: {exc}") from None
    except BackendError:
        return
    with contextlib.suppress(BackendError):
        device.close()


@pytest.fixture(scope="session")
def rig_config(pytestconfig: pytest.Config) -> RigConfig:
    """The real robot the options name; only the deselectable [rig] variants ask for it."""
    rig = pytestconfig.stash.get(_RIG, None)
    if rig is None:
        pytest.fail("a [rig] test ran without --quanser-board or --nidaq-device", pytrace=False)
    return rig


# -- synthetic EMG subject 1, recorded and its model checked once for the run ------------------

@pytest.fixture(scope="session")
def emg_subject_1(tmp_path_factory) -> tuple[Path, ...]:
    """Synthetic subject 1's session of three trials with a 30° cone
    (tests.emg_subjects.record_session), recorded once for the run (about 5 s idle, 17 s
    at load 8): the tests of the EMG estimate, the `rehab emg model` command and the
    window's EMG trials read it, none may change it. Its files' digests are checked when
    the run ends: a change is an error naming them."""
    import hashlib

    from tests.emg_subjects import record_session

    session = tuple(record_session(tmp_path_factory.mktemp("emg-subject-1")))

    def digests() -> dict[str, str]:
        return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in session}

    recorded = digests()
    yield session
    changed = [name for name, digest in digests().items() if recorded[name] != digest]
    assert not changed, f"a test changed the shared EMG session's files {changed}: copy them"


@pytest.fixture(scope="session")
def emg_model_1(emg_subject_1):
    """The network EMG model of subject 1 for the assistance, checked on the session with
    its last trial held out and replayed at the live source's latency (app.emg.validation.
    check_model; about 7 s idle, 24 s at load 8), once for the run."""
    from app.emg.feed import SyntheticEmgFeed
    from app.emg.subjects import Subject
    from app.emg.validation import check_model

    return check_model(list(emg_subject_1), "network", test=[emg_subject_1[-1]],
                       as_live=True, latency_s=SyntheticEmgFeed.latency_of(Subject.drawn(1)))


# -- which way the PostgreSQL server started, in the run's summary ---------------------------

_POSTGRES_PATHS: set[str] = set()


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Which way each test process started its PostgreSQL server, from the tests' reports
    (they reach this process from every pytest-xdist worker)."""
    for name, value in getattr(report, "user_properties", ()):
        if name == "postgres_server":
            _POSTGRES_PATHS.add(value)


# -- the shared registry's PostgreSQL server (tests/postgres.py) -----------------------------
PATH_PROPERTY = "postgres_server"


@pytest.fixture(scope="session")
def postgres_server():
    """The tests' throwaway PostgreSQL server, one per test process, started at the first
    test that needs it; when it cannot start, such a test fails in one line saying why
    (never a skip)."""
    from tests.postgres import ServerError, start

    try:
        server, problem = start(), None
    except ServerError as exc:
        server, problem = None, str(exc)
    if server is None:  # failed outside the except: one line, no chained traceback
        pytest.fail(f"the tests' PostgreSQL server did not start: {problem}", pytrace=False)
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture(autouse=True)
def _say_which_server(request):
    """The server's path in the report of every test that used it (tests/conftest.py
    prints it once at the end, from any pytest-xdist worker)."""
    if "postgres_server" in request.fixturenames:
        server = request.getfixturevalue("postgres_server")
        request.node.user_properties.append((PATH_PROPERTY, server.path))


@pytest.fixture(autouse=True)
def _recorded_files_kept(request):
    """After a test that used `tmp_path`: every registered trial's file in it is still the
    one its registry recorded (tests/recorded_files.py says why)."""
    from tests.recorded_files import MARK, changed_trial_files

    if "tmp_path" not in request.fixturenames or request.node.get_closest_marker(MARK):
        yield
        return
    folder = request.getfixturevalue("tmp_path")
    yield
    if changed := changed_trial_files(folder):
        pytest.fail("; ".join(changed) + f" (a console write into a finished trial's file "
                    f"must record its new checksum: app.trials.rewrite; a test that changes "
                    f"it on purpose is marked {MARK})", pytrace=False)


@pytest.fixture(scope="session")
def server_registries(postgres_server):
    """Registry databases on the server, each a copy of one made as a department's owner
    makes it, and a station's clinic login (tests/registries.py)."""
    from tests.registries import ServerRegistries

    return ServerRegistries(postgres_server)


