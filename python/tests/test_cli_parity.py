"""Python and the CLI take the same options with the same defaults: tac3d.friction_map
and `tac3d friction-map` (friction::FrictionMapCommandOptions) give the same map of the same
frames, a small twin slide recorded once and mapped by both; tac3d.SensorSpec, tac3d.run and
tac3d.Pipeline against `tac3d run` (runtime::SensorRunSpec)."""
import ast
import json
import re
import subprocess

import numpy as np
import pytest
import yaml

import tac3d
from conftest import SMALL_TWIN

# `tac3d friction-map`'s flags that are not map options: its inputs and files (Python takes
# the frames and poses as arguments and returns the map), --config (Python's `config`) and the
# gain fit on --calibration (--gains, --min-r-squared: Python's frames carry their forces).
CLI_ONLY = {"help", "dataset", "calibration", "gains", "min_r_squared", "steps", "cache",
            "recording", "poses", "out", "json", "view", "up", "config"}


def cli_flags_and_defaults(tac3d_cli, command):
    """{snake_case name: default as printed, or None} of `tac3d COMMAND --help`."""
    text = subprocess.run([tac3d_cli, command, "--help"], check=True,
                          capture_output=True, text=True, timeout=60).stdout
    flags = {}
    for m in re.finditer(r"^\s+(?:-\w,)?--([a-z][a-z0-9-]*)(?:\s+[A-Z]+(?:\s+x\s+\d+)?(?:=(\S+))?)?",
                         text, re.M):
        flags[m.group(1).replace("-", "_")] = m.group(2)
    return flags


def test_python_takes_every_cli_option_with_its_default(tac3d_cli):
    cli = cli_flags_and_defaults(tac3d_cli, "friction-map")
    defaults = tac3d.friction_map_defaults()
    assert set(cli) - CLI_ONLY == set(defaults)
    for name, value in defaults.items():
        printed = cli[name]
        assert printed is not None, f"--{name} prints no default"
        if isinstance(value, bool):
            assert printed == str(value).lower(), name
        else:
            assert float(printed) == value, name
    # The defaults are the CLI's, not the paper's equation 6 (beta 2, gamma 0, every slip).
    assert defaults["beta"] == 0.0 and defaults["gamma"] == 1.0
    assert defaults["gross_slip_only"] and defaults["friction_along_slip"]


# `tac3d run`'s flags Python names otherwise or does not have: the sensor's serial number and
# source are SensorSpec's positional arguments; --cache, --max-frames and --json are tac3d.run's
# cache_dir, max_frames and json; --run-file is tac3d.load_run_file; the camera's size and the
# web viewer are the CLI's only.
RUN_ELSEWHERE = {"help", "sn", "source", "run_file", "cache", "max_frames", "json", "width",
                 "height", "web", "web_root", "web_hold"}


def test_sensor_spec_and_pipeline_take_tac3d_runs_options_with_its_defaults(tac3d_cli):
    cli = cli_flags_and_defaults(tac3d_cli, "run")
    spec = tac3d.SensorSpec("X", "camera:0")
    names = set(cli) - RUN_ELSEWHERE
    assert names == {n for n in dir(spec) if not n.startswith("_")} - {"sn", "source"}
    # --speed prints 1, a recording's pace, but leaves a dataset unpaced unless given:
    # SensorSpec's None.
    assert spec.speed is None
    compared = 0
    for name, printed in cli.items():
        if printed is None or name in RUN_ELSEWHERE | {"speed"}:
            continue
        value = getattr(spec, name)
        if isinstance(value, str):
            assert value == printed, name
        else:
            assert float(printed) == value, name
        compared += 1
    assert compared >= 3  # reference_frames, drift_time_constant_s, fps at least

    # tac3d.Pipeline, one image at a time, takes the pipeline's options of both, alike.
    signature = tac3d.Pipeline.__init__.__doc__.splitlines()[0]
    pipeline = {m.group(1): ast.literal_eval(m.group(2)) for m in re.finditer(
        r"(\w+): [\w.\[\]]+ = ('[^']*'|\[[^\]]*\]|[-\d.e]+)", signature)}
    # Neither prints an SN: without one, an imported sensor's own is taken from its config.
    assert cli["sn"] is None and "sn: Optional[str] = None" in signature
    for name in ("reference_frames", "gains", "drift", "drift_time_constant_s"):
        assert pipeline[name] == getattr(spec, name), name
    # The inverse's weight and re-solve: unset, each sensor's own (the CLI prints no default).
    for name, kind in (("weight", "float"), ("support_resolve", "bool")):
        assert f"{name}: Optional[{kind}] = None" in signature and getattr(spec, name) is None, name
        assert cli[name] is None, name
    with pytest.raises(tac3d.Error, match="drift 'sideways': must be off, flag or rezero"):
        tac3d.Pipeline(drift="sideways")


def test_unknown_and_mistyped_options_are_refused_naming_the_accepted_ones():
    frames = [tac3d.TactileFrame(3, 3) for _ in range(2)]
    poses = np.tile(np.eye(4), (2, 1, 1))
    with pytest.raises(tac3d.Error, match=r"unknown option 'radius_mm' \(accepted: "
                                          r"contact_threshold, .*gross_slip_margin, .*threads\)"):
        tac3d.friction_map(frames, poses, {"radius_mm": 1.0})
    with pytest.raises(tac3d.Error, match="option 'depth' takes a int, not 'deep'"):
        tac3d.friction_map(frames, poses, {"depth": "deep"})
    with pytest.raises(tac3d.Error, match="^radius = -1 is out of range: must be > 0"):
        tac3d.friction_map(frames, poses, {"radius": -1.0})
    with pytest.raises(tac3d.Error, match="no_such.yaml"):
        tac3d.friction_map(frames, poses, config="no_such.yaml")


def small_slide(folder):
    """A 6 x 6-marker fingertip on a 12 mm dome (conftest's small sensor, more markers) pressed
    0.15 mm into a 5 mm ball (mu 0.3) and slid 1.2 mm along x: 36 steps."""
    cfg = yaml.safe_load(tac3d.default_sensor_yaml())
    cfg["markers"]["rows"] = cfg["markers"]["cols"] = 6
    cfg["elastic_body"].update(base_diameter_mm=12.0, thickness_mm=3.0, outer_radius_mm=20.0)
    sensor = folder / "small_sensor.yaml"
    sensor.write_text(yaml.safe_dump(cfg))
    scene = folder / "small_slide.yaml"
    scene.write_text(f"""name: small_slide
sensor: {sensor}
deviation: {{mesh_refinement: 1.0, youngs_modulus_factor: 1.0, poisson_ratio_factor: 1.0}}
objects:
  - {{name: ball, shape: sphere, radius_mm: 5, position_mm: [0, 0, 8.0], friction: {{default: 0.3}}}}
trajectory:
  steps: 36
  keyframes:
    - {{t_s: 0, position_mm: [0, 0, -0.05]}}
    - {{t_s: 0.1, position_mm: [0, 0, -0.05]}}
    - {{t_s: 0.3, position_mm: [0, 0, 0.15]}}
    - {{t_s: 0.7, position_mm: [1.2, 0, 0.15]}}
""")
    return sensor, scene


def quaternion(r):
    """(qw, qx, qy, qz) of a rotation matrix."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(r))) / 2.0
    if w > 1e-6:
        return w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), \
            (r[1, 0] - r[0, 1]) / (4 * w)
    pytest.skip("the scene's poses rotate by pi")


def test_cli_and_python_give_the_same_map_of_a_twin_slide(tmp_path, tac3d_cli, cache_dir):
    sensor, scene = small_slide(tmp_path)
    dataset = tmp_path / "ds"
    tac3d.simulate(str(scene), str(dataset), cache_dir=cache_dir, twin_options=SMALL_TWIN)
    recording = tmp_path / "slide.rec"
    [report] = tac3d.run([tac3d.SensorSpec("TWIN", f"dataset:{dataset}", config=str(sensor),
                                           reference_frames=3, record=str(recording))],
                         cache_dir=cache_dir)
    assert report.failure == ""
    frames = tac3d.open_recording(str(recording), images=False)
    truth = tac3d.Dataset(str(dataset)).truth()
    assert len(frames) == len(truth["index"]) == 36
    # The dataset's poses at the frames' timestamps, for the CLI (exactly: each at a knot).
    poses = truth["world_from_sensor"]
    lines = ["t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz"]
    for t, pose in zip(frames.timestamps, poses):
        values = [t, *pose[:3, 3], *quaternion(pose[:3, :3])]
        lines.append(",".join(repr(float(v)) for v in values))
    (tmp_path / "poses.csv").write_text("\n".join(lines) + "\n")

    out = tmp_path / "map"
    subprocess.run([tac3d_cli, "friction-map", "--recording", str(recording), "--poses",
                    str(tmp_path / "poses.csv"), "--config", str(sensor), "--out", str(out),
                    "--json"], check=True, capture_output=True, timeout=120)
    cli = json.loads((out / "summary.json").read_text())["map"]
    python = tac3d.friction_map(frames, poses, config=str(sensor))["summary"]

    # A map with known and unknown vertices from steady gross slip, not an empty one.
    assert cli["status"] == "ok", cli
    assert cli["gross_slip_frames"] > 0 and cli["voting_slip_points"] > 0
    assert 0 < cli["unknown_fraction"] < 1
    figures = {k for k in cli if not k.endswith("time_s")}
    assert figures == {k for k in python if not k.endswith("time_s")}
    for k in sorted(figures):
        if isinstance(cli[k], float):
            assert python[k] == pytest.approx(cli[k], rel=1e-12, abs=1e-15), k
        else:
            assert python[k] == cli[k], k
