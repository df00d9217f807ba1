"""`rehab emg …`: surface EMG beside a trial: import a recording into the trial file
(app.emg.importing), the session's MVC per muscle with its quality check
(app.emg.session), a trial's envelopes in % MVC, an EMG-to-torque model validated held
out and refused for the assistance unless it passes (app.emg.validation), and the Lab
Streaming Layer's streams (device.lsl)."""

from __future__ import annotations

import argparse
import contextlib
import math
from pathlib import Path

import numpy as np

from app.cli.common import (
    CommandError,
    absolute,
    data_dir_for,
    input_file,
    output_path,
    registry_for,
    rewritten_trial,
    subcommands,
    trial_id_or_none,
)
from app.cli.emg_demo import cmd_demo
from app.emg.muscle_words import MUSCLE_WORDS
from core.emg.force import USABLE_CONE_AGREEMENT
from core.emg.models import USABLE_R2
from core.trial import MODEL_NAME, THESIS_SUBJECT

XDF_SUFFIXES = (".xdf", ".xdfz")
"""LabRecorder's recordings (app.emg.xdf), read by pyxdf."""


def add_emg_commands(commands) -> None:
    emg = commands.add_parser(
        "emg", help="surface EMG: import, MVC, envelopes, LSL streams",
        description="Surface EMG beside a trial (thesis chapter 5). TRIAL is a trial's id "
                    "(`rehab trials CODE`) or the path of its .h5 file.")
    sub = subcommands(emg, dest="emg_command", metavar="subcommand")

    p = sub.add_parser("import", help="store an exported EMG file or an XDF recording in a "
                                      "trial",
                       description="Read a Delsys Trigno CSV export, a plain CSV with a time "
                                   "column (docs/data-format.md, EMG) or a LabRecorder XDF "
                                   "recording that holds the robot's rehab-robot stream, and "
                                   "store the EMG in the trial's file on the trial's clock.")
    p.add_argument("trial", help="trial id or trial file")
    p.add_argument("file", help="the EMG file (.csv) or recording (.xdf, .xdfz)")
    p.add_argument("--muscles", help="comma-separated muscle under each EMG channel, in order "
                                     "(default: the channel names)")
    p.add_argument("--offset", type=float, default=0.0, metavar="S",
                   help="trial time of the EMG file's time 0, s (default 0: started together; "
                        "negative, as --offset=-1.5, when the EMG started first; some of the "
                        "EMG must fall within the trial; not for an XDF recording, which has "
                        "its own clock)")
    p.add_argument("--stream", help="the XDF recording's EMG stream by name (default: the one "
                                    "stream of type EMG)")
    p.add_argument("--unit", help="the unit of an XDF EMG stream's channels that declare none "
                                  "(V, mV or uV)")
    p.add_argument("--replace", action="store_true", help="replace EMG the trial already has")
    p.set_defaults(func=cmd_import)

    p = sub.add_parser("mvc", help="the session's MVC per muscle, checked, stored in its trials",
                       description="Compute each muscle's MVC (the maximum RMS envelope, window "
                                   "0.125 s, overlap 0.0625 s unless given) from its contraction "
                                   "recording, flag a contraction that is too short, saturated "
                                   "or lower than the trials' own activity, and store it in "
                                   "every trial given.")
    p.add_argument("trials", nargs="+", help="the session's trials (ids or files)")
    p.add_argument("--contraction", action="append", required=True, metavar="MUSCLE=FILE[:CH]",
                   help="a muscle's MVC recording, and its channel when the file has several "
                        "(repeat for each muscle)")
    _processing_options(p)
    p.add_argument("--full-scale", type=float, metavar="V",
                   help="the amplifier's full scale in V, to detect saturation (Trigno: 0.011)")
    p.set_defaults(func=cmd_mvc)

    p = sub.add_parser("show", help="a trial's EMG: channels, MVCs, %% MVC figures")
    p.add_argument("trial", help="trial id or trial file")
    p.set_defaults(func=cmd_show)

    p = sub.add_parser("record", help="record a live EMG source to a CSV (e.g. an MVC, guided)",
                       description="Record a Trigno base station (Trigno Control Utility) or an "
                                   "LSL EMG stream for a few seconds into a plain CSV. With "
                                   "--muscle, guide an MVC: a rest, the contraction, then check "
                                   "it (too short, saturated, no effort above the rest) at once.")
    p.add_argument("source", help="trigno:HOST, avanti:HOST or lsl:STREAM_NAME")
    p.add_argument("--seconds", type=float, default=5.0, help="how long (default 5 s)")
    p.add_argument("--output", required=True, help="the CSV to write (an existing file is "
                                                   "kept unless --overwrite)")
    p.add_argument("--overwrite", action="store_true", help="replace the --output file")
    p.add_argument("--muscle", choices=tuple(MUSCLE_WORDS), metavar="MUSCLE",
                   help="guide and check an MVC of this muscle: "
                        + ", ".join(MUSCLE_WORDS))
    p.add_argument("--channel", type=int, default=1,
                   help="the muscle's channel, from 1 (default 1)")
    p.add_argument("--rest", type=float, default=3.0,
                   help="with --muscle: seconds of rest before the contraction, the level "
                        "it must rise above (default 3 s; 0 leaves that check out); not "
                        "written to the CSV")
    p.add_argument("--command-port", type=int, default=50040, help=argparse.SUPPRESS)
    p.add_argument("--data-port", type=int, help=argparse.SUPPRESS)
    p.set_defaults(func=cmd_record)

    p = sub.add_parser("model", help="validate an EMG-to-torque model held out; refuse it "
                                     "for the assistance unless it passes",
                       description="Fit an EMG-to-joint-torque model (linear baseline, the "
                                   "thesis's network, or the muscle model) on the trials' "
                                   "% MVC envelopes and torques, and score it held out: on "
                                   "the --test trials, or leaving one subject out; the "
                                   "force its torques imply on the handle is scored by "
                                   "replaying each held-out trial as the live console would "
                                   "have received its EMG (--latency). With "
                                   "--for-assistance, refuse (exit 2, saying why) a model "
                                   f"that does not reach held-out R² {USABLE_R2:.2f} at both "
                                   "joints, does not beat the linear baseline, or whose "
                                   "force does not judge the tolerance cone as the sensor "
                                   f"does on {USABLE_CONE_AGREEMENT:.0%} of the samples.")
    p.add_argument("trials", nargs="+", help="trials with EMG and MVCs (ids or files)")
    p.add_argument("--model", choices=("linear", "network", "muscle"), default="network",
                   help="network (default): the thesis's feed-forward network; linear: the "
                        "baseline every model must beat; muscle: activation dynamics, a "
                        "delay and a strength per muscle")
    p.add_argument("--test", action="append", metavar="TRIAL",
                   help="a trial to hold out (repeat; default: leave one subject out)")
    p.add_argument("--for-assistance", action="store_true",
                   help="require the model to pass, as the patient's force estimate")
    p.add_argument("--latency", type=float, default=0.05, metavar="S",
                   help="how late the live EMG source delivers each sample (s, 0 to 1, "
                        "default 0.05): each held-out trial's force is replayed with, at "
                        "each estimate, only the EMG recorded this long before it (with or "
                        "without --for-assistance). A model saved with --save is bound to "
                        "it: `rehab run --force-estimate` refuses a later source, and the "
                        "window makes no estimate from EMG older than it plus the step between "
                        "estimates. Give the source's worst: `bench/emg.py --only "
                        "lsl` measures this computer's LSL inlet with a sender of its own "
                        "(p99, max), to which the amplifier's own delay adds")
    p.add_argument("--save", metavar="NAME",
                   help="with --for-assistance: save the passing model as NAME in the data "
                        "folder's models/emg/, for `rehab run --force-estimate NAME`")
    p.set_defaults(func=cmd_model)

    p = sub.add_parser("demo", help="write a synthetic subject's trial and MVC files to try",
                       description="Simulate a trial of a synthetic subject (a virtual patient "
                                   "whose joint torques drive a muscle model, app.emg.subjects) "
                                   "with its EMG in the trial file, and write its MVC "
                                   "contractions as CSV files, to try `rehab emg mvc` and "
                                   "`rehab emg show` on; with --trials 3 --tolerance 30, "
                                   "the trials an EMG model for the assistance is trained "
                                   "and held out on (`rehab emg model --for-assistance`).")
    p.add_argument("folder", help="where to write (created; existing files are kept)")
    p.add_argument("--subject", type=int, default=2, help="which synthetic subject (1-99)")
    p.add_argument("--trials", type=int, default=1,
                   help="how many trials of the subject (1-10, default 1), each its own "
                        "seed: two or more let `rehab emg model --test` hold one out")
    p.add_argument("--tolerance", type=float, default=math.degrees(THESIS_SUBJECT.tolerance_rad),
                   metavar="DEG",
                   help="the trials' tolerance cone in degrees (default the thesis's 20); "
                        "an EMG model is approved for the cone its trials had, and wider")
    p.add_argument("--bad-mvc", type=float, metavar="SHARE",
                   help="the anterior deltoid's MVC effort as a share of a maximum, e.g. 0.15 "
                        "(the thesis's subject 2)")
    p.add_argument("--engine", choices=("auto", "python"), default="auto",
                   help=argparse.SUPPRESS)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("streams", help="list the Lab Streaming Layer's streams on the network",
                       description="List the Lab Streaming Layer streams this computer sees "
                                   "on the network: name, type, channels, rate, host and "
                                   "source id (a source is lsl:NAME).")
    p.add_argument("--wait", type=float, default=2.0, metavar="S", help="how long to look")
    p.set_defaults(func=cmd_streams)


def _processing_options(p) -> None:
    p.add_argument("--mains", default="50", choices=("50", "60", "none"),
                   help="mains frequency to notch, Hz (default 50)")
    p.add_argument("--window", type=float, default=0.125, metavar="S", help="RMS window, s")
    p.add_argument("--overlap", type=float, default=0.0625, metavar="S", help="RMS overlap, s")


def _settings(args):
    from core.emg.processing import EmgSettings

    mains = None if args.mains == "none" else float(args.mains)
    return EmgSettings(mains_hz=mains, window_s=args.window, overlap_s=args.overlap)


def trial_file(args: argparse.Namespace, text: str) -> Path:
    """A trial given as its registry id or as a file, checked to be an HDF5 file (a PDF
    given by mistake is refused as the other commands refuse it, not in h5py's words)."""
    from app.trials.opening import check_file

    number = trial_id_or_none(text)
    if number is not None:
        path = registry_for(args).trial_path(number)
    else:
        path = absolute(text)
        if not path.exists():
            raise CommandError(f"{text}: no such trial file (give a trial id or an .h5 file)")
        path = input_file(str(path), "trial file")
    check_file(Path(path))
    return path


def cmd_import(args: argparse.Namespace) -> int:
    from app.emg.importing import import_emg_file

    muscles = [m.strip() for m in args.muscles.split(",")] if args.muscles else None
    if not np.isfinite(args.offset):
        raise CommandError(f"--offset {args.offset}: give a finite number of seconds")
    trial = trial_file(args, args.trial)
    source = input_file(args.file, "EMG file")
    if Path(source).suffix.lower() in XDF_SUFFIXES:
        if args.offset != 0.0:
            raise CommandError("--offset is for exported files: an XDF recording is placed "
                               "on the trial's clock through its rehab-robot stream")
        from app.emg.xdf import import_xdf

        with rewritten_trial(args, args.trial, trial, "imported EMG"):
            done = import_xdf(trial, source, stream=args.stream,
                              unit=args.unit, muscles=muscles, replace=args.replace)
    else:
        if args.stream or args.unit:
            raise CommandError("--stream and --unit are for an XDF recording (.xdf); an "
                               "exported file says its channels and units itself")
        with rewritten_trial(args, args.trial, trial, "imported EMG"):
            done = import_emg_file(trial, source, muscles=muscles,
                                   offset_s=args.offset, replace=args.replace)
    print(f"stored {len(done.names)} EMG channels ({', '.join(done.muscles)}) at "
          f"{done.rate_hz:g} Hz, {done.n_samples} samples, trial time "
          f"{done.first_s:.3f}–{done.last_s:.3f} s, in {done.trial.name}")
    for note in done.notes:
        print(f"note: {note}")
    return 0


def _contraction(text: str):
    from app.emg.session import Contraction

    muscle, sep, rest = text.partition("=")
    if not sep or not muscle.strip() or not rest.strip():
        raise CommandError(f"--contraction {text!r}: write MUSCLE=FILE or MUSCLE=FILE:CHANNEL")
    path, _, channel = rest.partition(":") if not Path(rest).exists() else (rest, "", "")
    return Contraction(muscle.strip(), input_file(path, f"--contraction {muscle.strip()}"),
                       channel.strip() or None)


def cmd_mvc(args: argparse.Namespace) -> int:
    from app.emg.session import session_mvc

    contractions = [_contraction(c) for c in args.contraction]
    trials = [trial_file(args, t) for t in args.trials]
    with contextlib.ExitStack() as registered:
        for text, path in zip(args.trials, trials, strict=True):
            registered.enter_context(rewritten_trial(args, text, path, "the session's MVCs"))
        results = session_mvc(trials, contractions, settings=_settings(args),
                              full_scale_V=args.full_scale)
    print(f"{'muscle':<20} {'MVC':>10} {'held':>7}  quality")
    for mvc in results:
        quality = "ok" if mvc.ok else "FLAGGED: " + ", ".join(mvc.flags)
        print(f"{mvc.muscle:<20} {1e6 * mvc.value_V:>7.0f} µV {mvc.hold_s:>5.2f} s  {quality}")
    for mvc in results:
        for reason in mvc.reasons:
            print(f"warning: {reason}")
    print(f"stored in {len(trials)} trial file(s)")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    from app.emg.session import trial_emg, trial_envelopes

    path = trial_file(args, args.trial)
    emg = trial_emg(path)
    # a synthetic subject's EMG has no source file: no empty field after its comma; a live
    # capture's is its source ('lsl:amp'), said once, not "(lsl:amp, lsl:amp)"
    origin = dict.fromkeys(str(v) for v in (emg.attrs.get("source"),
                                            emg.attrs.get("source_file")) if v)
    print(f"{path.name}: {len(emg.names)} EMG channels at {emg.rate_hz:g} Hz, "
          f"{emg.time_s.size} samples, trial time {emg.time_s[0]:.3f}–{emg.time_s[-1]:.3f} s "
          f"({', '.join(origin)})")
    offsets = [offset for _, offset in emg.clock_offsets]
    if offsets:  # what was added to the sender's stamps: a live LSL capture's, an XDF's
        said = (f"{offsets[0]:.6f} s" if len(set(offsets)) == 1 else
                f"{len(offsets)} estimates from {min(offsets):.6f} to {max(offsets):.6f} s")
        print("  clock: " + ("LabRecorder's clock offsets of the EMG stream, a line through "
                             "them added to the sender's stamps by pyxdf"
                             if emg.attrs.get("source") == "xdf" else
                             "liblsl's clock offset added to the LSL sender's stamps")
              + f", {said} (/emg clock_offsets)")
    for note in emg.notes:  # kept with the EMG as it was stored
        print(f"  note: {note}")
    if not emg.mvc:
        print("no MVC yet: rehab emg mvc TRIAL --contraction MUSCLE=FILE …")
        return 0
    env = trial_envelopes(path, with_mvc_only=True)
    print(f"{'muscle':<20} {'MVC':>10} {'median':>8} {'p95':>8} {'max':>8}  quality")
    for c, muscle in enumerate(env.muscles):
        v = env.values[:, c]
        v = v[np.isfinite(v)]
        cells = [f"{100 * np.percentile(v, q):>6.1f} %" for q in (50, 95, 100)] if v.size \
            else ["—"] * 3
        flags = env.flags[muscle]
        print(f"{muscle:<20} {1e6 * emg.mvc[muscle]['value_V']:>7.0f} µV "
              + " ".join(f"{c:>8}" for c in cells)
              + ("  ok" if not flags else "  FLAGGED: " + ", ".join(flags)))
    for muscle in emg.muscles:
        if muscle not in emg.mvc:
            print(f"{muscle:<20} {'no MVC yet':>10}  (rehab emg mvc TRIAL --contraction "
                  f"{muscle}=FILE)")
    return 0


def cmd_model(args: argparse.Namespace) -> int:
    from app.emg.validation import approve, check_model

    if not (np.isfinite(args.latency) and 0.0 <= args.latency <= 1.0):
        raise CommandError(f"--latency {args.latency}: give a delay from 0 to 1 s")
    if args.save is not None and not args.for_assistance:
        raise CommandError("--save needs --for-assistance: only a model that passes its "
                           "held-out validation is saved to feed the assistance")
    if args.save is not None and not MODEL_NAME.fullmatch(args.save):
        raise CommandError(f"--save {args.save!r} is not a model name: letters, digits, . _ - "
                           "(at most 100)")
    if args.save is not None:
        # a name already taken is refused at once, not after the fit (save_approved checks
        # again when it writes)
        from app.emg.modelfile import refuse_taken

        with contextlib.suppress(OSError):  # a folder that cannot be read: said at the save
            refuse_taken(data_dir_for(args).models_dir, args.save)
    trials = [trial_file(args, t) for t in args.trials]
    test = [trial_file(args, t) for t in args.test] if args.test else None
    # a model for the assistance learns from the envelopes the live console will give it
    checked = check_model(trials, args.model, test=test, as_live=args.for_assistance,
                          latency_s=args.latency)
    validations, model = checked.validations, checked.model
    print(f"{model.name}, held out, against the linear baseline (RMSE N·m, R²; shoulder, "
          f"elbow); passes at R² ≥ {USABLE_R2:.2f} at both joints, beating the baseline, and "
          f"with the force it implies judged as the sensor's on ≥ "
          f"{USABLE_CONE_AGREEMENT:.0%} of the samples (replayed as the live console would)")
    for v in validations:
        s, b, f = v.score, v.baseline, v.force
        force = "" if f is None else (
            f"   force RMSE {f.rmse_N[0]:.2f}, {f.rmse_N[1]:.2f} N, cone judged alike "
            f"{f.cone_agreement:.0%} ({math.degrees(f.tolerance_rad):.0f}°)")
        print(f"{v.split:<24} RMSE {s.rmse_Nm[0]:.2f}, {s.rmse_Nm[1]:.2f}  R² {s.r2[0]:.2f}, "
              f"{s.r2[1]:.2f}   baseline RMSE {b.rmse_Nm[0]:.2f}, {b.rmse_Nm[1]:.2f}  R² "
              f"{b.r2[0]:.2f}, {b.r2[1]:.2f}{force}   {'passes' if v.usable else 'fails'}")
    if args.for_assistance:
        approve(model, validations)
        print(f"{model.name} passed every held-out validation: it may stand in for the force "
              "sensor as the patient's force estimate")
    if args.save is not None:
        from app.emg.modelfile import FOLDER, save_approved

        data_dir = data_dir_for(args)
        data_dir.ensure(data_dir.models_dir.name, FOLDER)  # private to its user, like the rest
        path = save_approved(data_dir.models_dir, args.save, checked)
        print(f"saved as {args.save} ({path}); use it with `rehab run --force-estimate "
              f"{args.save}`")
    return 0


def _liblsl_log(args: argparse.Namespace) -> None:
    """liblsl's errors into the data folder's logs, not under the command's own lines
    (device.lsl.library.log_liblsl_into); where there is no data folder yet, they stay on
    stderr (an EMG command makes none for them)."""
    from app.errors import DataDirError
    from app.records.datadir import LOGS
    from device.lsl.library import LIBLSL_LOG, log_liblsl_into

    with contextlib.suppress(CommandError, DataDirError):
        data_dir = data_dir_for(args)
        if data_dir.root.is_dir():
            log_liblsl_into(data_dir.ensure(LOGS) / LIBLSL_LOG)


def cmd_streams(args: argparse.Namespace) -> int:
    if not (np.isfinite(args.wait) and 0 < args.wait <= 60):
        raise CommandError(f"--wait {args.wait}: give a time in (0, 60] s")
    from device.lsl.library import find_streams

    _liblsl_log(args)

    streams = find_streams(args.wait)
    if not streams:
        print(f"no Lab Streaming Layer stream seen in {args.wait:g} s")
    for s in streams:  # an irregular stream (markers) declares rate 0: not one to record
        rate = (f"at {s.nominal_rate_hz:g} Hz" if s.nominal_rate_hz > 0 else
                "at no regular rate (markers, not EMG)")
        print(f"{s.name!r} type {s.type!r}: {s.channel_count} channels {rate} from "
              f"{s.hostname} ({s.source_id or 'no source id'})")
    return 0


def _open_source(args):
    from app.emg.live import open_source

    return open_source(args.source, command_port=args.command_port, data_port=args.data_port)


def cmd_record(args: argparse.Namespace) -> int:
    import dataclasses
    import time

    from app.emg.importing import EmgImportError, csv_column_names
    from app.emg.protocol import check_live_range
    from core.emg.mvc import mvc_from_contraction
    from device.emg.capture import EmgCapture
    from device.emg.files import write_plain_csv

    if not (np.isfinite(args.seconds) and 0.2 <= args.seconds <= 600):
        raise CommandError(f"--seconds {args.seconds}: give 0.2 to 600 s")
    if not (np.isfinite(args.rest) and 0 <= args.rest <= 60):
        raise CommandError(f"--rest {args.rest}: give 0 to 60 s")
    output = output_path(args, args.output, overwrite=args.overwrite)
    if args.source.strip().startswith("lsl:"):
        _liblsl_log(args)
    source, label = _open_source(args)
    width = getattr(source, "channel_count", None)
    if width is not None and not 1 <= args.channel <= width:
        # before the prompt: a patient was told to contract for a channel that is not there
        source.close()
        raise CommandError(f"--channel {args.channel}: the source has channels 1 to {width}")
    for note in getattr(source, "notes", ()):  # an LSL stream's trigger channel left out
        print(f"note: {note}", flush=True)
    capture = EmgCapture(source).start()
    resting = args.rest if args.muscle else 0.0
    if resting:  # the level the push must rise above (core.emg.mvc: no effort above rest)
        print(f"Rest, relaxed ({resting:g} s) …", flush=True)
        if capture.wait_ended(resting):
            captured = capture.stop()
            raise CommandError("the source stopped during the rest, before the contraction"
                               + (f": {captured.error}" if captured.error else "")
                               + "; nothing written: check the source, then record again")
    began = time.monotonic()
    # the rest ends with the samples it brought: counted, as a source may restamp the
    # whole recording evenly at its end (device.emg.capture.stop)
    rest_count = capture.snapshot().samples.shape[0] if resting else None
    if args.muscle:
        print(f"Contract the {args.muscle} as hard as you can, and hold it "
              f"({args.seconds:g} s) … now", flush=True)
    # the source ending (unplugged, the base station stopped) ends the recording at once:
    # the patient is not kept contracting for the rest of --seconds
    ended_early = capture.wait_ended(args.seconds)
    stopped_after_s = time.monotonic() - began
    captured = capture.stop()
    if ended_early:
        print(f"the source stopped after {stopped_after_s:.1f} s of {args.seconds:g} s"
              + (f": {captured.error}" if captured.error else "")
              + "; the recording ends here, with what came", flush=True)
    if args.muscle:
        print("Relax.")
    rest_samples = None
    if rest_count is not None:  # the rest's samples are the check's, the CSV the push's
        rest_samples = captured.samples[:rest_count]
        captured = dataclasses.replace(captured, stamps_s=captured.stamps_s[rest_count:],
                                       samples=captured.samples[rest_count:])
    if captured.samples.shape[0] < 2:
        raise CommandError(f"no EMG came from {label}" + (f": {captured.error}"
                                                         if captured.error else ""))
    width = captured.samples.shape[1]
    if not 1 <= args.channel <= width:
        raise CommandError(f"--channel {args.channel}: the source has channels 1 to {width}")
    # the columns keep the names the source declares (an LSL stream's labels), as the
    # trial file does; `--contraction MUSCLE=FILE:LABEL` picks one
    names, renamed = csv_column_names(captured.labels, width)
    if renamed:
        print(f"note: {renamed}")
    try:  # not a file our own import refuses, nor an MVC of hundreds of volts said to be ok
        check_live_range(captured.samples, range(width), names, args.source.strip())
    except EmgImportError as exc:
        raise CommandError(f"nothing written: {exc}") from None
    # one sample a period: the capture's samples follow each other (a source that stops or
    # jumps ends it, device.emg.capture), while an LSL sender's chunk stamps jitter by its
    # pushes, 37 ms once, which the file's readers refuse as a gap in the recording
    times = np.arange(captured.samples.shape[0]) / captured.rate_hz
    write_plain_csv(output, names, times, captured.samples, overwrite=args.overwrite)
    print(f"recorded {captured.samples.shape[0]} samples of {width} channels at "
          f"{captured.rate_hz:g} Hz from {label} into {output}"
          + (f"; {captured.missing} missing" if captured.missing else ""))
    if captured.error and not ended_early:
        print(f"warning: the source stopped early: {captured.error}")
    if args.muscle:
        rest = None if rest_samples is None or rest_samples.shape[0] < 2 else \
            rest_samples[:, args.channel - 1]
        mvc = mvc_from_contraction(captured.samples[:, args.channel - 1], captured.rate_hz,
                                   args.muscle, rest=rest)
        print(f"{args.muscle}: MVC {1e6 * mvc.value_V:.0f} µV, held {mvc.hold_s:.2f} s: "
              + ("ok" if mvc.ok else "FLAGGED: " + ", ".join(mvc.flags)))
        for reason in mvc.reasons:
            print(f"warning: {reason}")
    # what came is kept, but the recording is shorter than asked: a partial result, exit 1
    # as a batch that did only part of its work (README: the CLI's exit codes)
    return 1 if ended_early else 0
