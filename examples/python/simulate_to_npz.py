#!/usr/bin/python3
"""Simulates a twin scene and saves arrays for learning as .npz: the twin's truth per step
(marker positions and forces, contact, total force, poses) and, optionally, what the
pipeline measures from the rendered images.

    /usr/bin/python3 examples/python/simulate_to_npz.py probe probe.npz [--steps 60] [--measure]

The first run builds the twin body model (~15 min, 7 GB for the default sensor) and caches
it in ~/.cache/tac3d; later runs load it in about a second.
"""
import argparse
import os
import sys
import tempfile

import numpy as np

import tac3d


def main():
    p = argparse.ArgumentParser()
    p.add_argument("scene", help="built-in name (%s) or a scene YAML" % ", ".join(tac3d.builtin_scenes()))
    p.add_argument("out", help="the .npz to write")
    p.add_argument("--steps", type=int, default=0, help="only the first N steps")
    p.add_argument("--dataset", help="keep the dataset folder here (default: a temporary one)")
    p.add_argument("--measure", action="store_true", help="also run the pipeline on the images")
    args = p.parse_args()

    folder = args.dataset or tempfile.mkdtemp(prefix="tac3d_ds_")
    if args.dataset is None:
        os.rmdir(folder)  # simulate() wants a new or empty folder

    def progress(done, total):
        print(f"\rsimulating {done}/{total}", end="", file=sys.stderr, flush=True)

    summary = tac3d.simulate(args.scene, folder, steps=args.steps, progress=progress,
                             images=args.measure)
    print(f"\n{summary['steps']} steps, {summary['contact_steps']} in contact", file=sys.stderr)

    truth = tac3d.Dataset(folder).truth()
    arrays = {f"true_{k}": v for k, v in truth.items()}
    if args.measure:
        # The dataset's images through the runtime (as `tac3d run --source dataset:DIR`).
        frames = []
        tac3d.run([tac3d.SensorSpec("TAC3D-TWIN", f"dataset:{folder}")], on_frame=frames.append)
        arrays["measured_positions"] = np.stack([f.positions for f in frames])
        arrays["measured_displacements"] = np.stack([f.displacements for f in frames])
        arrays["measured_forces"] = np.stack([f.forces for f in frames])
        arrays["measured_resultant_force"] = np.stack([f.resultant_force for f in frames])
        arrays["measured_valid"] = np.stack([f.initialize_progress == 100 for f in frames])
    np.savez_compressed(args.out, **arrays)
    print(f"{args.out}: " + ", ".join(f"{k} {v.shape}" for k, v in arrays.items()))


if __name__ == "__main__":
    main()
