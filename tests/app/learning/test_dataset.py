"""The dynamics data file: written, read back, and every bad file refused in one line."""

import h5py
import numpy as np
import pytest

from app.learning.dataset import Dataset, DatasetError, read_dataset, write_dataset
from app.learning.workflow import held_out, make_pendulum_file


def small(n=12, dof=2):
    rng = np.random.default_rng(0)
    arrays = [rng.normal(size=(n, dof)) for _ in range(4)]
    return Dataset(*arrays, np.repeat(np.arange(3), n // 3), "my-rig", ("a", "b")[:dof],
                   ("Fa", "Fb")[:dof], {"note": "bench"})


def test_round_trip(tmp_path):
    data = small()
    back = read_dataset(write_dataset(tmp_path / "d.h5", data))
    for name in ("q", "qd", "qdd", "tau", "cycle"):
        np.testing.assert_array_equal(getattr(back, name), getattr(data, name))
    assert (back.system, back.coordinates, back.forces) == ("my-rig", ("a", "b"), ("Fa", "Fb"))
    assert back.description == {"note": "bench"}


def test_pendulum_file_is_the_thesis_data_set(tmp_path):
    data = make_pendulum_file(tmp_path / "p.h5")
    back = read_dataset(tmp_path / "p.h5")
    assert len(back) == 101_000
    assert back.system == "sliding-inverted-pendulum"
    assert back.forces == ("f", "tau")
    assert back.coordinates == ("x1", "theta2")
    assert held_out(back).sum() == 101
    np.testing.assert_array_equal(back.qd[held_out(back), 1], 5.0)
    with h5py.File(tmp_path / "p.h5") as f:  # plain h5py reads it: the documented layout
        assert f["tau"].dtype == np.float64
        assert f["tau"].shape == (101_000, 2)
        assert f["cycle"].shape == (101_000,)
    np.testing.assert_array_equal(back.tau, data.tau)


def test_a_researchers_own_file_without_names(tmp_path):
    """Only q, qd, qdd, tau, cycle and `system` are needed; names default to q1…, tau1…"""
    with h5py.File(tmp_path / "own.h5", "w") as f:
        for name in ("q", "qd", "qdd", "tau"):
            f[name] = np.ones((5, 3))
        f["cycle"] = np.zeros(5, dtype=np.int32)
        f.attrs["system"] = "three-link"
    data = read_dataset(tmp_path / "own.h5")
    assert data.forces == ("tau1", "tau2", "tau3")
    assert data.dof == 3


def bad_file(path, change):
    with h5py.File(path, "w") as f:
        for name in ("q", "qd", "qdd", "tau"):
            f[name] = np.ones((6, 2))
        f["cycle"] = np.zeros(6, dtype=np.int64)
        f.attrs["system"] = "x"
        change(f)
    return path


def _replace(f, name, value):
    del f[name]
    f[name] = value


@pytest.mark.parametrize(("change", "message"), [
    (lambda f: f.__delitem__("qdd"), "has no dataset qdd"),
    (lambda f: f.attrs.__delitem__("system"), "has no 'system' attribute"),
    (lambda f: _replace(f, "tau", np.ones((5, 2))), r"'tau' has shape \(5, 2\), 'q' has"),
    (lambda f: _replace(f, "q", np.ones(6)), r"'q' has shape \(6,\), not \(N, n\)"),
    (lambda f: _replace(f, "qd", np.full((6, 2), np.nan)), "'qd' holds NaN"),
    (lambda f: _replace(f, "cycle", np.zeros(4)), r"'cycle' has shape \(4,\)"),
    (lambda f: _replace(f, "q", np.array([b"a"] * 6)), "'q' is not a numeric dataset"),
    (lambda f: f.attrs.__setitem__("forces", "not json"), "attribute 'forces' is not JSON"),
    (lambda f: f.attrs.__setitem__("forces", '["f"]'), "names 2 coordinates and 1 forces"),
    (lambda f: f.attrs.__setitem__("format_version", 9), "format version 9, newer"),
])
def test_bad_file_refused_by_its_fault(tmp_path, change, message):
    path = bad_file(tmp_path / "bad.h5", change)
    with pytest.raises(DatasetError, match=message):
        read_dataset(path)


def test_missing_and_not_hdf5_refused(tmp_path):
    with pytest.raises(DatasetError, match="no such file"):
        read_dataset(tmp_path / "none.h5")
    with pytest.raises(DatasetError, match="is a folder"):  # it said "no such file"
        read_dataset(tmp_path)
    (tmp_path / "text.h5").write_text("q,qd\n")
    with pytest.raises(DatasetError, match="is not an HDF5 file"):
        read_dataset(tmp_path / "text.h5")


def test_writing_into_a_missing_folder_refused(tmp_path):
    with pytest.raises(DatasetError, match="cannot be written"):
        write_dataset(tmp_path / "no" / "d.h5", small())
