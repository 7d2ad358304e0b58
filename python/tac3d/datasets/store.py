"""An episode as a zarr group, its checksum, and reading a dataset folder back lazily.

Layout of a dataset folder (docs/datasets.md, "Randomized datasets"):

    DIR/spec.yaml                          the spec the episodes were drawn from (a copy)
    DIR/manifest.jsonl                     one line an episode, sorted by id
    DIR/episodes/episode_000000.zarr/      one zarr group an episode, complete once renamed

A dataset folder may come from anywhere, so the reader trusts none of it: every file zarr reads
passes through CheckedStore, which refuses what write_group does not write before zarr decodes
it, and a damaged file is a tac3d.Error naming it (named_errors). The writer never writes
through a symbolic link planted in the folder (replace_file).
"""
import concurrent.futures
import contextlib
import functools
import hashlib
import json
import math
import os
import pathlib
import re
import stat
import struct
import threading
import uuid

import numpy as np
import zarr
from numcodecs import Blosc, blosc

from .. import _core

FORMAT = "tac3d-zarr-episodes"
VERSION = 1
EPISODES = "episodes"
MANIFEST = "manifest.jsonl"
SPEC_COPY = "spec.yaml"

# Episode ids are 0 .. MAX_EPISODES - 1: six digits in an episode's folder name, and the most
# `--episodes` may ask for.
MAX_EPISODES = 1_000_000
EPISODE_FOLDER = re.compile(r"episode_([0-9]{6})\.zarr")

# The largest JSON file (or manifest line) read: far above what the writer writes (a .zarray
# ~300 bytes, an episode's attributes or manifest line a few kB), so a planted one is refused
# rather than read whole.
MAX_JSON_BYTES = 16 << 20

# Arrays chunked one frame a chunk; the others are one chunk each.
SURFACE_PER_FRAME = ("surface_tractions", "surface_states", "surface_friction")
PER_FRAME = ("images", "reference_images") + SURFACE_PER_FRAME
# Arrays whose first dimension is not the episode's steps: the surface's nodes, and the frames of
# the sensor at rest its pipeline took as its reference before step 0.
NOT_PER_STEP = ("surface_positions", "reference_images")
# Frames Episode.frames reads with one zarr call: a call's overhead is paid once a block.
READ_BLOCK_FRAMES = 32

# Images: LZ4 without Blosc's byte shuffle, which does nothing for one-byte pixels but made
# decoding a 640 x 480 frame 2.7 times slower (0.35 against 0.13 ms, docs/datasets.md).
IMAGE_COMPRESSOR = Blosc(cname="lz4", clevel=5, shuffle=Blosc.NOSHUFFLE)
# The other arrays: zarr 2's default compressor, named so that the reader can require it.
ARRAY_COMPRESSOR = Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE)
# The numeric dtypes an array may have (zarr's little-endian names); anything else, an object
# array above all (its codec would unpickle the file), is refused before zarr decodes it.
DTYPES = frozenset(np.dtype(t).str for t in (np.bool_, np.uint8, np.int8, np.uint16, np.int16, np.uint32,
                                             np.int32, np.uint64, np.int64, np.float32, np.float64))
ARRAY_KEYS = frozenset({"zarr_format", "shape", "chunks", "dtype", "compressor", "fill_value", "order",
                        "filters"})

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


@contextlib.contextmanager
def named_errors(what):
    """Raises what a library raises on a damaged or unreadable file (OSError: missing,
    unreadable, a name too long; ValueError: not JSON or UTF-8, zarr's and numcodecs' checks,
    and this module's own, which raise it to be named here; RuntimeError: Blosc's decoding, JSON
    nested too deep) as tac3d.Error naming `what`, the file or option."""
    try:
        yield
    except _core.Error:
        raise
    except (OSError, ValueError, RuntimeError) as e:
        if isinstance(e, OSError) and e.strerror:
            same = e.filename is None or str(e.filename) == str(what)
            message = e.strerror if same else f"{e.filename}: {e.strerror}"
        else:
            message = str(e) or type(e).__name__
        raise _core.Error(f"{what}: {message}") from e


def open_regular(path):
    """`path` opened to read if it is a regular file (a FIFO planted there is not waited on)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError("not a regular file")
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_regular(path, limit):
    """The bytes of the regular file `path`, of at most `limit` bytes."""
    with named_errors(path):
        with open_regular(path) as f:
            data = f.read(limit + 1)
        if len(data) > limit:
            raise ValueError(f"larger than the {limit} bytes such a file may hold")
        return data


def regular_file_exists(path):
    """Whether `path` exists, a regular file; @raises ValueError if something else is there (a
    symbolic link, a folder): an output is never written through or over one."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return False
    if not stat.S_ISREG(mode):
        raise ValueError("not a regular file (a symbolic link?): not written")
    return True


def replace_file(path, data):
    """Writes `data` (bytes) to `path` atomically, never through a symbolic link: `path` must
    be a regular file if it exists, and the temporary is a new file of a random name (O_EXCL:
    not a link planted in its place), renamed over `path` when complete."""
    path = pathlib.Path(path)
    with named_errors(path):
        regular_file_exists(path)
        tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o666)
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise


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


def compressor(name):
    return IMAGE_COMPRESSOR if name in ("images", "reference_images") else ARRAY_COMPRESSOR


def write_group(path, arrays, attrs):
    """Writes `arrays` (name -> numpy array, time first) and `attrs` as a zarr group at path."""
    group = zarr.open_group(str(path), mode="w")
    for name, a in arrays.items():
        chunks = (1,) + a.shape[1:] if name in PER_FRAME else a.shape
        group.create_dataset(name, data=a, chunks=chunks or None, compressor=compressor(name))
    group.attrs.update(attrs)


def check_array_metadata(name, meta):
    """The decoded size of a chunk of array `name` if `meta` (its .zarray) is what write_group
    writes: a numeric dtype, the array's Blosc compressor and no filters (zarr makes the codecs
    a .zarray names, and one of them unpickles), its chunks one frame or the whole array, no
    dimension empty. @raises ValueError saying what differs."""
    def shown(value):
        return json.dumps(value)[:80]

    if not isinstance(meta, dict) or not ARRAY_KEYS <= set(meta) <= ARRAY_KEYS | {"dimension_separator"}:
        raise ValueError(f"not a zarr array's metadata as tac3d writes it (keys {sorted(ARRAY_KEYS)})")
    # Compared as JSON: 5.0 is not 5, nor true 1.
    fixed = {"zarr_format": 2, "order": "C", "filters": None, "compressor": compressor(name).get_config(),
             "dimension_separator": "."}
    for key, value in fixed.items():
        if json.dumps(meta.get(key, value), sort_keys=True) != json.dumps(value, sort_keys=True):
            raise ValueError(f"{key} {shown(meta[key])}: tac3d writes {shown(value)}")
    dtype, shape, chunks = meta["dtype"], meta["shape"], meta["chunks"]
    if not (isinstance(dtype, str) and dtype in DTYPES):
        raise ValueError(f"dtype {shown(dtype)}: not one tac3d writes ({', '.join(sorted(DTYPES))})")
    if not (type(meta["fill_value"]) in (bool, int, float) and meta["fill_value"] == 0):
        raise ValueError(f"fill_value {shown(meta['fill_value'])}: tac3d writes 0")
    if not (isinstance(shape, list) and shape and all(type(n) is int and n > 0 for n in shape)):
        raise ValueError(f"shape {shown(shape)}: not a list of sizes of at least 1")
    frame = [1] + shape[1:] if name in PER_FRAME else shape
    if chunks != frame or not all(type(n) is int for n in chunks):
        raise ValueError(f"chunks {shown(chunks)}: tac3d writes {shown(frame)} for shape {shown(shape)}")
    nbytes = math.prod(chunks) * np.dtype(dtype).itemsize
    if nbytes > blosc.MAX_BUFFERSIZE:
        raise ValueError(f"chunks {shown(chunks)}: {nbytes} bytes a chunk, more than Blosc holds")
    return nbytes


def require_chunks(folder, name, shape):
    """@raises ValueError unless array `name`'s folder holds each of its chunk files (a frame's or
    the one): zarr would read a missing one as zeros. So no array is larger than its files say
    either (the loop ends at the first of a billion frames missing)."""
    files = set(os.listdir(folder))
    rest = ".0" * (len(shape) - 1)
    for k in range(shape[0] if name in PER_FRAME else 1):
        if f"{k}{rest}" not in files:
            raise ValueError(f"chunk file {k}{rest} is missing")


def check_chunk(data, nbytes):
    """@raises ValueError unless `data` is a whole Blosc buffer of `nbytes` decoded bytes:
    Blosc trusts its header's sizes, and decodes a truncated buffer from past its end."""
    if len(data) < blosc.MAX_OVERHEAD:
        raise ValueError(f"{len(data)} bytes: too short for a Blosc chunk")
    decoded, _, stored = struct.unpack_from("<III", data, 4)
    if (decoded, stored) != (nbytes, len(data)):
        raise ValueError(f"a Blosc header of {decoded} bytes decoded from {stored}, the chunk being "
                         f"{nbytes} bytes decoded from {len(data)}")


class CheckedStore(zarr.storage.DirectoryStore):
    """An episode's zarr group, read only, each file checked before zarr has it: an array's
    .zarray by check_array_metadata before zarr makes its codecs, and require_chunks; a chunk
    by check_chunk."""

    def __init__(self, path):
        super().__init__(str(path))
        self.chunk_bytes = {}  # array name -> a chunk's decoded size, once its .zarray is checked

    def __getitem__(self, key):
        name, _, leaf = key.rpartition("/")
        path = os.path.join(self.path, key)
        if leaf == ".zarray":
            data = read_regular(path, MAX_JSON_BYTES)
            with named_errors(path):
                meta = json.loads(data)
                nbytes = check_array_metadata(name, meta)
            folder = os.path.dirname(path)
            with named_errors(folder):
                require_chunks(folder, name, meta["shape"])
            self.chunk_bytes[name] = nbytes
            return data
        if name not in self.chunk_bytes:  # no other file: zarr reads it as absent
            raise KeyError(key)
        data = read_regular(path, self.chunk_bytes[name] + blosc.MAX_OVERHEAD)
        with named_errors(path):
            check_chunk(data, self.chunk_bytes[name])
        return data

    def getitems(self, keys, **kwargs):
        # Each chunk through __getitem__: zarr's default leaves a missing one out.
        return {key: self[key] for key in keys}


def check_record(record):
    """@raises ValueError unless `record` is a manifest record: an object with an episode id in
    [0, MAX_EPISODES) and a checksum."""
    episode = record.get("episode") if isinstance(record, dict) else None
    if not (type(episode) is int and 0 <= episode < MAX_EPISODES and isinstance(record.get("checksum"), str)):
        raise ValueError(f"not an episode's record (an object with an 'episode' in [0, {MAX_EPISODES}) "
                         f"and a 'checksum')")


def read_attrs(path):
    """An episode group's attributes (its .zattrs), checked: format, version, episode, seed,
    parameters and record."""
    file = pathlib.Path(path) / ".zattrs"
    data = read_regular(file, MAX_JSON_BYTES)
    with named_errors(file):
        attrs = json.loads(data)
        if not isinstance(attrs, dict) or (attrs.get("format"), attrs.get("version")) != (FORMAT, VERSION):
            raise ValueError(f"not a {FORMAT} version {VERSION} episode")
        for key, kind in (("episode", int), ("seed", int), ("parameters", dict), ("record", dict)):
            if not isinstance(attrs.get(key), kind):
                raise ValueError(f"'{key}' is not a{'n' if kind is int else ''} {kind.__name__}")
        check_record(attrs["record"])
    return attrs


def complete_record(out, episode):
    """The manifest record of episode `episode` if its group is in place (renamed there when
    complete), else None. @raises tac3d.Error if it is there but damaged."""
    path = episode_path(out, episode)
    if not os.path.lexists(path):
        return None
    record = read_attrs(path)["record"]
    if record["episode"] != episode:
        raise _core.Error(f"{path}: holds episode {record['episode']}")
    return record


def complete_episodes(out):
    """{episode id: manifest record} of the complete groups in out/episodes."""
    folder = pathlib.Path(out) / EPISODES
    found = {}
    with named_errors(folder):
        names = sorted(os.listdir(folder)) if folder.is_dir() else []
    for name in names:
        m = EPISODE_FOLDER.fullmatch(name)
        if m:
            found[int(m.group(1))] = complete_record(out, int(m.group(1)))
    return found


def write_manifest(out, records):
    """Rewrites the manifest atomically, one JSON line an episode, sorted by id."""
    lines = "".join(json.dumps(records[episode], sort_keys=True) + "\n" for episode in sorted(records))
    replace_file(pathlib.Path(out) / MANIFEST, lines.encode())


def read_manifest(out):
    """The manifest's records in order ([] if there is none). @raises tac3d.Error naming the
    line of one that is damaged."""
    path = pathlib.Path(out) / MANIFEST
    if not os.path.lexists(path):
        return []
    records = []
    with named_errors(path), open_regular(path) as f:
        lines = iter(functools.partial(f.readline, MAX_JSON_BYTES + 1), b"")
        for number, line in enumerate(lines, 1):
            with named_errors(f"{path}: line {number}"):
                if len(line) > MAX_JSON_BYTES:
                    raise ValueError(f"longer than {MAX_JSON_BYTES} bytes")
                if line.strip():
                    records.append(json.loads(line))
                    check_record(records[-1])
    return records


def require_dataset(folder):
    """@raises tac3d.Error if `folder` has no episodes/ folder."""
    with named_errors(folder):
        if not (pathlib.Path(folder) / EPISODES).is_dir():
            raise _core.Error(f"'{folder}' is not a tac3d dataset folder: it has no {EPISODES}/ folder")


class Episode:
    """One episode: its drawn parameters and arrays (`arrays`, by name), read from the zarr
    group on demand. Opening it checks its attributes and every array's metadata (CheckedStore),
    reading a chunk checks the chunk: a damaged group is a tac3d.Error naming the file."""

    def __init__(self, path):
        self.path = pathlib.Path(path)
        self.attrs = read_attrs(self.path)
        self.id = self.attrs["episode"]
        self.seed = self.attrs["seed"]
        self.parameters = self.attrs["parameters"]
        store = CheckedStore(self.path)
        with named_errors(self.path):
            names = sorted(n for n in os.listdir(self.path) if not n.startswith("."))
            self.arrays = {n: zarr.Array(store, path=n, read_only=True) for n in names}
        if "t" not in self.arrays:
            raise _core.Error(f"{self.path}: no array 't'")
        for name, a in self.arrays.items():
            if name not in NOT_PER_STEP and a.shape[0] != len(self):
                raise _core.Error(f"{self.path}: array '{name}' has {a.shape[0]} frames, 't' {len(self)}")

    def __len__(self):
        return self.arrays["t"].shape[0]

    @property
    def measured(self):
        """Whether the episode holds what the sensor's pipeline measured (the measured_* arrays)
        beside the truth."""
        return "measured_total_force" in self.arrays

    def array(self, name):
        """The whole array `name` (e.g. marker_forces, T x N x 3)."""
        return self._read(name, Ellipsis)

    def _read(self, name, selection):
        array = self.arrays[name]
        with named_errors(f"{self.path}: array '{name}'"):
            return array[selection]

    def checksum(self):
        """checksum() of the stored arrays and parameters."""
        return checksum({name: self.array(name) for name in self.arrays}, self.parameters)

    def frames(self, images=True, surface=False):
        """Each frame as a dict of numpy arrays: t, sensor_pose, the truth (marker_*,
        total_force, total_moment), what the sensor measured (measured_*, when the episode was
        generated with measurements: `measured`), and image (when the episode has images and
        `images`) and the surface truth (surface_tractions, surface_states, surface_friction,
        with `surface`). The small
        per-marker arrays are read once; images and surface frames READ_BLOCK_FRAMES at a time,
        the next block read in a background thread (read_pool) while this one is yielded."""
        small = {n: self.array(n) for n in self.arrays if n not in PER_FRAME and n not in NOT_PER_STEP}
        per_frame = []
        if images and "images" in self.arrays:
            per_frame.append(("image", "images"))
        if surface and "surface_tractions" in self.arrays:
            per_frame += [(n, n) for n in SURFACE_PER_FRAME if n in self.arrays]
        count = len(self)

        def read_block(start):
            block = slice(start, start + READ_BLOCK_FRAMES)
            return [(key, self._read(name, block)) for key, name in per_frame]

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
    Raises tac3d.Error if `folder` is not a dataset folder, or names a damaged file."""
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
        if not os.path.lexists(path):
            problems.append(f"episode {episode}: {path} is missing")
        elif Episode(path).checksum() != r["checksum"]:
            problems.append(f"episode {episode}: the arrays do not match the manifest's checksum")
        else:
            verified += 1
    on_disk = set(complete_episodes(folder))
    for episode in sorted(on_disk - seen):
        problems.append(f"episode {episode} is complete but not in the manifest")
    return {"episodes": len(records), "verified": verified, "problems": problems}
