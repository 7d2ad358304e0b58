"""`tac3d run --udp` as the vendor's PyTac3D 3.3.0-p1 receives it when started BEFORE the
sender: it gives up for good at the first frame still initialising, so the stream
must send none by default, neither at the start nor while a `$C` re-takes the reference. The
receiver is vendor_pytac3d.PyTac3DClient (plain sockets, no tac3d); the sender is the real CLI
running a 3 x 3-marker twin dataset through the pipeline."""
import json
import subprocess
import time

import numpy as np
import pytest

import tac3d
from conftest import SMALL_TWIN, write_small_sensor_yaml
from vendor_pytac3d import PyTac3DClient

STEPS = 40
REFERENCE_FRAMES = 5


@pytest.fixture(scope="module")
def twin(tmp_path_factory, cache_dir):
    """A small twin dataset at rest, then pressed: 40 steps over 2 s, and its sensor config."""
    folder = tmp_path_factory.mktemp("vendor_twin")
    sensor = write_small_sensor_yaml(folder)
    scene = folder / "rest_then_press.yaml"
    scene.write_text(f"""
name: rest_then_press
sensor: {sensor}
deviation: {{mesh_refinement: 1.0, youngs_modulus_factor: 1.0, poisson_ratio_factor: 1.0}}
objects:
  - {{name: ball, shape: sphere, radius_mm: 5, position_mm: [0, 0, 8.0], friction: {{default: 0.3}}}}
trajectory:
  steps: {STEPS}
  keyframes:
    - {{t_s: 0, position_mm: [0, 0, -0.05]}}
    - {{t_s: 1.2, position_mm: [0, 0, -0.05]}}
    - {{t_s: 2, position_mm: [0, 0, 0.1]}}
""")
    tac3d.simulate(str(scene), str(folder / "ds"), cache_dir=cache_dir, twin_options=SMALL_TWIN)
    return {"dataset": folder / "ds", "sensor": sensor}


def run_stream(cli, twin, cache_dir, port, *flags):
    """`tac3d run` of the twin at its pace to 127.0.0.1:port; returns its --json lines and stderr."""
    proc = subprocess.run(
        [cli, "run", "--source", f"dataset:{twin['dataset']}", "--speed", "1",
         "--config", str(twin["sensor"]), "--cache", cache_dir,
         "--reference-frames", str(REFERENCE_FRAMES), "--sn", "VENDOR-3x3", "--json",
         "--udp", f"127.0.0.1:{port}", *flags],
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    time.sleep(0.3)  # the last datagrams
    return [json.loads(line) for line in proc.stdout.splitlines()], proc.stderr


def test_started_first_it_receives_every_measured_frame_through_a_rezero(tac3d_cli, twin,
                                                                        cache_dir):
    client = PyTac3DClient()
    client.on_frame = lambda f: client.calibrate() if len(client.frames) == 3 else None
    sent, err = run_stream(tac3d_cli, twin, cache_dir, client.port)
    client.close()
    measured = [s["index"] for s in sent if s["initialize_progress"] == 100]
    rezero = [s["index"] for s in sent if s["initialize_progress"] < 100 and s["index"] >= 5]
    assert len(sent) == STEPS
    assert client.gave_up_at is None, f"gave up at frame {client.gave_up_at}"
    assert len(rezero) == REFERENCE_FRAMES - 1, "the $C did not re-take the reference"
    assert [f["index"] for f in client.frames] == measured
    assert f"{len(measured)} streamed" in err
    for f in client.frames:
        assert set(f) == {"SN", "index", "sendTimestamp", "3D_Displacements", "3D_Positions",
                          "3D_Forces", "3D_ResultantForce", "3D_ResultantMoment",
                          "InitializeProgress"}
        assert isinstance(f["InitializeProgress"], float)
        assert f["3D_Positions"].shape == (9, 3) and f["3D_ResultantMoment"].shape == (1, 3)
    by_index = {s["index"]: s for s in sent}
    last = client.frames[-1]
    np.testing.assert_allclose(last["3D_ResultantForce"][0],
                               by_index[last["index"]]["resultant_force_n"], rtol=1e-9)
    assert last["3D_ResultantForce"][0, 2] < -0.05  # pressed at the end


def test_the_extra_items_arrive_when_asked(tac3d_cli, twin, cache_dir):
    client = PyTac3DClient()
    sent, _ = run_stream(tac3d_cli, twin, cache_dir, client.port, "--udp-items", "all")
    client.close()
    assert client.gave_up_at is None
    assert [f["index"] for f in client.frames] == [
        s["index"] for s in sent if s["initialize_progress"] == 100]
    by_index = {s["index"]: s for s in sent}
    states = ["unknown", "none", "stick", "partial_slip", "gross_slip"]  # docs/protocol.md
    for f in client.frames:
        assert f["3D_Normals"].shape == (9, 3)
        np.testing.assert_allclose(np.linalg.norm(f["3D_Normals"], axis=1), 1.0, rtol=1e-9)
        assert states[f["SlipState"]] == by_index[f["index"]]["slip_state"]
        for name in ("SlipFraction", "Friction", "FrictionSigma"):
            assert isinstance(f[name], float)
        assert f["SlipMargin"].shape == (1, 3)


def test_progress_frames_when_asked_end_this_client_at_the_first(tac3d_cli, twin, cache_dir):
    """Why they are not sent by default: --udp-progress streams the initialisation, which this
    client version cannot take (later ones skip such frames)."""
    client = PyTac3DClient()
    run_stream(tac3d_cli, twin, cache_dir, client.port, "--udp-progress")
    client.close()
    assert client.gave_up_at == 0
    assert client.frames == []
