#!/usr/bin/env python3
"""The `tac3d run --run-file` figures of docs/pipeline.md ("Three twin sensors in one process", in its appendix).

Copies a twin dataset three times (a, b, c) into WORK, writes hand.yaml (HAND-A/B/C, speed 1,
reference_frames 5, each recording to a|b|c.rec), runs `tac3d run --run-file hand.yaml --json`
and prints, per SN, the frames and the lateness of frame k behind k/30 s on the run's common
clock, and each recording's frames and rate. With --kill, HAND-C's dataset folder is deleted
once its 10th frame has been printed.

usage: run_file_figures.py TAC3D_BINARY DATASET WORK [--cache DIR] [--kill]
(DATASET: e.g. the one cli/sensor_group_test leaves in
/tmp/tac3d_tests/SensorGroup.ThreeTwinSensorsDeliverEveryFrameOnOneClock/dataset/ds)
"""
import argparse
import collections
import json
import os
import shutil
import subprocess

RUN_FILE = """sensors:
""" + "".join("""  - sn: HAND-{0}
    source: dataset:{1}
    speed: 1
    reference_frames: 5
    record: {1}.rec
""".format(s.upper(), s) for s in "abc")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("tac3d")
    parser.add_argument("dataset")
    parser.add_argument("work")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--kill", action="store_true")
    args = parser.parse_args()
    tac3d = os.path.abspath(args.tac3d)
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    for s in "abc":
        shutil.copytree(args.dataset, os.path.join(args.work, s))
    with open(os.path.join(args.work, "hand.yaml"), "w") as f:
        f.write(RUN_FILE)
    command = [tac3d, "run", "--run-file", "hand.yaml", "--json"]
    if args.cache:
        command += ["--cache", args.cache]
    run = subprocess.Popen(command, cwd=args.work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    frames = collections.defaultdict(list)
    for line in run.stdout:
        frame = json.loads(line)
        frames[frame["sn"]].append((frame["index"], frame["timestamp_s"]))
        if args.kill and frame["sn"] == "HAND-C" and len(frames["HAND-C"]) == 10:
            shutil.rmtree(os.path.join(args.work, "c"))
    errors = run.stderr.read()
    print("exit code", run.wait())
    print("\n".join(l for l in errors.splitlines() if "skipped a bad" not in l and "WARN" not in l))
    for sn, fr in sorted(frames.items()):
        late = sorted(t - k / 30.0 for k, t in fr)
        print("%s: %d frames, lateness behind k/30 s %.1f-%.1f ms (median %.1f)" %
              (sn, len(fr), 1e3 * late[0], 1e3 * late[-1], 1e3 * late[len(late) // 2]))
    for s in "abc":
        info = json.loads(subprocess.run([tac3d, "recording", "info", "--json", s + ".rec"], cwd=args.work,
                                         capture_output=True, text=True, check=True).stdout)
        print("%s.rec: %d frames, %.3f s, %.1f frames/s" % (s, info["frames"], info["duration_s"], info["mean_fps"]))


if __name__ == "__main__":
    main()
