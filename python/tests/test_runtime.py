"""tac3d.run: the library's runtime (several sensors on their threads, their outputs, one clock)
from Python. Recordings replayed as sources: no compliance model to build."""
import _thread
import threading
import time

import numpy as np
import pytest

import tac3d
from conftest import synthetic_frame, write_recording


def wait_for(condition, timeout_s=3.0):
    deadline = time.time() + timeout_s
    while not condition() and time.time() < deadline:
        time.sleep(0.01)


def test_two_sensors_deliver_every_frame_to_python_udp_and_their_recordings(tmp_path):
    a = write_recording(tmp_path / "a.tac3drec", 40, sn="REC-A")
    b = write_recording(tmp_path / "b.tac3drec", 25, sn="REC-B")
    received = []
    sensor = tac3d.Sensor(recvCallback=lambda f, p: received.append(f), port=0)
    udp = f"127.0.0.1:{sensor.port}"
    specs = [
        tac3d.SensorSpec("HAND-A", f"recording:{a}", speed=0, udp=udp, record=str(tmp_path / "out_a.rec")),
        tac3d.SensorSpec("HAND-B", f"recording:{b}", speed=0, udp=udp),
    ]
    frames = []
    reports = tac3d.run(specs, on_frame=frames.append)
    wait_for(lambda: len(received) >= 65)
    sensor.close()

    assert [r.sn for r in reports] == ["HAND-A", "HAND-B"]
    assert [(r.frames, r.skipped, r.failure) for r in reports] == [(40, 0, ""), (25, 0, "")]
    assert all(r.first_frame_s <= r.last_frame_s for r in reports)
    assert "HAND-A: 40 frames, 0 skipped" in reports[0].brief_report()
    # Every frame to Python as a TactileFrame, with its sensor's SN and the recorded values.
    by_sn = {sn: [f for f in frames if f.sn == sn] for sn in ("HAND-A", "HAND-B")}
    assert [len(v) for v in by_sn.values()] == [40, 25]
    assert [f.index for f in by_sn["HAND-B"]] == list(range(25))
    np.testing.assert_array_equal(by_sn["HAND-A"][7].forces, synthetic_frame(7).forces)
    # One clock: the timestamps are seconds since the sensors started, not the recorded ones.
    assert all(0 <= f.timestamp < 60 for f in frames)
    assert sorted(f["SN"] for f in received) == ["HAND-A"] * 40 + ["HAND-B"] * 25
    rec = tac3d.open_recording(str(tmp_path / "out_a.rec"))
    assert len(rec) == 40 and rec[0].sn == "HAND-A"


def test_max_frames_json_lines_and_a_sensor_that_cannot_start(tmp_path, capfd):
    a = write_recording(tmp_path / "a.tac3drec", 30)
    specs = [tac3d.SensorSpec("OK", f"recording:{a}", speed=0),
             tac3d.SensorSpec("MISSING", f"recording:{tmp_path}/none.rec")]
    reports = tac3d.run(specs, max_frames=10, json=True)
    assert reports[0].frames == 10 and reports[0].failure == ""
    assert reports[1].frames == 0 and "could not start" in reports[1].failure
    assert "none.rec" in reports[1].failure
    out = capfd.readouterr().out
    assert out.count('"sn":"OK"') == 10


def test_a_run_file_runs_as_the_cli_runs_it(tmp_path):
    write_recording(tmp_path / "a.tac3drec", 12)
    run_file = tmp_path / "hand.yaml"
    run_file.write_text("sensors:\n  - sn: THUMB\n    source: recording:a.tac3drec\n    speed: 0\n")
    specs = tac3d.load_run_file(str(run_file))
    assert [(s.sn, s.source, s.speed) for s in specs] == [("THUMB", f"recording:{tmp_path}/a.tac3drec", 0.0)]
    assert [r.frames for r in tac3d.run(specs)] == [12]
    run_file.write_text("sensors:\n  - sn: THUMB\n    source: camera:0\n    pixel_format: MJPG\n")
    assert tac3d.load_run_file(str(run_file))[0].pixel_format == "MJPG"
    run_file.write_text("sensors:\n  - sn: THUMB\n    source: camera:0\n    pixel_format: MJPEG\n")
    with pytest.raises(tac3d.Error, match="pixel format 'MJPEG' is not a V4L2 four-character code"):
        tac3d.load_run_file(str(run_file))
    run_file.write_text("sensors:\n  - sn: THUMB\n    source: camera:0\n    colour: red\n")
    with pytest.raises(tac3d.Error, match="hand.yaml: line 4: sensors\\[0\\].colour: unknown key"):
        tac3d.load_run_file(str(run_file))


def test_specs_are_checked_when_made():
    spec = tac3d.SensorSpec("S", "dataset:ds", speed=2, gains=(1, 2, 3), drift="rezero")
    assert (spec.speed, spec.gains, spec.drift, spec.udp) == (2.0, [1.0, 2.0, 3.0], "rezero", "")
    with pytest.raises(tac3d.Error, match="speed applies to recording:FILE, vendor:DIR or dataset:DIR only"):
        tac3d.SensorSpec("S", "camera:0", speed=1)
    with pytest.raises(tac3d.Error, match="--udp 'nowhere': expected HOST:PORT"):
        tac3d.SensorSpec("S", "camera:0", udp="nowhere")
    with pytest.raises(tac3d.Error, match="weight"):
        tac3d.SensorSpec("S", "camera:0", weight=-1)
    with pytest.raises(tac3d.Error, match="must be off, flag or rezero"):
        tac3d.SensorSpec("S", "camera:0", drift="sometimes")
    assert tac3d.SensorSpec("S", "camera:0", pixel_format="YUYV").pixel_format == "YUYV"
    with pytest.raises(tac3d.Error, match="pixel format 'yuv' is not"):
        tac3d.SensorSpec("S", "camera:0", pixel_format="yuv")
    with pytest.raises(tac3d.Error, match="sn must not be empty"):
        tac3d.SensorSpec("", "camera:0")
    extras = tac3d.SensorSpec("S", "camera:0", udp="127.0.0.1:9988", udp_items="all", udp_progress=True)
    assert (extras.udp_items, extras.udp_progress) == ("all", True)
    assert not extras.allow_zero_under_load
    assert tac3d.SensorSpec("S", "camera:0", allow_zero_under_load=True).allow_zero_under_load
    with pytest.raises(tac3d.Error, match="unknown item 'Slip'"):
        tac3d.SensorSpec("S", "camera:0", udp="127.0.0.1:9988", udp_items="Slip")
    with pytest.raises(tac3d.Error, match="--udp-items needs --udp HOST:PORT"):
        tac3d.SensorSpec("S", "camera:0", udp_items="all")
    with pytest.raises(tac3d.Error, match="max_frames"):
        tac3d.run([spec], max_frames=-1)
    # As strict as the command line whatever the source: a frame rate of NaN, a config that is
    # not there, a speed that would wait for ever.
    with pytest.raises(tac3d.Error, match="fps = nan must be in"):
        tac3d.SensorSpec("S", "vendor:rec", fps=float("nan"))
    with pytest.raises(tac3d.Error, match="sensor config '/nonexistent.yaml' does not exist"):
        tac3d.SensorSpec("S", "vendor:rec", config="/nonexistent.yaml")
    with pytest.raises(tac3d.Error, match="replay speed 1e-308 must be 0"):
        tac3d.SensorSpec("S", "vendor:rec", speed=1e-308)


def test_an_exception_in_on_frame_stops_every_sensor_and_is_raised(tmp_path):
    # 1000 frames at their recorded pace (10 s): stopped long before.
    slow = write_recording(tmp_path / "slow.tac3drec", 1000, dt_s=0.01)
    out = tmp_path / "out.rec"
    seen = []

    def on_frame(frame):
        seen.append(frame.index)
        if frame.sn == "A" and frame.index == 5:
            raise ValueError("enough")

    specs = [tac3d.SensorSpec("A", f"recording:{slow}", record=str(out)),
             tac3d.SensorSpec("B", f"recording:{slow}")]
    start = time.time()
    with pytest.raises(ValueError, match="enough"):
        tac3d.run(specs, on_frame=on_frame)
    assert time.time() - start < 5
    assert len(seen) < 100
    # The recording was closed cleanly with the frames emitted before the stop.
    rec = tac3d.open_recording(str(out))
    assert rec.status == "complete" and 5 <= len(rec) < 100


def test_ctrl_c_stops_every_sensor_and_raises_keyboard_interrupt(tmp_path):
    slow = write_recording(tmp_path / "slow.tac3drec", 1000, dt_s=0.01)
    specs = [tac3d.SensorSpec(sn, f"recording:{slow}", record=str(tmp_path / f"{sn}.rec")) for sn in "AB"]
    timer = threading.Timer(0.5, _thread.interrupt_main)
    start = time.time()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        tac3d.run(specs)
    assert time.time() - start < 5
    for sn in "AB":
        rec = tac3d.open_recording(str(tmp_path / f"{sn}.rec"))
        assert rec.status == "complete" and 10 <= len(rec) < 900, sn


def test_the_gil_is_released_while_the_sensors_run(tmp_path):
    slow = write_recording(tmp_path / "slow.tac3drec", 50, dt_s=0.01)
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.005)

    thread = threading.Thread(target=count)
    thread.start()
    tac3d.run([tac3d.SensorSpec("A", f"recording:{slow}")])
    stop.set()
    thread.join()
    assert len(ticks) > 20  # 0.5 s of replay: the other thread ran meanwhile


LOOPBACK_CYCLONE = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
                    '<AllowMulticast>false</AllowMulticast></General><Discovery><Peers><Peer address="127.0.0.1"/>'
                    '</Peers><ParticipantIndex>auto</ParticipantIndex></Discovery></Domain></CycloneDDS>')


def test_sensors_publish_on_ros2_under_their_namespaces_and_say_so(tmp_path, capfd, monkeypatch):
    # What a ROS 2 node receives is checked by ros2/interop_test (a Fast DDS subscriber); here, that
    # Python's specs and a run file reach the publisher, one namespace a sensor.
    monkeypatch.setenv("CYCLONEDDS_URI", LOOPBACK_CYCLONE)
    monkeypatch.setenv("ROS_DOMAIN_ID", "174")
    a = write_recording(tmp_path / "a.tac3drec", 20, sn="REC-A")
    b = write_recording(tmp_path / "b.tac3drec", 12, sn="REC-B")
    specs = [tac3d.SensorSpec("THUMB", f"recording:{a}", speed=0, ros2="hand/thumb", ros2_reliable=True),
             tac3d.SensorSpec("INDEX", f"recording:{b}", speed=0, ros2="/hand/index")]
    reports = tac3d.run(specs)
    assert [(r.frames, r.failure) for r in reports] == [(20, ""), (12, "")]
    assert reports[0].outputs == ", 20 published on ROS 2 under /hand/thumb"
    assert reports[1].outputs == ", 12 published on ROS 2 under /hand/index"
    err = capfd.readouterr().err
    assert "THUMB: 20 frames, 0 skipped" in err and "published on ROS 2 under /hand/thumb\n" in err

    run_file = tmp_path / "hand.yaml"
    run_file.write_text("sensors:\n  - sn: THUMB\n    source: recording:a.tac3drec\n    ros2: hand/thumb\n"
                        "    ros2_frame_id: thumb_tip\n  - sn: INDEX\n    source: recording:b.tac3drec\n"
                        "    ros2: hand/thumb\n")
    with pytest.raises(tac3d.Error, match="hand/thumb"):
        tac3d.load_run_file(str(run_file))
    run_file.write_text(run_file.read_text().replace("ros2: hand/thumb\n", "ros2: hand/index\n")
                        .replace("ros2: hand/index\n", "ros2: hand/thumb\n", 1))
    specs = tac3d.load_run_file(str(run_file))
    assert [(s.ros2, s.ros2_frame_id) for s in specs] == [("hand/thumb", "thumb_tip"), ("hand/index", "")]
    with pytest.raises(tac3d.Error, match="ROS 2"):
        tac3d.SensorSpec("X", f"recording:{a}", ros2="1st/bad")
