#!/usr/bin/python3
"""CPU time of one scene simulated by the twin with each contact solved on a window around it
and on the whole grid (`tac3d simulate` and `tac3d simulate --no-window`; docs/contact.md,
"Windows around the contact"):

    TAC3D_CACHE_DIR=DIR /usr/bin/python3 python/bench/contact_window.py [--tac3d build/bin/tac3d]
        [--scene two_material_slide] [--steps 70] [--twin-refinement 1]

Runs `tac3d simulate --no-images` once each way and prints, for each, the process' CPU time
(user + system, the twin body model's loading included), the contact solves' wall time (the
summary's timings), the twin body's cache status (`built` means the time includes building it:
run again), and the smallest and largest window of the steps in contact; then the largest
difference between the two runs' total forces over the steps."""
import argparse
import json
import pathlib
import resource
import subprocess
import tempfile


def children_cpu_s():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def simulate(args, out, windowed):
    command = [args.tac3d, "simulate", "--scene", args.scene, "--out", str(out), "--no-images",
               "--steps", str(args.steps), "--json"]
    if args.twin_refinement is not None:
        command += ["--twin-refinement", str(args.twin_refinement)]
    if not windowed:
        command.append("--no-window")
    before = children_cpu_s()
    report = json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)
    cpu_s = children_cpu_s() - before
    steps = [json.loads(p.read_text()) for p in sorted((out / "steps").glob("*.json"))]
    return cpu_s, report, steps


def describe(name, cpu_s, report, steps):
    windows = sorted((s["solver"]["window"] for s in steps if s["solver"].get("num_contact", 0) > 0),
                     key=lambda w: w[0] * w[1])
    sizes = f"{windows[0]} to {windows[-1]}" if windows else "none (no step in contact)"
    summary = report["summary"]
    print(f"{name}: CPU {cpu_s:.2f} s, contact solves {summary['timings_s']['contact']:.2f} s wall; "
          f"{summary['steps']} steps ({summary['contact_steps']} in contact), "
          f"{summary['non_converged_steps']} not converged; windows {sizes}; "
          f"twin body {report['twin_body']['cache_status']}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tac3d", default="build/bin/tac3d")
    parser.add_argument("--scene", default="two_material_slide")
    parser.add_argument("--steps", type=int, default=70)
    parser.add_argument("--twin-refinement", type=float, default=1.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        runs = {}
        for name, windowed in (("windowed", True), ("whole grid", False)):
            runs[name] = simulate(args, pathlib.Path(folder) / name.replace(" ", "_"), windowed)
            describe(name, *runs[name])
    force_difference = max(
        (sum((a - b) ** 2 for a, b in zip(w["total_force_n"], g["total_force_n"])) ** 0.5
         for w, g in zip(runs["windowed"][2], runs["whole grid"][2])), default=0.0)
    print(f"whole grid / windowed CPU: {runs['whole grid'][0] / runs['windowed'][0]:.2f}x; "
          f"largest total force difference {force_difference:.3g} N")


if __name__ == "__main__":
    main()
