#!/usr/bin/python3
"""A script written for the vendor's PyTac3D client, with only its import changed.

Start a stream first, e.g. a twin dataset through the pipeline:
    tac3d run --source dataset:DIR --udp 127.0.0.1:9988
then run this script: it prints each frame's resultant force, zeroes the sensor after 5 s
(`$C`) and stops it (`$Q`) after 10 s.
"""
import time

import tac3d as PyTac3D  # was: import PyTac3D

SN = ""


def Tac3DRecvCallback(frame, param):
    global SN
    SN = frame["SN"]
    force = frame.get("3D_ResultantForce")  # numpy 1 x 3, N
    print(f"{SN} #{frame['index']:5d} t={frame['sendTimestamp']:7.3f} s "
          f"F = [{force[0, 0]:+.3f} {force[0, 1]:+.3f} {force[0, 2]:+.3f}] N  ({param})")


tac3d = PyTac3D.Sensor(recvCallback=Tac3DRecvCallback, port=9988, maxQSize=5,
                       callbackParam="test param")
tac3d.waitForFrame()
time.sleep(5)
tac3d.calibrate(SN)  # zero: the sensor must not touch anything now
time.sleep(5)
frame = tac3d.getFrame()
if frame is not None:
    print("last queued frame:", frame["index"], frame["3D_Positions"].shape)
tac3d.quitSensor(SN)
