"""Opening a live EMG source from the words a researcher types: `trigno:HOST`,
`avanti:HOST` (a Delsys base station through the Trigno Control Utility) or
`lsl:STREAM_NAME` (any Lab Streaming Layer EMG stream). The source is started and ready
for device.emg.capture.EmgCapture."""

from __future__ import annotations

from app.emg.importing import EmgImportError

FORMS = ("trigno:HOST, avanti:HOST or lsl:STREAM_NAME (lsl:STREAM_NAME@uV when the stream "
         "does not say its unit)")
KINDS = {"trigno": "Trigno base station (host)", "avanti": "Avanti / Trigno+ (host)",
         "lsl": "LSL stream (name)"}
# the amplifier's range, for the MVC's saturation check; unknown for an LSL stream, whose
# clipping shows as repeated extremes instead (core.emg.mvc)
FULL_SCALE_V = {"trigno": 0.011}


def source_spec(kind: str, where: str) -> str:
    """The words for `open_source` from a chosen kind and a typed host or stream name; a
    typed `word:WHERE` is taken as it is (and refused by `open_source` if the word is not
    one of KINDS)."""
    where = where.strip()
    typed, sep, _ = where.partition(":")
    if sep and typed.isalpha():
        return where
    return f"{kind}:{where}"


def full_scale_of(label: str) -> float | None:
    return FULL_SCALE_V.get(label.partition(":")[0])


def open_source(spec: str, *, command_port: int = 50040, data_port: int | None = None,
                timeout_s: float = 3.0):
    """(source, label): the opened, streaming source and how to name it."""
    from device.emg.trigno import TrignoClient
    from device.lsl.inlet import LslEmgInlet

    kind, sep, where = spec.strip().partition(":")
    where = where.strip()
    if not sep or not where or kind not in ("trigno", "avanti", "lsl"):
        raise EmgImportError(f"EMG source {spec!r}: give {FORMS}")
    if kind == "lsl":
        # lsl:NAME, or lsl:NAME@uV for a stream that does not declare its channels' unit
        name, at, unit = where.rpartition("@") if "@" in where else (where, "", "")
        if at and not (name.strip() and unit.strip()):
            raise EmgImportError(f"EMG source {spec!r}: give lsl:STREAM_NAME or "
                                 "lsl:STREAM_NAME@UNIT (V, mV or uV)")
        inlet = LslEmgInlet(name.strip(), timeout_s=timeout_s, unit=unit.strip() or None)
        return inlet.open(timeout_s), f"lsl:{name.strip()}"
    client = TrignoClient(where, model=kind, command_port=command_port, data_port=data_port,
                          timeout_s=timeout_s).open()
    client.start()
    return client, f"{kind}:{where}"
