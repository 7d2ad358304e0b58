#!/usr/bin/python3
"""A script written for the vendor's PyTac3D client, with only its import changed.

Start a stream first, e.g. a twin dataset through the pipeline:
    tac3d run --source dataset:DIR --udp 127.0.0.1:9988
then run this script: it prints each frame's resultant force, zeroes the sensor (`$C`) at
rest, on the first frame whose resultant is under 0.1 N (normally the stream's first frames,
before anything touches the sensor), and stops it (`$Q`) after 10 s.

Zero only at rest: `$C` takes the present state as undeformed, so a zero taken mid-contact
offsets every later reading by the load of that moment (this script used to zero 5 s in, which
on the twin dataset two_material_slide is mid-contact, F about (-2.36, 0, -3.57) N: issue 27).
`tac3d run` refuses a `$C` while the sensor is loaded (a marker displaced more than 0.1 mm),
unless --allow-zero-under-load.
"""
import time

import numpy as np

import tac3d as PyTac3D  # was: import PyTac3D

SN = ""
REST_FORCE_N = 0.1  # |F| under this: nothing presses on the sensor


def Tac3DRecvCallback(frame, param):
    global SN
    SN = frame["SN"]
    force = frame.get("3D_ResultantForce")  # numpy 1 x 3, N
    print(f"{SN} #{frame['index']:5d} t={frame['sendTimestamp']:7.3f} s "
          f"F = [{force[0, 0]:+.3f} {force[0, 1]:+.3f} {force[0, 2]:+.3f}] N  ({param})")


def wait_at_rest(sensor, timeout_s=5.0):
    """The first queued frame whose resultant is under REST_FORCE_N, or None after timeout_s."""
    end = time.time() + timeout_s
    while time.time() < end:
        frame = sensor.getFrame()
        if frame is not None and np.linalg.norm(frame["3D_ResultantForce"]) < REST_FORCE_N:
            return frame
        time.sleep(0.005)
    return None


tac3d = PyTac3D.Sensor(recvCallback=Tac3DRecvCallback, port=9988, maxQSize=5,
                       callbackParam="test param")
tac3d.waitForFrame()
start = time.time()
rest = wait_at_rest(tac3d)
if rest is not None:
    tac3d.calibrate(rest["SN"])  # zero at rest: nothing touches the sensor now
    print(f"zeroed at rest on frame {rest['index']}")
else:
    print(f"not zeroed: no frame under {REST_FORCE_N} N within 5 s (the sensor is loaded)")
time.sleep(max(0.0, 10.0 - (time.time() - start)))
frame = tac3d.getFrame()
if frame is not None:
    print("last queued frame:", frame["index"], frame["3D_Positions"].shape)
tac3d.quitSensor(SN)
