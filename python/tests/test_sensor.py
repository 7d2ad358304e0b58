"""tac3d.Sensor (the vendor PyTac3D interface) against `tac3d run --udp` on loopback."""
import socket
import struct
import subprocess
import time

import numpy as np
import pytest

import tac3d
from conftest import synthetic_frame, write_recording

VENDOR_KEYS = {"SN", "index", "sendTimestamp", "recvTimestamp", "3D_Positions",
               "3D_Displacements", "3D_Forces", "3D_Normals", "3D_ResultantForce",
               "3D_ResultantMoment"}


def stream(cli, recording, port, speed=1.0, sn=None):
    args = [cli, "run", "--source", f"recording:{recording}", "--udp", f"127.0.0.1:{port}",
            "--speed", str(speed)]
    if sn:
        args += ["--sn", sn]
    return subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_receives_every_frame_with_the_vendor_keys_shapes_and_values(tmp_path, tac3d_cli):
    n = 300
    rec = write_recording(tmp_path / "s.tac3drec", n, dt_s=0.002)
    frames = []
    params = []

    def on_frame(frame, param):
        frames.append(frame)
        params.append(param)

    sensor = tac3d.Sensor(recvCallback=on_frame, port=0, maxQSize=5, callbackParam="p")
    proc = stream(tac3d_cli, rec, sensor.port)
    assert proc.wait(timeout=60) == 0, proc.stderr.read()
    deadline = time.time() + 2
    while len(frames) < n and time.time() < deadline:
        time.sleep(0.01)
    assert len(frames) == n, sensor.stats()
    assert set(params) == {"p"}
    for k, f in enumerate(frames):
        assert VENDOR_KEYS <= set(f)
        assert f["SN"] == "PY-TEST" and f["index"] == k
        assert isinstance(f["sendTimestamp"], float) and f["sendTimestamp"] == pytest.approx(0.002 * k)
        assert isinstance(f["recvTimestamp"], float) and f["recvTimestamp"] > 0
        for key in ("3D_Positions", "3D_Displacements", "3D_Forces", "3D_Normals"):
            assert f[key].dtype == np.float64 and f[key].shape == (400, 3), key
        for key in ("3D_ResultantForce", "3D_ResultantMoment"):
            assert f[key].dtype == np.float64 and f[key].shape == (1, 3), key
        assert f["InitializeProgress"] == 100
        expected = synthetic_frame(k)
        np.testing.assert_array_equal(f["3D_Positions"], expected.positions)
        np.testing.assert_array_equal(f["3D_Forces"], expected.forces)
        np.testing.assert_array_equal(f["3D_ResultantForce"][0], expected.resultant_force)
    # The queue keeps the last maxQSize frames, per SN and for 'any'.
    queued = []
    while (f := sensor.getFrame()) is not None:
        queued.append(f["index"])
    assert queued == list(range(n - 5, n))
    assert [sensor.getFrame("PY-TEST")["index"] for _ in range(5)] == list(range(n - 5, n))
    assert sensor.getFrame("PY-TEST") is None and sensor.getFrame("OTHER") is None
    sensor.close()


def test_calibrate_sends_zero_and_quit_stops_the_sender(tmp_path, tac3d_cli, capsys):
    rec = write_recording(tmp_path / "long.tac3drec", 5000, dt_s=0.002)  # 10 s at pace
    with tac3d.Sensor(port=0) as sensor:
        assert sensor.calibrate("PY-TEST") is False  # nothing received yet
        proc = stream(tac3d_cli, rec, sensor.port, sn="AD2-0065L")
        start = time.time()
        assert sensor.waitForFrame("AD2-0065L", timeout=10)
        assert sensor.getFrame("AD2-0065L")["SN"] == "AD2-0065L"
        assert sensor.calibrate("AD2-0065L") is True
        time.sleep(0.3)
        assert sensor.quitSensor("AD2-0065L") is True
        proc.wait(timeout=5)
        elapsed = time.time() - start
        err = proc.stderr.read()
    assert elapsed < 5, "the sender did not stop on $Q"
    assert "ignored $C" in err, err  # the recording replay received the zero command
    out = capsys.readouterr().out
    assert "Calibration failed! (sensor PY-TEST is not connected)" in out
    assert "Calibrate signal send to AD2-0065L." in out


def test_wait_for_frame_times_out_without_a_sender():
    with tac3d.Sensor(port=0) as sensor:
        t0 = time.time()
        assert sensor.waitForFrame(timeout=0.3) is False
        assert 0.25 < time.time() - t0 < 2
        assert sensor.getFrame() is None
        assert sensor.quitSensor("X") is False


def test_incomplete_frames_time_out_and_garbage_is_counted():
    with tac3d.Sensor(port=0, frame_timeout=0.2) as sensor:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            # Frame 7: 2 body datagrams announced, only the header sent.
            s.sendto(struct.pack("<IHH", 7, 2, 0) + b"SN: X\n", ("127.0.0.1", sensor.port))
            s.sendto(b"abc", ("127.0.0.1", sensor.port))  # shorter than the 8-byte prefix
        time.sleep(0.6)
        drops = sensor.stats()["drops"]
        assert drops["timed_out"] == 1 and drops["short_datagram"] == 1
        assert sensor.stats()["frames"] == 0


def test_bad_arguments_raise_tac3d_error():
    with pytest.raises(tac3d.Error, match="maxQSize = 0"):
        tac3d.Sensor(port=0, maxQSize=0)
    with pytest.raises(tac3d.Error, match="port = 70000"):
        tac3d.Sensor(port=70000)
    with pytest.raises(tac3d.Error, match="callable"):
        tac3d.Sensor(recvCallback=5, port=0)
    with tac3d.Sensor(port=0) as a:
        with pytest.raises(tac3d.Error):
            tac3d.Sensor(port=a.port)  # already bound
    with pytest.raises(tac3d.Error, match="timeout"):
        tac3d.Sensor(port=0, frame_timeout=0)


def test_a_raising_callback_does_not_stop_reception(tmp_path, tac3d_cli):
    rec = write_recording(tmp_path / "r.tac3drec", 20, dt_s=0.002)
    seen = []

    def bad(frame, param):
        seen.append(frame["index"])
        raise ValueError("user bug")

    with tac3d.Sensor(recvCallback=bad, port=0) as sensor:
        proc = stream(tac3d_cli, rec, sensor.port)
        proc.wait(timeout=30)
        deadline = time.time() + 2
        while len(seen) < 20 and time.time() < deadline:
            time.sleep(0.01)
    assert seen == list(range(20))


def test_no_memory_growth_over_10000_streamed_frames(tmp_path, tac3d_cli):
    from test_frames_and_recordings import rss_kb

    rec = write_recording(tmp_path / "10k.tac3drec", 10_000, dt_s=0.0004)  # 4 s at pace
    count = [0]
    rss = {}

    def on_frame(frame, param):
        count[0] += 1
        frame["3D_Forces"].sum()
        if count[0] == 2000:
            rss["start"] = rss_kb()

    with tac3d.Sensor(recvCallback=on_frame, port=0) as sensor:
        proc = stream(tac3d_cli, rec, sensor.port)
        assert proc.wait(timeout=60) == 0
        time.sleep(0.3)
        received = sensor.stats()["frames"]
        grown = rss_kb() - rss["start"]
    assert received >= 9_900, sensor.stats()  # loopback may drop a few under load
    assert grown < 4_000, f"RSS grew by {grown} kB over {received - 2000} frames"
