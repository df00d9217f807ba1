"""Every Delsys export layout described in public sources (device/emg/delsys.py cites them),
written here by the tests themselves: the volts written come back (to the printed
precision), units come from the file, non-EMG channels are named in one note, mixed EMG
rates are resampled with a note, and every refusal is one line naming the layout."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from device.emg.files import EmgFileError, read_emg_file

TRIGNO_AVANTI_HZ = 1259.2593   # 17 / 13.5 ms, as Discover prints it
TRIGNO_QUATTRO_HZ = 2222.2222  # 30 / 13.5 ms
IMU_HZ = 148.1481
PER_VOLT = {"V": 1.0, "mV": 1e3, "µV": 1e6}


def emg(n, seed, unit="mV"):
    """Surface EMG of tens of µV, in `unit`, rounded to the 7 decimals Discover prints."""
    x = 5e-5 * np.random.default_rng(seed).standard_normal(n) * PER_VOLT[unit]
    return np.round(x, 7)


def sensor(name, mode, *channels):
    """(sensor name, mode, [(channel, unit, rate, values)])."""
    return name, mode, list(channels)


def discover_text(version, sensors, length_s, *, timed, periods=False, markers=False,
                  separator=", ", decimal="."):
    """A Trigno Discover export as the sources describe it (device/emg/delsys.py)."""
    columns = []  # (sensor cell, mode cell, name, rate cell, period cell, cells)
    for name, mode, channels in sensors:
        for k, (channel, unit, rate, values) in enumerate(channels):
            first = k == 0
            cells = [f"{v:.7f}" for v in values]
            if timed:
                times = [f"{i / rate:.7f}" for i in range(len(values))]
                columns.append((name if first else "", f"sensor mode: {mode}" if first else "",
                                f"{channel} Time Series (s)", "", "", times))
                first = False
            columns.append((name if first else "", f"sensor mode: {mode}" if first else "",
                            f"{channel} ({unit})", f"{rate:.4f} Hz", f"{1 / rate:.6f} s",
                            cells))
    rows = max(len(c[5]) for c in columns)

    def line(cells):
        return separator.join(c.replace(".", decimal) for c in cells)

    out = [f"Application:{separator}Trigno Discover ({version})",
           f"Date/Time:{separator}4/10/2026 12:13:39 PM",
           f"Collection Length (seconds):{separator}{length_s:.6f}".replace(".", decimal),
           line(c[0] for c in columns), line(c[1] for c in columns),
           separator.join(c[2] for c in columns),  # names: "ACC X Time Series (s)" keeps its dot
           line(c[3] for c in columns)]
    if periods:
        heading = [*(c[4] for c in columns)]
        if markers:
            heading += ["", "Type", "Name", "Label", "Time (s)", "", "Pair"]
        out.append(line(heading))
    for i in range(rows):
        cells = [c[5][i] if i < len(c[5]) else "" for c in columns]
        if markers and i == 0:
            cells += ["", "General", "E1", "E1", "0.5", "", ""]
        out.append(line(cells))
    return "\n".join(out) + "\n"


def basic_sensors(unit="mV", seconds=0.2):
    """Two Avanti sensors (EMG + ACC X + GYRO X), as in Discover 1.5–1.7's basic export."""
    n_emg, n_imu = round(seconds * TRIGNO_AVANTI_HZ), round(seconds * IMU_HZ)
    return [sensor("Avanti Sensor 1 (75923)", 65, ("EMG 1", unit, TRIGNO_AVANTI_HZ,
                                                   emg(n_emg, 1, unit)),
                   ("ACC X", "G", IMU_HZ, np.round(np.linspace(-1, 1, n_imu), 7)),
                   ("GYRO X", "deg/s", IMU_HZ, np.round(np.linspace(0, 9, n_imu), 7))),
            sensor("Avanti Sensor 2 (75924)", 65, ("EMG 1", unit, TRIGNO_AVANTI_HZ,
                                                   emg(n_emg, 2, unit)),
                   ("ACC X", "G", IMU_HZ, np.round(np.linspace(1, 0, n_imu), 7)))]


def written_volts(sensors):
    return np.column_stack([values / PER_VOLT[unit] for _, _, channels in sensors
                            for name, unit, _, values in channels if name.startswith("EMG")])


def write(tmp_path, text, name="export.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------------------------ Trigno Discover
@pytest.mark.parametrize("version", ["1.5.0", "1.6.4", "1.7.0"])
@pytest.mark.parametrize("unit", ["mV", "µV", "V"])
def test_discover_basic_export_reads_the_volts_written(tmp_path, version, unit):
    sensors = basic_sensors(unit)
    data = read_emg_file(write(tmp_path, discover_text(version, sensors, 0.2, timed=False)))
    assert data.source == "discover-csv"
    assert data.names == ("Avanti Sensor 1 (75923): EMG 1", "Avanti Sensor 2 (75924): EMG 1")
    assert data.rate_hz == pytest.approx(TRIGNO_AVANTI_HZ)
    np.testing.assert_allclose(data.samples, written_volts(sensors), rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(data.t_s, np.arange(data.t_s.size) / TRIGNO_AVANTI_HZ)
    skipped = [n for n in data.notes if n.startswith("skipped channels that are not EMG")]
    assert len(skipped) == 1
    assert "ACC X (G) ×2" in skipped[0]
    assert "GYRO X (deg/s)" in skipped[0]


@pytest.mark.parametrize(("version", "periods", "markers"), [
    ("1.6.4", False, False),    # Discover 1.6 with Time Series columns
    ("2.1.0.7", True, False),   # Discover 2.x: an eighth row of sample periods
    ("2.1.0.7", True, True),    # … and the marker table to the right
])
def test_discover_export_with_a_time_column_per_channel(tmp_path, version, periods, markers):
    sensors = basic_sensors()
    text = discover_text(version, sensors, 0.2, timed=True, periods=periods, markers=markers)
    data = read_emg_file(write(tmp_path, text))
    np.testing.assert_allclose(data.samples, written_volts(sensors), rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(data.t_s, np.arange(data.t_s.size) / TRIGNO_AVANTI_HZ,
                               atol=1e-7)  # the printed times
    assert sum("not EMG" in n for n in data.notes) == 1


def test_mixed_emg_rates_are_resampled_to_the_fastest_with_a_note(tmp_path):
    """Avanti EMG at 1259.26 Hz and Quattro EMG at 2222.22 Hz in one collection (as in the
    real Discover 1.7.0 file): the Avanti channel is brought to 2222.22 Hz (30/17)."""
    seconds, f = 0.5, 40.0  # a 40 Hz tone, well inside both bands
    n_slow, n_fast = round(seconds * TRIGNO_AVANTI_HZ), round(seconds * TRIGNO_QUATTRO_HZ)
    slow = np.round(0.05 * np.sin(2 * np.pi * f * np.arange(n_slow) / TRIGNO_AVANTI_HZ), 7)
    fast = [emg(n_fast, k) for k in range(2)]
    sensors = [sensor("Avanti Sensor 1 (1)", 65, ("EMG 1", "mV", TRIGNO_AVANTI_HZ, slow),
                      ("ACC X", "G", IMU_HZ, np.zeros(round(seconds * IMU_HZ)))),
               sensor("Quattro 19 01639 (79082)", 296,
                      ("EMG 1", "mV", TRIGNO_QUATTRO_HZ, fast[0]),
                      ("EMG 2", "mV", TRIGNO_QUATTRO_HZ, fast[1]))]
    data = read_emg_file(write(tmp_path, discover_text("1.7.0", sensors, seconds, timed=False)))
    assert data.rate_hz == pytest.approx(TRIGNO_QUATTRO_HZ)
    assert data.names[1:] == ("Quattro 19 01639 (79082): EMG 1", "Quattro 19 01639 (79082): EMG 2")
    np.testing.assert_allclose(data.samples[:, 1:], np.column_stack(fast) * 1e-3, rtol=1e-12)
    middle = slice(data.t_s.size // 4, 3 * data.t_s.size // 4)  # the FIR's edges aside
    tone = 0.05e-3 * np.sin(2 * np.pi * f * data.t_s[middle])
    np.testing.assert_allclose(data.samples[middle, 0], tone, atol=0.01 * 0.05e-3)
    note = [n for n in data.notes if n.startswith("resampled")]
    assert len(note) == 1
    assert "Avanti Sensor 1 (1): EMG 1 1259.26 Hz" in note[0]
    assert "2222.22 Hz" in note[0]
    assert "anti-alias" in note[0]


def test_a_semicolon_export_with_decimal_commas(tmp_path):
    sensors = basic_sensors()
    text = discover_text("2.1.0.7", sensors, 0.2, timed=True, periods=True, separator=";",
                         decimal=",")
    assert "0,0" in text
    assert ";" in text
    data = read_emg_file(write(tmp_path, text))
    np.testing.assert_allclose(data.samples, written_volts(sensors), rtol=1e-12, atol=1e-18)
    assert data.rate_hz == pytest.approx(TRIGNO_AVANTI_HZ)


# ------------------------------------------------------------------ EMGworks
def emgworks_text(channels, separator=",", decimal="."):
    """An EMGworks export without 'Label:' lines (praneethnamburi/delsys's fixture): X[s]
    before each "sensor: channel", volts in E-notation, slower columns ending early."""
    header = separator.join(f'X[s]{separator}"{name}"' for name, _, _ in channels)
    rows = max(len(v) for _, _, v in channels)
    lines = [header]
    for i in range(rows):
        cells = []
        for _, rate, v in channels:
            cells += ([f"{i / rate:.10g}", f"{v[i]:.7G}"] if i < len(v) else ["", ""])
        lines.append(separator.join(c.replace(".", decimal) for c in cells))
    return "\n".join(lines) + "\n"


def test_emgworks_without_label_lines_reads_volts_and_resamples_mixed_rates(tmp_path):
    rate_a, rate_b = 1925.9259, TRIGNO_AVANTI_HZ  # 26/13.5 ms and 17/13.5 ms: ratio 26/17
    a = np.array([float(f"{x:.7G}") for x in emg(400, 3, "V")])
    b = np.array([float(f"{x:.7G}") for x in emg(round(400 * rate_b / rate_a), 4, "V")])
    text = emgworks_text([("Avanti sensor 1: EMG 1", rate_a, a),
                          ("Avanti sensor 1: ACC.X 1", IMU_HZ, np.zeros(31)),
                          ("Avanti sensor 2: EMG 2", rate_b, b)])
    data = read_emg_file(write(tmp_path, text))
    assert data.source == "emgworks-csv"
    assert data.names == ("Avanti sensor 1: EMG 1", "Avanti sensor 2: EMG 2")
    assert data.rate_hz == pytest.approx(rate_a, rel=1e-6)
    np.testing.assert_array_equal(data.samples[:, 0], a[:data.t_s.size])
    assert any("ACC.X 1" in n for n in data.notes)
    assert any("volts were taken" in n for n in data.notes)
    assert any(n.startswith("resampled") and "Avanti sensor 2: EMG 2" in n for n in data.notes)


@pytest.mark.parametrize("separator", [",", ";"])
def test_emgworks_with_label_lines_in_both_separators(tmp_path, separator):
    decimal = "," if separator == ";" else "."
    x = np.round(np.array([[1.5, -2.25], [3.0, 0.125], [-0.5, 4.0]]), 7)
    text = ("Label: EMG1 Sampling frequency: 2000 Unit: mV Domain: Time\n"
            "Label: EMG2 Sampling frequency: 2000 Unit: µV Domain: Time\n\n"
            + separator.join(["X[s]", "EMG1", "X[s]", "EMG2"]) + "\n"
            + "".join(separator.join(c.replace(".", decimal) for c in
                                     [f"{k / 2000:.6f}", f"{r[0]}", f"{k / 2000:.6f}", f"{r[1]}"])
                      + "\n" for k, r in enumerate(x)))
    data = read_emg_file(write(tmp_path, text))
    np.testing.assert_allclose(data.samples, x * [1e-3, 1e-6], rtol=1e-15)


def emgworks_analysis_text(channels, unit="V", rows=None):
    """An EMGworks export as its Label lines are really written (neuromechanist/emgio,
    examples/truncated_trigno_sample.csv, a truncated real export of Trigno Mini sensors):
    `… Number of points: N start: 0.000000e+000 Unit: V Domain Unit: s`, gyroscopes in
    `°/s`, 'Start/Stop Trigger Method' lines and a blank line before the quoted header,
    Windows line ends."""
    labels = []
    for name, rate, values in channels:
        u = unit if "EMG" in name else ("°/s" if "GYRO" in name else "g")
        labels.append(f"Label: {name} Sampling frequency: {rate:.6e} Number of points: "
                      f"{len(values)} start: 0.000000e+000 Unit: {u} Domain Unit: s")
    lines = [*labels, "Start Trigger Method: None", "Stop Trigger Method: None", ""]
    lines.append(",".join(f'X[s],"{name}"' for name, _, _ in channels))
    for i in range(max(len(v) for _, _, v in channels)):
        cells = []
        for _, rate, v in channels:
            cells += [f"{i / rate:.7g}", f"{v[i]:.7g}"] if i < len(v) else ["", ""]
        lines.append(",".join(cells))
    return "\r\n".join(lines) + "\r\n"


@pytest.mark.parametrize("bom", [False, True])  # Windows tools may write UTF-8 with a BOM
@pytest.mark.parametrize(("unit", "per_volt"), [("V", 1.0), ("Volts", 1.0), ("mV", 1e3)])
def test_emgworks_label_lines_as_emgworks_writes_them(tmp_path, unit, per_volt, bom):
    """'Domain Unit: s' (not 'Domain: Time'), trigger lines before the header: the real
    layout was refused at line 1. 'Volts' is what a Chinese lab's export says (a public
    reader's comment: 'Label: 2左股直 10: EMG 10 (IM) Sampling frequency: 2.000000e+003
    Number of points: 58000 start: 0.000000e+000 Unit: Volts Domain Unit: s')."""
    rate = 1.259259e3
    a, b = emg(300, 1, "V") * per_volt, emg(300, 2, "V") * per_volt
    channels = [("Mini sensor 10: EMG 10", rate, a),
                ("Mini sensor 10: ACC.X 10", IMU_HZ, np.zeros(36)),
                ("Mini sensor 10: GYRO.X 10", IMU_HZ, np.zeros(36)),
                ("Mini sensor 11: EMG 11", rate, b)]
    path = write(tmp_path, emgworks_analysis_text(channels, unit))
    if bom:
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    data = read_emg_file(path)
    assert data.source == "trigno-csv"
    assert data.names == ("Mini sensor 10: EMG 10", "Mini sensor 11: EMG 11")
    assert data.rate_hz == pytest.approx(rate)
    np.testing.assert_allclose(data.samples, np.column_stack([a, b]) / per_volt,
                               rtol=1e-6, atol=1e-18)
    assert data.t_s[-1] == pytest.approx(299 / rate, rel=1e-6)
    assert any("ACC.X 10 (g)" in n and "GYRO.X 10 (°/s)" in n for n in data.notes)


def test_a_comma_export_whose_sensor_name_holds_a_semicolon(tmp_path):
    """A sensor named by the lab "Biceps; left" does not make a comma export a ';' one."""
    sensors = basic_sensors()
    sensors[0] = ("Biceps; left (75923)", *sensors[0][1:])
    data = read_emg_file(write(tmp_path, discover_text("1.7.0", sensors, 0.2, timed=False)))
    assert data.names[0] == "Biceps; left (75923): EMG 1"
    np.testing.assert_allclose(data.samples, written_volts(sensors), rtol=1e-12, atol=1e-18)


def test_an_emgworks_export_in_windows_1252(tmp_path):
    """'µV' written by a Windows PC in its code page (byte 0xB5), not UTF-8."""
    path = tmp_path / "cp1252.csv"
    path.write_bytes("Label: EMG1 Sampling frequency: 2000 Unit: µV Domain: Time\n"
                     "X[s],EMG1\n0,12.5\n0.0005,-3.25\n".encode("cp1252"))
    data = read_emg_file(path)
    np.testing.assert_allclose(data.samples[:, 0], [12.5e-6, -3.25e-6])
    assert "read as Windows-1252 text (the file is not UTF-8)" in data.notes


def test_a_plain_semicolon_file_with_decimal_commas(tmp_path):
    data = read_emg_file(write(tmp_path, "time;biceps [mV]\n0,000;1,5\n0,001;-2,25\n"))
    np.testing.assert_allclose(data.samples[:, 0], [1.5e-3, -2.25e-3])


# ------------------------------------------------------------------ refusals
def discover_with(tmp_path, edit, version="2.1.0.7", timed=True, periods=True):
    text = discover_text(version, basic_sensors(seconds=0.05), 0.05, timed=timed,
                         periods=periods)
    return write(tmp_path, edit(text))


def replace_line(k, new):
    return lambda text: "\n".join(new if i == k else line
                                  for i, line in enumerate(text.split("\n")))


REFUSED = {
    "discover_1_4": (
        lambda t: write(t, "Application:, Trigno Discover (1.4.2)\nDate/Time:, 4/12/2022\n"
                           "Collection Length (seconds):, 0.001\nEMG 01 (54717), \n"
                           "sensor mode: 55, \nEMG 1 (1259Hz), ACC X (148Hz)\n"
                           "-0.039, -0.16\n-0.037, -0.15\n"),
        "a Trigno Discover 1.4.2 export (Discover 1.4 layout, rates in the channel names"),
    "emg_not_a_voltage": (
        lambda t: discover_with(t, lambda s: s.replace("EMG 1 (mV)", "EMG 1 (%)", 1)),
        "a Trigno Discover 2.1.0.7 export with a time column per channel: line 6: "
        "Avanti Sensor 1 (75923): EMG 1 is in '%', not a voltage"),
    "no_emg": (
        lambda t: discover_with(t, lambda s: s.replace("EMG 1 (mV)", "Analog 1 (V)")),
        "a Trigno Discover 2.1.0.7 export with a time column per channel: no EMG channel "
        "(only Analog 1 (V) ×2, ACC X (G) ×2, GYRO X (deg/s))"),
    "no_length": (
        lambda t: discover_with(t, replace_line(2, "Length:, 0.05")),
        "a Trigno Discover 2.1.0.7 export: line 3 is 'Length:,0.05', expected "
        "'Collection Length (seconds):, …'"),
    "bad_rate": (
        lambda t: discover_with(t, lambda s: s.replace(", 1259.2593 Hz", ", fast", 1)),
        "a Trigno Discover 2.1.0.7 export with a time column per channel: line 7, column 2: "
        "'fast' is not the rate of Avanti Sensor 1 (75923): EMG 1"),
    "time_without_value": (
        lambda t: discover_with(t, replace_line(9, "0.0007941, , " + ", ".join(["1"] * 8))),
        "a Trigno Discover 2.1.0.7 export with a time column per channel: line 10: "
        "Avanti Sensor 1 (75923): EMG 1 has a time but no value"),
    "not_a_number": (
        lambda t: discover_with(t, lambda s: s.replace("\n0.0007941, ", "\n0.0007941x, ", 1)),
        "a Trigno Discover 2.1.0.7 export with a time column per channel: line 10, column "
        "'Avanti Sensor 1 (75923): EMG 1 time': '0.0007941x' is not a number"),
    "basic_cut": (
        lambda t: discover_with(t, lambda s: s.replace("Collection Length (seconds):, 0.050000",
                                                       "Collection Length (seconds):, 5.0"),
                                version="1.7.0", timed=False, periods=False),
        "a Trigno Discover 1.7.0 export without time columns: Avanti Sensor 1 (75923): EMG 1 "
        "has 63 samples; the collection length and its rate say 6296"),
    "rates_not_whole_ratio": (
        lambda t: discover_with(t, lambda s: s.replace("1259.2593 Hz", "1259.0000 Hz", 1)
                                .replace("1259.2593 Hz", "1258.7000 Hz", 1),
                                version="1.7.0", timed=False, periods=False),
        "the EMG rates 1258.7 Hz (Avanti Sensor 2 (75924): EMG 1) and 1259 Hz (Avanti Sensor "
        "1 (75923): EMG 1) are not in a ratio of whole numbers"),
    "emgworks_gap": (
        lambda t: write(t, emgworks_text([("S1: EMG 1", 2000.0, np.ones(5)),
                                          ("S1: ACC.X 1", 100.0, np.ones(2))])
                        .replace("\n0.0015,1", "\n,")),
        "an EMGworks export without 'Label:' lines: line 6: S1: EMG 1 has a sample after its "
        "column ended (line 5)"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_each_refusal_is_one_line_naming_the_layout(tmp_path, case):
    make, expected = REFUSED[case]
    path = make(tmp_path)
    with pytest.raises(EmgFileError) as info:
        read_emg_file(path)
    message = str(info.value)
    assert message.startswith(f"EMG file {path}: ")
    assert expected in message
    assert "\n" not in message
    assert "not the time" not in message  # the old refusal that misled


def test_the_rehab_cli_imports_a_discover_export_into_a_trial(tmp_path, capsys, monkeypatch):
    """End to end: `rehab emg import TRIAL FILE` with a Discover 2.x export."""
    from app.trials.headless import save, simulate
    from core.trial import THESIS_SUBJECT
    from device.recording.emgfile import read_emg
    from tests.app.cli.running import run

    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    trial = tmp_path / "t.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), trial)
    sensors = basic_sensors(seconds=2.0)
    export = write(tmp_path, discover_text("2.1.0.7", sensors, 2.0, timed=True, periods=True,
                                           markers=True))
    code, out, err = run(["emg", "import", str(trial), str(export),
                          "--muscles", "biceps,triceps"], capsys)
    assert code == 0, err
    assert "stored 2 EMG channels (biceps, triceps) at 1259.26 Hz" in out
    assert "ACC X (G) ×2" in out
    stored = read_emg(trial)
    np.testing.assert_allclose(stored.samples, written_volts(sensors), rtol=1e-12, atol=1e-18)
    shutil.rmtree(tmp_path / "data", ignore_errors=True)


def test_the_sample_files_in_tests_data_still_read():
    data_dir = Path(__file__).parents[1] / "data" / "emg"
    assert read_emg_file(data_dir / "trigno_export.csv").source == "trigno-csv"
    assert read_emg_file(data_dir / "plain.csv").source == "csv"


# ------------------------------------------------------------------ any collection
TRIGNO_EMG_HZ = (TRIGNO_AVANTI_HZ, 1925.9259, 2148.1481, TRIGNO_QUATTRO_HZ)  # k / 13.5 ms


@st.composite
def collections(draw):
    """A Discover collection as the sources show them: 1–3 sensors, each with 1–4 EMG
    channels (a Quattro has 4) in one unit at one of the Trigno EMG rates, 0–3 IMU or
    analog channels, any version and layout, either separator."""
    version = draw(st.sampled_from(["1.5.0", "1.6.4", "1.7.0", "2.1.0.7"]))
    timed = version.startswith("2") or (version == "1.6.4" and draw(st.booleans()))
    seconds = draw(st.sampled_from([0.02, 0.05, 0.1]))
    sensors = []
    for s in range(draw(st.integers(1, 3))):
        unit = draw(st.sampled_from(list(PER_VOLT)))
        rate = draw(st.sampled_from(TRIGNO_EMG_HZ))
        n = round(seconds * rate)
        channels = [(f"EMG {k + 1}", unit, rate, emg(n, draw(st.integers(0, 99)), unit))
                    for k in range(draw(st.integers(1, 4)))]
        others = draw(st.lists(st.sampled_from([("ACC Y", "G", IMU_HZ), ("GYRO Z", "deg/s",
                                                                           IMU_HZ),
                                                ("Analog 1", "V", 2222.2222)]), max_size=3))
        channels += [(name, u, r, np.round(np.linspace(0, 1, round(seconds * r)), 7))
                     for name, u, r in others]
        sensors.append(sensor(f"Sensor {s + 1} ({70000 + s})", 55, *channels))
    separator = draw(st.sampled_from([", ", ";"]))
    text = discover_text(version, sensors, seconds, timed=timed, periods=version.startswith("2"),
                         separator=separator, decimal="," if separator == ";" else ".")
    return sensors, text


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(collection=collections())
def test_any_discover_collection_keeps_its_fastest_emg_exactly(tmp_path, collection):
    """Whatever the sensors, units, rates, layout and separator: the EMG channels at the
    fastest EMG rate come back as the volts written, the others resampled to that rate
    with one note naming them, the non-EMG channels named in one note."""
    sensors, text = collection
    data = read_emg_file(write(tmp_path, text))
    emg_channels = [(f"{name}: {channel}", rate, values / PER_VOLT[unit])
                    for name, _, channels in sensors
                    for channel, unit, rate, values in channels if channel.startswith("EMG")]
    top = max(rate for _, rate, _ in emg_channels)
    assert data.names == tuple(name for name, _, _ in emg_channels)
    assert data.rate_hz == pytest.approx(top)
    for k, (name, rate, volts) in enumerate(emg_channels):
        if rate == top:
            np.testing.assert_allclose(data.samples[:, k], volts[:data.t_s.size], rtol=1e-12,
                                       atol=1e-18, err_msg=name)
    slower = [name for name, rate, _ in emg_channels if rate != top]
    resampled = [n for n in data.notes if n.startswith("resampled")]
    assert len(resampled) == (1 if slower else 0)
    assert all(name in resampled[0] for name in slower)
    assert sum(n.startswith("skipped channels") for n in data.notes) <= 1


TOKENS = ["", ",", ";", "\n", "1e308", "inf", "nan", "-1", "0", " Hz", " s", "(", ")", "EMG",
          "X[s]", " Time Series (s)", "Application:", "1e-300", '"', "µV", "Label: "]


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(collection=collections(), edits=st.lists(
    st.tuples(st.floats(0, 1), st.sampled_from(["insert", "delete", "replace"]),
              st.sampled_from(TOKENS), st.integers(1, 20)), min_size=1, max_size=4))
def test_a_damaged_export_is_read_or_refused_in_one_line(tmp_path, collection, edits):
    """Cells cut, doubled or replaced anywhere in any layout: EMG read, or one line
    naming the file; never a traceback (3,000 such files by hand: 0 tracebacks)."""
    text = collection[1]
    for where, how, token, width in edits:
        k = int(where * len(text))
        text = (text[:k] + token + text[k:] if how == "insert" else
                text[:k] + text[k + width:] if how == "delete" else
                text[:k] + token + text[k + width:])
    path = write(tmp_path, text)
    try:
        data = read_emg_file(path)
    except EmgFileError as exc:
        refusal = str(exc)
    else:
        assert np.isfinite(data.samples).all()
        assert (np.diff(data.t_s) > 0).all()
        return
    assert "\n" not in refusal
    assert refusal.startswith(f"EMG file {path}: ")


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(start=st.sampled_from([0.0, 12.5, 999.9, 1000.0, 2345.678, 9000.0]),
       rate=st.sampled_from([1259.259259, 1925.925926, 2222.222222]),
       n=st.integers(2, 300), labels=st.booleans())
def test_times_printed_to_seven_digits_read_at_any_point_of_a_long_recording(
        tmp_path, start, rate, n, labels):
    """EMGworks prints times as %.7g: from 1000 s on, to the millisecond, so consecutive
    samples print the same time, and an export of a long recording (or of its part from
    1000 s on, 'start: 1.000000e+003') was refused: 'the time goes back or stands
    still'."""
    true = start + np.arange(n) / rate
    x = np.round(emg(n, n, "V"), 12)
    name = "Trigno IM sensor 1: EMG 1 (IM)"
    head = ([f"Label: {name} Sampling frequency: {rate:.6e} Number of points: {n} start: "
             f"{start:.6e} Unit: Volts Domain Unit: s", "Start Trigger Method: None", ""]
            if labels else [])
    rows = [f"{t:.7g},{v:.7g}" for t, v in zip(true, x, strict=True)]
    path = write(tmp_path, "\r\n".join([*head, f'X[s],"{name}"', *rows]) + "\r\n",
                 f"late{n}.csv")
    data = read_emg_file(path)
    assert np.all(np.diff(data.t_s) > 0)
    digit = 10.0 ** (np.floor(np.log10(np.maximum(true, 1e-300))) - 6)
    assert np.all(np.abs(data.t_s - true) <= digit + 0.1 / rate)
    np.testing.assert_allclose(data.samples[:, 0], [float(f"{v:.7g}") for v in x])
