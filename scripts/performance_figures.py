#!/usr/bin/env python3
"""Figures of docs/performance.md that time or weigh the `tac3d` program as a user runs it.

  first-frame  time to the first frame: `tac3d run` on the built-in sensor's rendered images,
               from the start of the process to the first JSON frame on stdout, and to the first
               frame with forces (after the reference frames). Run twice: with an empty model
               cache (the model is built), then with that cache (it is loaded).
  memory       peak resident memory of `tac3d run --run-file` with 1 and with N sensors of the
               built-in sensor, each reading the same rendered images (the model cached first, so
               its build does not count).

usage: performance_figures.py first-frame [--tac3d build/bin/tac3d] [--reference-frames 20]
       performance_figures.py memory [--tac3d build/bin/tac3d] [--sensors 10] [--frames 300]
                                     [--cache DIR]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

RENDERED_FRAMES = 6  # distinct images; longer sources link to them in turn


def render_frames(tac3d, work, count):
    """An image folder of `count` images of the built-in sensor at rest (tac3d render markers:
    RENDERED_FRAMES distinct ones, linked to in turn); returns its path."""
    rendered = os.path.join(work, "rendered")
    frames = os.path.join(work, "frames")
    os.makedirs(rendered)
    os.makedirs(frames)
    for i in range(RENDERED_FRAMES):
        subprocess.run([tac3d, "render", "markers", "--frame", str(i), "--out",
                        os.path.join(rendered, "f{}.png".format(i))], check=True, stdout=subprocess.DEVNULL)
    for i in range(count):
        os.symlink(os.path.join(rendered, "f{}.png".format(i % RENDERED_FRAMES)),
                   os.path.join(frames, "f{:06d}.png".format(i)))
    return frames


def time_first_frame(tac3d, frames, cache, reference_frames):
    """Seconds from the start of `tac3d run` to its first JSON frame and to its first frame with
    forces (initialize_progress 100), and the whole run's."""
    env = dict(os.environ, TAC3D_CACHE_DIR=cache)
    command = [tac3d, "run", "--source", frames, "--json", "--reference-frames", str(reference_frames),
               "--max-frames", str(reference_frames + 1)]
    start = time.monotonic()
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = with_forces = None
    for line in process.stdout:
        now = time.monotonic() - start
        if first is None:
            first = now
        if with_forces is None and json.loads(line).get("initialize_progress") == 100:
            with_forces = now
    stderr = process.stderr.read()
    if process.wait() != 0:
        sys.exit("tac3d run failed:\n" + stderr)
    return first, with_forces, time.monotonic() - start


def first_frame(args):
    with tempfile.TemporaryDirectory(prefix="tac3d-first-frame-") as work:
        frames = render_frames(args.tac3d, work, args.reference_frames + 1)
        cache = os.path.join(work, "cache")
        os.makedirs(cache)
        print("tac3d run --source FRAMES --json --reference-frames {0} --max-frames {1}, built-in sensor"
              .format(args.reference_frames, args.reference_frames + 1))
        for label in ("empty model cache", "model cached"):
            first, with_forces, total = time_first_frame(args.tac3d, frames, cache, args.reference_frames)
            print("{:18s}: first frame {:.2f} s, first frame with forces {:.2f} s, run {:.2f} s"
                  .format(label, first, with_forces, total))


def peak_rss_mb(command, env):
    """Runs `command`; its peak resident memory (MiB, the kernel's maxrss of that process)."""
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    stderr = process.stderr.read()
    _, status, usage = os.wait4(process.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit("{} failed:\n{}".format(" ".join(command), stderr))
    return usage.ru_maxrss / 1024.0


def memory(args):
    with tempfile.TemporaryDirectory(prefix="tac3d-memory-") as work:
        frames = render_frames(args.tac3d, work, args.frames)
        env = dict(os.environ)
        if args.cache:
            env["TAC3D_CACHE_DIR"] = args.cache
        # The model built (or loaded) once, outside the figures.
        subprocess.run([args.tac3d, "run", "--source", frames, "--max-frames", "1"], env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        print("tac3d run --run-file RUN_FILE: N sensors of the built-in sensor, {} images each"
              .format(args.frames))
        for sensors in sorted({1, args.sensors}):
            run_file = os.path.join(work, "run{}.yaml".format(sensors))
            with open(run_file, "w") as f:
                f.write("sensors:\n")
                for i in range(sensors):
                    f.write("  - {{sn: HAND-{0}, source: {1}}}\n".format(i, frames))
            start = time.monotonic()
            rss = peak_rss_mb([args.tac3d, "run", "--run-file", run_file], env)
            print("{:3d} sensor(s): peak resident {:.0f} MiB, run {:.1f} s".format(
                sensors, rss, time.monotonic() - start))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="figure", required=True)
    here = os.path.dirname(os.path.abspath(__file__))
    default_tac3d = os.path.join(here, "..", "build", "bin", "tac3d")
    p = sub.add_parser("first-frame")
    p.add_argument("--tac3d", default=default_tac3d)
    p.add_argument("--reference-frames", type=int, default=20)
    p.set_defaults(run=first_frame)
    p = sub.add_parser("memory")
    p.add_argument("--tac3d", default=default_tac3d)
    p.add_argument("--sensors", type=int, default=10)
    p.add_argument("--frames", type=int, default=300)
    p.add_argument("--cache", default=None, help="model cache (default: tac3d's, TAC3D_CACHE_DIR)")
    p.set_defaults(run=memory)
    args = parser.parse_args()
    args.tac3d = os.path.abspath(args.tac3d)
    args.run(args)


if __name__ == "__main__":
    main()
