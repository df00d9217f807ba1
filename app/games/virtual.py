"""Rounds of a game played by a virtual patient on the headless simulator, the staircase
setting each round's difficulty from the last: the closed loop the staircase is judged by
(tests/app/games/test_staircase_loop.py, bench/staircase.py)."""

from __future__ import annotations

import statistics
from dataclasses import dataclass

from app.games.figures import game_figures
from app.trials.headless import simulate
from core.games import GameFigures
from core.games.staircase import Staircase, next_round, start
from core.trial import TrialParameters


@dataclass(frozen=True, slots=True)
class RoundPlayed:
    """One round: the staircase that set it (its rung and values) and the game's figures."""

    state: Staircase
    figures: GameFigures


@dataclass(frozen=True, slots=True)
class Convergence:
    """How a run of rounds settled. `settled_rung` is the median rung of the run's second
    half; `rounds_to_converge` the first round (1-based) that reached it; `success_after`
    the success over every movement from that round on (hits / movements); `final` the last
    round's rung and its values."""

    rounds_to_converge: int
    settled_rung: float
    success_after: float
    movements_after: int
    final_rung: int
    final_values: dict[str, float]


def play_rounds(base: TrialParameters, patient: str, rounds: int, *, seed: int = 0,
                patient_options: dict | None = None,
                state: Staircase | None = None) -> tuple[RoundPlayed, ...]:
    """`rounds` rounds of the base's game by a virtual patient of kind `patient`, round k
    with simulator seed `seed + k` (each round's effort drawn anew, device.sim.patients),
    the staircase (a new one at rung 0 unless given) moved between rounds by its figures."""
    state = state or start(base)
    played = []
    for k in range(rounds):
        parameters = state.apply(base)
        trial = simulate(parameters, patient=patient, seed=seed + k,
                         patient_options=patient_options)
        figures = game_figures(trial.records, parameters)
        played.append(RoundPlayed(state, figures))
        state = next_round(state, figures.hits, figures.misses)
    return tuple(played)


def convergence(played: tuple[RoundPlayed, ...]) -> Convergence:
    """Where a run of rounds settled and the success from then on (see Convergence)."""
    rungs = [r.state.rung for r in played]
    settled = statistics.median(rungs[len(rungs) // 2:])
    first = next(k for k, rung in enumerate(rungs) if rung >= settled) \
        if rungs[0] <= settled else next(k for k, rung in enumerate(rungs) if rung <= settled)
    after = played[first:]
    hits = sum(r.figures.hits for r in after)
    movements = sum(r.figures.hits + r.figures.misses for r in after)
    return Convergence(first + 1, settled, hits / movements if movements else float("nan"),
                       movements, rungs[-1], played[-1].state.values())
