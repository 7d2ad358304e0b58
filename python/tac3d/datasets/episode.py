"""One episode: drawn from the spec, simulated by the twin (tac3d.simulate), stored as a zarr
group under a temporary name and renamed into place when complete."""
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


def twin_arrays(folder):
    """The episode's arrays from the twin's dataset folder (docs/datasets.md's twin layout)."""
    ds = _core.Dataset(str(folder))
    truth = ds.truth()
    arrays = {
        "t": truth["t"],
        "sensor_pose": truth["world_from_sensor"],
        "marker_positions": truth["marker_positions"],
        # The true marker displacement since the episode's first (unloaded) frame.
        "marker_displacements": truth["marker_positions"] - truth["marker_positions"][:1],
        "marker_forces": truth["marker_forces"],
        "marker_contact": truth["marker_contact"],
        "marker_slip": truth["marker_slip"],
        "total_force": truth["total_force"],
        "total_moment": truth["total_moment"],
    }
    images, tractions, states = [], [], []
    for k in ds.steps:
        step = ds.step(k, surface=True, image=True)
        if step["image"] is not None:
            images.append(step["image"])
        if "surface_tractions" in step:
            if "surface_positions" not in arrays:
                arrays["surface_positions"] = step["surface_positions"]
            tractions.append(step["surface_tractions"])
            states.append(step["surface_states"])
    if images:
        arrays["images"] = np.stack(images)
    if tractions:
        arrays["surface_tractions"] = np.stack(tractions)
        arrays["surface_states"] = np.stack(states)
    return arrays


def run_episode(spec_path, out, episode, cache_dir=""):
    """Generates episode `episode` into out/episodes unless it is complete already; returns
    its manifest record {episode, seed, parameters, checksum, seconds, steps, worker}.

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
    twin = folder / f".episode_{episode:06d}.{tag}.twin"
    try:
        scene = _core.parse_scene(draw["scene_yaml"], ".")
        summary = _core.simulate(scene, str(twin), cache_dir=cache_dir, images=spec.images,
                                 twin_options=spec.twin_options)
        arrays = twin_arrays(twin)
        digest = store.checksum(arrays, draw["parameters"])
        record = {
            "episode": episode,
            "seed": draw["seed"],
            "parameters": draw["parameters"],
            "checksum": digest,
            "steps": int(arrays["t"].shape[0]),
            "seconds": round(time.perf_counter() - start, 3),
            "worker": tag.rsplit("-", 1)[0],
        }
        attrs = {
            "format": store.FORMAT,
            "version": store.VERSION,
            "spec": spec.name,
            "episode": episode,
            "seed": draw["seed"],
            "parameters": draw["parameters"],
            "scene": draw["scene_yaml"],
            "simulation": {k: summary[k] for k in ("steps", "contact_steps", "non_converged_steps")},
            "record": record,
        }
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
        shutil.rmtree(twin, ignore_errors=True)
