"""A headless trial end to end: simulate, supervise, write, read back, measure."""

import math

import numpy as np
import pytest

from app.cli.main import main
from app.trials.analysis import analyse
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.errors import UnreachableError
from core.trial import THESIS_AS_PRINTED, THESIS_SUBJECT
from device.loop.pipeline import PHASE_EXERCISE, PHASE_HOLD

SHORT = THESIS_SUBJECT.replace(repetitions=1)
FIGURES_RTOL = 1e-9
"""How close a figure computed a block at a time is to the whole-array one (rounding: the
block sums' order, the filters' block boundaries, the spectrum's folding)."""


def same_figures(a: dict, b: dict) -> None:
    """Equal figures to FIGURES_RTOL (NaN equal to NaN, as for a trial without reaches)."""
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_allclose(a[name], b[name], rtol=FIGURES_RTOL, atol=0.0,
                                   err_msg=name)


def test_healthy_trial_round_trips_through_its_file(tmp_path):
    trial = simulate(SHORT, patient="healthy", seed=1)
    assert trial.status == "complete"
    path = tmp_path / "trial.h5"
    analysis = save(trial, path)
    data = read_trial(path)
    assert data.status == "complete"
    assert data.parameters == SHORT
    for name in trial.records.dtype.names:
        np.testing.assert_array_equal(data.channels[name], trial.records[name])
    assert data.metrics["rmse_x_m"] == pytest.approx(analysis.metrics.rmse_x_m)
    kinds = [e["kind"] for e in data.events]
    assert kinds[0] == "start"
    assert kinds[-1] == "stop"


def test_the_robot_tracks_the_d_for_a_healthy_subject():
    trial = simulate(SHORT, patient="healthy")
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    metrics = analyse(channels, SHORT).metrics
    assert metrics.rmse_x_m < 0.005
    assert metrics.rmse_y_m < 0.005
    assert metrics.directional_performance_pct > 50.0
    assert 0.95 < metrics.path_length_ratio < 1.05


def test_phases_follow_each_other_and_the_trial_ends_at_rest():
    trial = simulate(SHORT)
    phase = trial.records["phase"]
    assert np.all(np.diff(phase.astype(int)) >= 0)
    assert (phase == PHASE_EXERCISE).sum() == round(SHORT.duration_s / 0.002)
    assert phase[-1] == PHASE_HOLD


def test_deterministic_for_a_seed():
    a = simulate(SHORT, patient="tremor", seed=5).records
    b = simulate(SHORT, patient="tremor", seed=5).records
    np.testing.assert_array_equal(a["force_sensor"], b["force_sensor"])
    c = simulate(SHORT, patient="tremor", seed=6).records
    assert not np.array_equal(a["force_sensor"], c["force_sensor"])


def test_unreachable_trial_is_refused_before_it_starts():
    with pytest.raises(UnreachableError, match=r"0\.68 m from the shoulder"):
        simulate(THESIS_AS_PRINTED)


def test_torque_never_exceeds_the_drives():
    trial = simulate(SHORT.replace(duration_s=2.0, timing="minimum_jerk"), patient="spastic")
    applied = trial.records["torque_applied"]
    assert np.all(np.abs(applied) <= 0.115 * 307 / 16 + 1e-9)


def test_run_command_writes_the_file_and_prints_the_table(tmp_path, capsys):
    out = tmp_path / "run.h5"
    code = main(["run", "--patient", "weak", "--trajectory", "d", "--controller", "ctpid",
                 "--repetitions", "1", "--output", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "Directional performance" in text
    assert "Trial complete" in text
    assert "compiled engine" in text
    assert read_trial(out).status == "complete"


def test_run_command_can_take_the_python_engine(tmp_path, capsys):
    out = tmp_path / "python.h5"
    assert main(["run", "--repetitions", "1", "--engine", "python", "--output", str(out)]) == 0
    assert "python engine" in capsys.readouterr().out
    assert read_trial(out).summary["engine"] == "python"


def test_run_refuses_an_existing_file_and_bad_patients(tmp_path, capsys):
    out = tmp_path / "x.h5"
    out.write_bytes(b"")
    assert main(["run", "--repetitions", "1", "--output", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["run", "--patient", "zombie"])
    assert exc.value.code == 2


def test_subject_channels_are_finite_on_the_exercise():
    trial = simulate(SHORT)
    exercise = trial.records["phase"] == PHASE_EXERCISE
    for name in ("subject_angle", "subject_torque", "subject_angle_isb"):
        assert np.isfinite(trial.records[name][exercise]).all(), name
    isb = np.degrees(trial.records["subject_angle_isb"][exercise])
    assert 30 < isb[:, 0].min() < isb[:, 0].max() < 95
    assert not math.isnan(trial.speed_vs_real_time)


@pytest.mark.parametrize("controller", ["smc", "ctpid"])
@pytest.mark.parametrize("patient", ["healthy", "weak", "spastic", "tremor", "passive",
                                     "wrong_way"])
def test_controllers_track_the_d_for_every_virtual_patient(controller, patient):
    """Bounds: 5 mm RMS per axis for an active subject, 15 mm for a limp arm (the drives'
    2.21 N·m limit and the supervisor's 0.5 s start ramp meet the arm's inertia and tissue
    stiffness at the corners); the trial completes."""
    params = SHORT.replace(controller=controller)
    trial = simulate(params, patient=patient, seed=3)
    assert trial.status == "complete"
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    metrics = analyse(channels, params).metrics
    bound = 0.015 if patient == "passive" else 0.005
    assert metrics.rmse_x_m < bound
    assert metrics.rmse_y_m < bound


# --- a long trial streams to its file (issue: memory grew with the trial's length) ------


def test_a_streamed_trial_holds_one_block_at_a_time_and_writes_what_memory_would(
        tmp_path, monkeypatch):
    """simulate_to_file hands the records to the file in blocks of at most BLOCK_TICKS
    (here made small so a short trial has several), keeps none itself, and the file it
    writes has the same samples and metrics as the whole trial held in memory."""
    from app.trials.headless import simulate_to_file
    from device.loop import engine

    monkeypatch.setattr(engine, "BLOCK_TICKS", 700)
    params = THESIS_SUBJECT.replace(repetitions=2)
    blocks = []
    writer_append = engine.run_trial

    def watching(*args, **kwargs):
        sink = kwargs.pop("sink", None) if "sink" in kwargs else args[4]
        args = args[:4]

        def counting(records):
            blocks.append(len(records))
            sink(records)

        return writer_append(*args, sink=counting)

    monkeypatch.setattr("app.trials.headless.run_trial", watching)
    streamed, analysis, problem = simulate_to_file(params, tmp_path / "streamed.h5", seed=3)
    assert problem == ""
    assert len(streamed.records) == 0  # nothing kept in memory
    assert len(blocks) > 3
    assert max(blocks) <= 700
    assert sum(blocks) == streamed.n_ticks

    monkeypatch.undo()
    whole = simulate(params, seed=3)
    reference = save(whole, tmp_path / "whole.h5")
    a, b = read_trial(tmp_path / "streamed.h5"), read_trial(tmp_path / "whole.h5")
    assert a.n_samples == b.n_samples == streamed.n_ticks
    for name in b.channels:
        np.testing.assert_array_equal(a.channels[name], b.channels[name], err_msg=name)
    # the streamed analysis reads the file a block at a time: the same figures to rounding
    same_figures(a.metrics, b.metrics)
    same_figures(analysis.metrics.to_dict(), reference.metrics.to_dict())
    assert [e["kind"] for e in a.events] == [e["kind"] for e in b.events]
    assert a.status == b.status == "complete"


def test_a_streamed_trial_without_figures_keeps_its_file_and_says_why(tmp_path, monkeypatch):
    """A trial that faulted (here a subject pushing 50 N the wrong way) and that has too
    little exercise for its figures: the file is kept with its samples, its fault and its
    status, and the reason comes back instead of the figures (no exception: the trial
    happened and is registered)."""
    from app.errors import AppError
    from app.trials.headless import simulate_to_file

    def too_short(read, n_ticks, names, parameters, **options):
        raise AppError("the trial has only 3 samples of exercise; at least 64 are needed")

    monkeypatch.setattr("app.trials.headless.analyse_stored", too_short)
    trial, analysis, problem = simulate_to_file(
        SHORT, tmp_path / "t.h5", patient="wrong_way", patient_options={
            "wrong_way_force_N": 50.0, "wrong_way_fraction": 0.9, "wrong_way_episode_s": 5.0})
    assert trial.status == "faulted"
    assert analysis is None
    assert "samples of exercise" in problem
    data = read_trial(tmp_path / "t.h5")
    assert data.status == "faulted"
    assert data.n_samples == trial.n_ticks
    assert data.events[-1]["kind"] == "fault"
    assert not data.metrics


def test_the_analysis_reads_only_the_channels_it_needs(tmp_path):
    """finalize reads back CHANNELS_USED (with tick and time), not the whole trial."""
    from app.trials.analysis import CHANNELS_USED

    save(simulate(THESIS_SUBJECT.replace(repetitions=1)), tmp_path / "t.h5")
    data = read_trial(tmp_path / "t.h5", CHANNELS_USED)
    assert set(data.channels) == {"tick", "time", *CHANNELS_USED} & set(
        read_trial(tmp_path / "t.h5").channels)
    np.testing.assert_equal(
        analyse(data.channels, data.parameters).metrics.to_dict(),
        analyse(read_trial(tmp_path / "t.h5").channels, data.parameters).metrics.to_dict())


def test_the_exercise_is_analysed_in_place_and_figures_do_not_change(monkeypatch):
    """Issue 13 #21: the exercise phase is one run of ticks, so the analysis takes the
    channels as views (a 1,800 s trial's analysis peaked 118 MB lower, bench/memory.py);
    a phase with a gap is still taken by its mask, to the same figures."""
    import app.trials.analysis as analysis

    trial = simulate(THESIS_SUBJECT.replace(repetitions=1))
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    mask = analysis.exercise_mask(channels)
    taken = analysis._as_slice(mask, int(mask.sum()))
    assert isinstance(taken, slice)
    assert np.shares_memory(channels["force"][taken], channels["force"])
    gap = mask.copy()
    gap[taken.start + 10] = False
    assert analysis._as_slice(gap, int(gap.sum())) is gap
    by_slice = analyse(channels, trial.plan.parameters).metrics.to_dict()
    monkeypatch.setattr(analysis, "_as_slice", lambda mask, n: mask)  # as before
    np.testing.assert_equal(analyse(channels, trial.plan.parameters).metrics.to_dict(),
                            by_slice)


@pytest.mark.parametrize(("params", "patient"), [
    (THESIS_SUBJECT.replace(repetitions=4), "tremor"),
    (THESIS_SUBJECT.replace(repetitions=3, assist="as-needed", controller="ctpid"),
     "wrong_way"),
    (THESIS_SUBJECT.replace(repetitions=3, shape="targets"), "weak"),
])
def test_a_trial_analysed_a_block_at_a_time_has_the_whole_arrays_figures(
        monkeypatch, params, patient):
    """Issue 13 #21: every figure of a trial analysed in blocks of 1,000 samples (its speed's
    spectrum folded into 4,096 bins, several passes) equals the whole-array analysis
    (`analyse`, the reference) to FIGURES_RTOL, the notes too; and no channel is read
    more than a block and the filter's margins at a time."""
    import core.smoothness
    from app.trials.analysis import analyse_stored
    from core.blockwise import MARGIN_PERIODS

    monkeypatch.setattr(core.smoothness, "FOLD", 4096)
    trial = simulate(params, patient=patient, seed=7)
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    reads = []

    def read(name, first, stop):
        reads.append(stop - first)
        return channels[name][first:stop]

    whole = analyse(channels, params)
    blocks = analyse_stored(read, len(trial.records), list(channels), params, block=1000)
    assert len(trial.records) > 5 * 1000
    same_figures(blocks.metrics.to_dict(), whole.metrics.to_dict())
    assert blocks.notes == whole.notes
    assert blocks.exercise_start_s == whole.exercise_start_s
    assert len(blocks.metrics.reaches) == len(whole.metrics.reaches)
    margin = math.ceil(MARGIN_PERIODS / (10.0 * 0.002)) + 1  # from the median step
    assert max(reads) <= 1000 + 2 * margin + 2


def test_a_streamed_trials_analysis_reads_the_file_a_block_at_a_time(tmp_path, monkeypatch):
    """rehab run's analysis (simulate_to_file) never asks the trial file for more than a
    block of a channel (plus the low-pass's margins), whatever the trial's length, and its
    figures are the whole trial's."""
    import core.blockwise
    from app.trials.headless import simulate_to_file
    from device.recording.trialfile import TrialFileWriter

    monkeypatch.setattr(core.blockwise, "BLOCK", 1000)
    reads = []
    read_stretch = TrialFileWriter.read_stretch

    def watched(self, name, first, stop):
        reads.append(stop - first)
        return read_stretch(self, name, first, stop)

    monkeypatch.setattr(TrialFileWriter, "read_stretch", watched)
    params = THESIS_SUBJECT.replace(repetitions=3)
    streamed, analysis, problem = simulate_to_file(params, tmp_path / "t.h5", seed=3)
    assert problem == ""
    assert streamed.n_ticks > 5 * 1000
    margin = math.ceil(core.blockwise.MARGIN_PERIODS / (10.0 * 0.002)) + 1
    assert reads
    assert max(reads) <= 1000 + 2 * margin + 2
    whole = simulate(params, seed=3)
    reference = analyse({n: whole.records[n] for n in whole.records.dtype.names}, params)
    same_figures(analysis.metrics.to_dict(), reference.metrics.to_dict())
    np.testing.assert_equal(read_trial(tmp_path / "t.h5").metrics, analysis.metrics.to_dict())


def test_every_tick_records_the_level_it_ran_with_in_both_engines():
    """The per-tick assistance level (issue 27): a headless trial runs its built level at
    every tick, compiled and interpreted alike."""
    params = SHORT.replace(assist="as-needed", assistance_level=0.6)
    fast = simulate(params, patient="weak", seed=1)
    slow = simulate(params, patient="weak", seed=1, engine="python")
    np.testing.assert_array_equal(fast.records["assistance_level"], 0.6)
    np.testing.assert_array_equal(slow.records["assistance_level"], 0.6)


def test_rehab_run_draws_a_new_seed_unless_one_is_given(tmp_path, capsys, monkeypatch):
    """Issue 27, item 16: a course of `rehab run` at one setting varies; --seed fixes it."""
    import re

    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))

    def run(name, *more):
        path = tmp_path / name
        assert main(["run", "--patient", "tremor", "--repetitions", "1", "--output",
                     str(path), *more]) == 0
        seed = int(re.search(r"seed (\d+)", capsys.readouterr().out).group(1))
        data = read_trial(path)
        assert data.backend == f"simulator (tremor, seed {seed})"
        return seed, data.metrics["rmse_x_m"]

    drawn = [run(f"drawn{i}.h5") for i in range(3)]
    assert len({seed for seed, _ in drawn}) == 3
    assert len({rmse for _, rmse in drawn}) == 3  # the figures vary as a person's would
    assert run("a.h5", "--seed", "5") == run("b.h5", "--seed", "5")
    assert main(["run", "--seed", "-1", "--output", str(tmp_path / "c.h5")]) == 2
    assert "--seed -1" in capsys.readouterr().err
