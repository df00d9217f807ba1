"""The games in the clinic's work (issue 30): a game trial's figures from its recorded
channels, the line that shows them, the staircase's next round from a finished trial, and
rounds played by a virtual patient on the simulator.

* `figures`: `game_figures(channels, parameters)` (core.games.score_game over the exercise's
  samples, as the window's live scorer sees them) and `game_figures_stored` (the same fed a
  block at a time, for a trial too long to hold); app.trials.analysis puts them in the
  trial's metrics ('game_*'), so the file, the registry, `rehab trials`, the report and the
  exports carry them; `game_line` says them in one line.
* `rounds`: the next round's staircase from a finished round's parameters and metrics.
* `virtual`: rounds of a game on the headless simulator with a virtual patient, the
  staircase between them (tests/app/games, bench/staircase.py).

It imports core, device (the simulator and the phase numbers) and app.trials' headless run
only in `virtual`.
"""
