#!/usr/bin/python3
"""Frames a second reading every frame of a dataset folder with tac3d.datasets.open
(docs/datasets.md, "Acceptance runs"; issue 25: >= 2,000 with images):

    PYTHONPATH=build/python /usr/bin/python3 python/bench/dataset_read.py DIR [--no-images] [--surface]

Reads each frame's arrays as training code would (every episode, every frame, the image
touched), best of 3 rounds (the first warms the page cache), and prints frames, megabytes and
frames a second."""
import argparse
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
    best = None
    for _ in range(args.rounds):
        start = time.perf_counter()
        frames, nbytes = read_all(args.folder, not args.no_images, args.surface)
        seconds = time.perf_counter() - start
        best = seconds if best is None else min(best, seconds)
    print(f"{frames} frames, {nbytes / 1e6:.0f} MB: {frames / best:.0f} frames/s "
          f"(best of {args.rounds}: {best:.2f} s)")


if __name__ == "__main__":
    main()
