#!/usr/bin/python3
"""Frames a second reading every frame of a dataset folder with tac3d.datasets.open
(docs/datasets.md, "Acceptance runs"; target: >= 2,000 with images):

    PYTHONPATH=build/python /usr/bin/python3 python/bench/dataset_read.py DIR [--no-images] [--surface]

Reads each frame's arrays as training code would (every episode, every frame, the image
touched), best of 3 rounds (the first warms the page cache), and prints frames, megabytes,
frames a second and the process' CPU time a frame (all threads: on a machine shared with
other work the wall time says how much of the CPU the reader got, the CPU time what it needed),
and the images' bytes on disk a frame."""
import argparse
import pathlib
import time

import tac3d.datasets


def read_all(folder, images, surface):
    frames = nbytes = 0
    for episode in tac3d.datasets.open(folder):
        for frame in episode.frames(images=images, surface=surface):
            frames += 1
            nbytes += sum(a.nbytes for a in frame.values())
    return frames, nbytes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder")
    parser.add_argument("--no-images", action="store_true")
    parser.add_argument("--surface", action="store_true")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    best = best_cpu = None
    for _ in range(args.rounds):
        start, start_cpu = time.perf_counter(), time.process_time()
        frames, nbytes = read_all(args.folder, not args.no_images, args.surface)
        seconds, cpu = time.perf_counter() - start, time.process_time() - start_cpu
        best = seconds if best is None else min(best, seconds)
        best_cpu = cpu if best_cpu is None else min(best_cpu, cpu)
    stored = sum(p.stat().st_size for p in pathlib.Path(args.folder).glob("episodes/*/images/*"))
    print(f"{frames} frames, {nbytes / 1e6:.0f} MB: {frames / best:.0f} frames/s "
          f"(best of {args.rounds}: {best:.2f} s), CPU {1e3 * best_cpu / frames:.3f} ms a frame; "
          f"images stored {stored / 1e3 / frames:.1f} kB a frame")


if __name__ == "__main__":
    main()
