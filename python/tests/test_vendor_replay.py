"""`tac3d run --source vendor:DIR` (docs/real-sensors.md): a recording of the vendor's software,
written here with numpy as its recorder writes it (or the real one where ../shared/realdata is),
replayed over UDP to tac3d.Sensor (the PyTac3D interface) and as JSON lines."""
import json
import os
import pathlib
import subprocess
import time

import numpy as np
import pytest

import tac3d
from conftest import REPO

REALDATA = pathlib.Path(os.environ.get("TAC3D_REALDATA") or REPO.parent / "shared" / "realdata")


def write_vendor_recording(folder, sn, frames, first_time_s, dt_s=0.01, markers=400):
    """`folder/sn/<field>.npy` as the vendor's recorder writes them; returns the fields."""
    rng = np.random.default_rng(len(sn) + frames)
    fields = {
        "3D_Positions": rng.normal(size=(frames, markers, 3)),
        "3D_Displacements": rng.normal(scale=0.1, size=(frames, markers, 3)),
        "3D_Forces": rng.normal(scale=0.01, size=(frames, markers, 3)),
        "3D_ResultantForce": rng.normal(size=(frames, 1, 3)),
        "3D_ResultantMoment": rng.normal(size=(frames, 1, 3)),
        "index": np.arange(1000, 1000 + frames, dtype=np.int64),
        "sendTimestamp": first_time_s + dt_s * np.arange(frames),
    }
    (folder / sn).mkdir(parents=True, exist_ok=True)
    for name, values in fields.items():
        np.save(folder / sn / f"{name}.npy", values)
    return fields


def replay_to_client(cli, source, *flags, expected):
    """Streams `source` to a tac3d.Sensor; returns the frames it got and the run's stderr."""
    frames = []
    sensor = tac3d.Sensor(recvCallback=lambda frame, _: frames.append(frame), port=0)
    run = subprocess.run([cli, "run", "--source", source, "--udp", f"127.0.0.1:{sensor.port}", *flags],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    deadline = time.time() + 5  # a bound on a hang, not a timing assertion
    while len(frames) < expected and time.time() < deadline:
        time.sleep(0.01)
    sensor.close()
    return frames, run.stderr


def test_two_sensors_reach_a_vendor_client_interleaved_and_bit_for_bit(tmp_path, tac3d_cli):
    left = write_vendor_recording(tmp_path, "AD2-0065L", 30, first_time_s=5.0)
    right = write_vendor_recording(tmp_path, "AD2-0065R", 30, first_time_s=5.005)
    frames, log = replay_to_client(tac3d_cli, f"vendor:{tmp_path}", expected=60)
    assert "AD2-0065L (30 frames of 400 markers" in log and "AD2-0065R (30 frames" in log
    assert "60 frames replayed" in log and "60 streamed" in log
    assert [f["SN"] for f in frames] == ["AD2-0065L", "AD2-0065R"] * 30  # in sendTimestamp order
    for k, frame in enumerate(frames):
        fields = left if k % 2 == 0 else right
        assert frame["index"] == 1000 + k // 2
        assert frame["sendTimestamp"] == fields["sendTimestamp"][k // 2]
        for name in ("3D_Positions", "3D_Displacements", "3D_Forces", "3D_ResultantForce", "3D_ResultantMoment"):
            np.testing.assert_array_equal(frame[name], fields[name][k // 2], err_msg=name)
        assert frame["InitializeProgress"] == 100


def test_json_lines_and_an_sn_folder(tmp_path, tac3d_cli):
    fields = write_vendor_recording(tmp_path, "AD2-0065L", 5, first_time_s=1.0)
    run = subprocess.run([tac3d_cli, "run", "--source", f"vendor:{tmp_path}/AD2-0065L", "--speed", "0", "--json",
                          "--sn", "THUMB"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [line["index"] for line in lines] == list(range(1000, 1005))
    assert {line["sn"] for line in lines} == {"THUMB"}
    assert [line["resultant_force_n"] for line in lines] == fields["3D_ResultantForce"][:, 0].tolist()
    assert [line["timestamp_s"] for line in lines] == fields["sendTimestamp"].tolist()


def test_a_resultant_the_vendor_left_nan_is_said_and_sent_as_unknown(tmp_path, tac3d_cli):
    fields = write_vendor_recording(tmp_path, "AD2-0065L", 5, first_time_s=1.0)
    fields["3D_ResultantForce"][1, 0, :] = np.nan
    fields["3D_ResultantMoment"][3, 0, 2] = np.inf
    for name in ("3D_ResultantForce", "3D_ResultantMoment"):
        np.save(tmp_path / "AD2-0065L" / f"{name}.npy", fields[name])
    run = subprocess.run([tac3d_cli, "run", "--source", f"vendor:{tmp_path}", "--speed", "0", "--json"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert "2 frame(s) with a NaN or infinite resultant, sent as recorded (null in JSON)" in run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert len(lines) == 5
    assert lines[1]["resultant_force_n"] == [None, None, None]
    assert lines[3]["resultant_moment_nmm"][2] is None
    assert lines[0]["resultant_force_n"] == fields["3D_ResultantForce"][0, 0].tolist()


def test_a_truncated_or_misshapen_file_is_refused_naming_it(tmp_path, tac3d_cli):
    write_vendor_recording(tmp_path, "AD2-0065L", 5, first_time_s=1.0)
    forces = tmp_path / "AD2-0065L" / "3D_Forces.npy"
    forces.write_bytes(forces.read_bytes()[:-100])
    run = subprocess.run([tac3d_cli, "run", "--source", f"vendor:{tmp_path}", "--speed", "0"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 1
    assert f"'{forces}': " in run.stderr and "(truncated)" in run.stderr
    np.save(forces, np.zeros((5, 400, 2)))
    run = subprocess.run([tac3d_cli, "view", "--vendor", str(tmp_path), "--web-hold", "0"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 1
    assert f"'{forces}': shape (5, 400, 2), expected (5, 400, 3)" in run.stderr


def test_the_real_recording_reaches_a_vendor_client_as_recorded(tac3d_cli):
    recording = REALDATA / "tac3d" / "YA1-007" / "recording" / "example"
    if not recording.is_dir():
        pytest.skip("no real sensor data: ../shared/realdata (or $TAC3D_REALDATA) is absent, as in a user's clone")
    frames, log = replay_to_client(tac3d_cli, f"vendor:{recording}", "--speed", "4", expected=168)
    assert "zero point moved up to 0.061 mm" in log
    assert len(frames) == 168
    positions = np.load(recording / "YA1-007" / "3D_Positions.npy")
    force = np.load(recording / "YA1-007" / "3D_ResultantForce.npy")
    for k, frame in enumerate(frames):
        assert frame["SN"] == "YA1-007"
        np.testing.assert_array_equal(frame["3D_Positions"], positions[k])
        np.testing.assert_array_equal(frame["3D_ResultantForce"], force[k])
