"""The real MediaPipe model on a real photograph (scikit-image's public-domain NASA
`astronaut`, 512×512, upper body), the visibility rule, and the installation guards."""

from __future__ import annotations

import importlib.metadata

import numpy as np
import pytest
from skimage import data

from core.pose.keypoints import ELBOW, OTHER_SHOULDER, SHOULDER, WRIST
from device.camera import detector
from device.camera.detector import MediaPipePose, check_complexity, check_installation
from device.errors import PoseModelError


@pytest.fixture(scope="module")
def astronaut_bgr() -> np.ndarray:
    return np.ascontiguousarray(data.astronaut()[:, :, ::-1])


@pytest.fixture(scope="module")
def model():
    with MediaPipePose("right", video=False) as pose:
        yield pose


def test_the_shoulders_are_found_where_they_are(model, astronaut_bgr):
    k = model.detect(astronaut_bgr)
    # measured with MediaPipe 0.10.14, complexity 1: right shoulder (113, 240), the left
    # one (306, 257), both at visibility 0.998; a few pixels of slack for other CPUs
    assert np.allclose(k.xy_px[SHOULDER], [113, 240], atol=6)
    assert np.allclose(k.xy_px[OTHER_SHOULDER], [306, 257], atol=6)
    assert k.visibility[SHOULDER] > 0.99
    assert k.visibility[OTHER_SHOULDER] > 0.99
    # the right arm hangs down the picture: elbow below the shoulder, wrist near the edge
    assert k.xy_px[ELBOW, 1] > k.xy_px[SHOULDER, 1] + 100
    assert k.xy_px[WRIST, 1] > 440


def test_a_wrist_cut_off_by_the_edge_becomes_a_gap(model, astronaut_bgr):
    k = model.detect(astronaut_bgr)
    assert k.visibility[WRIST] < 0.5  # 0.32 measured: the hand is out of the picture
    gapped = k.gapped()
    assert np.isnan(gapped[WRIST]).all()
    assert np.isfinite(gapped[[SHOULDER, OTHER_SHOULDER]]).all()
    assert np.array_equal(gapped[SHOULDER], k.xy_px[SHOULDER])  # kept, not changed
    assert np.isnan(k.gapped(min_visibility=0.999)).all()  # nothing is sure enough


def test_the_left_arm_uses_the_other_landmarks(astronaut_bgr):
    with MediaPipePose("left", video=False) as left:
        k = left.detect(astronaut_bgr)
    assert np.allclose(k.xy_px[SHOULDER], [306, 257], atol=6)
    assert np.allclose(k.xy_px[OTHER_SHOULDER], [113, 240], atol=6)


def test_no_person_is_all_gaps(model):
    k = model.detect(np.full((480, 640, 3), 127, np.uint8))
    assert np.isnan(k.xy_px).all()
    assert (k.visibility == 0).all()
    assert np.isnan(k.gapped()).all()


def test_a_picture_that_is_not_bgr_uint8_is_refused(model):
    with pytest.raises(PoseModelError, match="H×W×3 uint8"):
        model.detect(np.zeros((48, 64), np.uint8))
    with pytest.raises(PoseModelError, match="H×W×3 uint8"):
        model.detect(np.zeros((48, 64, 3), np.float32))


def test_making_the_model_prints_nothing(capfd):
    with MediaPipePose("right") as pose:
        pose.detect(np.zeros((480, 640, 3), np.uint8))
    out, err = capfd.readouterr()
    assert out == ""
    assert err == ""


@pytest.mark.parametrize(("complexity", "name"), [(0, "lite"), (2, "heavy")])
def test_models_that_would_be_downloaded_are_refused_by_name(complexity, name):
    with pytest.raises(PoseModelError, match=rf"model_complexity={complexity} \({name} "
                                             r"model\) is not bundled.*download"):
        MediaPipePose(model_complexity=complexity)
    with pytest.raises(PoseModelError, match="does not exist"):
        check_complexity(3)
    with pytest.raises(PoseModelError, match="side"):
        MediaPipePose(side="both")


def test_the_installation_is_what_the_setup_installs():
    check_installation()
    assert importlib.metadata.version("mediapipe") == "0.10.14"
    for rival in detector.RIVAL_OPENCV:
        with pytest.raises(importlib.metadata.PackageNotFoundError):
            importlib.metadata.version(rival)


def fake_versions(versions: dict[str, str]):
    def version(name):
        if name in versions:
            return versions[name]
        raise importlib.metadata.PackageNotFoundError(name)
    return version


@pytest.mark.parametrize(("installed", "match"), [
    ({"opencv-python-headless": "5.0.0.93"}, "not installed; run scripts/setup-venv"),
    ({"mediapipe": "0.10.30", "opencv-python-headless": "5.0.0.93"},
     "needs MediaPipe 0.10.14, but 0.10.30 is installed"),
    ({"mediapipe": "0.10.14", "opencv-python-headless": "5.0.0.93",
      "opencv-contrib-python": "4.11.0.86"},
     "opencv-contrib-python is installed beside opencv-python-headless"),
    ({"mediapipe": "0.10.14"}, "opencv-python-headless is not installed"),
])
def test_a_wrong_installation_is_refused_with_what_to_do(monkeypatch, installed, match):
    monkeypatch.setattr(detector.importlib.metadata, "version", fake_versions(installed))
    with pytest.raises(PoseModelError, match=match):
        check_installation()
