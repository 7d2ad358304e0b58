#!/usr/bin/python3
"""Records 10 s of a Tac3D stream to a tac3d recording, then plots the resultant force.

    tac3d run --source dataset:DIR --udp 127.0.0.1:9988 &
    /usr/bin/python3 examples/python/record_and_plot.py [out.tac3drec] [--port 9988] [--seconds 10]

The frames arrive as the vendor client's dicts (tac3d.Sensor); each is written as a
TactileFrame (tac3d.RecordingWriter), crash-safe frame by frame, then read back whole
(tac3d.open_recording) for the plot, saved next to the recording as PNG.
"""
import argparse
import math
import sys
import time

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import tac3d  # noqa: E402


def grid_shape(n):
    """rows x cols = n, as square as n allows: the stream does not say the grid's shape, and
    its markers are row-major, so a square grid (20 x 20 for 400) is read back as it was."""
    rows = max(r for r in range(1, math.isqrt(n) + 1) if n % r == 0)
    return rows, n // rows


def to_tactile_frame(d):
    n = d["3D_Positions"].shape[0]
    f = tac3d.TactileFrame(*grid_shape(n))
    f.sn, f.index, f.timestamp = d["SN"], d["index"], d["sendTimestamp"]
    f.positions = d["3D_Positions"]
    f.displacements = d["3D_Displacements"]
    f.forces = d["3D_Forces"]
    # Sent only when asked (`tac3d run --udp-items 3D_Normals`): NaN, "not measured", without.
    f.normals = d.get("3D_Normals", np.full((n, 3), np.nan))
    f.resultant_force = d["3D_ResultantForce"][0]
    f.resultant_moment = d["3D_ResultantMoment"][0]
    return f


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("out", nargs="?", default="stream.tac3drec")
    parser.add_argument("--port", type=int, default=9988)
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()

    with tac3d.RecordingWriter(args.out, overwrite=True) as writer:
        def on_frame(frame, _):
            writer.write(to_tactile_frame(frame))

        with tac3d.Sensor(recvCallback=on_frame, port=args.port) as sensor:
            print(f"listening on port {args.port}", file=sys.stderr, flush=True)  # a sender may start
            if not sensor.waitForFrame(timeout=30):
                raise SystemExit("no Tac3D stream on port %d" % args.port)
            time.sleep(args.seconds)
        print(f"{writer.frames_written} frames recorded to {args.out}")

    rec = tac3d.open_recording(args.out)
    t = rec.timestamps - rec.timestamps[0]
    force = rec.resultant_forces  # T x 3, N
    fig, ax = plt.subplots(figsize=(8, 4))
    for c, name in enumerate("xyz"):
        ax.plot(t, force[:, c], label=f"F{name}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("resultant force (N)")
    ax.legend()
    ax.grid(True)
    png = args.out.rsplit(".", 1)[0] + "_force.png"
    fig.savefig(png, dpi=100, bbox_inches="tight")
    print(f"plot: {png}")


if __name__ == "__main__":
    main()
