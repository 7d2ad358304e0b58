#!/usr/bin/python3
"""A reference force sensor's log made from a twin dataset's truth, for trying
`tac3d recording pairs` without a rig (docs/calibrating-a-sensor.md).

Each step's true total force (sensor frame) becomes one reading, on a clock that runs
OFFSET seconds behind the recording's (recording time = reference time + OFFSET), with
Gaussian noise of NOISE newtons (1 sigma) on every axis.

    scripts/twin_reference_log.py DATASET_DIR OUT.csv [--offset 1.2345] [--noise 0.01]
"""
import argparse
import glob
import json
import os

import numpy as np


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset")
    parser.add_argument("out")
    parser.add_argument("--offset", type=float, default=1.2345)
    parser.add_argument("--noise", type=float, default=0.01)
    parser.add_argument("--seed", type=int, default=20221122)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    steps = sorted(glob.glob(os.path.join(args.dataset, "steps", "*.json")))
    if not steps:
        raise SystemExit(f"no steps/*.json in {args.dataset}")
    with open(args.out, "w") as out:
        out.write("t_s,fx_n,fy_n,fz_n\n")
        for path in steps:
            with open(path) as f:
                step = json.load(f)
            force = np.asarray(step["total_force_n"]) + rng.normal(0.0, args.noise, 3)
            out.write(f"{step['t_s'] - args.offset:.6f},{force[0]:.6f},{force[1]:.6f},{force[2]:.6f}\n")
    print(f"wrote {len(steps)} readings to {args.out}")


if __name__ == "__main__":
    main()
