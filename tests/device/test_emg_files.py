"""EMG files: the Trigno CSV export and the plain CSV, the sample files in tests/data/emg,
and every malformed file refused with one clear line."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from core.emg.synthetic import TRIGNO_RATE_HZ
from device.emg.files import (
    EmgFileError,
    read_emg_file,
    read_plain_csv,
    read_trigno_csv,
    write_plain_csv,
    write_trigno_csv,
)

DATA = Path(__file__).parents[1] / "data" / "emg"
LABELS = ("Label: EMG1 Sampling frequency: 2000 Unit: V Domain: Time\n"
          "Label: EMG2 Sampling frequency: 2000 Unit: mV Domain: Time\n")


def test_the_trigno_sample_export_reads_its_emg_and_skips_the_accelerometer():
    data = read_emg_file(DATA / "trigno_export.csv")
    assert data.source == "trigno-csv"
    assert data.names == ("EMG1", "EMG2", "EMG3")
    assert data.rate_hz == pytest.approx(TRIGNO_RATE_HZ)
    assert data.samples.shape == (data.t_s.size, 3)
    assert data.t_s[0] == 0.0
    np.testing.assert_allclose(np.diff(data.t_s), 1 / TRIGNO_RATE_HZ, atol=1e-6)
    assert any("ACC1.X" in note for note in data.notes)
    # surface EMG of a fraction of MVC: tens to hundreds of µV
    assert (data.samples.std(axis=0) > 1e-5).all()
    assert (data.samples.std(axis=0) < 1e-3).all()


def test_the_plain_sample_file_reads_millivolts_as_volts():
    data = read_emg_file(DATA / "plain.csv")
    assert data.source == "csv"
    assert data.names == ("biceps", "triceps", "anterior_deltoid")
    assert data.rate_hz == pytest.approx(1000.0, rel=1e-9)
    first = (DATA / "plain.csv").read_text().splitlines()[2].split(",")
    np.testing.assert_allclose(data.samples[0], [float(v) * 1e-3 for v in first[1:]])


def test_written_files_read_back(tmp_path):
    rng = np.random.default_rng(0)
    x = 1e-4 * rng.standard_normal((500, 2))
    t = np.arange(500) / 2000.0
    back = read_trigno_csv(write_trigno_csv(tmp_path / "a.csv", ("L", "R"), 2000.0, x))
    np.testing.assert_allclose(back.samples, x, rtol=1e-8)
    np.testing.assert_allclose(back.t_s, t, atol=1e-6)
    back = read_plain_csv(write_plain_csv(tmp_path / "b.csv", ("L", "R"), t, x))
    np.testing.assert_allclose(back.samples, x, rtol=1e-8)
    assert back.rate_hz == pytest.approx(2000.0)


def test_trigno_units_are_converted_to_volts(tmp_path):
    path = tmp_path / "units.csv"
    path.write_text(LABELS + "X[s],EMG1,X[s],EMG2\n0,0.001,0,1.0\n0.0005,0.002,0.0005,2.0\n")
    data = read_emg_file(path)
    np.testing.assert_allclose(data.samples, [[0.001, 0.001], [0.002, 0.002]])


MALFORMED_TRIGNO = {
    "no_frequency": ("Label: EMG1 Unit: V Domain: Time\nX[s],EMG1\n0,1\n",
                     "line 1: not a Trigno channel line"),
    "bad_frequency": ("Label: EMG1 Sampling frequency: -5 Unit: V Domain: Time\nX[s],EMG1\n0,1\n",
                      "sampling frequency '-5' of EMG1 is not a rate"),
    "no_header": ("Label: EMG1 Sampling frequency: 2000 Unit: V Domain: Time\n\n",
                  "no header row"),
    "header_count": (LABELS + "X[s],EMG1,X[s]\n0,1,0\n", "the header has 3 columns, expected 4"),
    # EMGworks can export one time column for all channels (bensenderling/DAMVi_App
    # load_csv_Delsys.m: "a time column to be located only in the first column")
    "one_time_column": (LABELS + "X[s],EMG1,EMG2\n0,1,2\n0.0005,1,2\n",
                        "expected 4 (a time column X[s] and a value column for each of the 2 "
                        "channels). Export it again from EMGworks with a time column for each "
                        "channel"),
    "header_time": (LABELS + "X[s],EMG1,time,EMG2\n0,1,0,1\n", "expected the time column 'X[s]'"),
    "not_number": (LABELS + "X[s],EMG1,X[s],EMG2\n0,1,0,1\n0.0005,abc,0.0005,1\n",
                   "line 5, column 'EMG1': 'abc' is not a number"),
    "missing_cell": (LABELS + "X[s],EMG1,X[s],EMG2\n0,1,0,1\n0.0005,1,,\n0.001,1,0.001,1\n",
                     "line 6: EMG2 has a sample after its column ended (line 5)"),
    "value_without_time": (LABELS + "X[s],EMG1,X[s],EMG2\n0,1,0,1\n0.0005,1,,1\n",
                           "line 5: EMG2 has a value but no time"),
    "time_back": (LABELS + "X[s],EMG1,X[s],EMG2\n0,1,0,1\n0.001,1,0.001,1\n0.0005,1,0.0005,1\n",
                  "the time goes back or stands still at sample 2"),
    "clocks_differ": (LABELS + "X[s],EMG1,X[s],EMG2\n0,1,0,1\n0.0005,1,0.003,1\n",
                      "the time of EMG2 (0.003 s) differs"),
    "no_emg": ("Label: ACC1.X Sampling frequency: 148 Unit: g Domain: Time\nX[s],ACC1.X\n0,1\n",
               "no EMG channel"),
    # different EMG rates are resampled (tests/device/test_delsys_layouts.py), unless they
    # are not in a ratio of whole numbers
    "rates_differ": ("Label: EMG1 Sampling frequency: 2000 Unit: V Domain: Time\n"
                     "Label: EMG2 Sampling frequency: 1999.3 Unit: V Domain: Time\n"
                     "X[s],EMG1,X[s],EMG2\n0,1,0,1\n0.0005,1,0.0005,1\n",
                     "are not in a ratio of whole numbers"),
    "one_sample": (LABELS + "X[s],EMG1,X[s],EMG2\n0,1,0,1\n", "1 samples"),
    "infinite": (LABELS + "X[s],EMG1,X[s],EMG2\n0,inf,0,1\n0.0005,1,0.0005,1\n", "not finite"),
}

MALFORMED_PLAIN = {
    "no_time": ("biceps,triceps\n1,2\n", "the first column is 'biceps', not the time"),
    "only_time": ("time\n0\n0.001\n", "no EMG column after the time"),
    "bad_unit": ("time,biceps [N]\n0,1\n0.001,1\n", "column 'biceps' is in 'N', not a voltage"),
    "duplicate": ("time,b,b\n0,1,1\n0.001,1,1\n", "two columns share one name"),
    "ragged": ("time,a,b\n0,1,1\n0.001,1\n", "line 3: 2 cells, the header has 3"),
    "not_number": ("time,a\n0,1\n0.001,x\n", "line 3, column 'a': 'x' is not a number"),
    "gap": ("time,a\n" + "".join(f"{k * 0.001:.3f},1\n" for k in range(10)) + "1.0,1\n",
            "a gap of"),
    "not_increasing": ("time,a\n0,1\n0.001,1\n0.001,1\n", "not increasing"),
    "too_short": ("time,a\n0,1\n", "1 samples"),
    "comments_only": ("# nothing here\n", "has only comments"),
    "unnamed": ("time, [mV]\n0,1\n0.001,1\n", "a column has no name"),
}


def _refused_in_one_line(tmp_path, case: str, text: str):
    """(the file, its refusal) of `text` written as the file `case`.csv and read: refused
    with EmgFileError, in one line."""
    path = tmp_path / f"{case}.csv"
    path.write_text(text)
    with pytest.raises(EmgFileError) as info:
        read_emg_file(path)
    message = str(info.value)
    assert "\n" not in message
    return path, message


@pytest.mark.parametrize("case", sorted(MALFORMED_TRIGNO))
def test_malformed_trigno_exports_are_one_clear_line(tmp_path, case):
    text, expected = MALFORMED_TRIGNO[case]
    path, message = _refused_in_one_line(tmp_path, case, text)
    assert expected in message
    assert message.startswith(f"EMG file {path}")


@pytest.mark.parametrize("case", sorted(MALFORMED_PLAIN))
def test_malformed_plain_files_are_one_clear_line(tmp_path, case):
    text, expected = MALFORMED_PLAIN[case]
    assert expected in _refused_in_one_line(tmp_path, case, text)[1]


def test_files_that_are_not_there_or_not_text(tmp_path):
    with pytest.raises(EmgFileError, match="no such file"):
        read_emg_file(tmp_path / "missing.csv")
    with pytest.raises(EmgFileError, match="is a folder"):
        read_emg_file(tmp_path)
    (tmp_path / "empty.csv").write_text("\n\n")
    with pytest.raises(EmgFileError, match="is empty"):
        read_emg_file(tmp_path / "empty.csv")
    (tmp_path / "binary.csv").write_bytes(b"\xff\xfe\x00\x81binary")
    with pytest.raises(EmgFileError, match="not a text file"):
        read_emg_file(tmp_path / "binary.csv")


MICROVOLTS_AS_VOLTS = {
    # EMG software that writes µV and no unit (a plain CSV: volts were taken)
    "plain_no_unit": ("time,biceps,triceps\n0,12.5,-3.1\n0.0005,-48.25,7.5\n0.001,3.0,1.0\n",
                      "biceps reaches 48.25 V", "no unit in its name, so volts were taken"),
    # the unit said wrong by hand: µV numbers under [V]
    "plain_said_volts": ("time,biceps [V]\n0,0.5\n0.0005,-187\n0.001,3\n",
                         "biceps reaches 187 V", "in V as its name says"),
    # an EMGworks export without Label lines names no unit; µV numbers there
    "emgworks_plain": ('X[s],"Avanti sensor 1: EMG 1"\n0,-71.5\n0.0005,20\n0.001,3\n',
                       "Avanti sensor 1: EMG 1 reaches 71.5 V",
                       "the export names no unit, so volts were taken"),
}


@pytest.mark.parametrize("case", sorted(MICROVOLTS_AS_VOLTS))
def test_microvolts_read_as_volts_are_refused_not_stored(tmp_path, case):
    """Surface EMG is never 1 V at an amplifier's input (Trigno ±11 mV, BrainAmp and
    LiveAmp at most a few hundred mV): a column that reaches it holds µV or mV numbers
    read as volts, which the file used to store as they were (a 50 V biceps), and % MVC
    against a live MVC in volts came out a million times too high."""
    text, peak, why = MICROVOLTS_AS_VOLTS[case]
    message = _refused_in_one_line(tmp_path, case, text)[1]
    assert peak in message
    assert why in message
    assert "[uV]" in message or "µV" in message


def test_emg_up_to_one_volt_still_reads(tmp_path):
    path = tmp_path / "big.csv"
    path.write_text("time,biceps [V]\n0,1\n0.0005,-1\n0.001,0.011\n")
    np.testing.assert_array_equal(read_emg_file(path).samples[:, 0], [1, -1, 0.011])


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.lists(st.floats(-5.0, 5.0, allow_nan=False), min_size=2, max_size=2),
                min_size=2, max_size=12),
       st.sampled_from(["V", "mV", "uV"]))
def test_a_file_reads_exactly_when_no_sample_reaches_a_volt(tmp_path, rows, unit):
    """Read back, in volts, when every sample is within ±1 V after its unit; otherwise
    refused in one line naming the first column that is beyond."""
    scale = {"V": 1.0, "mV": 1e-3, "uV": 1e-6}[unit]
    path = tmp_path / "any.csv"
    path.write_text(f"time,a [{unit}],b [{unit}]\n"
                    + "".join(f"{k * 0.001:.3f},{x!r},{y!r}\n" for k, (x, y) in enumerate(rows)))
    volts = np.array(rows) * scale
    beyond = [name for c, name in enumerate("ab") if np.max(np.abs(volts[:, c])) > 1.0]
    if not beyond:
        np.testing.assert_array_equal(read_emg_file(path).samples, volts)
        return
    with pytest.raises(EmgFileError) as refused:
        read_emg_file(path)
    assert f": {beyond[0]} reaches " in str(refused.value)
    assert "\n" not in str(refused.value)
