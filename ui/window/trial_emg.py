"""The live EMG source's part of a trial, into the trial's file once it is closed, and the
session's MVCs into its trials when one is recorded again (the EMG tab holds the source,
the capture and the session's MVC protocol; app.emg does the storing)."""

from __future__ import annotations

from pathlib import Path

from app.trials.rewrite import rewriting_files


class TrialEmg:
    """EMG with the trial (a part of MainWindow)."""

    _emg_noted: int | None = None  # the trial whose file was told the EMG's range problem

    def _note_emg_range(self, problem: str) -> None:
        """A live EMG source whose numbers reach volts while a trial runs (µV sent as V):
        the trial still records what came (the file keeps what the source gave, and is
        the truth of the trial), and its file says the problem as the event "emg" at the
        tick the loop takes it, once a trial. Before, the EMG tab warned and the file kept
        365 V of 'EMG' without a word, for any reader after."""
        from device.loop.messages import TrialNote
        from device.loop.states import State

        trial = getattr(self, "trial_id", None)
        if not problem or self.state != State.RUNNING or trial is None \
                or self._emg_noted == trial:
            return
        self._emg_noted = trial
        self.bridge.note(TrialNote("emg", problem, {"source": self.emg.live_label}))

    def _store_trial_emg(self, path: str) -> None:
        """The live EMG source's part of the trial into its file, after the metrics and the
        trial's finish in the registry (one job thread: in that order); the registry then
        keeps the file's new checksum (app.trials.rewrite: without it, every trial with
        live EMG was left out of exports and studies as "not the file recorded"). With the
        session's MVC protocol under way, the muscles' channels under their names and the
        session's MVCs, checked against this trial too (app.emg.protocol.store_trial); else
        every channel as it came. A source that died (or was disconnected) during the trial
        gives what it had before."""
        emg = self.emg
        if emg.capture is not None:
            captured, label, died = emg.capture.snapshot(), emg.live_label, False
        elif emg.lost is not None:
            (captured, label), died, emg.lost = emg.lost, True, None
        else:
            return
        session = emg.session
        ended = " up to where the source stopped" if died else ""
        if session is None or not session.records:
            # no MVC protocol under way: every channel as it came, named EMG1…
            from app.emg.importing import store_live_capture

            def store_all():
                with rewriting_files(self.registry, [path], "the trial's EMG"):
                    return store_live_capture(path, captured, label)

            self.jobs.run(store_all,
                          lambda done: self._say(
                              f"EMG stored with the trial{ended}: {len(done.names)} channels, "
                              f"{done.n_samples} samples from {label}"))
            return
        from app.emg.protocol import store_trial

        def stored(result) -> None:
            done, checked = result
            self._say(f"EMG stored with the trial{ended}: {', '.join(done.muscles)}, "
                      f"{done.n_samples} samples from {label}, in % of the session's MVCs")
            for mvc in checked.values():
                if not mvc.ok:
                    emg.show_mvc(mvc)

        def store_with_mvcs():
            # the session's earlier trials get the MVCs too: each one's file changes
            with rewriting_files(self.registry, _distinct([path, *session.trials]),
                                 "the trial's EMG and the session's MVCs"):
                return store_trial(path, captured, label, session)

        self.jobs.run(store_with_mvcs, stored)

    def _store_session_mvcs(self, _muscle: str) -> None:
        """An MVC recorded again: the session's trials so far are normalised by it too, as
        `rehab emg mvc` stores one MVC in all the session's trials."""
        session = self.emg.session
        if session is None or not session.trials:
            return
        from app.emg.session import store_mvcs

        trials = list(session.trials)
        from app.emg.importing import when_free

        measured = session.measured()

        def store():
            with rewriting_files(self.registry, trials, "the session's MVCs"):
                return when_free(lambda: store_mvcs(trials, measured))

        self.jobs.run(store,
                      lambda _checked: self._say(f"The session's MVCs are stored in its "
                                                 f"{len(trials)} trial(s) so far."))


def _distinct(paths) -> list[Path]:
    """`paths` without repeats (the trial just closed may be among the session's)."""
    seen: dict[Path, None] = {}
    for path in paths:
        seen.setdefault(Path(path).resolve(), None)
    return list(seen)
