"""One episode: drawn from the spec, simulated by the twin in memory (tac3d.simulate_arrays),
written as a zarr group under a temporary name and renamed into place when complete."""
import functools
import os
import pathlib
import shutil
import socket
import time
import uuid

import numpy as np

from .. import _core
from . import store


@functools.lru_cache(maxsize=4)
def load_spec(path):
    """The parsed spec (cached: a worker runs many episodes of one spec)."""
    return _core.load_dataset_spec(str(path))


# The pipeline's slip estimate, FrameSlip's fields by their stored names (measured_<name>), as
# tac3d.Recording.slip names them.
MEASURED_SLIP = {"slip_fraction": "fraction", "friction": "friction", "friction_sigma": "friction_sigma",
                 "slip_margin": "margin", "slip_margin_sigma": "margin_sigma",
                 "least_normal_force": "least_normal_force_n"}


def measured_arrays(recording):
    """What the sensor measured, as arrays measured_* (docs/datasets.md, "What the sensor
    measures"), from the tac3d.Recording simulate_arrays(measure=True) returns: one TactileFrame
    a step."""
    slip = recording.slip
    arrays = {
        "measured_marker_positions": recording.positions,
        "measured_marker_displacements": recording.displacements,
        "measured_marker_forces": recording.forces,
        "measured_marker_normals": recording.normals,
        "measured_marker_valid": recording.valid,
        "measured_marker_contact": recording.contact,
        "measured_total_force": recording.resultant_forces,
        "measured_total_moment": recording.resultant_moments,
        "measured_flags": recording.flags,
        "measured_slip_state": slip["state"].astype(np.uint8),
    }
    arrays.update({f"measured_{name}": slip[field] for name, field in MEASURED_SLIP.items()})
    return arrays


def episode_arrays(simulated):
    """The episode's arrays (docs/datasets.md, "Storage") from tac3d.simulate_arrays' result."""
    arrays = dict(simulated)
    del arrays["summary"]
    if "measured" in arrays:
        arrays.update(measured_arrays(arrays.pop("measured")))
    arrays["sensor_pose"] = arrays.pop("world_from_sensor")
    # The true marker displacement since the episode's first (unloaded) frame.
    positions = arrays["marker_positions"]
    arrays["marker_displacements"] = positions - positions[:1]
    return arrays


def run_episode(spec_path, out, episode, cache_dir="", measured=False):
    """Generates episode `episode` into out/episodes unless it is complete already; returns
    its manifest record {episode, seed, parameters, checksum, seconds, steps, worker, measured}.
    With `measured`, the rendered images also go through the sensor's pipeline and what it
    measures is stored beside the truth.

    Safe to run twice at once or again after a kill: the group is written in a temporary
    folder of this process and renamed into place; a loser of the race keeps the winner's."""
    done = store.complete_record(out, episode)
    if done:
        return done
    start = time.perf_counter()
    spec = load_spec(spec_path)
    draw = spec.draw(episode)
    folder = pathlib.Path(out) / store.EPISODES
    folder.mkdir(exist_ok=True)
    tag = f"{socket.gethostname()}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    tmp = folder / f".episode_{episode:06d}.{tag}.tmp"
    try:
        # Made first: while the episode runs, its temporary names the worker running it.
        tmp.mkdir()
        scene = _core.parse_scene(draw["scene_yaml"], ".")
        simulated = _core.simulate_arrays(scene, cache_dir=cache_dir, images=spec.images,
                                          twin_options=spec.twin_options, measure=measured)
        summary = simulated["summary"]
        arrays = episode_arrays(simulated)
        digest = store.checksum(arrays, draw["parameters"])
        record = {
            "episode": episode,
            "seed": draw["seed"],
            "parameters": draw["parameters"],
            "checksum": digest,
            "steps": int(arrays["t"].shape[0]),
            "seconds": round(time.perf_counter() - start, 3),
            "worker": tag.rsplit("-", 1)[0],
            "measured": measured,
        }
        attrs = {
            "format": store.FORMAT,
            "version": store.VERSION,
            "spec": spec.name,
            "episode": episode,
            "seed": draw["seed"],
            "parameters": draw["parameters"],
            "scene": draw["scene_yaml"],
            "simulation": {k: summary[k] for k in ("steps", "contact_steps", "non_converged_steps",
                                                   "youngs_modulus_scale")},
            "record": record,
        }
        if measured:
            attrs["measurement"] = summary["measurement"]
        store.write_group(tmp, arrays, attrs)
        try:
            os.rename(tmp, store.episode_path(out, episode))
        except OSError:
            # Another attempt finished first (a task Dask ran again): keep its group.
            winner = store.complete_record(out, episode)
            if not winner:
                raise
            record = winner
        return record
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
