"""liblsl through pylsl: loading it, what a stream is, this machine's LSL clock, and the
loopback configuration every test and bench runs with.

pylsl 1.18.6's manylinux_2_35 wheel carries liblsl itself (`pylsl/lib/liblsl.so`), so a
Linux with glibc 2.35 or newer (Debian 12, Ubuntu 22.04) needs nothing else. On an older
glibc pip installs the pure-Python wheel without the library, and importing pylsl fails
with "LSL binary library file was not found": `LslError` says so and what to do.

Clocks: LSL stamps samples with `local_clock()`, which on Linux is CLOCK_MONOTONIC, the
clock of `time.monotonic()` and of the loop's `wall_time` (plus its origin,
docs/data-format.md).

Discovery: liblsl finds streams by broadcast and multicast on every interface unless the
file named by `LSLAPICFG` says otherwise; it reads that file once, when pylsl is first
used. The console keeps liblsl's defaults (a lab's network); `use_loopback` points the
tests and benches at this machine only, before pylsl is loaded.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

from device.errors import DeviceError
from device.safewrite import make_private_folders, write_text

LOOPBACK_CONFIG = (
    "; liblsl confined to this machine (device.lsl.library.use_loopback)\n"
    "[ports]\nIPv6 = disable\n"
    "[multicast]\nResolveScope = machine\nMachineAddresses = {127.0.0.1}\n"
    "[log]\nlevel = -2\n"
)
"""liblsl's ini: `;` starts a comment; a repeated key or a line without `=` makes liblsl
throw the whole file away, so it is written whole, never patched."""


QUIET_CONFIG = "; liblsl's defaults, without its log (device.lsl.library)\n[log]\nlevel = -2\n"
"""What liblsl runs with when nobody configured it: its defaults (a lab's network), but
without the INFO line ("api_config.cpp:126 INFO| Loaded default config") it otherwise
writes on stderr at its first use, under a command's own output. Its errors stay, in the
console's log folder when it has one (`log_liblsl_into`)."""

LIBLSL_LOG = "liblsl.log"
"""liblsl's own log in the console's log folder (`log_liblsl_into`)."""

_log_file: list[Path] = []


def log_liblsl_into(path: Path | None) -> None:
    """Where liblsl writes its errors when nobody configured it: into `path` (the console's
    log folder) instead of stderr. A sender that goes away while its stream is read makes
    liblsl write "Stream transmission broke off (Input stream error.); re-connecting..."
    on stderr, under the console's own line for the same event (the EMG stopped); liblsl's
    level is one for all its lines, so a lower one would hide its other errors too (a
    configuration it cannot read, no network interface), while a file (liblsl's `[log]
    file`, since 1.14) keeps every one. Read once, when pylsl is first used; a path liblsl's
    ini cannot hold (a line break, spaces at its ends) leaves the errors on stderr."""
    _log_file.clear()
    text = str(path) if path is not None else ""
    if text and text == text.strip() and "\n" not in text and "\r" not in text:
        _log_file.append(Path(text))


def quiet_config() -> str:
    """QUIET_CONFIG, with liblsl's log file where one was given (`log_liblsl_into`)."""
    return QUIET_CONFIG + "".join(f"file = {path}\n" for path in _log_file)


def user_config_files() -> tuple[Path, ...]:
    """Where liblsl looks for a configuration besides LSLAPICFG, in its order (liblsl's
    api_config.cpp): the working folder, the user's, the system's."""
    return (Path("lsl_api.cfg"), Path.home() / "lsl_api" / "lsl_api.cfg",
            Path("/etc/lsl_api/lsl_api.cfg"))


class LslError(DeviceError):
    """A stream is missing or not what was asked; one line."""


def pylsl():
    """The pylsl module, or one line saying why it cannot be loaded. liblsl gets
    `quiet_config()` unless a configuration of the lab's or the tests' is there."""
    try:
        import pylsl as module
    except (ImportError, RuntimeError, OSError) as exc:
        raise LslError(f"the Lab Streaming Layer library cannot be loaded ({exc}); pylsl 1.18.6 "
                       "ships liblsl for Linux with glibc 2.35 or newer: on an older system "
                       "install liblsl from its releases or use mne-lsl") from None
    if not os.environ.get("LSLAPICFG") and not any(p.is_file() for p in user_config_files()):
        # read by liblsl once, at its first use; set again later, it changes nothing
        module.set_config_content(quiet_config())
        if _log_file:
            _first_use_without_stderr(module)
    return module


def _first_use_without_stderr(module) -> None:
    """Make liblsl read its configuration now, with the process's stderr on /dev/null.
    With a log file named, liblsl adds the file before it turns its stderr output off
    (liblsl's api_config.cpp), and loguru announces the file there: "loguru.cpp:842 INFO|
    Logging to '…/liblsl.log'", under a command's own output. Its errors from then on go
    to the file. Any use reads the configuration (once per process); the protocol
    version is the cheapest."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 2)
        finally:
            os.close(null)
        module.protocol_version()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def use_loopback(folder: Path) -> Path:
    """Write the loopback configuration into `folder` and point LSLAPICFG at it, so that no
    stream is announced or looked for beyond this machine. It must come before pylsl is
    loaded (liblsl reads the file once); after, it refuses rather than pretend."""
    if "pylsl" in sys.modules:
        raise LslError("pylsl is already loaded, so liblsl has read its configuration: set "
                       "the loopback configuration before anything imports pylsl")
    make_private_folders(folder)
    path = write_text(Path(folder) / "lsl-loopback.cfg", LOOPBACK_CONFIG, overwrite=True)
    os.environ["LSLAPICFG"] = str(path)
    return path


@dataclass(frozen=True, slots=True)
class StreamSummary:
    name: str
    type: str
    channel_count: int
    nominal_rate_hz: float
    hostname: str
    source_id: str


def summary(info) -> StreamSummary:
    return StreamSummary(info.name(), info.type(), info.channel_count(), info.nominal_srate(),
                         info.hostname(), info.source_id())


def find_streams(wait_s: float = 1.0) -> list[StreamSummary]:
    """Every LSL stream seen within `wait_s`."""
    return [summary(i) for i in pylsl().resolve_streams(wait_time=wait_s)]


def local_clock() -> float:
    return pylsl().local_clock()


CHANNEL_KEYS = ("label", "unit", "type", "scaling_factor")


def channel_descriptions(info) -> list[dict[str, str]]:
    """Each channel's `label`, `unit`, `type` and `scaling_factor` (core.emg.units) from the
    stream's description (`desc/channels/channel`, the XDF meta-data convention), '' where
    not given; one dict per channel, as many as the stream has."""
    out = []
    channel = info.desc().child("channels").child("channel")
    for _ in range(info.channel_count()):
        if channel.empty():
            out.append(dict.fromkeys(CHANNEL_KEYS, ""))
            continue
        out.append({key: channel.child_value(key).strip() for key in CHANNEL_KEYS})
        channel = channel.next_sibling("channel")
    return out
