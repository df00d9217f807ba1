"""The live EMG source's part of a trial, into the trial's file once it is closed, and the
session's MVCs into its trials when one is recorded again (the EMG tab holds the source,
the capture and the session's MVC protocol; app.emg does the storing)."""

from __future__ import annotations


class TrialEmg:
    """EMG with the trial (a part of MainWindow)."""

    def _store_trial_emg(self, path: str) -> None:
        """The live EMG source's part of the trial into its file, after the metrics (one
        job thread: in that order). With the session's MVC protocol under way, the
        muscles' channels under their names and the session's MVCs, checked against this
        trial too (app.emg.protocol.store_trial); else every channel as it came. A source
        that died (or was disconnected) during the trial gives what it had before."""
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

            self.jobs.run(lambda: store_live_capture(path, captured, label),
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

        self.jobs.run(lambda: store_trial(path, captured, label, session), stored)

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
        self.jobs.run(lambda: when_free(lambda: store_mvcs(trials, measured)),
                      lambda _checked: self._say(f"The session's MVCs are stored in its "
                                                 f"{len(trials)} trial(s) so far."))
