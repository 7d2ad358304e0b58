"""TactileFrame's numpy fields and recordings: write, read (streamed, whole), errors."""
import json
import os
import resource
import subprocess

import numpy as np
import pytest

import tac3d
from conftest import synthetic_frame, write_recording


def test_frame_fields_are_float64_views_of_the_frame():
    f = tac3d.TactileFrame(4, 5)
    assert f.num_markers == 20
    for name in ("positions", "displacements", "forces", "normals"):
        a = getattr(f, name)
        assert a.dtype == np.float64 and a.shape == (20, 3)
    p = f.positions
    p[3] = (1.0, 2.0, 3.0)  # a view: writes reach the C++ frame
    np.testing.assert_array_equal(f.positions[3], [1.0, 2.0, 3.0])
    del f  # the array keeps the frame alive
    np.testing.assert_array_equal(p[3], [1.0, 2.0, 3.0])


def test_frame_assignment_checks_shapes():
    f = tac3d.TactileFrame(2, 2)
    with pytest.raises(tac3d.Error, match=r"positions: expected shape \(4, 3\), got \(3, 3\)"):
        f.positions = np.zeros((3, 3))
    with pytest.raises(tac3d.Error, match=r"valid: expected shape \(4,\)"):
        f.valid = [True, False]
    with pytest.raises(tac3d.Error, match="three numbers"):
        f.resultant_force = [1.0, 2.0]
    with pytest.raises(tac3d.Error, match="grid 0 x 3 must be within 1 x 1 .. 100 x 100"):
        tac3d.TactileFrame(0, 3)
    with pytest.raises(tac3d.Error, match="'bogus' is not a frame flag"):
        f.has("bogus")


def test_frame_flags_slip_and_vendor_dict():
    f = synthetic_frame(3)
    assert f.flag_names == [] and not f.initializing
    f.flags = 1 | 16
    assert f.flag_names == ["markers_lost", "initializing"]
    assert f.has("markers_lost") and not f.has("zeroed")
    f.flags = 64 | 128
    assert f.flag_names == ["lighting_changed", "drift_at_rest"]
    assert f.has("drift_at_rest") and not f.has("markers_lost")
    assert f.slip_state == "unknown" and np.isnan(f.slip_fraction)
    d = f.to_dict()
    assert d["SN"] == "PY-TEST" and d["index"] == 3
    assert d["3D_Positions"].shape == (400, 3) and d["3D_ResultantForce"].shape == (1, 3)
    assert isinstance(d["InitializeProgress"], float) and d["InitializeProgress"] == 100
    np.testing.assert_array_equal(d["3D_Forces"], f.forces)
    assert f == f.copy()


def test_recording_round_trip_streamed_and_whole(tmp_path):
    path = write_recording(tmp_path / "r.tac3drec", 30)
    reader = tac3d.RecordingReader(path)
    frames = list(reader)
    assert len(frames) == 30 and reader.status == "complete" and reader.version == 3
    for k, f in enumerate(frames):
        expected = synthetic_frame(k)
        np.testing.assert_array_equal(f.positions, expected.positions)
        np.testing.assert_array_equal(f.forces, expected.forces)
        assert f.index == k and f.sn == "PY-TEST"

    rec = tac3d.open_recording(path)
    assert len(rec) == 30 and rec.status == "complete"
    assert rec.positions.shape == (30, 400, 3) and rec.positions.dtype == np.float64
    np.testing.assert_array_equal(rec.forces[7], synthetic_frame(7).forces)
    np.testing.assert_array_equal(rec.displacements[-1], synthetic_frame(29).displacements)
    np.testing.assert_allclose(rec.resultant_forces[5], synthetic_frame(5).forces.sum(axis=0))
    np.testing.assert_allclose(rec.timestamps, 0.001 * np.arange(30))
    np.testing.assert_array_equal(rec.indices, np.arange(30))
    assert rec[-1].index == 29 and rec.image(0) is None
    with pytest.raises(IndexError):
        rec[30]
    assert [f.index for f in rec] == list(range(30))


def test_open_recording_returns_every_recorded_field(tmp_path):
    path = str(tmp_path / "fields.tac3drec")
    frames = []
    with tac3d.RecordingWriter(path) as w:
        for k in range(3):
            f = synthetic_frame(k)
            valid = np.ones(400, bool)
            valid[k] = False
            contact = np.zeros(400, bool)
            contact[10 + k] = True
            f.valid, f.contact, f.flags = valid, contact, 1
            f.friction, f.friction_sigma = 0.4 + 0.1 * k, 0.02
            f.slip_margin, f.slip_margin_sigma, f.least_normal_force_n = 0.5, 0.1, 2.0 + k
            w.write(f)
            frames.append(f)
    rec = tac3d.open_recording(path)
    assert rec.valid.shape == (3, 400) and rec.valid.dtype == np.bool_
    np.testing.assert_array_equal(rec.valid, np.stack([f.valid for f in frames]))
    np.testing.assert_array_equal(rec.contact, np.stack([f.contact for f in frames]))
    np.testing.assert_array_equal(rec.flags, [1, 1, 1])
    slip = rec.slip
    np.testing.assert_array_equal(slip["state"], [0, 0, 0])  # unknown: the writer's frames had no estimate
    np.testing.assert_allclose(slip["friction"], [0.4, 0.5, 0.6])
    np.testing.assert_allclose(slip["least_normal_force_n"], [2.0, 3.0, 4.0])
    np.testing.assert_allclose(slip["margin"], [0.5] * 3)
    assert np.isnan(slip["fraction"]).all()


def test_recording_with_images(tmp_path):
    path = str(tmp_path / "img.tac3drec")
    image = (np.arange(48 * 64) % 251).astype(np.uint8).reshape(48, 64)
    with tac3d.RecordingWriter(path) as w:
        w.write(synthetic_frame(0), image)
        with pytest.raises(tac3d.Error, match="2D uint8"):
            w.write(synthetic_frame(1), image.astype(np.float32))
    frame, img = tac3d.RecordingReader(path).read()
    np.testing.assert_array_equal(img, image)
    np.testing.assert_array_equal(tac3d.open_recording(path).image(0), image)


def test_truncated_and_bad_recordings(tmp_path):
    path = write_recording(tmp_path / "cut.tac3drec", 5)
    size = os.path.getsize(path)
    with open(path, "r+b") as f:
        f.truncate(size - 100)
    rec = tac3d.open_recording(path)
    assert len(rec) == 4 and rec.status == "truncated" and "frame" in rec.message
    bad = tmp_path / "not.tac3drec"
    bad.write_bytes(b"hello world, not a recording")
    with pytest.raises(tac3d.Error, match="not.tac3drec"):
        tac3d.open_recording(str(bad))
    with pytest.raises(tac3d.Error):
        tac3d.RecordingReader(str(tmp_path / "missing.tac3drec"))
    with pytest.raises(tac3d.Error, match="exists"):
        tac3d.RecordingWriter(path)
    # Issue 22, defect 10: a folder was "File exists (... overwrite replaces it)".
    with pytest.raises(tac3d.Error, match="recording '.*' is a directory"):
        tac3d.RecordingWriter(str(tmp_path), overwrite=True)
    with pytest.raises(tac3d.Error, match="the folder '.*missing' does not exist"):
        tac3d.RecordingWriter(str(tmp_path / "missing" / "r.tac3drec"))
    with pytest.raises(tac3d.Error, match="read it with RecordingReader"):
        tac3d.open_source(f"recording:{path}")
    w = tac3d.RecordingWriter(path, overwrite=True)
    f = synthetic_frame(0)
    f.initialize_progress = 101
    with pytest.raises(tac3d.Error, match="initialize_progress"):
        w.write(f)
    w.close()
    with pytest.raises(tac3d.Error, match="closed"):
        w.write(synthetic_frame(0))


def rss_kb():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def test_no_memory_growth_over_10000_frames(tmp_path):
    path = str(tmp_path / "long.tac3drec")
    f = synthetic_frame(0)
    with tac3d.RecordingWriter(path) as w:
        for k in range(10_000):
            f.index = k
            w.write(f)

    def touch_all():
        total = 0.0
        for frame in tac3d.RecordingReader(path):
            total += frame.positions[0, 0] + frame.forces.sum() + frame.resultant_force[2]
            d = frame.to_dict()
            total += d["3D_Normals"][0, 2]
        return total

    touch_all()  # warm up allocator pools
    before = rss_kb()
    touch_all()
    grown = rss_kb() - before
    # A frame's four arrays are 38 kB: leaking one a frame would be 380 MB here, one Python
    # object a frame (~100 B) 1 MB.
    assert grown < 1_000, f"RSS grew by {grown} kB over 10,000 frames"


def test_a_frame_is_bounded_as_a_sensor_is():
    """Issue 22, defect 10: TactileFrame(10**6, 10**6) was not bounded."""
    assert tac3d.TactileFrame(100, 100).positions.shape == (10_000, 3)
    with pytest.raises(tac3d.Error, match="grid 1000000 x 1000000 must be within 1 x 1 .. 100 x 100"):
        tac3d.TactileFrame(10**6, 10**6)


def test_slip_estimate_round_trips_through_a_recording_and_json_lines(tmp_path, tac3d_cli):
    f = synthetic_frame(0)
    assert np.isnan(f.slip_margin) and np.isnan(f.least_normal_force_n)
    values = {"friction": 0.61, "friction_sigma": 0.012, "slip_margin": 0.35,
              "slip_margin_sigma": 0.021, "least_normal_force_n": 2.75}
    for name, value in values.items():
        setattr(f, name, value)
    path = str(tmp_path / "slip.tac3drec")
    with tac3d.RecordingWriter(path) as w:
        w.write(f)
    (read,) = list(tac3d.RecordingReader(path))
    for name, value in values.items():
        assert getattr(read, name) == value, name
    assert read == f
    # Replayed to JSON lines (docs/pipeline.md): the same numbers under their keys, null for NaN.
    f.friction = float("nan")
    with tac3d.RecordingWriter(path, overwrite=True) as w:
        w.write(f)
    run = subprocess.run([tac3d_cli, "run", "--source", f"recording:{path}", "--speed", "0",
                          "--json"], check=True, capture_output=True, text=True, timeout=60)
    (line,) = [json.loads(x) for x in run.stdout.splitlines()]
    assert line["friction"] is None
    assert line["friction_sigma"] == 0.012 and line["slip_margin"] == 0.35
    assert line["slip_margin_sigma"] == 0.021 and line["least_normal_force_n"] == 2.75
