"""An episode as a zarr group, its checksum, and reading a dataset folder back lazily.

Layout of a dataset folder (docs/datasets.md, "Randomized datasets"):

    DIR/spec.yaml                          the spec the episodes were drawn from (a copy)
    DIR/manifest.jsonl                     one line an episode, sorted by id
    DIR/episodes/episode_000000.zarr/      one zarr group an episode, complete once renamed
"""
import concurrent.futures
import hashlib
import json
import os
import pathlib
import threading

import numpy as np
import zarr
from numcodecs import Blosc

from .. import _core

FORMAT = "tac3d-zarr-episodes"
VERSION = 1
EPISODES = "episodes"
MANIFEST = "manifest.jsonl"
SPEC_COPY = "spec.yaml"

# Arrays chunked one frame a chunk; the others are one chunk each.
PER_FRAME = ("images", "surface_tractions", "surface_states", "surface_friction")
# Frames Episode.frames reads with one zarr call: a call's overhead is paid once a block.
READ_BLOCK_FRAMES = 32

_read_pool = None
_read_pool_lock = threading.Lock()


def read_pool():
    """The thread that reads (and decompresses) the next block while the caller uses the
    current one: Blosc and file reads release the GIL, so a second core decodes images."""
    global _read_pool
    with _read_pool_lock:
        if _read_pool is None:
            _read_pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="tac3d-read")
        return _read_pool


def episode_name(episode):
    return f"episode_{episode:06d}.zarr"


def episode_path(out, episode):
    return pathlib.Path(out) / EPISODES / episode_name(episode)


def checksum(arrays, parameters):
    """sha256 of the arrays' names, dtypes, shapes and bytes (by name) and the drawn
    parameters: what repeats exactly when an episode is generated again."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    h.update(json.dumps(parameters, sort_keys=True).encode())
    return h.hexdigest()


# Images: LZ4 without Blosc's byte shuffle, which does nothing for one-byte pixels but made
# decoding a 640 x 480 frame 2.7 times slower (0.35 against 0.13 ms, docs/datasets.md).
IMAGE_COMPRESSOR = Blosc(cname="lz4", clevel=5, shuffle=Blosc.NOSHUFFLE)


def write_group(path, arrays, attrs):
    """Writes `arrays` (name -> numpy array, time first) and `attrs` as a zarr group at path."""
    group = zarr.open_group(str(path), mode="w")
    for name, a in arrays.items():
        chunks = (1,) + a.shape[1:] if name in PER_FRAME else a.shape
        options = {"compressor": IMAGE_COMPRESSOR} if name == "images" else {}
        group.create_dataset(name, data=a, chunks=chunks or None, **options)
    group.attrs.update(attrs)


def read_arrays(group):
    return {name: group[name][...] for name in group.array_keys()}


def complete_record(out, episode):
    """The manifest record of episode `episode` if its group is complete (renamed into place
    with its record), else None."""
    path = episode_path(out, episode)
    if not (path / ".zattrs").is_file():
        return None
    record = zarr.open_group(str(path), mode="r").attrs.get("record")
    return dict(record) if record else None


def complete_episodes(out):
    """{episode id: manifest record} of the complete groups in out/episodes."""
    folder = pathlib.Path(out) / EPISODES
    found = {}
    if folder.is_dir():
        for entry in sorted(os.listdir(folder)):
            if entry.startswith("episode_") and entry.endswith(".zarr"):
                episode = int(entry[len("episode_"):-len(".zarr")])
                record = complete_record(out, episode)
                if record:
                    found[episode] = record
    return found


def write_manifest(out, records):
    """Rewrites the manifest atomically, one JSON line an episode, sorted by id."""
    path = pathlib.Path(out) / MANIFEST
    tmp = path.with_suffix(".jsonl.tmp")
    with open(tmp, "w") as f:
        for episode in sorted(records):
            f.write(json.dumps(records[episode], sort_keys=True) + "\n")
    os.replace(tmp, path)


def read_manifest(out):
    path = pathlib.Path(out) / MANIFEST
    if not path.is_file():
        return []
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def require_dataset(folder):
    """@raises tac3d.Error if `folder` has no episodes/ folder."""
    if not (pathlib.Path(folder) / EPISODES).is_dir():
        raise _core.Error(f"'{folder}' is not a tac3d dataset folder: it has no {EPISODES}/ folder")


class Episode:
    """One episode: its drawn parameters and arrays, read from the zarr group on demand."""

    def __init__(self, path):
        self.path = pathlib.Path(path)
        self.group = zarr.open_group(str(self.path), mode="r")
        attrs = self.group.attrs.asdict()
        if attrs.get("format") != FORMAT or attrs.get("version") != VERSION:
            raise ValueError(f"{self.path}: not a {FORMAT} version {VERSION} episode")
        self.attrs = attrs
        self.id = attrs["episode"]
        self.seed = attrs["seed"]
        self.parameters = attrs["parameters"]

    def __len__(self):
        return self.group["t"].shape[0]

    def array(self, name):
        """The whole array `name` (e.g. marker_forces, T x N x 3)."""
        return self.group[name][...]

    def frames(self, images=True, surface=False):
        """Each frame as a dict of numpy arrays: t, sensor_pose, marker_*, total_force,
        total_moment, and image (when the episode has images and `images`) and the surface
        truth (surface_tractions, surface_states, surface_friction, with `surface`). The small
        per-marker arrays are read once; images and surface frames READ_BLOCK_FRAMES at a time,
        the next block read in a background thread (read_pool) while this one is yielded."""
        names = [n for n in self.group.array_keys() if n not in PER_FRAME and n != "surface_positions"]
        small = {n: self.group[n][...] for n in names}
        per_frame = []
        if images and "images" in self.group:
            per_frame.append(("image", self.group["images"]))
        if surface and "surface_tractions" in self.group:
            per_frame += [(n, self.group[n]) for n in PER_FRAME[1:] if n in self.group]
        count = len(self)

        def read_block(start):
            return [(n, a[start:start + READ_BLOCK_FRAMES]) for n, a in per_frame]

        pool = read_pool()
        pending = pool.submit(read_block, 0)
        try:
            for start in range(0, count, READ_BLOCK_FRAMES):
                block = pending.result()
                if start + READ_BLOCK_FRAMES < count:
                    pending = pool.submit(read_block, start + READ_BLOCK_FRAMES)
                for k in range(start, min(start + READ_BLOCK_FRAMES, count)):
                    frame = {n: a[k] for n, a in small.items()}
                    for n, a in block:
                        frame[n] = a[k - start]
                    yield frame
        finally:
            pending.cancel()

    def __repr__(self):
        return f"<tac3d.datasets.Episode {self.id} ({len(self)} frames) {self.path}>"


class Dataset:
    """A dataset folder's complete episodes, by id, opened one at a time as they are used."""

    def __init__(self, folder):
        self.folder = pathlib.Path(folder)
        require_dataset(self.folder)
        self.ids = sorted(complete_episodes(self.folder))

    def __len__(self):
        return len(self.ids)

    def __getitem__(self, episode):
        if episode not in self.ids:
            raise KeyError(f"{self.folder}: no complete episode {episode}")
        return Episode(episode_path(self.folder, episode))

    def __iter__(self):
        for episode in self.ids:
            yield self[episode]

    def manifest(self):
        return read_manifest(self.folder)

    def __repr__(self):
        return f"<tac3d.datasets.Dataset {len(self)} episodes {self.folder}>"


def verify(folder):
    """Checks a dataset folder: every manifest line's episode present, no id twice, every
    checksum recomputed from the stored arrays. Returns {episodes, verified, problems}.
    Raises tac3d.Error if `folder` is not a dataset folder."""
    require_dataset(folder)
    records = read_manifest(folder)
    problems = []
    seen = set()
    verified = 0
    for r in records:
        episode = r["episode"]
        if episode in seen:
            problems.append(f"episode {episode} is in the manifest twice")
            continue
        seen.add(episode)
        path = episode_path(folder, episode)
        if not path.is_dir():
            problems.append(f"episode {episode}: {path} is missing")
            continue
        group = zarr.open_group(str(path), mode="r")
        if checksum(read_arrays(group), group.attrs["parameters"]) != r["checksum"]:
            problems.append(f"episode {episode}: the arrays do not match the manifest's checksum")
        else:
            verified += 1
    on_disk = set(complete_episodes(folder))
    for episode in sorted(on_disk - seen):
        problems.append(f"episode {episode} is complete but not in the manifest")
    return {"episodes": len(records), "verified": verified, "problems": problems}
