"""The live EMG source's part of a trial, into the trial's file once it is closed, and the
session's MVCs into its trials when one is recorded again (the EMG tab holds the source,
the capture and the session's MVC protocol; app.emg does the storing)."""

from __future__ import annotations

from pathlib import Path

from app.trials.rewrite import rewriting_files


class TrialEmg:
    """EMG with the trial (a part of MainWindow)."""

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
