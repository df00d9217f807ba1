"""The window of a station on the department's shared registry while the network is down
(issue 32: "when the server is unreachable it keeps recording …, says so on screen, and
syncs when the server returns"; app.records.station).

The status bar says where the records go now ("Shared registry unreachable: recording on
this station"), the event line says when that begins and ends, and every few seconds, while
no trial runs, the window asks the station to send what it recorded (on the job thread, after
any trial still being finished: a sync never comes between a trial's end and its proposal).
After a sync the patient's progress, proposal and Replay list are read again, off the window's
thread (on a slow network each read held the window): the trials recorded offline have their
server's ids now. A trial sent under another number than it was recorded with (another
station took its number meanwhile: app.records.station.renumber) is said once on the event
line, and its report, shown or saved, is made again with the registry's number.
"""

from __future__ import annotations

from pathlib import PurePosixPath

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QLabel

from app.records import station
from app.records.store import StationStore
from core.errors import capitalised
from device.loop.states import State
from ui import theme

KEEP_CURRENT_EVERY = 6
"""Online, every this many ticks (30 s) between trials the station brings its standby's copy
of the current patient up to the server's: what other stations recorded for them meanwhile
(app.records.station.StationRegistry.keep_current)."""

UNREACHABLE = "Shared registry unreachable: recording on this station"
"""The status bar's words while the server cannot be reached (its cause in the tooltip)."""

LOGIN_REFUSED = "Shared registry refused this login: recording on this station"
"""… while the server answers and refuses this station's login (what to do in the tooltip)."""

SYNC_REFUSED = "Shared registry refused the sync: recording on this station"
"""… while the server answers and refused what this station recorded offline (a row
another station changed meanwhile, not a number: those the sync renumbers; the registry's
owner resolves it; why in the tooltip). It said 'unreachable' there, and a therapist
checked a network that worked. As short as the other two: beside the robot's timing
warning at 1366 px, "… refused the offline records: …" was cut."""

REACH_WORDS = {station.UNREACHABLE: UNREACHABLE, station.LOGIN_REFUSED: LOGIN_REFUSED,
               station.SYNC_REFUSED: SYNC_REFUSED}
"""The status bar's words for each `StationRegistry.offline_cause`."""

SYNC_EVERY_MS = 5000
"""How often an offline station tries to reach the server again (a connection refused is
answered at once; an unanswered one waits the registry's connect timeout on the job
thread, never the window)."""


class StationStatus:
    """The shared registry's reach in the status bar and the sync (a part of MainWindow)."""

    def _build_station_status(self) -> None:
        self.registry_label = QLabel("")
        self.registry_label.setObjectName("registry_reach")
        self.registry_label.hide()  # shown while offline (_show_reach)
        self.status_warnings.layout().addWidget(self.registry_label, 0,
                                                Qt.AlignmentFlag.AlignRight)
        self._was_offline = False
        self._syncing = False
        self._ticks_online = 0
        self.station_timer = QTimer(self)
        self.station_timer.setInterval(SYNC_EVERY_MS)
        self.station_timer.timeout.connect(self.check_station)
        if isinstance(self.registry, StationStore) or self.settings.trial_store:
            self.station_timer.start()
        self._storing = False
        self._store_problem = ""
        self.store_trials()  # what an earlier session left to copy
        synced = self.registry.synced if isinstance(self.registry, StationStore) else []
        sent = sum(s.trials for s in synced)
        if sent:  # sent as the station opened: what an earlier session recorded offline
            self._say(f"The shared registry took {sent} trial{'s' if sent != 1 else ''} this "
                      "station recorded while it was unreachable"
                      + "".join(f"; {s.renumbering}" for s in synced if s.renumbered))
        problem = self.registry.sync_problem if isinstance(self.registry, StationStore) else ""
        if problem:  # found as it opened (a damaged standby set aside, a sync refused)
            self._said_problem = problem
            self._say(capitalised(problem), problem=True)
        self.check_station()

    def check_station(self) -> None:
        """Show the registry's reach; offline and idle, try to send the offline records."""
        registry = self.registry
        offline = isinstance(registry, StationStore) and registry.offline
        self._show_reach(offline)
        # between trials: none running or stopping, none being recorded or registered, no plan on
        between = self.state not in (State.RUNNING, State.STOPPING) and self.trial_id is None \
            and not self.registering() and self.plan_runner is None
        if offline and between and not self._syncing:
            self._syncing = True
            self.jobs.run(registry.try_sync, self._synced)
        elif isinstance(registry, StationStore) and between and not self._syncing:
            self._ticks_online += 1
            if self._ticks_online % KEEP_CURRENT_EVERY == 0:
                self._syncing = True
                self.jobs.run(registry.keep_current, self._kept_current)
        if self._store_problem:  # the trial store could not take them: try again
            self.store_trials()

    def store_trials(self) -> None:
        """Copy this station's finished trials into its shared trial store (the setting
        trial_store), on the job thread after the trial's own work; the store unreachable is
        said once, and the copies are tried again at each tick until they are made."""
        store = self.settings.trial_store
        if not store or self._storing:
            return
        from app.records.trialstore import store_pending

        self._storing = True
        self.jobs.run(lambda: store_pending(self.registry, store), self._stored)

    def _stored(self, stored) -> None:
        self._storing = False
        problem = stored.problems[0] if stored.problems else ""
        if problem and problem != self._store_problem:
            self._say(capitalised(problem), problem=True)
        elif self._store_problem and not problem:
            self._say(f"The trial store took the waiting trials ({len(stored.trials)} copied "
                      "and checked)")
        self._store_problem = problem

    def _show_reach(self, offline: bool) -> None:
        registry = self.registry
        if offline:
            cause = registry.offline_cause
            words = REACH_WORDS.get(cause, UNREACHABLE)
            self.registry_label.setText(f"{theme.PROBLEM_SIGN} {words}")
            self.registry_label.setStyleSheet(f"color: {theme.PROBLEM_TEXT};")
            self.registry_label.setToolTip(registry.sync_problem if cause == station.SYNC_REFUSED
                                           else registry.offline_reason)
            self.registry_label.show()
            # the refusal was said where it was found (as the station opened, or its sync's
            # answer); the offline reason then ("… waiting to be sent") said after it,
            # on the message line over the refusal, promised a sync that could not come
            if not self._was_offline and cause != station.SYNC_REFUSED:
                self._say(capitalised(registry.offline_reason),
                          problem=True)
        else:
            self.registry_label.setText("")
            self.registry_label.setToolTip("")
            self.registry_label.hide()
        self._was_offline = offline

    def _renumbered_reports(self, synced) -> None:
        """The reports of trials sent under another number, shown or saved before the sync,
        made again with the registry's number: the Report tab's (a trial just recorded
        offline) at once, and a PDF saved offline in reports/ (a derivative, named and
        headed with the old number) written anew under the new name, the old one removed.
        The trial file keeps its name: the registry points at it, or at a second name of it
        where another station's trial has its name (app.records.station.secondname)."""
        moved = {trial for m in synced.renumbered for trial in m.trial_ids}
        if not moved:
            return
        # the live trial's report, which the Report tab goes back to after a replay, by the
        # number the registry now has for it (it went back to the old one)
        self.live_report = synced.trial_ids.get(self.live_report, self.live_report)
        shown = synced.trial_ids.get(self.report.registry_trial())
        if shown in moved:
            self.report.load_registry_trial(self.registry, shown)
        registry, renumbered = self.registry, synced.renumbered
        # the name each file was recorded under, where the registry has it under a second
        recorded = {n.trial_id: PurePosixPath(n.file).name for n in synced.second_names}

        def rewrite() -> tuple[list[str], dict[str, str]]:
            from app.reports.build import report_for_registry_trial

            written, numbers = [], {}
            for m in renumbered:
                for trial_id in m.trial_ids:
                    trial = registry.trial(trial_id)
                    named = f"session {trial.session_number}, trial {trial.number}"
                    numbers[PurePosixPath(trial.file).name] = named
                    if trial_id in recorded:
                        numbers[recorded[trial_id]] = named
                    old = registry.data_dir.report_path(
                        trial.patient_code, m.session,
                        trial.number if m.trial is None else m.trial, trial.started_at)
                    if old.exists():
                        written.append(report_for_registry_trial(registry, trial_id).name)
                        old.unlink()
            return written, numbers

        self.jobs.run(rewrite, self._reports_renumbered)

    def _reports_renumbered(self, done: tuple[list[str], dict[str, str]]) -> None:
        written, numbers = done
        # the status bar's last trial ('session 1, trial 2: complete', from the name of the
        # file it recorded)
        now = numbers.get(self.trial_label.toolTip())
        if now is not None:
            self.trial_label.setText(f"{now}:{self.trial_label.text().split(':', 1)[-1]}")
        if written:
            many = len(written) != 1
            self._say(f"The report{'s' if many else ''} saved before the sync written again "
                      f"with the registry's number{'s' if many else ''}: {', '.join(written)} "
                      f"(the one{'s' if many else ''} named with the old number removed)")

    def _kept_current(self, _) -> None:
        self._syncing = False

    def _synced(self, synced) -> None:
        self._syncing = False
        if synced is None:
            problem = self.registry.sync_problem
            if problem and problem != getattr(self, "_said_problem", ""):
                self._said_problem = problem
                self._say(capitalised(problem), problem=True)
            return
        self._said_problem = ""
        moved = synced.trial_ids
        if self.unsaved_trial in moved:
            self.unsaved_trial = moved[self.unsaved_trial]
        sent = synced.trials
        # said once, here: which trial has which number now, and whose trial took its own
        # (the registry keeps it too: a correction of the trial's number)
        self._say("The shared registry is back: " + (
            f"{sent} trial{'s' if sent != 1 else ''} recorded on this station meanwhile "
            "sent to it" if sent else "nothing was waiting to be sent")
            + (f"; {synced.renumbering}" if synced.renumbered else ""))
        self._show_reach(False)
        self._renumbered_reports(synced)
        if self.patient is not None:  # what the tabs show now has the server's ids
            code = self.patient.code
            self.progress.set_patient(code)  # read on the tab's own threads
            self.read_proposal_and_trials(code)  # on the job thread: never the window's
