"""A session of games names its games (seen on the session report of a session of the
Games plan: every round read "point-to-point targets, as-needed" or "D shape,
transparent", as plain exercises, with no word of the game or its score)."""

from __future__ import annotations

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.session_report import session_content
from core.trial import THESIS_SUBJECT


def test_a_game_round_is_named_with_its_score(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", side="right").code
    rounds = (THESIS_SUBJECT.replace(shape="targets", game="reach", assist="as-needed"),
              THESIS_SUBJECT.replace(game="path", assist="transparent"), THESIS_SUBJECT)
    for parameters, score in zip(rounds, (80.0, -24.0, None), strict=True):
        begun = registry.begin_trial(code, parameters, backend="simulator",
                                     session_number=1)
        metrics = {"directional_performance_pct": 70.0}
        if score is not None:
            metrics |= {"game_score": score, "game_hits": 8.0, "game_misses": 0.0}
        registry.finish_trial(begun.trial_id, "complete", metrics)
    said = [row[3] for row in session_content(registry, code, 1).trials]
    assert said == ["Reaching game, score 80: point-to-point targets, as-needed",
                    "Path game, score -24: D shape, transparent",
                    "D shape, thesis"]
