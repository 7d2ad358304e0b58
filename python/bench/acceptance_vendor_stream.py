#!/usr/bin/python3
"""Issue 12's acceptance, by hand: a vendor-style script (PyTac3D's calls, only the import
changed) receives every frame of a twin dataset streamed by `tac3d run --udp`, with the
vendor's keys, shapes and dtypes, zeroes the sensor and quits it.

    PYTHONPATH=build/python /usr/bin/python3 python/bench/acceptance_vendor_stream.py \\
        build/bin/tac3d DATASET_DIR [--zero-at 15] [--quit-at 30]

The default sensor's compliance model must be cached (`tac3d build-model`). Prints what it
checked; exits non-zero on the first failed check.
"""
import json
import subprocess
import sys
import time

import numpy as np

import tac3d as PyTac3D  # the one changed line: was `import PyTac3D`

cli, dataset = sys.argv[1], sys.argv[2]
zero_at = int(sys.argv[sys.argv.index("--zero-at") + 1]) if "--zero-at" in sys.argv else 15
quit_at = int(sys.argv[sys.argv.index("--quit-at") + 1]) if "--quit-at" in sys.argv else 30

frames = []


def Tac3DRecvCallback(frame, param):
    frames.append(frame)
    if len(frames) == zero_at:
        sensor.calibrate(frame["SN"])
    if len(frames) == quit_at:
        sensor.quitSensor(frame["SN"])


sensor = PyTac3D.Sensor(recvCallback=Tac3DRecvCallback, port=9988, maxQSize=5, callbackParam=None)
run = subprocess.Popen([cli, "run", "--source", f"dataset:{dataset}", "--udp", "127.0.0.1:9988",
                        "--sn", "AD2-0065L", "--json"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
out, err = run.communicate(timeout=600)
time.sleep(0.5)
sent = [json.loads(line) for line in out.splitlines()]
measured = [s["index"] for s in sent if s["initialize_progress"] == 100]
zeroed = [s["index"] for s in sent if s["initialize_progress"] < 100 and s["index"] >= 20]
steps = len(PyTac3D.Dataset(dataset))


def check(what, ok):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        sys.exit(1)


check(f"run exited 0 after {len(sent)} of {steps} frames (stopped by $Q)", run.returncode == 0 and len(sent) < steps)
check(f"every measured frame received: {len(frames)} == {len(measured)}, same indices",
      [f["index"] for f in frames] == measured)
keys = {"SN", "index", "sendTimestamp", "recvTimestamp", "3D_Positions", "3D_Displacements",
        "3D_Forces", "3D_ResultantForce", "3D_ResultantMoment", "InitializeProgress"}
check("vendor keys in every frame", all(keys <= set(f) for f in frames))
check("3D_* per marker: float64 400 x 3", all(
    f[k].dtype == np.float64 and f[k].shape == (400, 3) for f in frames
    for k in ("3D_Positions", "3D_Displacements", "3D_Forces")))
check("resultants: float64 1 x 3", all(
    f[k].dtype == np.float64 and f[k].shape == (1, 3) for f in frames
    for k in ("3D_ResultantForce", "3D_ResultantMoment")))
check("types: SN str, index int, timestamps float", all(
    isinstance(f["SN"], str) and isinstance(f["index"], int) and isinstance(f["sendTimestamp"], float)
    and isinstance(f["recvTimestamp"], float) for f in frames))
by_index = {s["index"]: s for s in sent}
check("values: resultant force as the sender computed it", all(
    np.allclose(f["3D_ResultantForce"][0], by_index[f["index"]]["resultant_force_n"], rtol=1e-12, atol=1e-15)
    for f in frames))
check(f"zeroed: the sender re-took its reference on frames {zeroed[:1]}..{zeroed[-1:]} after calibrate()",
      len(zeroed) == 19 and zeroed == list(range(zeroed[0], zeroed[0] + 19)))
print(f"{len(frames)} frames received, {sensor.stats()['initializing_dropped']} initializing frames dropped "
      f"(the sender withholds them); {err.strip().splitlines()[-1]}")
