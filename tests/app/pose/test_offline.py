"""`rehab pose` and app.pose.offline on a simulated trial with a recorded video beside it:
the /pose group written and read back, the comparison, reference angles, and every kind of
unusable video refused in one line with the trial file left readable and unchanged."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from app.cli.main import main
from app.pose.offline import estimate_pose
from app.pose.store import read_pose
from app.pose.synthetic import film
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.pose.keypoints import ArmKeypoints
from core.trial import THESIS_SUBJECT
from device.camera.capture import TIMESTAMPS_HEADER, timestamps_path
from device.errors import VideoError
from tests import pose_film as film_tools
from tests.pose_film import SIZE, write_video
from tests.trialfiles import edited

ORIGIN = 7000.0


class ReplayDetector(film_tools.ReplayDetector):
    """The film's detector, checking that each picture is the video's size."""

    def __init__(self, filmed, side="right"):
        super().__init__(filmed, side, size=SIZE)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A closed trial file with its loop's clock origin, and its video and timestamps."""
    folder = tmp_path_factory.mktemp("recorded")
    path = folder / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), patient="healthy", seed=2), path)
    with edited(path) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = ORIGIN
    filmed = film(read_trial(path), seed=1, origin_s=ORIGIN)
    write_video(path.with_suffix(".avi"), filmed.stamps_s)
    return path, filmed


@pytest.fixture
def trial(recorded, tmp_path):
    """A fresh copy of the recorded trial and its video for each test."""
    path, filmed = recorded
    for suffix in (".h5", ".avi"):
        shutil.copy(path.with_suffix(suffix), tmp_path / f"trial{suffix}")
    shutil.copy(timestamps_path(path.with_suffix(".avi")),
                timestamps_path(tmp_path / "trial.avi"))
    return tmp_path / "trial.h5", filmed


def test_the_pose_group_is_written_and_read_back(trial):
    path, filmed = trial
    detector = ReplayDetector(filmed)
    seen = []
    outcome = estimate_pose(path, detector, progress=seen.append)
    assert detector.calls == filmed.stamps_s.size
    assert detector.closed
    assert seen[-1] == 1.0
    assert seen == sorted(seen)
    pose = read_pose(path)
    data = read_trial(path)  # the trial reads as before
    n = data.n_samples
    assert pose["angle"].shape == (n, 2)
    assert pose["angle_isb"].shape == (n, 2)
    assert pose["shoulder"].shape == (n, 2)
    assert pose["frame_keypoints_px"].shape == (filmed.stamps_s.size, 4, 2)
    attrs = pose["attrs"]
    assert attrs["video"] == "trial.avi"
    assert attrs["fit_residual_mm"] < 6
    assert attrs["camera_vs_solver_shoulder_rmse_rad"] < np.radians(1.0)
    assert attrs["camera_vs_solver_elbow_rmse_rad"] < np.radians(1.0)
    assert attrs["shoulder_drift_exceeded"] == 0
    assert np.allclose(pose["angle_isb"], outcome.result.angle_isb, equal_nan=True)
    with h5py.File(path) as f:
        assert f["pose/angle"].attrs["units"] == "rad"
        assert f["pose/angle"].fletcher32
    # a second run replaces the group
    estimate_pose(path, ReplayDetector(filmed), min_visibility=0.9)
    assert read_pose(path)["attrs"]["min_visibility"] == 0.9


def test_the_camera_and_the_solver_against_reference_angles(trial, tmp_path):
    path, filmed = trial
    data = read_trial(path)
    arm = data.parameters.arm()
    frames = np.arange(10, 130, 12)
    stamps_t = filmed.true_frame_t_s[frames]
    truth = arm.isb_angles(np.column_stack([np.interp(stamps_t, data.time,
                                                      data.channels["subject_angle"][:, j])
                                            for j in range(2)]))
    reference = np.degrees(truth) + np.array([0.5, -0.5])  # a goniometer half a degree off
    csv_path = tmp_path / "goniometer.csv"
    csv_path.write_text("frame,shoulder_deg,elbow_deg\n" + "".join(
        f"{f},{s:.3f},{e:.3f}\n" for f, (s, e) in zip(frames, reference, strict=True)))
    outcome = estimate_pose(path, ReplayDetector(filmed), reference=csv_path, write=False)
    solver = outcome.reference_errors["solver"]
    assert np.degrees(solver[0].bias_rad) == pytest.approx(-0.5, abs=0.05)
    assert np.degrees(solver[1].bias_rad) == pytest.approx(0.5, abs=0.05)
    camera = outcome.reference_errors["camera"]
    assert np.degrees(camera[0].rmse_rad) < 2.0
    assert read_pose(path) is None  # write=False


def unusable(trial, how: str):
    path, filmed = trial
    video = path.with_suffix(".avi")
    stamps = filmed.stamps_s
    if how == "missing":
        video.unlink()
    elif how == "empty":
        video.write_bytes(b"")
    elif how == "corrupt":
        video.write_bytes(np.random.default_rng(0).bytes(50_000))
    elif how == "too small":
        write_video(video, stamps, size=(64, 48))
    elif how == "not its timestamps":
        write_video(video, stamps, n_frames=stamps.size // 2)
        timestamps_path(video).write_text(TIMESTAMPS_HEADER + "".join(
            f"{k},{s:.6f}\n" for k, s in enumerate(stamps)))
    elif how == "shorter than the trial":
        write_video(video, stamps[: stamps.size // 2])
    elif how == "no timestamps":
        timestamps_path(video).unlink()
    elif how == "cut short while decoding":
        data = video.read_bytes()
        video.write_bytes(data[: len(data) // 3])
    return path


@pytest.mark.parametrize(("how", "match"), [
    ("missing", "does not exist"),
    ("empty", "is empty"),
    ("corrupt", "cannot be decoded|no readable frame|frames but its timestamps"),
    ("too small", r"64×48 px; pose estimation needs at least 160×120"),
    ("not its timestamps", r"has \d+ frames but its timestamps list \d+"),
    ("shorter than the trial", "shorter than the trial"),
    ("no timestamps", "no timestamps file"),
    ("cut short while decoding", "stops decoding|frames but its timestamps|damaged"),
])
def test_an_unusable_video_is_refused_and_the_trial_stays_as_it_was(trial, how, match):
    path = unusable(trial, how)
    before = path.read_bytes()
    with pytest.raises(VideoError, match=match):
        estimate_pose(path, ReplayDetector(trial[1]))
    assert path.read_bytes() == before
    assert read_trial(path).n_samples > 0
    assert read_pose(path) is None


def test_a_trial_without_its_clocks_origin_needs_the_videos_start(trial):
    path, filmed = trial
    with edited(path) as f:
        del f["summary"].attrs["wall_time_origin_monotonic_s"]
    with pytest.raises(VideoError, match="--video-start-s"):
        estimate_pose(path, ReplayDetector(filmed))
    start = filmed.true_frame_t_s[0]
    outcome = estimate_pose(path, ReplayDetector(filmed), video_start_s=start, write=False)
    assert outcome.result.errors[0].rmse_rad < np.radians(1.0)


def test_the_command_prints_the_comparison(trial, monkeypatch, capsys):
    path, filmed = trial
    import device.camera.detector as detector

    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: ReplayDetector(filmed, side))
    assert main(["pose", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "camera vs equation solver" in out
    assert "shoulder" in out
    assert "written to" in out
    assert "100 % of the frames" in err
    assert read_pose(path) is not None


@pytest.mark.parametrize(("how", "match"), [
    ("empty", "is empty"),
    ("shorter than the trial", "shorter than the trial"),
])
def test_the_command_refuses_an_unusable_video_in_one_line(trial, capsys, how, match):
    path = unusable(trial, how)
    assert main(["pose", str(path)]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1
    assert err.startswith("rehab pose: error: ")
    assert match in err
    assert read_pose(path) is None


def test_the_real_model_on_a_video_without_a_person_refuses_the_fit(trial, capsys):
    """MediaPipe itself on the recorded (grey) frames: nobody is there, so there is no
    wrist to fit the camera with; one line, the trial untouched."""
    path, _ = trial
    assert main(["pose", str(path)]) == 2
    _, err = capsys.readouterr()
    assert err.splitlines()[-1].startswith("rehab pose: error: only 0 frames have both a "
                                           "visible wrist")
    assert read_pose(path) is None


@pytest.mark.parametrize("argv", [
    ["--drift-limit-cm", "0"], ["--max-residual-mm", "-1"], ["--min-visibility", "2"],
])
def test_the_command_refuses_bad_options(trial, capsys, argv):
    path, _ = trial
    assert main(["pose", str(path), *argv]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1


def test_the_report_carries_the_comparison(trial):
    from app.reports.build import build_report

    path, filmed = trial
    assert not any("camera vs equation solver" in n
                   for n in build_report(read_trial(path)).notes)
    estimate_pose(path, ReplayDetector(filmed))
    notes = build_report(read_trial(path)).notes
    lines = [n for n in notes if n.startswith("camera vs equation solver")]
    assert len(lines) == 2
    assert "shoulder (ISB)" in lines[0]
    assert "° RMSE" in lines[0]
    assert any(n.startswith("camera: the shoulder moved up to") for n in notes)


def test_four_marked_points_replace_the_handle_fit(trial, tmp_path, capsys, monkeypatch):
    from core.pose.homography import apply

    path, filmed = trial
    marks_m = np.array([[-0.55, 0.15], [0.05, 0.15], [0.05, 0.80], [-0.55, 0.80]])
    marks_px = apply(filmed.camera, marks_m)
    marks = tmp_path / "marks.csv"
    marks.write_text("u_px,v_px,x_m,y_m\n" + "".join(
        f"{u:.3f},{v:.3f},{x},{y}\n" for (u, v), (x, y) in zip(marks_px, marks_m, strict=True)))
    import device.camera.detector as detector

    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: ReplayDetector(filmed, side))
    assert main(["pose", str(path), "--marks", str(marks)]) == 0
    out, _ = capsys.readouterr()
    assert "points fit from 4 points: exact" in out
    attrs = read_pose(path)["attrs"]
    assert attrs["fit_method"] == "points"
    assert attrs["camera_vs_solver_shoulder_rmse_rad"] < np.radians(1.0)
    assert attrs["camera_vs_solver_elbow_rmse_rad"] < np.radians(1.0)


def test_a_video_that_never_shows_the_whole_arm_is_refused_with_marked_points(
        trial, tmp_path, capsys, monkeypatch):
    """With four marked points no wrist is needed to fit the camera: a video whose wrist
    the model never saw on the handle wrote an empty /pose, printed dashes and exit 0."""
    import dataclasses

    from core.pose.homography import apply
    from core.pose.keypoints import WRIST

    path, filmed = trial
    visibility = filmed.visibility.copy()
    visibility[:, WRIST] = 0.2  # the hand always hidden (a sleeve, the edge of the picture)
    hidden = dataclasses.replace(filmed, visibility=visibility)
    marks_m = np.array([[-0.55, 0.15], [0.05, 0.15], [0.05, 0.80], [-0.55, 0.80]])
    marks = tmp_path / "marks.csv"
    marks.write_text("u_px,v_px,x_m,y_m\n" + "".join(
        f"{u:.3f},{v:.3f},{x},{y}\n"
        for (u, v), (x, y) in zip(apply(filmed.camera, marks_m), marks_m, strict=True)))
    import device.camera.detector as detector

    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: ReplayDetector(hidden, side))
    before = path.read_bytes()
    assert main(["pose", str(path), "--marks", str(marks)]) == 2
    out, err = capsys.readouterr()
    assert "written to" not in out
    line = err.splitlines()[-1]
    n = filmed.stamps_s.size
    assert line.startswith("rehab pose: error: video trial.avi: the whole arm is seen in "
                           f"none of its {n} frames (the shoulder in "), line
    assert "the wrist on the handle in 0)" in line
    assert path.read_bytes() == before
    assert read_pose(path) is None


@pytest.mark.parametrize(("text", "match"), [
    ("x,y\n1,2\n", "first line must be u_px,v_px,x_m,y_m"),
    ("u_px,v_px,x_m,y_m\n1,2,3\n", "four numbers"),
    ("u_px,v_px,x_m,y_m\n1,2,0.1,0.2\n3,4,0.3,0.4\n", "2 marked points"),
])
def test_marked_points_that_cannot_be_used_are_refused_in_one_line(trial, tmp_path, capsys,
                                                                   text, match):
    path, _ = trial
    marks = tmp_path / "marks.csv"
    marks.write_text(text)
    assert main(["pose", str(path), "--marks", str(marks)]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1
    assert match in err


def test_a_registered_trial_is_found_by_its_id(tmp_path, monkeypatch, capsys):
    """`rehab pose 1`: the registry's trial 1, whose file has no video beside it: the refusal
    names the file the registry points to."""
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    assert main(["patients", "add", "--first-name", "Ada", "--last-name", "Example",
                 "--body-mass", "80", "--upper-arm", "0.30", "--forearm", "0.29", "--side",
                 "right", "--shoulder", "-0.12", "0.73"]) == 0
    code = capsys.readouterr().out.strip()
    assert main(["run", "--code", code, "--repetitions", "1"]) == 0
    capsys.readouterr()
    assert main(["pose", "1"]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1
    assert f"{code}_S" in err
    assert "does not exist" in err
    assert main(["pose", "99"]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1


def test_the_pose_reaches_the_researchers_export(trial, tmp_path):
    """Issue 14: the camera's angles, shoulder and drift per sample and its keypoints per
    frame are in the .mat export (and the loader), as in the file's /pose."""
    import scipy.io

    from app.exports.loader import load_trial
    from app.exports.run import export_trial

    path, filmed = trial
    estimate_pose(path, ReplayDetector(filmed))
    loaded = load_trial(path)
    assert "pose" in loaded.groups
    (out,) = export_trial(loaded, tmp_path / "out", format="mat")
    pose = scipy.io.loadmat(out)["pose"][0, 0]
    np.testing.assert_array_equal(pose["angle_isb"], read_pose(path)["angle_isb"])
    assert pose["frame_keypoints_px"].shape == (filmed.stamps_s.size, 4, 2)
    assert pose["video"][0] == "trial.avi"


def test_the_report_draws_the_camera_against_the_solver(trial, tmp_path):
    """Issue 14: Table 3.4's comparison in the PDF: a page with the camera's angles
    beside the solver's, the shoulder's drift and the comparison in words."""
    from pypdf import PdfReader

    from app.reports.build import build_report, write_report_pdf

    path, filmed = trial
    assert build_report(read_trial(path)).pose is None  # no pose yet, no page
    estimate_pose(path, ReplayDetector(filmed))
    content = build_report(read_trial(path))
    figure = content.pose
    pose = read_pose(path)
    data = read_trial(path)
    assert figure.camera_isb_rad.shape == figure.solver_isb_rad.shape
    assert figure.t_s[0] == 0.0
    from app.trials.analysis import exercise_mask

    exercise = exercise_mask(data.channels)
    np.testing.assert_array_equal(figure.drift_m, pose["shoulder_drift"][exercise])
    np.testing.assert_array_equal(figure.camera_isb_rad, pose["angle_isb"][exercise])
    pdf = write_report_pdf(content, tmp_path / "report.pdf")
    pages = PdfReader(pdf).pages
    # the patient's page, the therapist's (continued when its notes need it), then the pose
    assert "For the therapist" in pages[1].extract_text()
    text = pages[-1].extract_text()
    assert "The camera against the equation solver" in text
    assert "camera vs equation solver, shoulder (ISB)" in text


def test_reference_angles_after_the_fact_use_the_stored_pose(trial, tmp_path):
    """compare_with_reference: the same errors as when given to the pose run; refused in
    one line before a pose run, or for a frame the run kept no time for."""
    from app.pose.offline import compare_with_reference

    path, filmed = trial
    with pytest.raises(VideoError, match="has no camera angles yet: run `rehab pose`"):
        compare_with_reference(path, tmp_path / "never_read.csv")
    reference = tmp_path / "frames.csv"
    reference.write_text("frame,shoulder_deg,elbow_deg\n10,40,60\n20,45,70\n30,50,80\n")
    during = estimate_pose(path, ReplayDetector(filmed), reference=reference).reference_errors
    after = compare_with_reference(path, reference)
    assert after == during
    beyond = tmp_path / "beyond.csv"
    beyond.write_text(f"frame,shoulder_deg,elbow_deg\n{filmed.stamps_s.size + 5},40,60\n")
    with pytest.raises(VideoError, match=r"names frame \d+, but the pose run kept frames 0–"):
        compare_with_reference(path, beyond)


def test_the_detector_on_every_kth_frame(trial):
    """For a computer too slow for the model at the camera's rate: the detector sees every
    k-th frame, the rest are left out as dropped frames are, and the camera still agrees
    with the solver (the film's known camera: within 1° at every third frame); k out of
    1-10 is refused in one line."""
    from core.errors import ParameterError

    path, filmed = trial
    detector = ReplayDetector(filmed)
    seen = []

    class EveryThird(ReplayDetector):
        def detect(self, image_bgr):
            seen.append(self.calls)
            k = ArmKeypoints(self.filmed.keypoints_px[self.calls],
                             self.filmed.visibility[self.calls])
            self.calls += 3  # the next frame it is shown
            return k

    every_frame = np.isfinite(estimate_pose(path, detector).result.angle_isb).mean()
    outcome = estimate_pose(path, EveryThird(filmed), detect_every=3)
    assert seen == list(range(0, filmed.stamps_s.size, 3))
    pose = read_pose(path)
    np.testing.assert_array_equal(pose["frame_index"], seen)
    assert pose["attrs"]["detect_every"] == 3
    assert outcome.result.errors[0].rmse_rad < np.radians(1.0)
    assert outcome.result.errors[1].rmse_rad < np.radians(1.0)
    # the 2 ms series interpolated between the frames seen; a keypoint the model missed
    # now leaves a gap of three frames' length, not one
    coverage = np.isfinite(pose["angle_isb"]).mean()
    assert coverage > 0.7 * every_frame
    for k in (0, 11, 2.5, True):
        with pytest.raises(ParameterError, match="detect_every"):
            estimate_pose(path, ReplayDetector(filmed), detect_every=k)


def test_the_command_says_how_many_of_the_videos_frames_the_model_saw(trial, capsys,
                                                                      monkeypatch):
    """With --every 3 it printed "88 frames of trial.mp4" for a video of 264: the
    researcher read a video cut short."""
    path, filmed = trial
    import device.camera.detector as detector

    class EveryThird(ReplayDetector):
        def detect(self, image_bgr):
            k = ArmKeypoints(self.filmed.keypoints_px[self.calls],
                             self.filmed.visibility[self.calls])
            self.calls += 3
            return k

    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: EveryThird(filmed, side))
    assert main(["pose", str(path), "--every", "3"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    n = filmed.stamps_s.size
    assert first.startswith(f"trial.h5: {len(range(0, n, 3))} of the {n} frames of trial.avi "
                            "through the model, "), first
    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: ReplayDetector(filmed, side))
    assert main(["pose", str(path)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith(f"trial.h5: {n} frames of trial.avi through the model, "), first


def test_the_command_refuses_every_out_of_range(trial, capsys):
    path, _ = trial
    assert main(["pose", str(path), "--every", "11"]) == 2
    assert "--every 11: give a whole number of frames from 1 to 10" in capsys.readouterr().err
