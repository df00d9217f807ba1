"""The Trigno Control Utility client against a fake TCU on localhost that follows its TCP
protocol (tests/device/fakes/trigno_server.py)."""

import socket
import time

import numpy as np
import pytest

from device.emg.trigno import EMG_PORT, TrignoClient, TrignoError
from tests.fake_trigno import fake_trigno

fake = fake_trigno()


def _client(server, **kw):
    return TrignoClient("127.0.0.1", command_port=server.command_port,
                        data_port=server.data_port, **kw)


def _read_at_least(client, n):
    stamps, samples = [], []
    while sum(len(s) for s in stamps) < n:
        t, x = client.read(1.0)
        stamps.append(t)
        samples.append(x)
        assert t.size == 0 or t[-1] <= time.monotonic()  # never stamped after it arrived
        np.testing.assert_allclose(np.diff(t), 1 / client.rate_hz, rtol=1e-6)
    return np.concatenate(stamps), np.concatenate(samples)


def test_streams_every_sample_exactly_with_even_stamps():
    with fake.FakeTrignoServer() as server, _client(server) as client:
        assert client.greeting.startswith("Delsys Trigno System")
        assert client.rate_hz == pytest.approx(26 / 0.0135)
        assert client.paired(1)
        assert not client.paired(5)
        client.start()
        t, x = _read_at_least(client, 600)
        client.stop()
        assert x.dtype == np.dtype("<f4")
        assert x.shape[1] == 16
        np.testing.assert_array_equal(x, fake.default_signal(np.arange(x.shape[0])))
        # the last origin stamps the whole recording evenly, never after any arrival
        assert client.sample_count == x.shape[0]
        assert client.origin_s <= t[0]
        final = client.origin_s + np.arange(x.shape[0]) / client.rate_hz
        assert (final <= t + 1e-9).all()
        assert server.commands[:2] == ["FRAME INTERVAL?", "MAX SAMPLES EMG?"]
        assert server.commands[-2:] == ["START", "STOP"]


def test_close_stops_a_running_stream():
    with fake.FakeTrignoServer() as server:
        client = _client(server).open()
        client.start()
        _read_at_least(client, 30)
        client.close()
        deadline = time.monotonic() + 5
        while "STOP" not in server.commands and time.monotonic() < deadline:
            time.sleep(0.01)
        assert server.commands[-1] == "STOP"


def test_the_models_emg_ports():
    assert TrignoClient(model="trigno").data_port == 50041
    assert TrignoClient(model="avanti").data_port == 50043
    assert EMG_PORT == {"trigno": 50041, "avanti": 50043}
    with pytest.raises(TrignoError, match="unknown Trigno model"):
        TrignoClient(model="myo")


def _free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def test_no_tcu_is_one_clear_line():
    client = TrignoClient("127.0.0.1", command_port=_free_port(), timeout_s=1.0)
    with pytest.raises(TrignoError, match=r"connection refused.*start the Trigno Control Utility"):
        client.open()


def test_a_server_that_is_not_the_tcu_is_refused():
    with fake.FakeTrignoServer(greeting="SSH-2.0-OpenSSH_9.2") as server, \
            pytest.raises(TrignoError, match="is not the Trigno Control Utility"):
        _client(server).open()


def test_refused_commands_and_lost_data_are_errors():
    with fake.FakeTrignoServer() as server, _client(server) as client:
        with pytest.raises(TrignoError, match="refused 'FROBNICATE'"):
            client.command("FROBNICATE")
        with pytest.raises(TrignoError, match="slots are numbered 1 to 16"):
            client.paired(17)
        server.fake_drop_data_after = 52
        client.start()
        with pytest.raises(TrignoError, match="closed the EMG data connection"):
            _read_at_least(client, 10_000)


def test_a_missing_data_port_is_named():
    with fake.FakeTrignoServer() as server:
        client = TrignoClient("127.0.0.1", command_port=server.command_port,
                              data_port=_free_port(), timeout_s=1.0)
        with pytest.raises(TrignoError, match=r"EMG data port.*connection refused"):
            client.open()
