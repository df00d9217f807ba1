"""The console's analysis as it was before the robot's share of the work counted its help
alone (2026-12-05): the same figures without `robot_help_work_J`, so what it writes into a
trial file and the registry is what an older console left (core.work.drop_old_share)."""

from __future__ import annotations

from app.trials.analysis import Analysis


def analysed_as_before(patch) -> None:
    """With `patch` (a pytest MonkeyPatch), trials are analysed as before until it is undone."""
    new = Analysis.to_metrics

    def old(self):
        metrics = new(self)
        del metrics["robot_help_work_J"]
        return metrics

    patch.setattr(Analysis, "to_metrics", old)
