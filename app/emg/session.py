"""The session's MVC per muscle (section 5.2.1) and the MVC-normalised envelopes of a trial.

The protocol: at the start of a session, one isometric maximal contraction per muscle,
recorded as a file (or live) of a few seconds. `session_mvc` takes each muscle's
contraction, computes its MVC (core.emg.mvc: the maximum RMS envelope), checks it
(too short, saturated) and checks it against every trial of the session given
(lower than the trial's own activity: subject 2's deltoid), and stores it, with its
flags and the processing settings it was computed with, in each trial's `/emg/mvc`.
`trial_envelopes` then gives the trial's envelopes in fractions of MVC on the trial's
own 2 ms ticks, with the same settings, so trial and MVC are always processed alike.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.emg.importing import EmgImportError
from app.trials.reader import read_trial
from core.emg.mvc import Mvc, MvcCriteria, check_against_trial, mvc_from_contraction
from core.emg.processing import EmgSettings, as_known, envelope, normalise, on_time_base
from device.emg.files import read_emg_file
from device.recording.emgfile import EmgGroup, read_emg, write_mvc


@dataclass(frozen=True, slots=True)
class Contraction:
    """One muscle's MVC recording: the file and, when it has several channels, which."""

    muscle: str
    path: Path
    channel: str | None = None


@dataclass(frozen=True, slots=True, eq=False)
class TrialEnvelopes:
    """A trial's EMG envelopes in fractions of MVC on its own ticks (NaN where no EMG)."""

    time_s: np.ndarray
    values: np.ndarray  # (N, C)
    muscles: tuple[str, ...]
    flags: dict[str, tuple[str, ...]]  # muscle -> its MVC's flags


def trial_emg(path: str | os.PathLike) -> EmgGroup:
    emg = read_emg(path)
    if emg is None:
        raise EmgImportError(f"trial file {Path(path).name} has no EMG; import it first "
                             "(rehab emg import TRIAL FILE)")
    return emg


def _contraction_channel(contraction: Contraction, names: tuple[str, ...],
                         trial_names: dict[str, str]) -> int:
    wanted = [contraction.channel] if contraction.channel else \
        [contraction.muscle, trial_names.get(contraction.muscle)]
    for name in wanted:
        if name in names:
            return names.index(name)
    if len(names) == 1 and not contraction.channel:
        return 0
    # EMG<k>, the k-th column: what `rehab emg record` named every column before it kept
    # the stream's labels, so commands written then pick the same channel of a newer file
    numbered = re.fullmatch(r"EMG([1-9][0-9]*)", contraction.channel or "")
    if numbered and int(numbered[1]) <= len(names):
        return int(numbered[1]) - 1
    raise EmgImportError(f"MVC file {contraction.path.name} has no channel "
                         f"{(contraction.channel or contraction.muscle)!r} "
                         f"(it has {', '.join(names)}); name it: MUSCLE=FILE:CHANNEL, "
                         "CHANNEL a column's name or EMG1, EMG2 … by its place")


def session_mvc(
    trials,
    contractions: list[Contraction],
    *,
    settings: EmgSettings | None = None,
    criteria: MvcCriteria | None = None,
    full_scale_V: float | None = None,
) -> list[Mvc]:
    """Each contraction's MVC, checked against every trial's activity, stored in every
    trial (module docstring). Returns one Mvc per muscle, flags from all trials."""
    settings = settings or EmgSettings()
    groups = [(Path(t), trial_emg(t)) for t in trials]
    if not groups:
        raise EmgImportError("no trial given: the MVC is stored with the session's trials")
    measured = []
    for contraction in contractions:
        channel_names = {m: n for _, g in groups for n, m in zip(g.names, g.muscles,
                                                                   strict=True)}
        if not any(contraction.muscle in g.muscles for _, g in groups):
            known = sorted({m for _, g in groups for m in g.muscles})
            raise EmgImportError(f"no trial has the muscle {contraction.muscle!r} "
                                 f"(they have {', '.join(known)})")
        data = read_emg_file(contraction.path)
        index = _contraction_channel(contraction, data.names, channel_names)
        mvc = mvc_from_contraction(data.samples[:, index], data.rate_hz, contraction.muscle,
                                   settings=settings, full_scale_V=full_scale_V,
                                   criteria=criteria)
        measured.append((mvc, data.path.name, data.names[index], settings))
    checked = _store(groups, measured, criteria)
    return [checked[mvc.muscle] for mvc, *_ in measured]


def check_with_trials(trials, mvcs: list[Mvc], *, settings_of: dict[str, EmgSettings],
                      criteria: MvcCriteria | None = None, groups=None) -> dict[str, Mvc]:
    """Each MVC checked against the activity of its muscle in every trial given that has
    it (core.emg.mvc.check_against_trial), the trial's envelope processed with the MVC's
    own settings, over the trial's own samples only: a live capture's margins before and
    after it may hold the session's MVCs themselves."""
    groups = groups if groups is not None else [(Path(t), trial_emg(t)) for t in trials]
    spans = {}
    out = {}
    for mvc in mvcs:
        for path, group in groups:
            if mvc.muscle in group.muscles:
                if path not in spans:
                    t = read_trial(path, channels=()).time
                    spans[path] = (t[0], t[-1])
                c = group.channel_of(mvc.muscle)
                env = envelope(group.samples[:, c], group.rate_hz, settings_of[mvc.muscle],
                               t0_s=group.time_s[0])
                first, last = spans[path]
                inside = (env.t_s >= first) & (env.t_s <= last)
                mvc = check_against_trial(mvc, env.values[inside], criteria)
        out[mvc.muscle] = mvc
    return out


def store_mvcs(trials, measured, criteria: MvcCriteria | None = None) -> dict[str, Mvc]:
    """MVCs measured from their contractions, `measured` [(Mvc, source, channel,
    EmgSettings)], checked against every trial given and stored in each trial that has
    the muscle (`/emg/mvc`); returns the checked MVC of each muscle."""
    return _store([(Path(t), trial_emg(t)) for t in trials], measured, criteria)


def _store(groups, measured, criteria) -> dict[str, Mvc]:
    checked = check_with_trials((), [m for m, *_ in measured], groups=groups,
                                settings_of={m.muscle: s for m, _, _, s in measured},
                                criteria=criteria)
    for path, group in groups:
        entries = {}
        for mvc, source, channel, settings in measured:
            if mvc.muscle in group.muscles:
                entries[mvc.muscle] = {**checked[mvc.muscle].to_dict(), "source_file": source,
                                       "channel": channel, "settings": settings.to_dict()}
        if entries:
            write_mvc(path, entries)
    return checked


def _settings(entry: dict) -> EmgSettings:
    return EmgSettings.from_dict(entry.get("settings"))


def trial_envelopes(path: str | os.PathLike, *, as_live: bool = False,
                    with_mvc_only: bool = False) -> TrialEnvelopes:
    """The trial's envelopes in fractions of MVC on its ticks; refuses a muscle without
    an MVC, naming it, unless `with_mvc_only` (then only the muscles that have one: MVCs
    recorded one muscle at a time, shown as they come). `as_live`: each tick gets the
    envelope a live console had then, its window ending there
    (core.emg.processing.as_known), not centred on it."""
    trial = read_trial(path)
    emg = trial_emg(path)
    missing = [m for m in emg.muscles if m not in emg.mvc]
    if missing and not with_mvc_only:
        raise EmgImportError(f"trial file {Path(path).name}: no MVC for {', '.join(missing)}; "
                             "record the session's MVC first (rehab emg mvc)")
    muscles = tuple(m for m in emg.muscles if m in emg.mvc)
    values = np.full((trial.n_samples, len(muscles)), np.nan)
    flags = {}
    for c, muscle in enumerate(muscles):
        c_emg = emg.muscles.index(muscle)
        entry = emg.mvc[muscle]
        env = envelope(emg.samples[:, c_emg], emg.rate_hz, _settings(entry),
                       t0_s=emg.time_s[0])
        if as_live:
            env = as_known(env, emg.rate_hz, _settings(entry))
        # the envelope's stamps are on an even grid from the first sample; EMG on the
        # trial's clock may run a hair fast or slow, so map the stamps through its time
        k = (env.t_s - emg.time_s[0]) * emg.rate_hz
        stamps = np.interp(k, np.arange(emg.time_s.size), emg.time_s)
        env_on_clock = type(env)(stamps, normalise(env.values, entry["value_V"]))
        values[:, c] = on_time_base(env_on_clock, trial.time)
        flags[muscle] = tuple(entry.get("flags") or ())
    return TrialEnvelopes(trial.time, values, muscles, flags)
