"""Shared fixtures: the built CLI, synthetic recordings, a small twin sensor."""
import os
import pathlib
import shutil
import socket

import numpy as np
import pytest

import tac3d

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def tac3d_cli():
    """The `tac3d` program CTest passes in TAC3D_CLI (else build/bin/tac3d)."""
    path = os.environ.get("TAC3D_CLI") or str(REPO / "build" / "bin" / "tac3d")
    if not os.access(path, os.X_OK):
        pytest.fail(f"the tac3d CLI is not built at {path} (set TAC3D_CLI)")
    return path


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def synthetic_frame(k, rows=20, cols=20, sn="PY-TEST"):
    """Frame k of a deterministic stream: every field differs from frame to frame."""
    f = tac3d.TactileFrame(rows, cols)
    n = rows * cols
    f.sn = sn
    f.index = k
    f.timestamp = 0.001 * k
    base = np.arange(3 * n, dtype=np.float64).reshape(n, 3)
    f.positions = base * 0.01 + k
    f.displacements = base * 1e-4 - 0.5 * k
    f.forces = np.sin(base + k)
    normals = np.zeros((n, 3))
    normals[:, 2] = 1.0
    f.normals = normals
    f.resultant_force = f.forces.sum(axis=0)
    f.resultant_moment = np.cross(f.positions, f.forces).sum(axis=0)
    return f


def write_recording(path, frames, dt_s=0.001, sn="PY-TEST"):
    """A recording of `frames` synthetic frames, `dt_s` apart; returns the frames' arrays."""
    with tac3d.RecordingWriter(str(path)) as w:
        for k in range(frames):
            f = synthetic_frame(k, sn=sn)
            f.timestamp = dt_s * k
            w.write(f)
    return str(path)


def write_small_sensor_yaml(folder):
    """The prototype shrunk to 3 x 3 markers on a 12 mm dome, 3 mm thick: its twin body and
    compliance build in seconds (as simulation_test's SmallSensor). Returns its path."""
    import yaml

    cfg = yaml.safe_load(tac3d.default_sensor_yaml())
    cfg["markers"]["rows"] = cfg["markers"]["cols"] = 3
    cfg["elastic_body"]["base_diameter_mm"] = 12.0
    cfg["elastic_body"]["thickness_mm"] = 3.0
    cfg["elastic_body"]["outer_radius_mm"] = 20.0
    path = folder / "small_sensor.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


@pytest.fixture
def small_sensor_yaml(tmp_path):
    """write_small_sensor_yaml in the test's folder."""
    return write_small_sensor_yaml(tmp_path)


SMALL_TWIN = {"margin_mm": 0.8, "quadrature_points_per_side": 2}


@pytest.fixture
def small_scene(tmp_path, small_sensor_yaml):
    """A 5 mm sphere (mu 0.3): from 0.05 mm clear, pressed 0.1 mm into the small fingertip by
    t = 1 s, then slid 0.5 mm along x by t = 2 s; 11 steps (simulation_test's press and slide)."""
    text = f"""
name: small_press
sensor: {small_sensor_yaml}
deviation: {{mesh_refinement: 1.0, youngs_modulus_factor: 1.0, poisson_ratio_factor: 1.0}}
objects:
  - name: ball
    shape: sphere
    radius_mm: 5
    position_mm: [0, 0, 8.0]
    friction: {{default: 0.3}}
trajectory:
  steps: 11
  keyframes:
    - {{t_s: 0, position_mm: [0, 0, -0.05]}}
    - {{t_s: 1, position_mm: [0, 0, 0.1]}}
    - {{t_s: 2, position_mm: [0.5, 0, 0.1]}}
"""
    path = tmp_path / "small_scene.yaml"
    path.write_text(text)
    return path


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory):
    """A private model cache, so tests never depend on (or fill) the user's."""
    return str(tmp_path_factory.mktemp("cache"))
