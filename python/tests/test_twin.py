"""The twin (scenes, simulate, datasets), the in-process pipeline on twin images, the design
solver and the friction map, each as a user calls it."""
import time

import numpy as np
import pytest

import tac3d
from conftest import SMALL_TWIN, synthetic_frame


def test_builtin_scenes_and_loading():
    names = tac3d.builtin_scenes()
    assert {"probe", "pins", "two_material_slide", "friction_block"} <= set(names)
    scene = tac3d.load_scene("probe")
    info = scene.info()
    assert info["name"] == "probe" and info["steps"] == scene.steps == 126
    assert info["marker_rows"] == 20 and info["objects"][0]["shape"] == "flat_punch"
    assert info["objects"][0]["world_from_object"].shape == (4, 4)
    with pytest.raises(tac3d.Error, match="probe"):  # the message lists the names
        tac3d.load_scene("no_such_scene")


def test_scene_errors_name_the_key(tmp_path):
    with pytest.raises(tac3d.Error, match="torus"):
        tac3d.parse_scene("name: x\nsensor: default\nobjects:\n  - {name: a, shape: torus}\n"
                          "trajectory: {steps: 2, keyframes: [{t_s: 0, position_mm: [0,0,0]}, "
                          "{t_s: 1, position_mm: [0,0,1]}]}\n")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    with pytest.raises(tac3d.Error, match="bad.yaml"):
        tac3d.load_scene(str(bad))


@pytest.fixture
def simulated(tmp_path, small_scene, cache_dir):
    out = tmp_path / "ds"
    calls = []
    summary = tac3d.simulate(str(small_scene), str(out), cache_dir=cache_dir,
                             progress=lambda done, total: calls.append((done, total)),
                             twin_options=SMALL_TWIN)
    return out, summary, calls


def test_simulate_writes_a_dataset_whose_truth_loads_as_arrays(simulated):
    out, summary, calls = simulated
    assert calls == [(k, 11) for k in range(1, 12)]
    assert summary["steps"] == 11 and summary["non_converged_steps"] == 0
    assert summary["contact_steps"] == 9  # from t = 0.4 s on
    ds = tac3d.Dataset(str(out))
    assert len(ds) == 11 and ds.steps == list(range(11))
    assert ds.header["name"] == "small_press"
    truth = ds.truth()
    assert truth["marker_positions"].shape == (11, 9, 3)
    assert truth["marker_forces"].shape == (11, 9, 3)
    assert truth["marker_contact"].dtype == np.bool_ and truth["marker_contact"].shape == (11, 9)
    assert truth["world_from_sensor"].shape == (11, 4, 4)
    np.testing.assert_allclose(truth["t"], np.linspace(0, 2, 11))
    np.testing.assert_allclose(truth["world_from_sensor"][10, :3, 3], [0.5, 0, 0.1], atol=1e-12)
    # Pressing, the normal force grows, pushing down (-z) on the fingertip; sliding along +x,
    # friction on the fingertip points along -x.
    fz = truth["total_force"][:, 2]
    assert fz[0] == 0 and fz[5] < -0.01 and np.all(np.diff(fz[:6]) <= 1e-12)
    assert truth["total_force"][10, 0] < 0
    assert truth["marker_contact"][10].any()
    np.testing.assert_allclose(truth["marker_forces"].sum(axis=1), truth["total_force"], atol=1e-3)
    step = ds.step(10, surface=True)
    np.testing.assert_array_equal(step["marker_forces"], truth["marker_forces"][10])
    assert step["image"].dtype == np.uint8 and step["image"].ndim == 2
    assert step["surface_tractions"].shape[1] == 3


def test_simulate_errors_and_a_raising_progress_callback(tmp_path, small_scene, cache_dir):
    with pytest.raises(tac3d.Error, match="steps must be >= 0"):
        tac3d.simulate(str(small_scene), str(tmp_path / "a"), steps=-1)
    with pytest.raises(tac3d.Error, match="no_such_scene"):
        tac3d.simulate("no_such_scene", str(tmp_path / "b"))
    with pytest.raises(tac3d.Error, match="unknown key 'margin'"):
        tac3d.simulate(str(small_scene), str(tmp_path / "c"), twin_options={"margin": 1})
    # Issue 22, defect 10: Python created the missing folders the CLI refuses.
    with pytest.raises(tac3d.Error, match="dataset folder .* the folder '.*missing/dir' does not exist"):
        tac3d.simulate(str(small_scene), str(tmp_path / "missing" / "dir" / "sim"))
    with pytest.raises(tac3d.Error, match="cache folder .* the folder '.*missing' does not exist"):
        tac3d.simulate(str(small_scene), str(tmp_path / "e"),
                       cache_dir=str(tmp_path / "missing" / "cache"))
    assert not (tmp_path / "missing").exists()

    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt("stop here")

    with pytest.raises(KeyboardInterrupt, match="stop here"):
        tac3d.simulate(str(small_scene), str(tmp_path / "d"), cache_dir=cache_dir,
                       progress=stop, twin_options=SMALL_TWIN)
    assert len(tac3d.Dataset(str(tmp_path / "d"))) == 2  # complete steps only
    with pytest.raises(tac3d.Error):
        tac3d.Dataset(str(tmp_path / "nothing_here"))


def test_dataset_images_as_a_frame_source(simulated):
    out, _, _ = simulated
    source = tac3d.open_source(f"dataset:{out}")
    frames = list(source)
    assert len(frames) == 11
    image, t, index = frames[3]
    assert image.dtype == np.uint8 and image.ndim == 2 and index == 3
    assert t == pytest.approx(0.6)
    np.testing.assert_array_equal(image, tac3d.Dataset(str(out)).step(3)["image"])
    with pytest.raises(tac3d.Error):
        tac3d.open_source("/no/such/video.avi")


def test_design_light_path_returns_the_papers_layout():
    d = tac3d.design_light_path()
    assert d["chosen"] is not None and d["sensor_yaml"]
    root = d["roots"][d["chosen"]]
    assert root["valid"] and root["rejections"] == []
    assert root["parallax_deg"] == pytest.approx(90.0, abs=1e-6)
    assert root["max_residual"] < 1e-9
    np.testing.assert_allclose(root["camera"], [0.0, -40.0])
    assert d["summary"]["starts"] == 8 ** 4
    with pytest.raises(tac3d.Error, match="fov"):
        tac3d.design_light_path(fov_deg=-5)


def test_friction_map_reports_no_contact_and_checks_its_input():
    frames = [synthetic_frame(k) for k in range(3)]
    for f in frames:
        f.forces = np.zeros((400, 3))
    poses = np.tile(np.eye(4), (3, 1, 1))
    m = tac3d.friction_map(frames, poses)
    assert m["summary"]["status"] == "no_contact"
    assert m["vertices"].shape == (0, 3) and m["mu"].shape == (0,)
    with pytest.raises(tac3d.Error, match="more frames than the 2 poses"):
        tac3d.friction_map(frames, poses[:2])
    with pytest.raises(tac3d.Error, match="unknown option 'radius_mm'"):
        tac3d.friction_map(frames, poses, {"radius_mm": 1.0})
    with pytest.raises(tac3d.Error, match="radius = -1"):
        tac3d.friction_map(frames, poses, {"radius": -1.0})


def test_recompute_forces_gives_the_pipelines_forces_from_recorded_displacements(
        simulated, small_sensor_yaml, cache_dir):
    out, _, _ = simulated
    frames = []
    spec = tac3d.SensorSpec("PY-PIPE", f"dataset:{out}", config=str(small_sensor_yaml),
                            reference_frames=3)
    tac3d.run([spec], cache_dir=cache_dir, on_frame=frames.append)
    measured = frames[3:]  # past the reference
    d = np.stack([f.displacements for f in measured])
    pipeline = tac3d.Pipeline(config=str(small_sensor_yaml), cache_dir=cache_dir)
    again = pipeline.recompute_forces(d, positions=np.stack([f.positions for f in measured]),
                                      timestamps=[f.timestamp for f in measured])
    assert len(again) == len(measured)
    for old, new in zip(measured, again):
        np.testing.assert_allclose(new.resultant_force, old.resultant_force, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(new.forces, old.forces, rtol=1e-6, atol=1e-9)
        np.testing.assert_array_equal(new.contact, old.contact)
    assert abs(measured[-1].resultant_force[2]) > 0.01  # a press, not zeros compared
    # Another weight is another inverse: a far larger one shrinks the forces.
    heavier = tac3d.Pipeline(config=str(small_sensor_yaml), cache_dir=cache_dir, weight=50.0)
    assert abs(heavier.recompute_forces(d)[-1].resultant_force[2]) < \
        0.9 * abs(measured[-1].resultant_force[2])
    # A lost marker (NaN) is lost, not a NaN force.
    d[-1, 4] = np.nan
    lost = pipeline.recompute_forces(d)[-1]
    assert not lost.valid[4] and np.isfinite(lost.forces).all() and lost.has("markers_lost")
    with pytest.raises(tac3d.Error, match=r"T x 9 x 3"):
        pipeline.recompute_forces(np.zeros((2, 10, 3)))
    with pytest.raises(tac3d.Error, match="timestamps must hold 2 values"):
        pipeline.recompute_forces(np.zeros((2, 9, 3)), timestamps=[0.0])


def test_pipeline_in_process_on_the_twin_images(simulated, small_sensor_yaml, cache_dir):
    out, _, _ = simulated
    truth = tac3d.Dataset(str(out)).truth()
    # The images through the runtime (tac3d.run), every frame to Python.
    frames = []
    spec = tac3d.SensorSpec("PY-PIPE", f"dataset:{out}", config=str(small_sensor_yaml),
                            reference_frames=3)
    [report] = tac3d.run([spec], cache_dir=cache_dir, on_frame=frames.append)
    assert report.frames == 11 and report.failure == ""
    assert len(frames) == 11
    assert [f.initializing for f in frames[:3]] == [True, True, False]
    assert frames[0].has("initializing") and frames[0].sn == "PY-PIPE"
    last = frames[-1]
    assert last.positions.shape == (9, 3) and last.valid.all()
    # Pressed 0.1 mm: the measured normal force has the truth's sign and size (the inverse on
    # 9 markers is coarse: within a factor of 2).
    fz_true = truth["total_force"][10, 2]
    assert fz_true < -0.05
    assert 0.5 * fz_true > last.resultant_force[2] > 2.0 * fz_true
    np.testing.assert_allclose(last.positions, truth["marker_positions"][10], atol=0.05)

    # The pipeline one image at a time: zero() makes the next frames build a new reference.
    pipeline = tac3d.Pipeline(config=str(small_sensor_yaml), cache_dir=cache_dir,
                              reference_frames=3, sn="PY-PIPE")
    image = tac3d.Dataset(str(out)).step(0)["image"]
    first = [pipeline.process(image, timestamp=0.1 * k) for k in range(4)]
    assert [f.initializing for f in first] == [True, True, False, False]
    pipeline.zero()
    again = [pipeline.process(image, timestamp=2.0 + 0.1 * k) for k in range(3)]
    assert [f.initializing for f in again] == [True, True, False]
    assert again[2].index == 6 and again[2].timestamp == pytest.approx(2.2)
    assert abs(again[2].resultant_force[2]) < 0.01  # the step-0 image, unloaded
    assert not pipeline.initializing

    with pytest.raises(tac3d.Error, match="2D uint8"):
        pipeline.process(image.astype(np.float32))
    with pytest.raises(tac3d.Error):
        pipeline.process(np.zeros((10, 10), np.uint8))  # not the camera's size
    with pytest.raises(tac3d.Error, match="weight"):
        tac3d.Pipeline(config=str(small_sensor_yaml), cache_dir=cache_dir, weight=-1)
    with pytest.raises(tac3d.Error, match="no_such.yaml"):
        tac3d.Pipeline(config="no_such.yaml", cache_dir=cache_dir)
    # Issue 22, defect 10: a NaN timestamp gave a frame that validate() and RecordingWriter
    # then refused.
    with pytest.raises(tac3d.Error, match="timestamp nan s is not finite"):
        pipeline.process(image, timestamp=float("nan"))


def test_friction_map_of_a_flat_slide_recovers_mu():
    """Oracle: a 20 x 20 grid pressed flat (F_n 0.05 N, F_t 0.02 N each: mu 0.4) on a plane,
    sliding 0.1 mm a frame along x for 12 frames: every marker slips in each of the 11 pairs,
    the mesh is the plane 0.5 mm (the cover) above the markers, and mu is 0.4 everywhere."""
    g = (np.arange(20) - 9.5) * 1.27
    x, y = np.meshgrid(g, g)
    frames, poses = [], []
    for k in range(12):
        f = tac3d.TactileFrame(20, 20)
        f.positions = np.stack([x.ravel(), y.ravel(), np.full(400, 7.5)], axis=1)
        f.normals = np.tile([0.0, 0.0, 1.0], (400, 1))
        f.forces = np.tile([-0.02, 0.0, -0.05], (400, 1))  # F_t against the slide (+x)
        f.index, f.timestamp = k, 0.1 * k
        frames.append(f)
        pose = np.eye(4)
        pose[0, 3] = 0.1 * k
        poses.append(pose)
    m = tac3d.friction_map(frames, np.array(poses))
    assert m["summary"]["status"] == "ok" and m["summary"]["slip_points"] == 11 * 400
    assert m["slip_points"].shape == (4400, 3)
    np.testing.assert_allclose(m["slip_mu"], 0.4, rtol=1e-12)
    assert m["vertices"].shape[0] > 100 and m["triangles"].shape[1] == 3
    assert m["triangles"].max() < m["vertices"].shape[0]
    np.testing.assert_allclose(m["vertices"][:, 2], 8.0, atol=0.05)
    known = ~np.isnan(m["mu"])
    assert known.mean() > 0.9
    np.testing.assert_allclose(m["mu"][known], 0.4, rtol=1e-9)


def alias_bomb():
    """Eight levels of ten aliases of the level above: 10^8 values for every YAML reader."""
    lines = ["a0: &a0 [" + ", ".join(["x"] * 10) + "]"]
    for level in range(1, 8):
        lines.append(f"a{level}: &a{level} [" + ", ".join([f"*a{level - 1}"] * 10) + "]")
    return "\n".join(lines) + "\n"


def test_yaml_aliases_are_bounded(tmp_path, cache_dir):
    """Issue 22, defect 7: parse_scene and Pipeline(config=...) ran for minutes on 332 bytes."""
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(alias_bomb())
    t0 = time.time()
    with pytest.raises(tac3d.Error, match="line 4: the aliases .* more than 10000 values"):
        tac3d.parse_scene(alias_bomb())
    with pytest.raises(tac3d.Error, match="bomb.yaml: line 4: the aliases"):
        tac3d.Pipeline(config=str(bomb), cache_dir=cache_dir)
    assert time.time() - t0 < 2
