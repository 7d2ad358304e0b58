"""Randomized twin datasets (tac3d.datasets, `tac3d dataset`): examples/datasets/small.yaml (a
3 x 3 marker sensor, 10-step episodes) generated on local Dask clusters, read back, verified."""
import json
import os
import re
import shutil
import signal
import subprocess
import time

import numpy as np
import pytest
import zarr

import tac3d
import tac3d.datasets
from conftest import REPO

SMALL = REPO / "examples" / "datasets" / "small.yaml"
EPISODES = 4


def generate(cli, cache_dir, out, workers, episodes=EPISODES, spec=SMALL, wait=True, options=()):
    cmd = [cli, "dataset", "generate", "--spec", str(spec), "--out", str(out),
           "--episodes", str(episodes), "--workers", str(workers), "--json", *options]
    env = dict(os.environ, TAC3D_CACHE_DIR=cache_dir)
    if not wait:
        return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    run = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def checksums(out):
    return {r["episode"]: r["checksum"] for r in tac3d.datasets.Dataset(out).manifest()}


@pytest.fixture(scope="module")
def two_workers(tmp_path_factory, tac3d_cli, cache_dir):
    """small.yaml's first 4 episodes on a local cluster of 2 workers."""
    out = tmp_path_factory.mktemp("datasets") / "small2"
    result = generate(tac3d_cli, cache_dir, out, workers=2)
    return out, result


def test_episode_draws_depend_only_on_the_spec_seed_and_the_index(tmp_path):
    spec = tac3d.datasets.load_spec(str(SMALL))
    assert (spec.name, spec.steps, spec.images) == ("small", 10, True)
    draws = [spec.draw(i) for i in range(6)]
    assert [d["episode"] for d in draws] == list(range(6))
    assert spec.draw(3) == draws[3]  # nothing carried from one draw to the next
    assert len({d["seed"] for d in draws}) == 6
    assert len({json.dumps(d["parameters"], sort_keys=True) for d in draws}) == 6
    # A copy of the spec with another seed draws other episodes.
    reseeded = tmp_path / "small.yaml"
    reseeded.write_text(SMALL.read_text().replace("seed: 2026", "seed: 2027"))
    (tmp_path / "small_sensor.yaml").write_text((SMALL.parent / "small_sensor.yaml").read_text())
    assert tac3d.datasets.load_spec(str(reseeded)).draw(3)["seed"] != draws[3]["seed"]
    scene = tac3d.parse_scene(draws[0]["scene_yaml"])
    assert scene.steps == 10 and scene.info()["marker_rows"] == 3


def test_a_malformed_spec_is_refused_naming_the_line(tmp_path, tac3d_cli, cache_dir):
    (tmp_path / "small_sensor.yaml").write_text((SMALL.parent / "small_sensor.yaml").read_text())
    text = SMALL.read_text()
    cases = {
        "dup.yaml": (text.replace("steps: 10 ", "steps: 10\nsteps: 12 "),
                     r"dup.yaml: line 7: duplicated key 'steps' \(first at line 6\)"),
        "typo.yaml": (text.replace("images: true", "imagez: true"),
                      r"typo.yaml: line 7: imagez: unknown key \(misspelt\?\)"),
        "range.yaml": (text.replace("mu: {uniform: [0.3, 1.0]}", "mu: {uniform: [0.3, 9]}"),
                       r"range.yaml: line 22: friction.mu.uniform\[1\]: 9 is out of range: must be in \[0, 5\]"),
    }
    for name, (bad, message) in cases.items():
        assert bad != text
        path = tmp_path / name
        path.write_text(bad)
        with pytest.raises(tac3d.Error, match=message):
            tac3d.datasets.load_spec(str(path))
        run = subprocess.run([tac3d_cli, "dataset", "generate", "--spec", str(path), "--out",
                              str(tmp_path / "never"), "--episodes", "2"],
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == 1 and re.search(message, run.stderr), run.stderr
    assert not (tmp_path / "never").exists()  # refused before anything is written


def test_two_workers_write_every_episode_with_its_truth(two_workers):
    out, result = two_workers
    assert result["episodes"] == result["generated"] == EPISODES and result["workers"] == 2
    ds = tac3d.datasets.open(out)
    assert len(ds) == EPISODES and ds.ids == list(range(EPISODES))
    manifest = ds.manifest()
    assert [r["episode"] for r in manifest] == list(range(EPISODES))
    assert tac3d.datasets.verify(out) == {"episodes": EPISODES, "verified": EPISODES, "problems": []}
    spec = tac3d.datasets.load_spec(str(SMALL))
    for episode, record in zip(ds, manifest):
        draw = spec.draw(episode.id)
        assert episode.parameters == draw["parameters"] == record["parameters"]
        assert episode.seed == draw["seed"] == record["seed"]
        assert len(episode) == 10 and record["steps"] == 10
        frames = list(episode.frames(surface=True))
        assert len(frames) == 10
        f = frames[-1]
        assert f["image"].dtype == np.uint8 and f["image"].ndim == 2
        assert f["marker_positions"].shape == f["marker_forces"].shape == (9, 3)
        assert f["sensor_pose"].shape == (4, 4) and f["marker_contact"].dtype == np.bool_
        assert f["surface_tractions"].shape[1] == 3
        # Truth that holds whatever was drawn: the first frame is clear of the object and
        # unloaded; the marker forces sum to the total; displacements start at zero.
        np.testing.assert_array_equal(frames[0]["total_force"], 0)
        np.testing.assert_array_equal(frames[0]["marker_displacements"], 0)
        for g in frames:
            np.testing.assert_allclose(g["marker_forces"].sum(axis=0), g["total_force"], atol=1e-3)
        # A press or slide ends pressed: the object pushes the fingertip down (-z).
        if draw["parameters"]["trajectory"]["kind"] != "lift":
            assert f["total_force"][2] < 0 and f["marker_contact"].any()
        forces = episode.array("marker_forces")
        np.testing.assert_array_equal(forces[-1], f["marker_forces"])
        # The friction truth: the drawn mu (the object's or a region's) where a node touches.
        states, mu = episode.array("surface_states"), episode.array("surface_friction")
        assert mu.shape == states.shape and (states > 0).any()
        assert np.isnan(mu[states == 0]).all()
        drawn = draw["parameters"]["friction"]
        assert set(np.unique(mu[states > 0])) <= {drawn["mu"]} | {r["mu"] for r in drawn["regions"]}
    assert not [p for p in (out / "episodes").iterdir() if p.name.startswith(".")]


def test_frames_read_in_blocks_are_the_stored_arrays(two_workers, monkeypatch):
    out, _ = two_workers
    monkeypatch.setattr(tac3d.datasets.store, "READ_BLOCK_FRAMES", 3)  # 10 frames: 4 blocks
    episode = tac3d.datasets.open(out)[1]
    frames = list(episode.frames(surface=True))
    for name, key in (("images", "image"), ("surface_tractions", "surface_tractions"),
                      ("surface_friction", "surface_friction"), ("t", "t")):
        np.testing.assert_array_equal(np.stack([f[key] for f in frames]), episode.array(name))


def scene_with_youngs_modulus(draw, factor):
    scene = json.loads(draw["scene_yaml"])
    scene["deviation"]["youngs_modulus_factor"] = factor
    return tac3d.parse_scene(json.dumps(scene))


def test_youngs_modulus_scales_one_body_model(cache_dir):
    spec = tac3d.datasets.load_spec(str(SMALL))
    draw = next(d for d in map(spec.draw, range(20)) if d["parameters"]["trajectory"]["kind"] == "press")

    def simulate(factor, **options):
        return tac3d.simulate_arrays(scene_with_youngs_modulus(draw, factor), cache_dir=cache_dir,
                                     images=False, twin_options=spec.twin_options, **options)

    at_e, at_2e = simulate(1.0), simulate(2.0)
    assert at_2e["summary"]["youngs_modulus_scale"] == 2.0
    assert at_e["total_force"][-1, 2] < -0.01
    # The contact is displacement-driven: at 2E the same indentation takes twice the forces
    # and moves the markers as much.
    np.testing.assert_allclose(at_2e["total_force"], 2 * at_e["total_force"], rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(at_2e["marker_positions"], at_e["marker_positions"], atol=1e-7)
    # The body model built at 2E (what `tac3d simulate` uses) gives the same truth.
    built = simulate(2.0, scale_youngs_modulus=False)
    assert built["summary"]["twin_body"]["cache_file"] != at_e["summary"]["twin_body"]["cache_file"]
    np.testing.assert_allclose(at_2e["total_force"], built["total_force"], rtol=1e-4, atol=1e-7)


def test_a_load_ramp_loads_through_partial_slip_into_gross_slip(cache_dir):
    spec = tac3d.datasets.load_spec(str(SMALL))
    draw = next(d for d in map(spec.draw, range(40)) if d["parameters"]["trajectory"]["kind"] == "load_ramp")
    scene = json.loads(draw["scene_yaml"])
    scene["trajectory"]["steps"] = 40  # small.yaml's 10 steps hold too few on the ramp
    load = scene["trajectory"]["tangential_load"]
    drawn = draw["parameters"]["trajectory"]
    assert (load["rate_per_s"], load["final_load"]) == (drawn["rate_per_s"], drawn["final_load"])
    assert 1.1 <= load["final_load"] <= 1.5
    run = tac3d.simulate_arrays(tac3d.parse_scene(json.dumps(scene)), cache_dir=cache_dir,
                                images=False, twin_options=spec.twin_options)
    assert run["summary"]["non_converged_steps"] == 0
    direction = np.radians(load["direction_deg"])
    phases, previous_capacity = [], 0.0
    for t, q, mu, states in zip(run["t"], run["surface_tractions"], run["surface_friction"],
                                run["surface_states"]):
        touching = states > 0
        # The friction capacity sum mu p, and |sum q| (the grid's cell area cancels).
        capacity = (mu[touching] * -q[touching, 2]).sum()
        tangential = np.hypot(*q[:, :2].sum(axis=0))
        if t >= load["start_s"]:
            asked = min(load["rate_per_s"] * (t - load["start_s"]), load["final_load"])
            stick, slip = (states == 1).sum(), (states == 2).sum()
            if stick:  # the load asked for, of the previous step's capacity
                assert tangential == pytest.approx(asked * previous_capacity, rel=1e-3, abs=1e-9), t
            else:  # sliding as a whole: Q = mu P, the load asked for being above it
                assert tangential == pytest.approx(capacity, rel=1e-6) and asked * previous_capacity >= (1 - 1e-6) * capacity, t
            if asked > 0.05:
                angle = np.arctan2(q[:, 1].sum(), q[:, 0].sum())
                assert abs(np.angle(np.exp(1j * (angle - direction)))) < 1e-3, t
            phases.append("stick" if slip == 0 else "gross" if stick == 0 else "partial")
        previous_capacity = capacity
    # Stick (or nearly: a curved contact's rim slips radially), then partial slip, then gross.
    order = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    assert order[-2:] == ["partial", "gross"] and order.count("gross") == 1, phases
    assert phases.count("partial") >= 5 and phases.count("gross") >= 3, phases


def test_a_rerun_skips_finished_episodes(two_workers, tac3d_cli, cache_dir):
    out, _ = two_workers
    group = out / "episodes" / "episode_000002.zarr" / ".zattrs"
    before = group.stat().st_mtime_ns
    result = generate(tac3d_cli, cache_dir, out, workers=2)
    assert (result["generated"], result["skipped"], result["episodes"]) == (0, EPISODES, EPISODES)
    assert group.stat().st_mtime_ns == before
    # One more episode runs only that one.
    more = generate(tac3d_cli, cache_dir, out, workers=2, episodes=EPISODES + 1)
    assert (more["generated"], more["skipped"]) == (1, EPISODES)
    assert tac3d.datasets.verify(out)["verified"] == EPISODES + 1


def test_one_and_two_workers_give_identical_checksums(two_workers, tmp_path, tac3d_cli, cache_dir):
    out, _ = two_workers
    one = tmp_path / "small1"
    generate(tac3d_cli, cache_dir, one, workers=1)
    reference = {k: v for k, v in checksums(out).items() if k < EPISODES}
    assert checksums(one) == reference
    assert len(set(reference.values())) == EPISODES


# Array names of what the sensor measured, by the TactileFrame field a replay compares them to.
MEASURED_MARKERS = {"measured_marker_positions": "positions", "measured_marker_displacements": "displacements",
                    "measured_marker_forces": "forces", "measured_marker_normals": "normals",
                    "measured_marker_valid": "valid", "measured_marker_contact": "contact"}
MEASURED_FRAME = {"measured_total_force": "resultant_force", "measured_total_moment": "resultant_moment",
                  "measured_flags": "flags", "measured_slip_fraction": "slip_fraction",
                  "measured_friction": "friction", "measured_friction_sigma": "friction_sigma",
                  "measured_slip_margin": "slip_margin", "measured_slip_margin_sigma": "slip_margin_sigma",
                  "measured_least_normal_force": "least_normal_force_n"}
SLIP_STATES = ("unknown", "none", "stick", "partial_slip", "gross_slip")  # measured_slip_state's codes


def replay_through_the_pipeline(reference_images, images, times, cache_dir):
    """The frames tac3d.Pipeline, as a user runs it on small.yaml's sensor (its defaults), gives
    for the reference images (the sensor at rest before step 0) and then each step's image."""
    pipeline = tac3d.Pipeline(config=str(SMALL.parent / "small_sensor.yaml"), cache_dir=cache_dir)
    count = len(reference_images)
    for k, image in enumerate(reference_images):
        pipeline.process(image, timestamp=times[0] - (count - k) / 30.0)
    assert not pipeline.initializing
    return [pipeline.process(image, timestamp=float(t)) for image, t in zip(images, times)]


def assert_measured_as_replayed(stored, replayed):
    """The stored measured_* arrays (name -> T-first array) equal the replayed TactileFrames,
    bit for bit (NaN where the pipeline gave NaN)."""
    assert len(replayed) == len(stored["measured_total_force"])
    for k, frame in enumerate(replayed):
        for name, field in {**MEASURED_MARKERS, **MEASURED_FRAME}.items():
            np.testing.assert_array_equal(stored[name][k], getattr(frame, field), err_msg=f"{name}, step {k}")
        assert SLIP_STATES[stored["measured_slip_state"][k]] == frame.slip_state, k


def test_measured_episodes_hold_the_pipelines_frames_of_their_images(tmp_path, tac3d_cli, cache_dir):
    """--measured on 2 Dask workers: each episode also holds what the sensor's pipeline measured on
    its rendered images; replaying the stored images (the reference, then each step's) through
    tac3d.Pipeline gives those arrays exactly, and they follow the truth."""
    out = tmp_path / "measured"
    result = generate(tac3d_cli, cache_dir, out, workers=2, episodes=3, options=["--measured"])
    assert result["measured"] is True and result["generated"] == 3
    assert tac3d.datasets.verify(out)["verified"] == 3
    ds = tac3d.datasets.open(out)
    pressed = 0
    for episode, record in zip(ds, ds.manifest()):
        assert episode.measured and record["measured"] is True
        measurement = episode.attrs["measurement"]
        # The compliance model was built once, by the client: the workers load it (or have it).
        assert measurement["compliance_model"]["cache_status"] in ("loaded from the cache", "in memory")
        assert measurement["reference_frames"] == 20 and measurement["sn"] == "TAC3D-TWIN"
        reference = episode.array("reference_images")
        assert reference.shape == (20, 480, 640) and reference.dtype == np.uint8
        frames = list(episode.frames())
        assert frames[0]["measured_marker_positions"].shape == (9, 3)
        stored = {name: np.stack([f[name] for f in frames]) for name in frames[0] if name.startswith("measured_")}
        assert set(stored) == set(MEASURED_MARKERS) | set(MEASURED_FRAME) | {"measured_slip_state"}
        replayed = replay_through_the_pipeline(reference, [f["image"] for f in frames],
                                               [f["t"] for f in frames], cache_dir)
        assert_measured_as_replayed(stored, replayed)
        # Measured, not made up: every marker seen past the reference, nothing on the sensor at
        # step 0, and under a press the normal force of the truth's sign and size (9 markers make
        # a coarse inverse: within a factor of 2).
        assert stored["measured_marker_valid"].all()
        assert not (stored["measured_flags"] & 16).any()  # never initializing
        assert np.linalg.norm(stored["measured_total_force"][0]) < 0.01
        for f in frames:
            if f["total_force"][2] < -0.05:
                pressed += 1
                assert 0.5 * f["total_force"][2] > f["measured_total_force"][2] > 2.0 * f["total_force"][2]
    assert pressed >= 3
    # A folder's episodes hold the same arrays: a run without the measurements is refused.
    run = subprocess.run([tac3d_cli, "dataset", "generate", "--spec", str(SMALL), "--out", str(out),
                          "--episodes", "4"], env=dict(os.environ, TAC3D_CACHE_DIR=cache_dir),
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 1 and "episodes 0, 1, 2 were generated with the sensor's measurements" in run.stderr
    assert len(tac3d.datasets.open(out)) == 3


def test_measured_without_stored_images_is_the_pipeline_on_the_same_images_rendered_again(
        tmp_path, cache_dir):
    """The spec's `measured: true` with `images: false`: the images are rendered for the pipeline
    and not stored; rendering the same episode again and replaying its images through
    tac3d.Pipeline gives the stored measurements exactly."""
    spec = tmp_path / "small.yaml"
    spec.write_text(SMALL.read_text().replace("images: true", "images: false\nmeasured: true"))
    shutil.copy(SMALL.parent / "small_sensor.yaml", tmp_path)
    out = tmp_path / "blind"
    result = tac3d.datasets.generate(str(spec), str(out), 1, workers=1, cache_dir=cache_dir)
    assert result["measured"] is True
    episode = tac3d.datasets.open(out)[0]
    assert episode.measured and not {"images", "reference_images"} & set(episode.arrays)
    draw = tac3d.datasets.load_spec(str(spec)).draw(0)
    again = tac3d.simulate_arrays(tac3d.parse_scene(draw["scene_yaml"]), cache_dir=cache_dir,
                                  twin_options=tac3d.datasets.load_spec(str(spec)).twin_options,
                                  images=True, measure=True)
    np.testing.assert_array_equal(again["marker_positions"], episode.array("marker_positions"))
    replayed = replay_through_the_pipeline(again["reference_images"], again["images"], again["t"], cache_dir)
    assert_measured_as_replayed({name: episode.array(name) for name in episode.arrays
                                 if name.startswith("measured_")}, replayed)


IN_FLIGHT = re.compile(r"^\.episode_(\d+)\..*-(\d+)-[0-9a-f]{8}\.tmp$")


def test_a_worker_killed_mid_run_leaves_the_dataset_complete(two_workers, tmp_path, tac3d_cli, cache_dir):
    out, _ = two_workers
    killed_out = tmp_path / "killed"
    run = generate(tac3d_cli, cache_dir, killed_out, workers=2, wait=False)
    killed = None
    deadline = time.monotonic() + 300
    while killed is None and run.poll() is None and time.monotonic() < deadline:
        folder = killed_out / "episodes"
        for name in (os.listdir(folder) if folder.is_dir() else []):
            m = IN_FLIGHT.match(name)
            if m:
                try:
                    os.kill(int(m.group(2)), signal.SIGKILL)
                    killed = (int(m.group(1)), int(m.group(2)))
                except ProcessLookupError:
                    continue
                break
        time.sleep(0.01)
    stdout, stderr = run.communicate(timeout=600)
    assert killed is not None, "no episode was seen in flight"
    assert run.returncode == 0, stderr
    assert json.loads(stdout.strip().splitlines()[-1])["episodes"] == EPISODES
    result = tac3d.datasets.verify(killed_out)
    assert result == {"episodes": EPISODES, "verified": EPISODES, "problems": []}
    # The episode in flight was run again, to the same arrays.
    reference = {k: v for k, v in checksums(out).items() if k < EPISODES}
    assert checksums(killed_out) == reference
    assert not [p for p in (killed_out / "episodes").iterdir() if p.name.startswith(".")]


def test_verify_finds_altered_arrays_and_repeated_lines(two_workers, tmp_path, tac3d_cli):
    out, _ = two_workers
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    forces = zarr.open_group(str(copy / "episodes" / "episode_000001.zarr"), mode="r+")["marker_forces"]
    forces[5, 0, 2] += 1e-9
    manifest = copy / "manifest.jsonl"
    lines = manifest.read_text().splitlines()
    manifest.write_text("\n".join(lines + lines[:1]) + "\n")
    result = tac3d.datasets.verify(copy)
    assert result["problems"] == ["episode 1: the arrays do not match the manifest's checksum",
                                  "episode 0 is in the manifest twice"]
    run = subprocess.run([tac3d_cli, "dataset", "verify", str(copy)], capture_output=True, text=True)
    assert run.returncode == 1 and "problem: episode 0 is in the manifest twice" in run.stdout
    with pytest.raises(tac3d.Error, match="not a tac3d dataset folder"):
        tac3d.datasets.verify(tmp_path / "nothing")
    with pytest.raises(tac3d.Error, match="not a tac3d dataset folder"):
        tac3d.datasets.open(tmp_path / "nothing")
