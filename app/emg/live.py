"""Opening a live EMG source from the words a researcher types: `trigno:HOST`,
`avanti:HOST` (a Delsys base station through the Trigno Control Utility) or
`lsl:STREAM_NAME` (any Lab Streaming Layer EMG stream). The source is started and ready
for device.emg.capture.EmgCapture."""

from __future__ import annotations

from app.emg.importing import EmgImportError

FORMS = "trigno:HOST, avanti:HOST or lsl:STREAM_NAME"


def open_source(spec: str, *, command_port: int = 50040, data_port: int | None = None,
                timeout_s: float = 3.0):
    """(source, label): the opened, streaming source and how to name it."""
    from device.emg.lsl import LslEmgInlet
    from device.emg.trigno import TrignoClient

    kind, sep, where = spec.strip().partition(":")
    where = where.strip()
    if not sep or not where or kind not in ("trigno", "avanti", "lsl"):
        raise EmgImportError(f"EMG source {spec!r}: give {FORMS}")
    if kind == "lsl":
        return LslEmgInlet(where, timeout_s=timeout_s).open(timeout_s), f"lsl:{where}"
    client = TrignoClient(where, model=kind, command_port=command_port, data_port=data_port,
                          timeout_s=timeout_s).open()
    client.start()
    return client, f"{kind}:{where}"
