"""`tac3d dataset generate`: one Dask task an episode, on a local cluster of K worker
processes or on an existing cluster (a `dask-scheduler` address)."""
import contextlib
import pathlib
import shutil
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
    folder made from another spec is refused. Removes temporary folders left by a run that
    was killed (one run a folder at a time)."""
    out = pathlib.Path(out)
    if not out.parent.is_dir():
        raise _core.Error(f"dataset folder '{out}': the folder '{out.parent}' does not exist")
    (out / store.EPISODES).mkdir(parents=True, exist_ok=True)
    text = pathlib.Path(spec_path).read_text()
    copy = out / store.SPEC_COPY
    if copy.exists() and copy.read_text() != text:
        raise _core.Error(f"dataset folder '{out}' was generated from another spec "
                          f"({copy} differs from {spec_path})")
    copy.write_text(text)
    remove_temporaries(out)


def remove_temporaries(out):
    folder = pathlib.Path(out) / store.EPISODES
    for entry in folder.iterdir():
        if entry.name.startswith(".episode_"):
            shutil.rmtree(entry, ignore_errors=True)


def prepare_models(spec_path, todo, cache_dir):
    """Loads, or builds and caches, each body model the episodes `todo` need (one a nu: E is
    scaled from it) before any worker starts, so the workers only load models (a build of the
    prototype's peaks at 7.4 GB, never to be done by every worker at once). Returns how many."""
    spec = load_spec(spec_path)
    prepared = set()
    for episode in todo:
        draw = spec.draw(episode)
        nu = draw["parameters"]["sensor"]["poisson_ratio_factor"]
        if nu not in prepared:
            prepared.add(nu)
            _core.prepare_twin_body(_core.parse_scene(draw["scene_yaml"], "."),
                                    cache_dir=cache_dir, twin_options=spec.twin_options)
    return len(prepared)


@contextlib.contextmanager
def dask_client(workers, scheduler, stream):
    """A Dask client: of the cluster at `scheduler`, else of a local cluster of `workers`
    processes of one thread each (with the dashboard where bokeh is installed), closed after."""
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as client:
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


def generate(spec, out, episodes, workers=1, scheduler=None, cache_dir="", stream=sys.stderr):
    """Generates episodes 0 .. episodes - 1 of `spec` into `out`, skipping complete ones.
    Returns {episodes (complete in out), skipped, generated, seconds, workers}.
    Raises tac3d.Error for a bad spec or folder, before any cluster starts."""
    spec_path = str(pathlib.Path(spec).resolve())
    out = str(pathlib.Path(out).resolve())
    if episodes < 1:
        raise _core.Error(f"--episodes must be >= 1, got {episodes}")
    if not scheduler and workers < 1:
        raise _core.Error(f"--workers must be >= 1, got {workers}")
    _core.load_dataset_spec(str(spec))  # a bad spec is refused here, named as the user gave it
    prepare_folder(spec_path, out)
    records = store.complete_episodes(out)  # any id: a run of fewer episodes keeps the others
    todo = [i for i in range(episodes) if i not in records]
    start = time.perf_counter()
    used_workers = 0
    if todo:
        from distributed import as_completed

        prepare_models(spec_path, todo, cache_dir)
        with dask_client(workers, scheduler, stream) as client:
            used_workers = len(client.scheduler_info()["workers"])
            futures = client.map(run_episode, [spec_path] * len(todo), [out] * len(todo), todo,
                                 [cache_dir] * len(todo), key=[f"tac3d-episode-{i}" for i in todo])
            bar = Progress(len(todo), stream)
            for future in as_completed(futures):
                record = future.result()
                records[record["episode"]] = record
                bar.step()
    remove_temporaries(out)
    store.write_manifest(out, records)
    return {"episodes": len(records), "skipped": episodes - len(todo), "generated": len(todo),
            "seconds": round(time.perf_counter() - start, 3), "workers": used_workers}
