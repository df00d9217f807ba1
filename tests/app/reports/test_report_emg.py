"""The report of a trial with EMG has a third page: each muscle's % MVC envelope above the
joint torques, and each MVC's quality in words."""

import shutil

import numpy as np
import pytest
from pypdf import PdfReader

from app.emg.session import Contraction, session_mvc
from app.emg.subjects import Subject, record_trial, write_contractions
from app.reports.build import write_report_pdf
from app.reports.content import build_report
from app.trials.reader import read_trial
from tests.trialfiles import edited


@pytest.fixture(scope="module")
def subject_2(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report_emg")
    subject = Subject.drawn(2, bad_mvc={"anterior_deltoid": 0.08})
    synthetic = record_trial(folder / "P1_S001_T001.h5", subject, seed=0, engine="python")
    contractions = write_contractions(folder, subject, session=1)
    session_mvc([synthetic.path], [Contraction(m, p, ch) for m, (p, ch) in contractions.items()])
    return synthetic.path, folder


def test_a_trial_with_emg_reports_its_envelopes_and_the_bad_mvc(subject_2):
    path, folder = subject_2
    content = build_report(read_trial(path))
    emg = content.emg
    assert emg is not None
    assert emg.muscles == ("biceps", "triceps", "anterior_deltoid")
    assert emg.percent.shape == (emg.t_s.size, 3)
    assert emg.t_s[0] == pytest.approx(0.0, abs=0.01)  # from the exercise's start
    assert np.nanmax(emg.percent[:, 2]) > 80.0  # the bad MVC reads as most of an MVC
    assert emg.quality[0] == "biceps brachii: MVC sound"
    assert "not a maximal effort" in emg.quality[2]
    pdf = PdfReader(write_report_pdf(content, folder / "report.pdf"))
    assert len(pdf.pages) == 3
    text = pdf.pages[2].extract_text()
    assert "Muscle activity (surface EMG)" in text
    assert "record it again" in text


def test_the_emg_page_names_the_muscles_as_the_emg_tab_does(subject_2):
    """The page said 'biceps' and 'anterior deltoid: MVC …' where the EMG tab says 'biceps
    brachii': both name them by app.emg.muscle_words, the one map of muscle names."""
    from app.emg.muscle_words import words

    path, folder = subject_2
    content = build_report(read_trial(path))
    assert content.emg.names == tuple(words(m) for m in content.emg.muscles)
    assert content.emg.names[:2] == ("biceps brachii", "triceps brachii")
    text = " ".join(PdfReader(write_report_pdf(content, folder / "names.pdf")).pages[2]
                    .extract_text().split())
    for name in content.emg.names:
        assert f"{name}: MVC" in text


def test_a_trial_without_mvc_has_no_emg_page(subject_2, tmp_path):
    path, _ = subject_2
    bare = shutil.copy(path, tmp_path / "P1_S001_T002.h5")
    with edited(bare) as f:
        del f["emg/mvc"]
    content = build_report(read_trial(bare))
    assert content.emg is None
    assert len(PdfReader(write_report_pdf(content, tmp_path / "r.pdf")).pages) == 2
