"""Hostile dataset folders and arguments (tac3d.datasets, `tac3d dataset`): a damaged or planted
store, a link planted in the output folder, a count beyond its bound, a scheduler that does not
answer or has no workers, or an episode that fails on a worker ends in a tac3d.Error naming the
file, option or episode (from the CLI, one `tac3d: error:` line and exit code 1), fast and
without a traceback; nothing in a store is ever run or written through."""
import base64
import contextlib
import io
import json
import os
import pathlib
import pickle
import random
import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import time

import pytest

import tac3d
import tac3d.datasets
from conftest import REPO

SMALL = REPO / "examples" / "datasets" / "small.yaml"
EPISODE0 = pathlib.Path("episodes") / "episode_000000.zarr"


def cli(tac3d_cli, cache_dir, *args, timeout=120):
    """`tac3d dataset ARGS`: (the completed run, its seconds)."""
    start = time.monotonic()
    run = subprocess.run([tac3d_cli, "dataset", *map(str, args)], capture_output=True, text=True,
                         timeout=timeout, env=dict(os.environ, TAC3D_CACHE_DIR=cache_dir))
    return run, time.monotonic() - start


def assert_one_line_error(run, pattern):
    assert run.returncode == 1 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and re.match("tac3d: error: " + pattern, lines[0]), run.stderr


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, tac3d_cli, cache_dir):
    """small.yaml's first 2 episodes, generated once; tests damage copies of it."""
    out = tmp_path_factory.mktemp("hostile") / "small"
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", SMALL, "--out", out, "--episodes", 2,
                 "--workers", 1, timeout=600)
    assert run.returncode == 0, run.stderr
    return out


@pytest.fixture
def copy(dataset, tmp_path):
    shutil.copytree(dataset, tmp_path / "copy", symlinks=True)
    return tmp_path / "copy"


class Payload:
    """Creates `marker` when unpickled: what a pickled array planted in a store would run."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return pathlib.Path.touch, (self.marker,)


def plant_pickle(array, payload, where="filters"):
    """Makes `array` (a folder) decode `payload` with zarr's pickle codec: as an object array's
    filter (its chunks the payload), or also its fill_value, or as a float array's compressor."""
    meta = json.loads((array / ".zarray").read_text())
    if where == "compressor":
        meta.update(dtype="<f8", compressor={"id": "pickle"})
    else:
        fill_value = base64.b64encode(payload).decode() if where == "fill_value" else None
        meta.update(dtype="|O", compressor=None, filters=[{"id": "pickle"}], fill_value=fill_value)
    (array / ".zarray").write_text(json.dumps(meta))
    for chunk in array.iterdir():
        if chunk.name != ".zarray" and chunk.is_file():  # not a FIFO the fuzz left there
            chunk.write_bytes(payload)


PICKLE_REFUSED = {
    "filters": r'filters \[\{"id": "pickle"\}\]: tac3d writes null',
    "fill_value": r'filters \[\{"id": "pickle"\}\]: tac3d writes null',
    "compressor": r'compressor \{"id": "pickle"\}: tac3d writes \{"id": "blosc"',
}


def assert_every_reader_refuses(copy, episode, tac3d_cli, cache_dir, message):
    """Python's frames() and verify(), and `tac3d dataset verify`, each refuse the damaged copy
    with a tac3d error matching `message` (the CLI's as one line)."""
    with pytest.raises(tac3d.Error, match=message):
        list(tac3d.datasets.open(copy)[episode].frames())
    with pytest.raises(tac3d.Error, match=message):
        tac3d.datasets.verify(copy)
    run, _ = cli(tac3d_cli, cache_dir, "verify", copy)
    assert_one_line_error(run, message)


@pytest.mark.parametrize("where", PICKLE_REFUSED)
def test_a_pickled_array_is_refused_before_zarr_decodes_it(copy, tmp_path, tac3d_cli, cache_dir, where):
    marker = tmp_path / "the payload ran"
    plant_pickle(copy / EPISODE0 / "t", pickle.dumps(Payload(marker)), where)
    message = r".*episode_000000\.zarr/t/\.zarray: " + PICKLE_REFUSED[where]
    assert_every_reader_refuses(copy, 0, tac3d_cli, cache_dir, message)
    assert not marker.exists()


@pytest.mark.parametrize("option, value", [("--episodes", 1_000_000_000_000), ("--episodes", 0),
                                           ("--workers", 1000), ("--workers", 0),
                                           ("--worker-timeout", 0), ("--worker-timeout", "nan")])
def test_counts_beyond_their_bounds_are_refused_up_front(copy, tac3d_cli, cache_dir, option, value):
    # On the complete copy, a run within bounds would only rewrite the manifest.
    manifest = (copy / "manifest.jsonl").stat().st_mtime_ns
    counts = {"--episodes": 2, "--workers": 1, option: value}
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", SMALL, "--out", copy,
                 *[x for item in counts.items() for x in item])
    bound = {"--episodes": r"\[1, 1000000\]",
             "--workers": rf"\[1, {2 * len(os.sched_getaffinity(0))}\] \(twice this machine's cores\)",
             "--worker-timeout": r"\(0, 86400\] seconds"}[option]
    assert_one_line_error(run, rf"{option} must be in {bound}, got {value}$")
    assert (copy / "manifest.jsonl").stat().st_mtime_ns == manifest  # refused before any work


@pytest.mark.parametrize("chunk", ["images/3.0.0", "t/0"])
def test_a_missing_chunk_is_an_error_not_zeros(copy, tac3d_cli, cache_dir, chunk):
    array, name = chunk.split("/")
    (copy / "episodes" / "episode_000001.zarr" / chunk).unlink()
    message = rf".*episode_000001\.zarr/{array}: chunk file {re.escape(name)} is missing"
    assert_every_reader_refuses(copy, 1, tac3d_cli, cache_dir, message)


def outside(tmp_path, copy):
    """Every file under tmp_path but in the copy, with its bytes: what a write through a link
    planted in the copy would change."""
    return {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file() and copy not in p.parents}


@pytest.mark.parametrize("planted", ["manifest.jsonl.tmp", "manifest.jsonl", "spec.yaml", "episodes"])
def test_links_planted_in_the_output_folder_are_never_written_through(copy, tmp_path, tac3d_cli, cache_dir,
                                                                      planted):
    target = tmp_path / "target"
    if planted == "episodes":  # the episodes moved elsewhere, linked from their place
        (copy / planted).rename(target)
    elif planted != "spec.yaml":  # the copy of the spec: a dangling link, which a write would follow
        target.write_text("not the dataset's\n")
    if os.path.lexists(copy / planted):
        (copy / planted).unlink()
    (copy / planted).symlink_to(target)
    before = outside(tmp_path, copy)
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", SMALL, "--out", copy, "--episodes", 2)
    assert outside(tmp_path, copy) == before
    if planted == "manifest.jsonl.tmp":  # not a name the writer uses: left alone
        assert run.returncode == 0, run.stderr
        assert len((copy / "manifest.jsonl").read_text().splitlines()) == 2
    elif planted == "episodes":
        assert_one_line_error(run, rf".*'{re.escape(str(copy / planted))}' is not a folder")
    else:
        assert_one_line_error(run, re.escape(f"{copy / planted}: not a regular file (a symbolic link?)"))


def test_generating_onto_a_file_is_refused(tmp_path, tac3d_cli, cache_dir):
    file = tmp_path / "file"
    file.write_text("mine\n")
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", SMALL, "--out", file, "--episodes", 1)
    assert_one_line_error(run, rf".*'{re.escape(str(file))}' is not a folder")
    assert file.read_text() == "mine\n"


def cut_last_line(copy):
    manifest = copy / "manifest.jsonl"
    manifest.write_bytes(manifest.read_bytes()[:-40])


def edit_record(copy, edit):
    manifest = copy / "manifest.jsonl"
    records = [json.loads(line) for line in manifest.read_text().splitlines()]
    edit(records[0])
    manifest.write_text("".join(json.dumps(r) + "\n" for r in records))


def edit_chunk(copy, chunk, edit):
    path = copy / EPISODE0 / chunk
    path.write_bytes(edit(path.read_bytes()))


def empty_episode(copy):
    """Every array of episode 0 of zero frames, as zarr would write it."""
    for meta_file in (copy / EPISODE0).glob("*/.zarray"):
        meta = json.loads(meta_file.read_text())
        if meta_file.parent.name != "surface_positions":
            meta["shape"][0] = meta["chunks"][0] = 0
            for chunk in meta_file.parent.iterdir():
                if chunk.name != ".zarray":
                    chunk.unlink()
        meta_file.write_text(json.dumps(meta))


def prepend_non_utf8(copy):
    manifest = copy / "manifest.jsonl"
    manifest.write_bytes(b"\xff" + manifest.read_bytes())


RECORD = r".*manifest\.jsonl: line 1: not an episode's record"
DAMAGE = {
    "a truncated manifest": (cut_last_line, r".*manifest\.jsonl: line 2: (Unterminated|Expecting)"),
    "a manifest not UTF-8": (prepend_non_utf8, r".*manifest\.jsonl: line 1: 'utf-8' codec can't decode"),
    "a record without its checksum": (lambda c: edit_record(c, lambda r: r.pop("checksum")), RECORD),
    "a record without its episode": (lambda c: edit_record(c, lambda r: r.pop("episode")), RECORD),
    "an episode id too long for a file name": (lambda c: edit_record(c, lambda r: r.update(episode=10**250)),
                                               RECORD),
    "bad Blosc data in a chunk": (
        lambda c: edit_chunk(c, "images/2.0.0", lambda b: b[:16] + b"\xff" * (len(b) - 16)),
        r".*episode_000000\.zarr: array 'images': error during blosc decompression"),
    "a truncated chunk": (
        lambda c: edit_chunk(c, "images/2.0.0", lambda b: b[:len(b) // 2]),
        r".*episode_000000\.zarr/images/2\.0\.0: a Blosc header of 307200 bytes decoded from \d+, "
        r"the chunk being 307200 bytes decoded from \d+"),
    "an episode of no frames": (
        empty_episode,
        r".*episode_000000\.zarr/\w+/\.zarray: shape \[0(, \d+)*\]: not a list of sizes of at least 1"),
}


@pytest.mark.parametrize("case", DAMAGE)
def test_a_damaged_store_is_an_error_naming_the_file(copy, tac3d_cli, cache_dir, case):
    damage, message = DAMAGE[case]
    damage(copy)
    with pytest.raises(tac3d.Error, match=message):
        tac3d.datasets.verify(copy)
    with pytest.raises(tac3d.Error, match=message):
        ds = tac3d.datasets.open(copy)
        ds.manifest()
        for episode in ds:
            for _ in episode.frames(surface=True):
                pass
    run, _ = cli(tac3d_cli, cache_dir, "verify", copy)
    assert_one_line_error(run, message)


@pytest.mark.parametrize("address, message", [
    ("tcp://127.0.0.1:1", r"--scheduler tcp://127\.0\.0\.1:1: Timed out trying to connect"),
    ("foo://x", r"--scheduler foo://x: unknown address scheme 'foo'")], ids=["unreachable", "unknown scheme"])
def test_a_scheduler_that_does_not_answer_fails_fast(tmp_path, tac3d_cli, cache_dir, address, message):
    run, seconds = cli(tac3d_cli, cache_dir, "generate", "--spec", SMALL, "--out", tmp_path / "d",
                       "--episodes", 1, "--scheduler", address)
    assert_one_line_error(run, message)
    assert seconds < 30  # distributed alone waits 30 s


def free_tcp_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until_listening(port, process, log):
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and process.poll() is None:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    pytest.fail(f"the dask-scheduler did not listen on {port}: {log.read_text()}")


@contextlib.contextmanager
def started(command, log):
    """`command` running (its output in `log`) for the block, stopped after."""
    with open(log, "wb") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT)
    try:
        yield process
    finally:
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@pytest.fixture
def scheduler(tmp_path):
    """The address of a `dask-scheduler` (Debian's python3-distributed) on a free port of
    127.0.0.1, with no worker, stopped after the test."""
    port = free_tcp_port()
    log = tmp_path / "scheduler.log"
    command = [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
               "--port", str(port), "--dashboard-address", "127.0.0.1:0"]
    with started(command, log) as process:
        wait_until_listening(port, process, log)
        yield f"tcp://127.0.0.1:{port}"


def without_progress(stderr):
    """stderr's lines but the progress bar's (a line a tenth when not on a terminal)."""
    return [line for line in stderr.strip().splitlines() if not line.startswith("episodes [")]


def test_a_scheduler_without_workers_is_an_error_saying_how_to_start_one(scheduler, tmp_path, tac3d_cli,
                                                                        cache_dir):
    message = (f"the scheduler {scheduler} has no workers and none joined in 1 s: start one with "
               f"`dask-worker {scheduler}`")
    stream = io.StringIO()
    with pytest.raises(tac3d.Error, match="^" + re.escape(message)):
        tac3d.datasets.generate(str(SMALL), str(tmp_path / "api"), 1, scheduler=scheduler, cache_dir=cache_dir,
                                stream=stream, worker_timeout=1)
    assert stream.getvalue() == (f"the scheduler {scheduler} has no workers: waiting up to 1 s for a worker "
                                 f"(start one with `dask-worker {scheduler}`)\n")
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", SMALL, "--out", tmp_path / "cli", "--episodes", 1,
                 "--scheduler", scheduler, "--worker-timeout", 1)
    assert run.returncode == 1 and "Traceback" not in run.stderr, run.stderr
    waiting, error = run.stderr.strip().splitlines()
    assert waiting.startswith(f"the scheduler {scheduler} has no workers: waiting up to 1 s") and \
        error.startswith(f"tac3d: error: {message}"), run.stderr


def test_workers_that_all_leave_mid_run_are_an_error_keeping_the_complete_episodes(scheduler, tmp_path, tac3d_cli,
                                                                                   cache_dir):
    out = tmp_path / "left"
    command = [sys.executable, "-m", "distributed.cli.dask_worker", scheduler, "--nthreads", "1", "--no-nanny",
               "--no-dashboard", "--local-directory", str(tmp_path / "worker")]
    with started(command, tmp_path / "worker.log") as worker:
        run = subprocess.Popen([tac3d_cli, "dataset", "generate", "--spec", str(SMALL), "--out", str(out),
                                "--episodes", "40", "--scheduler", scheduler, "--worker-timeout", "2"],
                               env=dict(os.environ, TAC3D_CACHE_DIR=cache_dir), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 300
            while run.poll() is None and time.monotonic() < deadline and \
                    not list((out / "episodes").glob("episode_*.zarr")):
                time.sleep(0.05)
            worker.kill()  # with no nanny to start another
            _, stderr = run.communicate(timeout=120)
        finally:
            if run.poll() is None:  # it hung: the test fails, the command is not left behind
                run.kill()
                run.wait()
    assert run.returncode == 1 and "Traceback" not in stderr, stderr
    complete = tac3d.datasets.open(out).ids
    assert 1 <= len(complete) < 40
    assert without_progress(stderr)[-1] == (
        f"tac3d: error: the scheduler {scheduler} has no workers left and none joined in 2 s: start one with "
        f"`dask-worker {scheduler}` (with the tac3d package importable), or wait longer with --worker-timeout; "
        f"the episodes complete are kept: a run again generates only the others"), stderr
    # The manifest lists every complete episode, as a finished run's would.
    assert [r["episode"] for r in tac3d.datasets.open(out).manifest()] == complete
    assert tac3d.datasets.verify(out) == {"episodes": len(complete), "verified": len(complete), "problems": []}


def test_ctrl_c_ends_a_local_run_with_one_line_keeping_the_complete_episodes(tmp_path, tac3d_cli, cache_dir):
    """Ctrl-C, as a terminal sends it (SIGINT to the whole process group: the CLI, Python and the
    local cluster's workers): exit code 130, one line saying what is kept, no worker's
    traceback, and the manifest lists every complete episode."""
    out = tmp_path / "interrupted"
    run = subprocess.Popen([tac3d_cli, "dataset", "generate", "--spec", str(SMALL), "--out", str(out),
                            "--episodes", "3000", "--workers", "2"],
                           env=dict(os.environ, TAC3D_CACHE_DIR=cache_dir), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, start_new_session=True,
                           # a terminal's job takes SIGINT; a test runner's child may inherit it ignored
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 300
        while run.poll() is None and time.monotonic() < deadline and \
                len(list((out / "episodes").glob("episode_*.zarr"))) < 2:
            time.sleep(0.05)
        os.killpg(run.pid, signal.SIGINT)
        _, stderr = run.communicate(timeout=120)
    finally:
        if run.poll() is None:  # it hung: the test fails, nothing is left behind
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    assert run.returncode == 130 and "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert without_progress(stderr) == [
        "tac3d: interrupted; the episodes complete are kept: a run again generates only the others"], stderr
    complete = tac3d.datasets.open(out).ids
    assert 2 <= len(complete) < 3000
    assert [r["episode"] for r in tac3d.datasets.open(out).manifest()] == complete
    assert tac3d.datasets.verify(out) == {"episodes": len(complete), "verified": len(complete), "problems": []}


def pins_spec(folder):
    """small.yaml with pins of a drawn radius 0.3 or 0.6 mm, 1 mm apart: the spec takes both,
    a scene only the first (its pins must be apart), so an episode that draws 0.6 fails when
    its scene is read. Returns (the spec, the first failing episode, its seed)."""
    text = re.sub(r"(?m)^  - \{shape: .*\n", "", SMALL.read_text())
    text = text.replace("objects:\n", "objects:\n  - {shape: pins, radius_mm: {choice: [0.3, 0.6]}, "
                                       "pitch_mm: 1.0, rows: 2, cols: 2}\n")
    spec = folder / "pins.yaml"
    spec.write_text(text)
    shutil.copy(SMALL.parent / "small_sensor.yaml", folder)
    draws = [tac3d.datasets.load_spec(str(spec)).draw(i) for i in range(10)]
    radii = [d["parameters"]["object"]["radius_mm"] for d in draws]
    # Episode 0, whose scene the client reads before the workers start, draws the good radius.
    assert radii[0] == 0.3 and 0.6 in radii, radii
    bad = radii.index(0.6)
    return spec, bad, draws[bad]["seed"]


def test_an_episode_that_fails_on_a_worker_is_one_error_naming_it(tmp_path, tac3d_cli, cache_dir):
    spec, bad, seed = pins_spec(tmp_path)
    reason = (r"scene: objects\[0\] \(pins 'object'\)\.pitch_mm = 1 is out of range: must be > 2 radius_mm "
              r"\(pins apart\)")
    message = rf"episode {bad} \(seed {seed}\) failed: {reason}"
    out = tmp_path / "api"
    with pytest.raises(tac3d.Error) as raised:
        tac3d.datasets.generate(str(spec), str(out), bad + 1, workers=1, cache_dir=cache_dir,
                                stream=io.StringIO())
    assert re.fullmatch(message, str(raised.value)), str(raised.value)
    # The episodes complete are in place and in the manifest; the failed one is not.
    complete = tac3d.datasets.open(out).ids
    assert bad not in complete and [r["episode"] for r in tac3d.datasets.open(out).manifest()] == complete
    assert tac3d.datasets.verify(out)["problems"] == []
    # From the CLI: the error line, without the worker's log of the task or a traceback.
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", spec, "--out", tmp_path / "cli", "--episodes", bad + 1)
    assert run.returncode == 1 and "Traceback" not in run.stderr and "distributed" not in run.stderr, run.stderr
    assert len(without_progress(run.stderr)) == 1 and re.fullmatch(
        "tac3d: error: " + message, without_progress(run.stderr)[0]), run.stderr
    # --verbose adds the worker's traceback.
    run, _ = cli(tac3d_cli, cache_dir, "generate", "--spec", spec, "--out", tmp_path / "verbose", "--episodes",
                 bad + 1, "--verbose")
    assert run.returncode == 1 and f"episode {bad} (seed {seed}): the worker's traceback:\nTraceback" in run.stderr
    assert re.fullmatch("tac3d: error: " + message, run.stderr.strip().splitlines()[-1]), run.stderr
    # A run again skips the episodes complete: the client reads the failing episode's scene
    # first (if those before it are complete), and names it as the worker did.
    with pytest.raises(tac3d.Error) as again:
        tac3d.datasets.generate(str(spec), str(out), bad + 1, workers=1, cache_dir=cache_dir, stream=io.StringIO())
    assert str(again.value) == str(raised.value)


# The store fuzzed: files mutated a few at a time, each mutation read by verify, open, frames
# and array, which must return or raise tac3d.Error within a time limit and a memory limit,
# never run a pickle.
class Hang(BaseException):
    """Raised by the alarm in a call that takes too long (not an Exception: nothing catches it)."""


WRONG_VALUES = [None, True, -1, 0, 2**64, 10**30, 1e308, float("nan"), "", "x" * 5000, "|O", "NaN", [], [0],
                [[[]]], {}, {"id": "pickle"}, [{"id": "pickle"}]]


def json_paths(value, path=()):
    yield path
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        yield from json_paths(item, path + (key,))


def replaced(value, path, new):
    if not path:
        return new
    value[path[0]] = replaced(value[path[0]], path[1:], new)
    return value


def mutate(rng, path, data, payload):
    """One of: truncated, bytes changed, removed, a JSON value of a wrong type, an object array
    of the pickle codec, a FIFO, a link (to /dev/zero, nothing, /), a folder, bytes appended.
    Returns the files changed."""
    kind = rng.randrange(9)
    if kind == 0:
        path.write_bytes(data[:rng.randrange(len(data) + 1)])
    elif kind == 1:
        changed = bytearray(data)
        for _ in range(rng.randint(1, 4) if data else 0):
            changed[rng.randrange(len(changed))] = rng.randrange(256)
        path.write_bytes(bytes(changed))
    elif kind == 2:
        path.unlink()
    elif kind == 3 and (path.name.startswith(".") or path.name == "manifest.jsonl"):
        lines = data.splitlines() if path.name == "manifest.jsonl" else [data]
        k = rng.randrange(len(lines))
        value = json.loads(lines[k])
        value = replaced(value, rng.choice(list(json_paths(value))), rng.choice(WRONG_VALUES))
        lines[k] = json.dumps(value).encode()
        path.write_bytes(b"\n".join(lines) + b"\n")
    elif kind == 4 and path.name == ".zarray":
        plant_pickle(path.parent, payload, rng.choice(list(PICKLE_REFUSED)))
        return list(path.parent.iterdir())
    elif kind == 5:
        path.unlink()
        os.mkfifo(path)
    elif kind == 6:
        path.unlink()
        path.symlink_to(rng.choice(["/dev/zero", "/nonexistent", "/"]))
    elif kind == 7:
        path.unlink()
        path.mkdir()
    else:
        path.write_bytes(data + rng.randbytes(rng.randint(1, 64)))
    return [path]


def restore(path, data):
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif os.path.lexists(path):
        path.unlink()
    path.write_bytes(data)


def read_everything(folder):
    """verify, then open and read every frame and array: each returns or raises tac3d.Error."""
    def read():
        ds = tac3d.datasets.open(folder)
        ds.manifest()
        for episode in ds:
            for _ in episode.frames(surface=True):
                pass
            for name in episode.arrays:
                episode.array(name)

    for call in (lambda: tac3d.datasets.verify(folder), read):
        try:
            call()
        except tac3d.Error:
            pass


def cap_address_space(more_bytes):
    """Caps this process's address space at its size now plus `more_bytes` (so an allocation
    without bound fails as MemoryError rather than swapping); returns the limit to restore."""
    limit = resource.getrlimit(resource.RLIMIT_AS)
    size_kb = re.search(r"VmSize:\s+(\d+) kB", pathlib.Path("/proc/self/status").read_text()).group(1)
    resource.setrlimit(resource.RLIMIT_AS, ((int(size_kb) << 10) + more_bytes, limit[1]))
    return limit


def test_a_fuzzed_store_reads_or_raises_tac3d_error(copy, tmp_path):
    files = sorted(p for p in copy.rglob("*") if p.is_file() and p.name != "spec.yaml")
    pristine = {p: p.read_bytes() for p in files}
    # The chunks of an array (a frame each) are alike: drawn by array, not by file, so that the
    # frames do not take most of the draws.
    groups = {}
    for p in files:
        groups.setdefault(p.parent if p.name[0].isdigit() else p, []).append(p)
    marker = tmp_path / "the payload ran"
    payload = pickle.dumps(Payload(marker))
    rng = random.Random(2026)

    def alarm(*_):
        raise Hang()

    previous = signal.signal(signal.SIGALRM, alarm)
    limit = cap_address_space(2 << 30)
    iterations, start = 0, time.monotonic()
    try:
        while iterations < 200 and time.monotonic() - start < 20:
            chosen = [rng.choice(groups[key]) for key in rng.sample(sorted(groups), rng.randint(1, 2))]
            mutated = {changed for path in chosen for changed in mutate(rng, path, pristine[path], payload)}
            signal.setitimer(signal.ITIMER_REAL, 10)
            try:
                read_everything(copy)
            except (Exception, Hang) as e:
                changed = sorted(str(p.relative_to(copy)) for p in mutated)
                pytest.fail(f"{type(e).__name__} {e} with {changed} mutated")
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
                for path in mutated:
                    restore(path, pristine[path])
            assert not marker.exists(), mutated
            iterations += 1
    finally:
        resource.setrlimit(resource.RLIMIT_AS, limit)
        signal.signal(signal.SIGALRM, previous)
    assert iterations >= 50, "too few mutations in the time bound: a slow path?"
    assert tac3d.datasets.verify(copy)["verified"] == 2  # restored whole


def test_a_binary_spec_is_an_error_that_prints():
    # Bytes of a binary file echoed in a message made it one Python could not show (empty).
    rng = random.Random(7)
    for _ in range(300):
        text = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 64))).decode("latin-1")
        try:
            tac3d._core.parse_dataset_spec(text)
        except tac3d.Error as e:
            assert str(e).startswith("<python>"), repr(text)
