"""`tac3d recording export --format mcap` read back by an independent oracle: Foxglove's own
libraries from npm (@mcap/core's indexed and stream readers, @foxglove/rosmsg's parser of the
ros2msg schemas, @foxglove/rosmsg2-serialization's CDR decoder; tests/mcap_oracle). Every
message must decode and carry the recording's values."""
import base64
import json
import shutil
import struct
import subprocess
import zlib

import numpy as np
import pytest

import tac3d
from conftest import REPO, synthetic_frame

ORACLE = REPO / "tests" / "mcap_oracle"
ROWS, COLS, FRAMES, DT_S = 20, 20, 80, 0.03  # 2.37 s: status at frames 0, 34 (1.02 s) and 68 (2.04 s)


@pytest.fixture(scope="session")
def oracle(tmp_path_factory):
    """The oracle with its locked packages installed once a session (npm ci, cached in the
    session's temporary folder); skipped only when npm cannot reach the registry."""
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.fail("the MCAP oracle needs Node.js and npm (scripts/setup.sh installs them)")
    folder = tmp_path_factory.mktemp("mcap_oracle")
    for name in ("package.json", "package-lock.json", "read.mjs"):
        shutil.copy(ORACLE / name, folder / name)
    npm = ["npm", "--cache", str(folder / "npm-cache"), "--no-audit", "--no-fund", "--prefer-offline"]
    try:
        done = subprocess.run(npm + ["ci"], cwd=folder, capture_output=True, text=True, timeout=600)
        failed = done.returncode != 0
        output = done.stdout + done.stderr
    except subprocess.TimeoutExpired:
        failed, output = True, "npm ci timed out"
    if failed:
        ping = subprocess.run(["npm", "ping"], capture_output=True, text=True, timeout=120)
        if ping.returncode != 0:
            lines = ping.stderr.strip().splitlines() or ["npm ping failed"]
            why = next((line for line in lines if "code E" in line), lines[0])
            pytest.skip(f"npm cannot reach the registry ({why}): the Foxglove oracle did not run")
        pytest.fail(f"npm ci failed with the registry reachable:\n{output[-2000:]}")
    return folder


def read_with_oracle(oracle, path):
    done = subprocess.run(["node", str(oracle / "read.mjs"), str(path)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def png_grey(data):
    """An 8-bit grey, non-interlaced PNG's pixels (no imaging library on the test machine)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat = 8, b""
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            w, h, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
    assert (depth, color, interlace) == (8, 0, 0)
    raw = zlib.decompress(idat)
    out = np.zeros((h, w), np.uint8)
    prev = [0] * w
    for r in range(h):
        kind, line = raw[r * (w + 1)], raw[r * (w + 1) + 1:(r + 1) * (w + 1)]
        cur = [0] * w
        for x in range(w):
            a, b, c = (cur[x - 1] if x else 0), prev[x], (prev[x - 1] if x else 0)
            p = a + b - c
            paeth = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)
            cur[x] = (line[x] + [0, a, b, (a + b) // 2, paeth][kind]) & 255
        out[r] = cur
        prev = cur
    return out


def image_of(k):
    return ((np.arange(24 * 32).reshape(24, 32) * 7 + k) % 256).astype(np.uint8)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """Frames with lost markers, contact, a flag on some, an image on every other one."""
    path = tmp_path_factory.mktemp("mcap_rec") / "rec.tac3d"
    frames = []
    with tac3d.RecordingWriter(str(path)) as w:
        for k in range(FRAMES):
            f = synthetic_frame(k, ROWS, COLS, sn="AD2-0065L")
            f.timestamp = DT_S * k
            valid = np.ones(ROWS * COLS, bool)
            valid[k % 7::50] = False
            f.valid = valid
            f.contact = (np.arange(ROWS * COLS) + k) % 3 == 0
            f.flags = 1 if k % 10 == 5 else 0  # markers_lost on some frames
            image = image_of(k) if k % 2 == 0 else None
            w.write(f, image)
            frames.append(f)
    return path, frames


def test_export_decodes_with_foxglove_libraries(oracle, recording, tac3d_cli, tmp_path):
    path, frames = recording
    out = tmp_path / "rec.mcap"
    done = subprocess.run([tac3d_cli, "recording", "export", str(path), "--format", "mcap", "--out", str(out)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"exported {FRAMES} frames to {out}")
    got = read_with_oracle(oracle, out)

    ns = "/tac3d/AD2_0065L"
    assert got["profile"] == "ros2"
    channels = {c["topic"]: c for c in got["channels"]}
    assert {t: (c["schema_name"], c["schema_encoding"], c["message_encoding"]) for t, c in channels.items()} == {
        f"{ns}/wrench": ("geometry_msgs/msg/WrenchStamped", "ros2msg", "cdr"),
        f"{ns}/markers": ("sensor_msgs/msg/PointCloud2", "ros2msg", "cdr"),
        f"{ns}/status": ("diagnostic_msgs/msg/DiagnosticArray", "ros2msg", "cdr"),
        f"{ns}/image": ("sensor_msgs/msg/CompressedImage", "ros2msg", "cdr"),
    }
    messages = got["messages"]
    expected_count = 2 * FRAMES + FRAMES // 2 + 3
    assert len(messages) == expected_count
    assert int(got["statistics"]["messageCount"]) == expected_count
    counts = {c["topic"].rsplit("/", 1)[1]: int(got["statistics"]["channelMessageCounts"][str(c["id"])])
              for c in got["channels"]}
    assert counts == {"wrench": FRAMES, "markers": FRAMES, "image": FRAMES // 2, "status": 3}
    assert got["stream_done"] and got["streamed"]["messages"] == expected_count
    assert not any(m["trailing_bytes"] for m in messages)

    by_topic = {}
    for m in messages:
        by_topic.setdefault(m["topic"].rsplit("/", 1)[1], []).append(m)
    for topic, ms in by_topic.items():
        for m in ms:
            k = round(int(m["log_time"]) / (DT_S * 1e9))
            stamp = m["message"]["header"]["stamp"]
            assert int(m["log_time"]) == int(m["publish_time"]) == round(frames[k].timestamp * 1e9)
            assert stamp["sec"] * 10**9 + stamp["nanosec"] == int(m["log_time"])
            assert m["message"]["header"]["frame_id"] == "tac3d_AD2_0065L"
        assert len(ms) == {"wrench": FRAMES, "markers": FRAMES, "image": FRAMES // 2, "status": 3}[topic]

    for m in by_topic["wrench"]:
        f = frames[round(int(m["log_time"]) / (DT_S * 1e9))]
        w = m["message"]["wrench"]
        np.testing.assert_array_equal([w["force"][a] for a in "xyz"], f.resultant_force)
        np.testing.assert_array_equal([w["torque"][a] for a in "xyz"], f.resultant_moment / 1000)

    for m in by_topic["markers"]:
        f = frames[round(int(m["log_time"]) / (DT_S * 1e9))]
        c = m["message"]
        assert (c["height"], c["width"], c["point_step"], c["row_step"]) == (ROWS, COLS, 40, 40 * COLS)
        assert c["is_bigendian"] is False and c["is_dense"] is False
        fields = {x["name"]: (x["offset"], x["datatype"], x["count"]) for x in c["fields"]}
        assert fields == {**{n: (4 * i, 7, 1) for i, n in enumerate(["x", "y", "z", "dx", "dy", "dz", "fx", "fy", "fz"])},
                          "valid": (36, 2, 1), "contact": (37, 2, 1), "slip_state": (38, 2, 1)}
        data = np.frombuffer(base64.b64decode(c["data"]["base64"]), np.uint8).reshape(ROWS * COLS, 40)
        column = lambda name: data[:, fields[name][0]:fields[name][0] + 4].copy().view("<f4")[:, 0]
        valid = np.asarray(f.valid)
        for names, values in ((("x", "y", "z"), f.positions / 1000), (("dx", "dy", "dz"), f.displacements / 1000),
                              (("fx", "fy", "fz"), f.forces)):
            got_values = np.stack([column(n) for n in names], axis=1)
            rows = valid if names[0] != "fx" else slice(None)
            np.testing.assert_array_equal(got_values[rows], values[rows].astype(np.float32))
        np.testing.assert_array_equal(data[:, 36], valid)
        np.testing.assert_array_equal(data[:, 37], f.contact)
        np.testing.assert_array_equal(data[:, 38], 0)  # the Python writer records the slip state unknown

    for m in by_topic["image"]:
        k = round(int(m["log_time"]) / (DT_S * 1e9))
        assert m["message"]["format"] == "png"
        np.testing.assert_array_equal(png_grey(base64.b64decode(m["message"]["data"]["base64"])), image_of(k))

    status_frames = []
    for m in by_topic["status"]:
        k = round(int(m["log_time"]) / (DT_S * 1e9))
        status_frames.append(k)
        (s,) = m["message"]["status"]
        values = {v["key"]: v["value"] for v in s["values"]}
        f = frames[k]
        assert s["hardware_id"] == "AD2-0065L" and s["level"] == (1 if f.flags else 0)
        assert int(values["lost_markers"]) == ROWS * COLS - int(np.sum(f.valid))
        assert int(values["contact_markers"]) == int(np.sum(f.contact))
        assert int(values["index"]) == k
        if k > 0:
            assert float(values["frame_rate_hz"]) == pytest.approx(1 / DT_S, rel=1e-3)
    assert status_frames == [0, 34, 68]


def test_vendor_recording_exports_to_mcap(oracle, recording, tac3d_cli, tmp_path):
    """`vendor:DIR`: the vendor's layout of the same frames gives the same wrenches."""
    path, frames = recording
    run = lambda *args: subprocess.run([tac3d_cli, "recording", "export", *args], capture_output=True, text=True)
    done = run(str(path), "--format", "vendor", "--out", str(tmp_path / "vendor"))
    assert done.returncode == 0, done.stderr
    out = tmp_path / "vendor.mcap"
    done = run(f"vendor:{tmp_path / 'vendor'}", "--format", "mcap", "--out", str(out), "--frame-id", "gripper_tip")
    assert done.returncode == 0, done.stderr
    wrenches = [m for m in read_with_oracle(oracle, out)["messages"] if m["topic"] == "/tac3d/AD2_0065L/wrench"]
    assert len(wrenches) == FRAMES
    for m, f in zip(wrenches, frames):
        assert m["message"]["header"]["frame_id"] == "gripper_tip"
        assert int(m["log_time"]) == round(f.timestamp * 1e9)
        np.testing.assert_array_equal([m["message"]["wrench"]["force"][a] for a in "xyz"], f.resultant_force)
        np.testing.assert_array_equal([m["message"]["wrench"]["torque"][a] for a in "xyz"], f.resultant_moment / 1000)


def test_mcap_export_refusals_and_a_truncated_recording(recording, tac3d_cli, tmp_path):
    path, _ = recording
    run = lambda *args: subprocess.run([tac3d_cli, "recording", "export", *args], capture_output=True, text=True)
    done = run(str(path), "--format", "mcap", "--out", str(tmp_path / "x.bag"))
    assert done.returncode == 1 and ".mcap" in done.stderr
    done = run(str(path), "--format", "csv", "--out", str(tmp_path / "csv"), "--frame-id", "tip")
    assert done.returncode == 1 and "--frame-id is for --format mcap" in done.stderr
    done = run(f"vendor:{tmp_path}", "--format", "npy", "--out", str(tmp_path / "npy"))
    assert done.returncode == 1 and "only with --format mcap" in done.stderr
    # Cut inside its last record: the good frames are exported, with a warning and exit 0.
    cut = tmp_path / "cut.tac3d"
    cut.write_bytes(path.read_bytes()[:-100])
    done = run(str(cut), "--format", "mcap", "--out", str(tmp_path / "cut.mcap"))
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"exported {FRAMES - 1} frames")
    assert "tac3d: warning:" in done.stderr and "truncated" in done.stderr
