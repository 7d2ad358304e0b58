#!/usr/bin/python3
"""How much of mu the markers carry before gross slip (docs/incipient.md, "How much of mu the
markers carry"):

    TAC3D_CACHE_DIR=DIR PYTHONPATH=build/python /usr/bin/python3 scripts/incipient_information.py
        [--tac3d build/bin/tac3d] [--indenters sphere cylinder punch] [--loads light heavy]
        [--mus 0.3 0.6 1] [--dmu 0.05] [--model-mu 0.6] [--work DIR]

For each incipient scene (slow ramp), the twin is run at mu and at mu + dmu, and the true marker
displacements are compared at equal tangential load Q over the frames with Q / (mu P) in
[0.5, 0.9] before gross slip (the window of `tac3d eval incipient`). The difference, over all
markers and axes and in units of the pipeline's marker noise (measured here: the displacements
of still frames after the reference, through the real pipeline on the rendered images), is the
signal-to-noise ratio with which one frame tells mu from mu + dmu to an estimator that knows
the sensor exactly. "gain-free" is the part of it that no error of the model's stiffness can
mimic: orthogonal to the frame's own field scaled per axis and to the pressed field.

The same comparison between the twin at the scenes' refinement (1.5) and at the pipeline's mesh
(refinement 1), at the same mu (--model-mu), measures how far two discretisations of one FEM
sensor differ at equal load: a lower bound of any sensor model's error. A mu fitted through a
forward model needs that error below the mu signal."""
import argparse
import pathlib
import subprocess
import sys

import numpy as np

import tac3d

RAMP_WINDOW = (0.5, 0.9)


def simulate(args, scene, out, refinement=None, images=False, steps=None):
    """The scene's truth through `tac3d simulate` (kept in --work, reused when present)."""
    if not (out / "dataset.json").exists():
        command = [args.tac3d, "simulate", "--scene", scene, "--out", str(out)]
        if not images:
            command.append("--no-images")
        if refinement is not None:
            command += ["--twin-refinement", str(refinement)]
        if steps is not None:
            command += ["--steps", str(steps)]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return out


def truth(folder):
    t = tac3d.Dataset(str(folder)).truth()
    force = t["total_force"]
    return dict(u=t["marker_positions"] - t["marker_positions"][0],
                P=-force[:, 2], Q=np.hypot(force[:, 0], force[:, 1]))


def marker_noise_mm(args, work):
    """Per-axis 1-sigma displacement noise of the pipeline on the twin's images: the first
    frames of a scene are still (the lead-in), so after the reference they measure noise only."""
    folder = simulate(args, "incipient_sphere_mu0.6_light_slow", work / "noise", images=True,
                      steps=25)
    pipeline = tac3d.Pipeline(reference_frames=15)
    still = []
    for n, (image, timestamp, _) in enumerate(tac3d.open_source("dataset:" + str(folder))):
        frame = pipeline.process(image, timestamp=timestamp)
        if n >= 15:
            still.append(np.asarray(frame.displacements)[np.asarray(frame.valid)])
    return np.concatenate(still).std(axis=0)


def ramp_start(d):
    """The last step before the tangential load starts to grow: the pressed state."""
    loaded = np.where(d["P"] > 0.05)[0]
    q = d["Q"][loaded[0]:]
    return loaded[0] + int(np.argmax(q > 0.02 * d["P"][loaded[0]:])) - 1


def load_peak(d):
    """The first step at the tangential load's peak: the end of the rising ramp."""
    return int(np.argmax(d["Q"] >= 0.99 * d["Q"].max()))


def compare(a, b, mu, sigma):
    """Per window frame of `a` (Q / (mu P) in the window, before gross slip): |u_a - u_b| / sigma
    with b interpolated to a's Q on b's rising load, whole and gain-free; |u_a| / sigma; and
    P_b - P_a there."""
    start = ramp_start(a)
    press = a["u"][start]
    b_steps = np.arange(ramp_start(b), load_peak(b) + 1)
    b_q = b["Q"][b_steps]
    whole, free, field, dp = [], [], [], []
    for i in range(start, load_peak(a) + 1):
        if not RAMP_WINDOW[0] <= a["Q"][i] / (mu * a["P"][i]) <= RAMP_WINDOW[1]:
            continue
        j = int(np.searchsorted(b_q, a["Q"][i]))
        if j == 0 or j >= len(b_q):
            continue
        k0, k1 = b_steps[j - 1], b_steps[j]
        w = (a["Q"][i] - b["Q"][k0]) / (b["Q"][k1] - b["Q"][k0])
        du = ((a["u"][i] - (1 - w) * b["u"][k0] - w * b["u"][k1]) / sigma).ravel()
        per_axis = [np.where(np.arange(3) == k, a["u"][i], 0.0) for k in range(3)]
        basis = np.stack([(v / sigma).ravel() for v in per_axis + [press]], axis=1)
        coef, *_ = np.linalg.lstsq(basis, du, rcond=None)
        whole.append(np.linalg.norm(du))
        free.append(np.linalg.norm(du - basis @ coef))
        field.append(np.linalg.norm(a["u"][i] / sigma))
        dp.append((1 - w) * b["P"][k0] + w * b["P"][k1] - a["P"][i])
    return np.array(whole), np.array(free), np.array(field), np.array(dp)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tac3d", default="build/bin/tac3d")
    parser.add_argument("--indenters", nargs="+", default=["sphere", "cylinder", "punch"])
    parser.add_argument("--loads", nargs="+", default=["light", "heavy"])
    parser.add_argument("--mus", nargs="+", type=float, default=[0.3, 0.6, 1.0])
    parser.add_argument("--dmu", type=float, default=0.05)
    parser.add_argument("--model-mu", type=float, default=0.6)
    parser.add_argument("--work", default="incipient_information")
    args = parser.parse_args()
    work = pathlib.Path(args.work)
    work.mkdir(exist_ok=True)

    sigma = marker_noise_mm(args, work)
    print("pipeline marker noise (1 sigma, mm): x %.5f y %.5f z %.5f" % tuple(sigma))
    print("SNR of one frame, median over the window frames (max; over the whole window):")
    for indenter in args.indenters:
        for load in args.loads:
            scene = lambda mu: f"incipient_{indenter}_mu{mu:g}_{load}_slow"
            for mu in args.mus:
                a = truth(simulate(args, scene(mu), work / scene(mu)))
                b = truth(simulate(args, scene(mu + args.dmu), work / scene(mu + args.dmu)))
                whole, free, field, dp = compare(a, b, mu, sigma)
                if len(whole) == 0:
                    print(f"{indenter:8s} {load:5s} mu {mu:g}: no window frame to compare")
                    continue
                print(f"{indenter:8s} {load:5s} mu {mu:g} vs {mu + args.dmu:g}: "
                      f"{len(whole)} frames, "
                      f"SNR {np.median(whole):.1f} (max {whole.max():.1f}; "
                      f"window {np.linalg.norm(whole):.0f}), "
                      f"gain-free {np.median(free):.1f}; the field {np.median(field):.0f}; "
                      f"P differs by {np.abs(dp).max():.4f} N at most", flush=True)
            mu = args.model_mu
            fine = truth(simulate(args, scene(mu), work / scene(mu)))
            coarse = truth(simulate(args, scene(mu), work / (scene(mu) + "_r1"), refinement=1))
            whole, free, field, dp = compare(fine, coarse, mu, sigma)
            print(f"{indenter:8s} {load:5s} mu {mu:g}, refinement 1.5 vs 1: {len(whole)} frames, "
                  f"SNR {np.median(whole):.1f}, gain-free {np.median(free):.1f}; "
                  f"the field {np.median(field):.0f}; "
                  f"P differs by {np.abs(dp).max():.4f} N at most", flush=True)


if __name__ == "__main__":
    sys.exit(main())
