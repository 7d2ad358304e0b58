"""`tac3d dataset generate`: one Dask task an episode, on a local cluster of K worker
processes or on an existing cluster (a `dask-scheduler` address)."""
import contextlib
import os
import pathlib
import shutil
import stat
import sys
import time

from .. import _core
from . import store
from .episode import load_spec, run_episode


class Progress:
    """tac3d's progress bar (util/progress.cc's format, "episodes [###...]  40% 4/10 1.2s") on
    stderr: redrawn in place on a terminal, a line a tenth in a log."""

    def __init__(self, total, stream=sys.stderr):
        self.total, self.done, self.stream = total, 0, stream
        self.start = time.perf_counter()
        self.tty = stream.isatty()
        self.last_decile = 0

    def step(self):
        self.done += 1
        decile = 10 * self.done // self.total
        if not self.tty and decile == self.last_decile:
            return
        self.last_decile = decile
        width = 30
        filled = width * self.done // self.total
        bar = "#" * filled + "." * (width - filled)
        prefix, suffix = ("\r", "") if self.tty else ("", "\n")
        self.stream.write(f"{prefix}episodes [{bar}] {100 * self.done // self.total:3d}% "
                          f"{self.done}/{self.total} {time.perf_counter() - self.start:.1f}s{suffix}")
        if self.tty and self.done == self.total:
            self.stream.write("\n")
        self.stream.flush()


def prepare_folder(spec_path, out):
    """Creates out (its parent must exist) with its episodes/ folder and the spec's copy; a
    folder made from another spec is refused, as is a symbolic link or a file where a folder
    or the spec's copy goes (never written through). Removes temporaries left by a run that
    was killed (one run a folder at a time)."""
    out = pathlib.Path(out)
    with store.named_errors(f"dataset folder '{out}'"):
        if not out.parent.is_dir():
            raise _core.Error(f"dataset folder '{out}': the folder '{out.parent}' does not exist")
    for folder in (out, out / store.EPISODES):
        with store.named_errors(folder):
            with contextlib.suppress(FileExistsError):
                os.mkdir(folder)
            if not stat.S_ISDIR(os.lstat(folder).st_mode):
                raise _core.Error(f"dataset folder '{out}': '{folder}' is not a folder "
                                  f"(a file or a symbolic link)")
    text = pathlib.Path(spec_path).read_bytes()
    copy = out / store.SPEC_COPY
    with store.named_errors(copy):
        if not store.regular_file_exists(copy):
            store.replace_file(copy, text)
        else:
            with store.open_regular(copy) as f:
                if f.read(len(text) + 1) != text:
                    raise _core.Error(f"dataset folder '{out}' was generated from another spec "
                                      f"({copy} differs from {spec_path})")
    remove_temporaries(out)


def remove_temporaries(out):
    """Removes the .*.tmp files and folders of out and out/episodes (never following a link)."""
    for folder in (pathlib.Path(out), pathlib.Path(out) / store.EPISODES):
        with store.named_errors(folder):
            entries = list(os.scandir(folder))
        for entry in entries:
            if entry.name.startswith(".") and entry.name.endswith(".tmp"):
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path, ignore_errors=True)
                else:
                    with contextlib.suppress(OSError):
                        os.unlink(entry.path)


def prepare_models(spec_path, todo, cache_dir, measured=False):
    """Loads, or builds and caches, each body model the episodes `todo` need (one a nu: E is
    scaled from it) and, with `measured`, the compliance model the sensor's pipeline runs with
    (one: every episode's sensor is the spec's) before any worker starts, so the workers only
    load models (a build of the prototype's body peaks at 7.4 GB, never to be done by every
    worker at once). Returns how many body models."""
    spec = load_spec(spec_path)
    prepared = set()
    for episode in todo:
        draw = spec.draw(episode)
        nu = draw["parameters"]["sensor"]["poisson_ratio_factor"]
        if nu not in prepared:
            scene = _core.parse_scene(draw["scene_yaml"], ".")
            if measured and not prepared:
                _core.prepare_sensor_model(scene, cache_dir=cache_dir)
            prepared.add(nu)
            _core.prepare_twin_body(scene, cache_dir=cache_dir, twin_options=spec.twin_options)
    return len(prepared)


def check_measured(out, records, measured):
    """@raises tac3d.Error if a complete episode of `out` was generated with the sensor's
    measurements and this run would not store them, or the other way round: a folder's episodes
    hold the same arrays."""
    other = sorted(episode for episode, record in records.items() if record.get("measured", False) != measured)
    if other:
        shown = ", ".join(map(str, other[:5])) + (", ..." if len(other) > 5 else "")
        raise _core.Error(
            f"dataset folder '{out}': episode{'s' if len(other) > 1 else ''} {shown} "
            f"{'were' if len(other) > 1 else 'was'} generated {'without' if measured else 'with'} "
            f"the sensor's measurements, which this run would {'store' if measured else 'leave out'}: "
            f"generate with the same setting (the spec's `measured`, --measured) or into another folder")


def max_workers():
    """The most worker processes of a local cluster: twice the cores this process may use. A
    worker is one thread busy on one core holding ~0.5 GB (docs/datasets.md, "Memory"), so past
    the cores workers add memory, not speed; twice leaves room to oversubscribe a little (two
    workers on one core)."""
    return 2 * len(os.sched_getaffinity(0))


# Seconds to connect to --scheduler: an address that does not answer is reported in seconds
# (distributed waits 30 s by default).
SCHEDULER_CONNECT_S = 5


def check_arguments(episodes, workers, scheduler):
    """@raises tac3d.Error for a count out of its bounds or an address no Dask transport takes,
    before anything is written or started."""
    if not 1 <= episodes <= store.MAX_EPISODES:
        raise _core.Error(f"--episodes must be in [1, {store.MAX_EPISODES}], got {episodes}")
    if scheduler:
        from distributed.comm import parse_address
        from distributed.comm.registry import get_backend

        with store.named_errors(f"--scheduler {scheduler}"):
            get_backend(parse_address(scheduler)[0])
    elif not 1 <= workers <= max_workers():
        raise _core.Error(f"--workers must be in [1, {max_workers()}] (twice this machine's cores), "
                          f"got {workers}")


@contextlib.contextmanager
def dask_client(workers, scheduler, stream):
    """A Dask client: of the cluster at `scheduler`, else of a local cluster of `workers`
    processes of one thread each (with the dashboard where bokeh is installed), closed after."""
    from distributed import Client, LocalCluster

    if scheduler:
        with store.named_errors(f"--scheduler {scheduler}"):
            client = Client(scheduler, timeout=SCHEDULER_CONNECT_S)
        with client:
            yield client
        return
    try:
        import bokeh  # noqa: F401  the dashboard's dependency
        dashboard = ":0"
    except ImportError:
        dashboard = None
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=dashboard) as cluster, Client(cluster) as client:
        if dashboard:
            stream.write(f"dashboard: {client.dashboard_link}\n")
        yield client


def generate(spec, out, episodes, workers=1, scheduler=None, cache_dir="", stream=sys.stderr,
             measured=None):
    """Generates episodes 0 .. episodes - 1 of `spec` into `out`, skipping complete ones.
    `measured`: store what the sensor's pipeline measures beside the truth (None: as the
    spec's `measured` says). Returns {episodes (complete in out), skipped, generated, seconds,
    workers, measured}.
    Raises tac3d.Error for a bad spec, count or folder, or a folder whose episodes were
    generated with the other `measured`, before any cluster starts."""
    spec_path = str(pathlib.Path(spec).resolve())
    out = str(pathlib.Path(out).resolve())
    check_arguments(episodes, workers, scheduler)
    parsed = _core.load_dataset_spec(str(spec))  # a bad spec is refused here, named as the user gave it
    measured = parsed.measured if measured is None else bool(measured)
    prepare_folder(spec_path, out)
    records = store.complete_episodes(out)  # any id: a run of fewer episodes keeps the others
    check_measured(out, records, measured)
    todo = [i for i in range(episodes) if i not in records]
    start = time.perf_counter()
    used_workers = 0
    if todo:
        from distributed import as_completed

        prepare_models(spec_path, todo, cache_dir, measured)
        with dask_client(workers, scheduler, stream) as client:
            used_workers = len(client.scheduler_info()["workers"])
            futures = client.map(run_episode, [spec_path] * len(todo), [out] * len(todo), todo,
                                 [cache_dir] * len(todo), [measured] * len(todo),
                                 key=[f"tac3d-episode-{i}" for i in todo])
            bar = Progress(len(todo), stream)
            for future in as_completed(futures):
                record = future.result()
                records[record["episode"]] = record
                bar.step()
    remove_temporaries(out)
    store.write_manifest(out, records)
    return {"episodes": len(records), "skipped": episodes - len(todo), "generated": len(todo),
            "seconds": round(time.perf_counter() - start, 3), "workers": used_workers, "measured": measured}
