"""`tac3d dataset generate`: one Dask task an episode, on a local cluster of K worker
processes or on an existing cluster (a `dask-scheduler` address)."""
import contextlib
import logging
import os
import pathlib
import shutil
import signal
import stat
import sys
import threading
import time
import traceback

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
        self.mid_line = False  # a bar drawn in place, its line not ended

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
        self.mid_line = self.tty and self.done < self.total
        self.stream.flush()

    def interrupt(self):
        """Ends the line of a bar drawn in place, so that what is written next (a message, an
        error) starts a line of its own; the bar goes on below it."""
        if self.mid_line:
            self.stream.write("\n")
            self.stream.flush()
            self.mid_line = False


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
        with named_episode(spec, episode):
            draw = spec.draw(episode)
        nu = draw["parameters"]["sensor"]["poisson_ratio_factor"]
        if nu not in prepared:
            with named_episode(spec, episode):
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
# Seconds to wait for a worker (--worker-timeout) when the cluster has none: at the start (its
# workers still starting) or after every worker left in the middle of a run. Without a bound
# the tasks would wait on the scheduler for ever.
WORKER_TIMEOUT_S = 30
MAX_WORKER_TIMEOUT_S = 24 * 3600
# Seconds between looks at the cluster's workers while no episode completes.
WORKER_POLL_S = 1.0
# What a run that ends early keeps (the episodes in place, and the manifest lists them).
KEPT = "the episodes complete are kept: a run again generates only the others"


def check_arguments(episodes, workers, scheduler, worker_timeout=WORKER_TIMEOUT_S):
    """@raises tac3d.Error for a count out of its bounds or an address no Dask transport takes,
    before anything is written or started."""
    if not 1 <= episodes <= store.MAX_EPISODES:
        raise _core.Error(f"--episodes must be in [1, {store.MAX_EPISODES}], got {episodes}")
    if not 0 < worker_timeout <= MAX_WORKER_TIMEOUT_S:  # NaN fails too
        raise _core.Error(f"--worker-timeout must be in (0, {MAX_WORKER_TIMEOUT_S}] seconds, "
                          f"got {worker_timeout:g}")
    if scheduler:
        from distributed.comm import parse_address
        from distributed.comm.registry import get_backend

        with store.named_errors(f"--scheduler {scheduler}"):
            get_backend(parse_address(scheduler)[0])
    elif not 1 <= workers <= max_workers():
        raise _core.Error(f"--workers must be in [1, {max_workers()}] (twice this machine's cores), "
                          f"got {workers}")


@contextlib.contextmanager
def named_episode(spec, episode):
    """Raises a tac3d.Error of the block as one naming episode `episode` and its seed, as
    episode_error does one of a worker."""
    try:
        yield
    except _core.Error as e:
        raise _core.Error(f"{episode_name(spec, episode)} failed: {e}") from e


def episode_name(spec, episode):
    """"episode 3 (seed 2159871899846873932)": what a rerun of one episode needs."""
    try:
        return f"episode {episode} (seed {spec.draw(episode)['seed']})"
    except _core.Error:  # the draw itself fails (a damaged mesh of the spec's)
        return f"episode {episode}"


@contextlib.contextmanager
def dask_client(workers, scheduler, stream, verbose=False):
    """A Dask client: of the cluster at `scheduler`, else of a local cluster of `workers`
    processes of one thread each (with the dashboard where bokeh is installed), closed after.
    The local cluster's workers log only what is critical (`verbose`: Dask's warnings and
    errors too): generate reports a failed episode once, not also each worker that ran it, and a
    worker's error as the cluster closes (one still beating while the scheduler drops it) is
    not the user's."""
    from distributed import Client, LocalCluster

    if scheduler:
        with store.named_errors(f"--scheduler {scheduler}"):
            client = Client(scheduler, timeout=SCHEDULER_CONNECT_S)
        with client:
            yield client
        return
    try:
        import bokeh  # noqa: F401  the dashboard's dependency
        dashboard = True
    except ImportError:
        dashboard = False
    # Port 0 even without the dashboard: the scheduler's HTTP server (health, metrics) always
    # starts, and on its default port 8787 it warns when another cluster holds that port.
    with workers_ignoring_ctrl_c():
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                               scheduler_kwargs={"dashboard": dashboard},
                               silence_logs=logging.WARNING if verbose else logging.CRITICAL)
    with cluster, Client(cluster) as client:
        if dashboard:
            stream.write(f"dashboard: {client.dashboard_link}\n")
        yield client


@contextlib.contextmanager
def workers_ignoring_ctrl_c():
    """Ctrl-C reaches every process of the terminal's process group. Processes started in this
    block ignore it (an ignored signal stays ignored in a child; Python then installs no
    KeyboardInterrupt), so a local cluster's workers do not each print a traceback: this
    process alone handles it, closing the cluster and listing the episodes kept. Off the main
    thread, where no signal handler can be set, the workers start as they are."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def wait_for_a_worker(client, scheduler, timeout, stream, left=False, bar=None):
    """Returns once the cluster has a worker (paused for memory counts: it resumes); if it has
    none, waits up to `timeout` seconds for one to join, saying so on `stream` for the cluster
    at `scheduler` (None: the local cluster, whose nanny restarts a worker that died).
    @raises tac3d.Error saying how to start one if none joined; `left`: every worker left in
    the middle of the run, whose progress `bar` the message interrupts."""
    from distributed import TimeoutError as DaskTimeoutError  # asyncio's

    if client.scheduler_info()["workers"]:
        return
    if scheduler:
        what = f"the scheduler {scheduler} has no workers{' left' if left else ''}"
        start = f"start one with `dask-worker {scheduler}`"
        advice = f"{start} (with the tac3d package importable), or wait longer with --worker-timeout"
        if bar:
            bar.interrupt()
        stream.write(f"{what}: waiting up to {timeout:g} s for a worker ({start})\n")
        stream.flush()
    else:
        what = "the local cluster has no workers left"
        advice = "they died and their nanny started none: out of memory? (--verbose shows the workers' logs)"
    try:
        client.wait_for_workers(1, timeout=timeout)
    except DaskTimeoutError:
        kept = f"; {KEPT}" if left else ""
        raise _core.Error(f"{what} and none joined in {timeout:g} s: {advice}{kept}") from None


def episode_error(spec, episode, future, stream, verbose):
    """The tac3d.Error of the episode whose `future` failed on a worker: one line naming the
    episode, its seed and the reason. `verbose`: the worker's traceback on `stream` first."""
    from distributed import KilledWorker

    e = future.exception()
    name = episode_name(spec, episode)
    if verbose:
        stream.write(f"{name}: the worker's traceback:\n"
                     + "".join(traceback.format_exception(type(e), e, future.traceback())))
    if isinstance(e, KilledWorker):  # the scheduler's allowed-failures + 1 deaths
        deaths = e.allowed_failures + 1
        reason = (f"the worker running it died, {deaths} time{'s' if deaths > 1 else ''} (the last "
                  f"{e.last_worker.address}): a crash or out of memory? (the workers' logs say; a "
                  f"local cluster's with --verbose)")
    elif isinstance(e, _core.Error):
        reason = str(e)
    else:
        reason = f"{type(e).__name__}: {e}"
        if not verbose:
            reason += " (--verbose prints the worker's traceback)"
    return _core.Error(f"{name} failed: {reason}")


def run_episodes(client, scheduler, spec, spec_path, out, todo, cache_dir, measured, records, stream,
                 worker_timeout, verbose):
    """Runs the episodes `todo` on the client's cluster, adding each record to `records` as it
    completes. @raises tac3d.Error at the first episode that fails (naming it), when every
    worker has left and none joins within `worker_timeout` s (the tasks would wait for ever), or
    when the scheduler drops the tasks."""
    from distributed import as_completed

    futures = client.map(run_episode, [spec_path] * len(todo), [out] * len(todo), todo,
                         [cache_dir] * len(todo), [measured] * len(todo),
                         key=[f"tac3d-episode-{i}" for i in todo])
    episode_of = {future.key: i for future, i in zip(futures, todo)}
    bar = Progress(len(todo), stream)
    # With the results: fetched in the background, so a record lost with its worker before it
    # was fetched (refetched once a worker reruns the task) never blocks the look at the workers.
    completed = as_completed(futures, with_results=True, raise_errors=False)
    looked = time.monotonic()
    try:
        while not completed.is_empty():
            batch = completed.next_batch(block=False)
            if not batch:  # as as_completed's own iteration waits, with a look at the workers a second
                if time.monotonic() - looked >= WORKER_POLL_S:
                    wait_for_a_worker(client, scheduler, worker_timeout, stream, left=True, bar=bar)
                    looked = time.monotonic()
                time.sleep(0.1)
            for future, record in batch:
                episode = episode_of[future.key]
                if future.status == "error":
                    bar.interrupt()  # before --verbose's traceback
                    raise episode_error(spec, episode, future, stream, verbose)
                if future.status == "cancelled":  # the client closed: it lost its scheduler
                    raise _core.Error(f"the scheduler {scheduler or 'of the local cluster'} dropped the "
                                      f"episodes (it stopped, or this client lost it); {KEPT}")
                records[episode] = record
                bar.step()
    except BaseException:
        bar.interrupt()  # the error on a line of its own
        raise


def generate(spec, out, episodes, workers=1, scheduler=None, cache_dir="", stream=sys.stderr,
             measured=None, worker_timeout=WORKER_TIMEOUT_S, verbose=False):
    """Generates episodes 0 .. episodes - 1 of `spec` into `out`, skipping complete ones.
    `measured`: store what the sensor's pipeline measures beside the truth (None: as the
    spec's `measured` says). `worker_timeout`: seconds to wait for a worker when the cluster
    has none. `verbose`: a failed episode's traceback on `stream`, and the local cluster's
    warnings. Returns {episodes (complete in out), skipped, generated, seconds, workers,
    measured}.
    Raises tac3d.Error for a bad spec, count or folder, or a folder whose episodes were
    generated with the other `measured`, before any cluster starts; for an episode that fails
    (naming it) or a cluster without workers, after writing the manifest of the episodes
    complete (a run again generates only the others)."""
    spec_path = str(pathlib.Path(spec).resolve())
    out = str(pathlib.Path(out).resolve())
    check_arguments(episodes, workers, scheduler, worker_timeout)
    parsed = _core.load_dataset_spec(str(spec))  # a bad spec is refused here, named as the user gave it
    measured = parsed.measured if measured is None else bool(measured)
    prepare_folder(spec_path, out)
    records = store.complete_episodes(out)  # any id: a run of fewer episodes keeps the others
    check_measured(out, records, measured)
    todo = [i for i in range(episodes) if i not in records]
    start = time.perf_counter()
    used_workers = 0
    try:
        if todo:
            prepare_models(spec_path, todo, cache_dir, measured)
            with dask_client(workers, scheduler, stream, verbose) as client:
                wait_for_a_worker(client, scheduler, worker_timeout, stream)
                used_workers = len(client.scheduler_info()["workers"])
                run_episodes(client, scheduler, parsed, spec_path, out, todo, cache_dir, measured, records,
                             stream, worker_timeout, verbose)
    except BaseException:
        # The episodes complete so far are in place whatever ended the run (some maybe after
        # the error, by a worker that was running them): list them. The temporaries stay (a
        # remote worker may still be writing one); the next run removes them.
        with contextlib.suppress(_core.Error):
            store.write_manifest(out, store.complete_episodes(out))
        raise
    remove_temporaries(out)
    store.write_manifest(out, records)
    return {"episodes": len(records), "skipped": episodes - len(todo), "generated": len(todo),
            "seconds": round(time.perf_counter() - start, 3), "workers": used_workers, "measured": measured}
