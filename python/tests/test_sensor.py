"""tac3d.Sensor (the vendor PyTac3D interface) against `tac3d run --udp` on loopback."""
import socket
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

import tac3d
from conftest import synthetic_frame, write_recording

# What tac3d sends by default: the vendor's six items (and the vendor client's own keys).
VENDOR_KEYS = {"SN", "index", "sendTimestamp", "recvTimestamp", "message", "3D_Displacements",
               "3D_Positions", "3D_Forces", "3D_ResultantForce", "3D_ResultantMoment",
               "InitializeProgress"}


def stream(cli, recording, port, speed=1.0, sn=None):
    args = [cli, "run", "--source", f"recording:{recording}", "--udp", f"127.0.0.1:{port}",
            "--speed", str(speed)]
    if sn:
        args += ["--sn", sn]
    return subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_receives_every_frame_with_the_vendor_keys_shapes_and_values(tmp_path, tac3d_cli):
    n = 300
    # 200 frames/s: within what the client decodes on a loaded 2-core machine (~380/s).
    rec = write_recording(tmp_path / "s.tac3drec", n, dt_s=0.005)
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
        assert set(f) == VENDOR_KEYS
        assert f["SN"] == "PY-TEST" and f["index"] == k
        assert isinstance(f["sendTimestamp"], float) and f["sendTimestamp"] == pytest.approx(0.005 * k)
        assert isinstance(f["recvTimestamp"], float) and f["recvTimestamp"] > 0
        for key in ("3D_Positions", "3D_Displacements", "3D_Forces"):
            assert f[key].dtype == np.float64 and f[key].shape == (400, 3), key
        for key in ("3D_ResultantForce", "3D_ResultantMoment"):
            assert f[key].dtype == np.float64 and f[key].shape == (1, 3), key
        assert isinstance(f["InitializeProgress"], float) and f["InitializeProgress"] == 100
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
    with pytest.raises(tac3d.Error, match="closed"):
        sensor.calibrate("PY-TEST")


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
    # Issue 22, defect 10: timeout=nan blocked for ever.
    with tac3d.Sensor(port=0) as sensor:
        t0 = time.time()
        for bad in (float("nan"), -1.0):
            with pytest.raises(tac3d.Error, match="timeout = .* must be >= 0 s"):
                sensor.waitForFrame(timeout=bad)
        assert time.time() - t0 < 1


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


def test_a_raising_callback_does_not_stop_reception(tmp_path, tac3d_cli, monkeypatch):
    rec = write_recording(tmp_path / "r.tac3drec", 20, dt_s=0.002)
    seen = []
    reported = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: reported.append(u.exc_value))

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
    assert len(reported) == 20 and all(isinstance(e, ValueError) for e in reported)


def test_no_memory_growth_over_10000_streamed_frames(tmp_path, tac3d_cli):
    """10,000 frames sent at 2 kHz. Under load loopback loses frames (the C++ client decodes
    ~300-500 frames/s on a busy 2-core machine), so the bound is per frame received: a leak of
    one 400 x 3 array a frame (9.6 kB) would show as megabytes."""
    from test_frames_and_recordings import rss_kb

    rec = write_recording(tmp_path / "10k.tac3drec", 10_000, dt_s=0.0005)
    count = [0]
    rss = {}

    def on_frame(frame, param):
        count[0] += 1
        frame["3D_Forces"].sum()
        if count[0] == 1000:
            rss["start"] = rss_kb()

    with tac3d.Sensor(recvCallback=on_frame, port=0) as sensor:
        proc = stream(tac3d_cli, rec, sensor.port)
        assert proc.wait(timeout=120) == 0
        time.sleep(0.3)
        stats = sensor.stats()
        grown = rss_kb() - rss["start"]
    measured = stats["frames"] - 1000
    assert measured >= 2000, stats
    assert grown < 2_000, f"RSS grew by {grown} kB over {measured} frames ({stats})"


def test_a_twin_dataset_through_the_pipeline_zeroed_by_calibrate(tmp_path, tac3d_cli,
                                                                small_sensor_yaml, cache_dir):
    """The acceptance path on the 3 x 3-marker twin: a dataset streamed by `tac3d run --udp`
    (images -> pipeline -> UDP), every measured frame received with the vendor keys, and
    calibrate() re-zeroing the sender's pipeline (its next reference_frames frames are
    initializing, which the sender does not send)."""
    from conftest import SMALL_TWIN

    scene = tmp_path / "idle_press.yaml"
    scene.write_text(f"""
name: idle_press
sensor: {small_sensor_yaml}
deviation: {{mesh_refinement: 1.0, youngs_modulus_factor: 1.0, poisson_ratio_factor: 1.0}}
objects:
  - {{name: ball, shape: sphere, radius_mm: 5, position_mm: [0, 0, 8.0], friction: {{default: 0.3}}}}
trajectory:
  steps: 60
  keyframes:
    - {{t_s: 0, position_mm: [0, 0, -0.05]}}
    - {{t_s: 1, position_mm: [0, 0, -0.05]}}
    - {{t_s: 2, position_mm: [0, 0, 0.1]}}
""")
    ds = tmp_path / "ds"
    tac3d.simulate(str(scene), str(ds), cache_dir=cache_dir, twin_options=SMALL_TWIN)
    frames = []

    def on_frame(frame, sensor):
        frames.append(frame)
        if len(frames) == 3:
            assert sensor.calibrate(frame["SN"])

    holder = {}
    sensor = tac3d.Sensor(recvCallback=lambda f, p: on_frame(f, holder["s"]), port=0)
    holder["s"] = sensor
    proc = subprocess.Popen(
        [tac3d_cli, "run", "--source", f"dataset:{ds}", "--config", str(small_sensor_yaml),
         "--cache", cache_dir, "--reference-frames", "5", "--sn", "TWIN-3x3", "--json",
         "--udp", f"127.0.0.1:{sensor.port}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    time.sleep(0.3)
    stats = sensor.stats()
    sensor.close()
    import json

    sent = [json.loads(line) for line in out.splitlines()]
    assert len(sent) == 60
    measured = [s["index"] for s in sent if s["initialize_progress"] == 100]
    # The reference is taken on 5 frames, the last of which is already measured (100).
    initial = [s["index"] for s in sent if s["initialize_progress"] < 100 and s["index"] < 5]
    zeroed = [s["index"] for s in sent if s["initialize_progress"] < 100 and s["index"] >= 5]
    assert initial == [0, 1, 2, 3]
    assert zeroed == list(range(zeroed[0], zeroed[0] + 4)), zeroed
    assert "ignored" not in err
    # Every frame the sender measured arrived, and only those: the initialising ones were
    # withheld by the sender, so the Sensor had none to drop.
    assert [f["index"] for f in frames] == measured
    assert f"{len(measured)} streamed (8 initialising withheld" in err
    assert stats["initializing_dropped"] == 0
    for f in frames:
        assert f["SN"] == "TWIN-3x3"
        for key in ("3D_Positions", "3D_Displacements", "3D_Forces"):
            assert f[key].dtype == np.float64 and f[key].shape == (9, 3)
        assert f["3D_ResultantForce"].shape == (1, 3) and f["3D_ResultantMoment"].shape == (1, 3)
    by_index = {s["index"]: s for s in sent}
    last = frames[-1]
    np.testing.assert_allclose(last["3D_ResultantForce"][0],
                               by_index[last["index"]]["resultant_force_n"], rtol=1e-9, atol=1e-12)
    assert last["3D_ResultantForce"][0, 2] < -0.05  # pressed at the end


def test_blocking_calls_release_the_gil():
    """While one thread waits in waitForFrame, another runs Python code."""
    import threading

    with tac3d.Sensor(port=0) as sensor:
        waiter = threading.Thread(target=sensor.waitForFrame, kwargs={"timeout": 0.5})
        spins = 0
        waiter.start()
        t0 = time.time()
        while waiter.is_alive():
            spins += 1
        assert time.time() - t0 > 0.4
        # Held GIL: the loop would be starved to a few switch intervals (5 ms each).
        assert spins > 10_000, spins


def test_a_script_exits_cleanly_without_closing_while_frames_arrive(tmp_path, tac3d_cli):
    rec = write_recording(tmp_path / "r.tac3drec", 1000, dt_s=0.002)
    script = (
        "import sys, time, tac3d\n"
        "s = tac3d.Sensor(recvCallback=lambda f, p: None, port=0)\n"
        "print(s.port, flush=True)\n"
        "s.waitForFrame(timeout=20)\n"
        "time.sleep(0.2)\n"  # exit with the thread busy and frames queued, no close()
    )
    py = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    port = int(py.stdout.readline())
    sender = stream(tac3d_cli, rec, port)
    try:
        assert py.wait(timeout=20) == 0
    finally:
        sender.kill()
        sender.wait()
