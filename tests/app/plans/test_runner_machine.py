"""The plan's runner against a model of the loop, the files and the therapist (issue 30, the
plan's THE TEST): commands, the loop's answers, faults and the emergency stop arrive in any
order at any moment, and the runner keeps its invariants:

* one trial per start asked, started only once its round was built, each linked once;
* no build or start during a rest, while paused, or after Stop, E-STOP or a fault;
* a rest is taken whole before the next block unless the plan ends in it;
* the movements and active time it counts are what the trials' files said;
* a plan that ends 'complete' ran every round of every block for all its laps;
* the share of the plan done (the patient's bar) never goes back, and is whole at a
  complete end;
* the robot disconnected between trials pauses the plan, recorded, and never ends it.
"""

import math

import pytest
from hypothesis import HealthCheck, settings, strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from app.plans.runner import ENDED, IDLE, PAUSED, RESTING, RUNNING, PlanRunner
from core.plan import Block, Plan, movements_per_lap
from core.trial import THESIS_SUBJECT

PLAN = Plan("Three blocks", (
    Block(shape="d", repetitions=2, duration_s=2.0, rest_s=1.0, name="D"),
    Block(shape="reach", repetitions=1, duration_s=2.0, rest_s=1.0, radius_m=0.06,
          rounds=2, name="Reach"),
    Block(shape="circle", repetitions=None, active_s=3.0, duration_s=2.0, rest_s=5.0,
          name="Circle"),
))
BASE = THESIS_SUBJECT
GONE = "the robot was disconnected; Connect, then Resume"
NOT_CONNECTED = "connect to the robot first (press Connect)"
RARELY = st.integers(0, 99).map(lambda n: n == 37)
SOMETIMES = st.integers(0, 99).map(lambda n: n % 4 == 3)
MOSTLY = st.integers(0, 99).map(lambda n: n % 10 != 7)


class FakeConsole:
    """The loop and the registry as the runner sees them: what it asked, in order."""

    def __init__(self) -> None:
        self.asked: list[tuple] = []
        self.building = None  # parameters waiting for the loop's answer
        self.starting = None  # (block, round) waiting for the loop's start
        self.stop_asked = False
        self.ended: tuple | None = None
        self.rests: list[tuple] = []
        self.linked: list[tuple] = []
        self.events: list[tuple] = []
        self.now = 0.0

    def build(self, parameters):
        assert self.ended is None, "built after the plan ended"
        assert self.building is None
        assert self.starting is None
        self.building = parameters
        self.asked.append(("build", parameters))

    def start(self, block, round_):
        assert self.ended is None, "started after the plan ended"
        assert self.building is None
        assert self.starting is None
        self.starting = (block, round_)
        self.asked.append(("start", block, round_, self.now))

    def stop(self):
        self.stop_asked = True

    def record_trial(self, block, round_, trial_id, planned_s):
        self.linked.append((block, round_, trial_id))

    def record_rest(self, block, planned_s, taken_s):
        assert 0.0 <= taken_s <= planned_s + 1e-9
        self.rests.append((block, planned_s, taken_s, self.now))

    def record_event(self, block, words):
        assert self.ended is None, "an event recorded after the plan ended"
        self.events.append((block, words, self.now))

    def end(self, status, reason):
        assert self.ended is None, "ended twice"
        self.ended = (status, reason)


class PlanMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.console = FakeConsole()
        self.runner = PlanRunner(PLAN, BASE, self.console)
        self.now = 0.0
        self.next_id = 1
        self.running = None  # (trial id, laps it runs, block)
        self.files: dict[int, tuple[int, float]] = {}  # what each trial's file said
        self.finishes: list[tuple[int, float]] = []  # (block, when) of each trial's end
        self.started_blocks: list[int] = []
        self.share = 0.0  # the share of the plan done, as last read
        self.connected = True
        self.gone = 0  # times the robot went while the plan ran

    # ---------------------------------------------------------------- the therapist
    @precondition(lambda self: self.runner.phase == IDLE and self.connected)
    @rule()
    def first_start(self):
        """Start plan needs the robot connected (ui.window.plan.start_plan)."""
        self.runner.start(self.now)

    @rule(now=SOMETIMES)
    def pause(self, now):
        if now:
            self.runner.pause(self.now)

    @rule()
    def resume(self):
        if self.connected:  # the console's Resume waits for the robot (ui.window.plan)
            self.runner.resume(self.now)

    @precondition(lambda self: self.connected and self.runner.phase != RUNNING)
    @rule(now=SOMETIMES)
    def disconnect(self, now):
        """The therapist's Disconnect, which the loop takes only between trials."""
        if now:
            self.connected = False
            if self.runner.phase not in (IDLE, ENDED) and not self.runner.held:
                self.gone += 1
            self.runner.robot_gone(self.now, GONE)

    @precondition(lambda self: not self.connected)
    @rule()
    def connect(self):
        self.connected = True

    # what ends a plan comes at any moment, but rarely enough for plans to reach their
    # later blocks (one draw in ten acts)
    @rule(now=RARELY)
    def stop(self, now):
        if now:
            self.runner.stop(self.now)

    @rule(now=RARELY)
    def emergency_stop(self, now):
        if now:
            self.runner.emergency_stop(self.now, "emergency stop pressed")
            self._loop_faults()

    @rule(now=RARELY)
    def fault(self, now):
        if now:
            self.runner.fault(self.now, "force too high")
            self._loop_faults()

    @rule(dt=st.sampled_from([0.1, 0.5, 1.0, 3.0]))
    def time_passes(self, dt):
        self.now += dt
        self.console.now = self.now
        self.runner.tick(self.now)

    # ---------------------------------------------------------------- the loop
    @rule(fraction=st.floats(0.0, 1.0))
    def loop_acts(self, fraction):
        """The loop's next answer: the build, the start, or the trial's end (complete, or
        where it was if a Stop was asked)."""
        console = self.console
        if console.building is not None:
            self.pending_laps = console.building.repetitions
            console.building = None
            self.runner.built(self.now, True)
        elif console.starting is not None and not self.connected:
            console.starting = None
            self.runner.refused(self.now, NOT_CONNECTED)
        elif console.starting is not None:
            block, _ = console.starting
            console.starting = None
            trial = self.next_id
            self.next_id += 1
            self.running = (trial, self.pending_laps, block)
            self.started_blocks.append(block)
            self.runner.started(self.now, trial)
        elif self.running is not None:
            trial, laps, block = self.running
            per_lap = movements_per_lap(PLAN.blocks[block - 1].shape, BASE.n_targets)
            if console.stop_asked:
                status, done = "stopped_early", int(fraction * laps * per_lap)
            else:
                status, done, fraction = "complete", laps * per_lap, 1.0
            self._finish(trial, status, done, laps * fraction)

    @precondition(lambda self: self.console.building is not None
                  or self.console.starting is not None)
    @rule(now=RARELY)
    def loop_refuses(self, now):
        if not now:
            return
        if self.console.building is not None:
            self.console.building = None
            self.runner.built(self.now, False, "unreachable")
        else:
            self.console.starting = None
            self.runner.refused(self.now, "the robot is faulted")

    def _loop_faults(self):
        if self.running is not None:
            self._finish(self.running[0], "faulted", 0, 0.1)
        self.console.building = self.console.starting = None

    def _finish(self, trial, status, movements, active_s):
        self.running = None
        self.console.stop_asked = False
        self.files[trial] = (movements, active_s)
        self.runner.trial_ended(self.now)
        self.finishes.append((self.started_blocks[-1], self.now))
        self.runner.finished(self.now, trial, status, movements, active_s)

    # ---------------------------------------------------------------- invariants
    @invariant()
    def one_trial_per_start_and_each_linked_once(self):
        starts = [a for a in self.console.asked if a[0] == "start"]
        ids = [t for _, _, t in self.console.linked]
        assert len(ids) == len(set(ids))
        assert len(ids) <= len(starts) == self.runner.starts

    @invariant()
    def nothing_runs_in_a_rest_while_paused_or_after_the_end(self):
        if self.runner.phase in (RESTING, PAUSED, ENDED, IDLE):
            assert self.console.building is None or self.runner.phase == ENDED
            assert self.console.starting is None or self.runner.phase == ENDED
        if self.runner.phase == ENDED:
            assert self.console.ended is not None

    @invariant()
    def a_rest_is_whole_before_the_next_block(self):
        for action in self.console.asked:
            if action[0] != "start" or action[2] != 1 or action[1] == 1:
                continue
            before, when = action[1] - 1, action[3]
            ended = [t for b, t in self.finishes if b == before and t <= when]
            assert ended, "a block started before the one before it ended"
            assert when - max(ended) >= PLAN.blocks[before - 1].rest_s - 1e-9, \
                "a block started before the rest after the one before it was over"
            rests = [r for r in self.console.rests if r[0] == before]
            assert rests, "a block started without the rest before it recorded"
            assert math.isclose(rests[0][2], PLAN.blocks[before - 1].rest_s, abs_tol=1e-9)

    @invariant()
    def the_counts_are_the_files(self):
        counted = sum(c.movements for c in self.runner.counts)
        assert counted == sum(m for m, _ in self.files.values())
        active = sum(c.active_s for c in self.runner.counts)
        assert math.isclose(active, sum(a for _, a in self.files.values()), abs_tol=1e-9)

    @invariant()
    def complete_means_every_lap_ran(self):
        if self.runner.outcome == "complete":
            planned = PLAN.planned_movements(BASE.n_targets)
            # a round cut by a pause runs again for its laps left: at least the plan's
            assert sum(c.movements for c in self.runner.counts) >= planned
            for k, block in enumerate(PLAN.blocks):
                assert len(self.runner.counts[k].trials) >= block.rounds

    @invariant()
    def the_share_done_never_goes_back(self):
        state = self.runner.state(self.now)
        assert 0.0 <= state.done_share <= 1.0
        assert state.done_share >= self.share - 1e-12
        self.share = state.done_share
        if state.outcome == "complete":
            assert state.done_share == 1.0

    @invariant()
    def the_robot_gone_pauses_and_is_recorded_never_ends_the_plan(self):
        assert NOT_CONNECTED not in self.runner.reason
        paused = [e for e in self.console.events if e[1] == f"paused: {GONE}"]
        assert len(paused) == self.gone
        if self.runner.held:
            assert self.runner.phase != RUNNING or self.console.stop_asked
            if self.runner.phase == PAUSED:
                assert self.runner.state(self.now).line().endswith(GONE)

    @invariant()
    def the_state_reads(self):
        state = self.runner.state(self.now)
        assert state.rest_left_s >= 0.0
        assert state.time_left_s >= 0.0
        assert "\n" not in state.line()


PlanMachine.TestCase.settings = settings(max_examples=150, stateful_step_count=100,
                                         deadline=None,
                                         suppress_health_check=[HealthCheck.filter_too_much])
test_the_runner_keeps_its_invariants = PlanMachine.TestCase


class Script:
    """A plan run by hand: the loop completes every trial it is given."""

    def __init__(self, plan=PLAN):
        self.console = FakeConsole()
        self.runner = PlanRunner(plan, BASE, self.console)
        self.trial = 0

    def loop(self, now, *, complete=True, fraction=1.0):
        """Answer the build and the start, and end the trial."""
        runner, console = self.runner, self.console
        params = console.building
        console.building = None
        runner.built(now, True)
        console.starting = None
        self.trial += 1
        runner.started(now, self.trial)
        per_lap = movements_per_lap(params.shape, BASE.n_targets)
        done = params.repetitions * per_lap if complete else int(
            fraction * params.repetitions * per_lap)
        runner.trial_ended(now)
        console.stop_asked = False
        runner.finished(now, self.trial, "complete" if complete else "stopped_early", done,
                        params.repetitions * params.duration_s * fraction)
        return params


def test_a_plan_runs_its_blocks_rounds_and_rests_in_order():
    s = Script()
    s.runner.start(0.0)
    assert s.runner.state(0.0).line().startswith("Block 1 of 3: D, 2 laps")
    assert s.loop(0.0).repetitions == 2
    assert s.runner.phase == RESTING
    assert s.runner.state(0.4).rest_left_s == pytest.approx(0.6)
    s.runner.tick(0.5)
    assert s.console.building is None  # still resting
    s.runner.tick(1.0)
    assert s.loop(1.0).shape == "reach"  # round 1
    assert s.runner.state(1.0).round == 2
    assert s.loop(1.0).shape == "reach"  # round 2, no rest between rounds
    s.runner.tick(2.0)
    assert s.loop(2.0).repetitions == 2  # 3 s of 2 s laps: two whole laps
    assert s.console.ended == ("complete", "")
    assert [r[:3] for r in s.console.rests] == [(1, 1.0, 1.0), (2, 1.0, 1.0)]
    assert sum(c.movements for c in s.runner.counts) == 2 + 2 * 2 + 2
    assert s.runner.state(3.0).line().startswith("Plan complete")


def test_a_rest_says_which_block_comes_next_as_it_will_run():
    """The patient's screen said "Next: block 2" in a rest: the state carries the next
    block's trial (its exercise, game and laps) and rounds, for it to say what comes."""
    s = Script()
    s.runner.start(0.0)
    assert s.runner.state(0.0).next_trial is None  # no rest: nothing to announce
    s.loop(0.0)
    resting = s.runner.state(0.4)
    assert (resting.next_trial.shape, resting.next_trial.repetitions,
            resting.next_rounds) == ("reach", 1, 2)
    assert resting.next_trial.radius_m == 0.06  # the block's, on the patient's setup
    s.runner.pause(0.5)
    assert s.runner.state(0.6).next_trial.shape == "reach"  # paused in the rest too
    s.runner.resume(0.6)
    s.runner.tick(2.0)
    assert s.runner.state(2.0).next_trial is None  # the block is under way


def test_the_share_done_counts_laps_weighted_by_each_block_s_planned_time():
    """The patient's bar (PlanState.done_share): each block of PLAN plans 4 s of
    exercise, a third of the plan; within a block each lap its share, so a block of
    several rounds moves at each round, and the running trial's laps go by lap_share."""
    s = Script()
    assert s.runner.state(0.0).done_share == 0.0
    s.runner.start(0.0)
    first = s.runner.state(0.0)
    assert (first.done_share, first.lap_share) == (0.0, pytest.approx(1 / 6))
    s.loop(0.0)
    assert s.runner.state(0.5).done_share == pytest.approx(1 / 3)  # resting after it
    s.runner.tick(1.0)
    s.loop(1.0)  # the reaching block's first round of two, one lap each
    assert s.runner.state(1.0).done_share == pytest.approx(1 / 2)
    assert s.runner.state(1.0).lap_share == pytest.approx(1 / 6)
    s.loop(1.0)
    s.runner.tick(2.0)
    assert s.runner.state(2.0).done_share == pytest.approx(2 / 3)
    s.loop(2.0)
    assert s.runner.state(2.0).done_share == 1.0


def test_a_pause_in_a_trial_runs_the_laps_it_had_left_and_in_a_rest_holds_the_clock():
    plan = Plan("One", (Block(shape="d", repetitions=4, duration_s=2.0, rest_s=10.0),
                        Block(shape="circle", repetitions=1, duration_s=2.0, rest_s=0.0)))
    s = Script(plan)
    s.runner.start(0.0)
    s.console.building = None
    s.runner.built(0.0, True)
    s.console.starting = None
    s.runner.started(0.0, 1)
    s.runner.pause(1.0)
    assert s.console.stop_asked
    s.runner.trial_ended(1.0)
    s.runner.finished(1.0, 1, "stopped_early", 1, 2.5)  # one lap of four
    assert s.runner.phase == PAUSED
    assert s.console.building is None
    s.runner.resume(50.0)
    assert s.console.building.repetitions == 3  # the laps it had left
    s.trial = 1
    s.loop(50.0)
    assert s.runner.phase == RESTING
    s.runner.pause(54.0)  # 6 s of rest left, held
    s.runner.tick(500.0)
    assert s.runner.state(500.0).rest_left_s == pytest.approx(6.0)
    s.runner.resume(500.0)
    s.runner.tick(505.0)
    assert s.console.building is None
    s.runner.tick(506.0)
    assert s.console.building.shape == "circle"


def test_stop_in_a_rest_ends_the_plan_with_the_rest_as_taken():
    s = Script()
    s.runner.start(0.0)
    s.loop(0.0)
    s.runner.stop(0.25)
    assert s.console.ended == ("stopped", "stopped by the therapist")
    assert s.console.rests == [(1, 1.0, 0.25, 0.0)]
    s.runner.tick(10.0)
    assert s.console.building is None


def test_a_proposal_applies_to_the_next_block_of_the_same_exercise():
    plan = Plan("Again", (Block(shape="d", repetitions=1, duration_s=4.0, rest_s=0.0),
                          Block(shape="circle", repetitions=1, duration_s=4.0, rest_s=0.0),
                          Block(shape="d", repetitions=1, duration_s=4.0, rest_s=0.0)))

    class Faster:
        def applied_to(self, parameters):
            return parameters.replace(duration_s=3.6, assistance_level=0.9)

    s = Script(plan)
    s.runner.start(0.0)
    params = s.console.building
    s.console.building = None
    s.runner.built(0.0, True)
    s.console.starting = None
    s.runner.started(0.0, 1)
    s.runner.finished(0.0, 1, "complete", 1, 4.0, proposal=Faster())
    assert s.console.building.shape == "circle"
    assert s.console.building.duration_s == params.duration_s  # not the circle's
    s.loop(0.0)
    assert (s.console.building.duration_s, s.console.building.assistance_level) == (3.6, 0.9)
    assert plan.blocks[2].duration_s == 4.0  # the plan as prescribed is kept


def test_a_game_block_s_rounds_take_the_staircase_s_difficulty_from_the_rounds_before():
    from app.games.rounds import staircase_rounds

    plan = Plan("Game", (Block(shape="targets", game="reach", repetitions=1, duration_s=12.0,
                               rest_s=0.0, rounds=3),))
    console = FakeConsole()
    runner = PlanRunner(plan, BASE, console, next_round=staircase_rounds())
    runner.start(0.0)
    built = []
    for trial in (1, 2, 3):
        params = console.building
        built.append(params)
        console.building = None
        runner.built(0.0, True)
        console.starting = None
        runner.started(0.0, trial)
        runner.finished(0.0, trial, "complete", 16, 12.0,
                        figures={"game_hits": 8.0, "game_misses": 0.0})
    assert console.ended == ("complete", "")
    assert built[0].staircase != built[1].staircase != built[2].staircase
    assert built[1] != built[0]  # every target hit: the next round is harder


def test_a_disconnect_in_a_rest_pauses_the_plan_and_resume_goes_on():
    """The therapist's Disconnect in the rest after block 1: the plan pauses with why and
    what to do, the rest's clock stops, the run's record says it with its time, nothing is
    built however long it is held, and Resume goes on with the rest it had left. Before,
    the next round was built at the rest's end, its Start refused (not connected), and the
    plan ended 'faulted'."""
    s = Script()
    s.runner.start(0.0)
    s.loop(0.0)
    assert s.runner.phase == RESTING
    s.console.now = 0.25
    s.runner.robot_gone(0.25, GONE)
    assert s.runner.phase == PAUSED
    assert s.runner.state(0.3).line() == f"Plan paused at block 1 of 3: {GONE}"
    assert s.console.events == [(1, f"paused: {GONE}", 0.25)]
    s.runner.tick(100.0)
    assert s.console.building is None
    assert s.console.ended is None
    assert s.runner.state(100.0).rest_left_s == pytest.approx(0.75)
    s.console.now = 100.0
    s.runner.resume(100.0)
    assert s.console.events[-1] == (1, "resumed", 100.0)
    assert s.runner.state(100.0).line().startswith("Rest 0:01 after block 1 of 3")
    s.runner.tick(100.74)
    assert s.console.building is None
    s.runner.tick(100.75)
    assert s.console.building.shape == "reach"
    assert [r[:3] for r in s.console.rests] == [(1, 1.0, 1.0)]


def test_a_start_refused_as_the_robot_went_holds_the_round_not_the_plan():
    """The robot went as a round's Start was asked (no rest after block 1): the loop's
    refusal pauses the plan, and Resume builds the round again."""
    plan = Plan("No rest", (Block(shape="d", repetitions=1, duration_s=2.0, rest_s=0.0),
                            Block(shape="circle", repetitions=1, duration_s=2.0)))
    s = Script(plan)
    s.runner.start(0.0)
    s.console.building = None
    s.runner.built(0.0, True)
    s.runner.robot_gone(0.5, GONE)
    s.console.starting = None
    s.runner.refused(0.6, NOT_CONNECTED)
    assert s.runner.phase == PAUSED
    assert s.console.ended is None
    s.runner.resume(9.0)
    assert s.console.building.shape == "d"
    assert s.console.building.repetitions == 1
    s.loop(9.0)
    s.loop(9.0)
    assert s.console.ended == ("complete", "")


def test_the_planned_movements_are_the_rounds_own_on_a_task_s_form():
    """Seen in the window: the plan started with the position sense task (4 targets) still
    in the Parameters form said "Plan complete (…; 18 of 10 movements)": its rounds ran
    with an exercise's 8 targets (core.assessment.protocol.without_task), the planned
    count took the form's 4. And a round paused in its first lap counted its laps by 4
    targets: one lap's 16 movements made two laps done, of two."""
    from core.assessment.protocol import protocol

    task_form = protocol("position").parameters(BASE)
    assert task_form.n_targets == 4
    plan = Plan("Targets", (Block(shape="targets", rounds=1, repetitions=2, duration_s=12.0,
                                  assist="as-needed", assistance_level=1.0, rest_s=0.0),))
    console = FakeConsole()
    runner = PlanRunner(plan, task_form, console)
    runner.start(0.0)
    ran = console.building
    assert ran.n_targets == 8
    assert runner.planned_movements() == 2 * 2 * ran.n_targets
    console.building = None  # the loop answers the build, then the start
    runner.built(0.0, True)
    console.starting = None
    runner.started(0.0, 1)
    runner.pause(0.5)
    runner.trial_ended(1.0)
    runner.finished(1.0, 1, "stopped_early", 2 * ran.n_targets, 12.0)  # one lap of two
    assert (runner.laps_done, runner.laps_left) == (1, 1)
