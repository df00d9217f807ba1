"""The window's side of a trial whose assistance judges the patient's force estimated from
EMG (the Parameters tab's "Patient's force: EMG model: <name>"): the model read and checked
at each Build, the live estimate started with the trial and stopped with it, what went
wrong said in the message line, and the estimates stored with the trial's file.

The estimating itself is app.emg.live_feed; it runs on the device bridge's thread, which
sends each estimate to the loop between ticks.
"""

from __future__ import annotations

import logging

from app.trials.rewrite import rewriting_files

log = logging.getLogger(__name__)


class ForceEstimateControl:
    """Owned by the main window, which calls it at Build, at a trial's start, at each
    repaint and when the trial's file is closed."""

    def __init__(self, window) -> None:
        self.window = window
        self.model = None
        """The checked EMG model of the trial built (None: the force sensor)."""
        self.feed = None
        self._said = ""

    def checked(self, params):
        """The parameters with the model's hash, or None after saying why not (Build
        refused)."""
        self.model = None
        if not params.force_estimate:
            return params
        from app.emg.live_feed import refusal
        from app.emg.modelfile import emg_model
        from app.learning.modelfile import ModelFileError

        w = self.window
        try:
            model = emg_model(w.registry.data_dir.models_dir, params.force_estimate)
        except ModelFileError as exc:
            w.refuse_build(str(exc))
            return None
        reason = refusal(model, params, w.emg.capture, w.emg.session)
        if reason:
            w.refuse_build(reason)
            return None
        self.model = model
        return params.replace(force_estimate_sha256=model.content_sha256)

    def trial_started(self, params) -> None:
        if self.model is None or params is None or params.force_estimate != self.model.name:
            return
        from app.emg.live_feed import LiveForceFeed

        w = self.window
        self.feed = LiveForceFeed(self.model, w.emg.capture, w.emg.session.copy(), params.arm())
        self._said = ""
        w.bridge.set_force_feed(self.feed)
        w.say(f"The assistance judges the patient's force estimated from EMG by "
              f"{self.model.name}.")

    def poll(self) -> None:
        """Say once when the estimate stops coming, and when it comes again."""
        feed = self.feed
        if feed is None or feed.lost == self._said:
            return
        self._said = feed.lost
        if feed.lost:
            self.window.say(f"EMG estimate lost: {feed.lost}.", problem=True)
        else:
            self.window.say("EMG estimate back: the assistance judges it again.")

    def trial_closed(self, path: str) -> None:
        """Stop the estimate and store what it gave in the trial's file (on the window's
        job thread, after the file's metrics and EMG)."""
        feed, self.feed = self.feed, None
        w = self.window
        w.bridge.set_force_feed(None)
        if feed is None:
            return

        def done(count) -> None:
            w.say(f"Stored {count} EMG estimates of the patient's force with the trial.")

        def store() -> int:
            # after the trial's finish recorded its file's checksum: recorded again
            # (app.trials.rewrite), or exports and studies would leave the trial out
            with rewriting_files(w.registry, [path], "the EMG estimates of the force"):
                return feed.store(path)

        w.jobs.run(store, done)
