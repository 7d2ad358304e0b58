#!/usr/bin/env python3
"""Writes src/tac3d/vendor_formats/test_hdl1_0001.h, the vendor tests' fixture, from the real sensor
HDL1-0001's files in ../shared/realdata (docs/real-sensors.md): the calibration values, the 800
reference pixels, the recording's reference positions (frame 0's 3D_Positions -
3D_Displacements, rounded to 1e-6 mm), and two of its frames (the first and the last: their
3D_Displacements, 3D_Forces and 3D_ResultantForce, rounded to 1e-6 mm and N), so the tests run
where ../shared is absent.
Usage: /usr/bin/python3 scripts/make_vendor_fixture.py [REALDATA_DIR]"""
import os
import sys

import numpy as np
import yaml

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
realdata = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "..", "shared", "realdata")
sensor = os.path.join(realdata, "tac3d", "HDL1-0001")
config = os.path.join(sensor, "config")
recording = os.path.join(sensor, "recording", "Tac3D_Record_20241227_161029", "HDL1-0001")

p = yaml.safe_load(open(os.path.join(config, "Reconstruction3D", "parameters.yaml")))
d = yaml.safe_load(open(os.path.join(config, "datasheet.yaml")))
pixels = np.loadtxt(os.path.join(config, "DMP3_by_Zhang", "markers.txt"), delimiter=",")
displacements = np.load(os.path.join(recording, "3D_Displacements.npy"))
forces = np.load(os.path.join(recording, "3D_Forces.npy"))
resultants = np.load(os.path.join(recording, "3D_ResultantForce.npy"))
reference = np.load(os.path.join(recording, "3D_Positions.npy"))[0] - displacements[0]
frames = [0, len(displacements) - 1]
assert pixels.shape == (800, 2) and reference.shape == (400, 3)
assert np.all(pixels == np.round(pixels)), "the fixture stores whole pixels"


def numbers(values):
    return ", ".join(repr(float(v)) for v in values)


def vector(values):
    return "{" + numbers(values) + "}"


def view(name):
    e = p["extrinsic"][name]
    return f"    {{{{{numbers([e['x'], e['y'], e['z']])}}}, {vector(e['rotation'])}}},  // {name}\n"


i, k, r, a = p["intrinsic"], p["distortion"], p["refraction"], d["Accuracy"]
out = []
out.append(f"""#pragma once

// A fixture derived from the real Tac3D sensor HDL1-0001 (the vendor's SDK 3.2.1 sample files, from
// github.com/ChangerC77/Tac-3D at commit a4d3724115666bb7aa405d2e4efe214a80b429ee; here in
// ../shared/realdata/tac3d/HDL1-0001, see its README): the numbers of
// config/Reconstruction3D/parameters.yaml, config/datasheet.yaml and config/sensor.yaml (1920 x 1080,
// flipX true, flipY false, a 20 x 20 grid), the 800 reference pixels of config/DMP3_by_Zhang/markers.txt
// (whole pixels), and the reference positions of the recording
// recording/Tac3D_Record_20241227_161029/HDL1-0001 (frame 0's 3D_Positions - 3D_Displacements, mm,
// rounded to 1e-6 mm). Written by scripts/make_vendor_fixture.py; do not edit.

#include <array>

namespace tac3d::testing::hdl1_0001 {{

inline constexpr int kWidth = 1920, kHeight = 1080, kGridCols = 20, kGridRows = 20;
inline constexpr bool kFlipX = true, kFlipY = false;
inline constexpr double kFx = {i['fx']!r}, kFy = {i['fy']!r}, kCx = {i['cx']!r}, kCy = {i['cy']!r};
inline constexpr std::array<double, 5> kDistortion = {vector([k['k1'], k['k2'], k['p1'], k['p2'], k['k3']])};  // k1 k2 p1 p2 k3

struct View {{
  std::array<double, 3> center_mm;
  std::array<double, 9> rotation;  ///< row-major, camera to sensor
}};
inline constexpr std::array<View, 2> kViews = {{{{
""")
out.append(view("left"))
out.append(view("right"))
out.append(f"""}}}};
inline constexpr double kN21 = {r['n21']!r}, kH0 = {r['h0']!r}, kTheta = {r['theta']!r}, kPhi = {r['phi']!r};
inline constexpr double kYoungsModulusMpa = {d['Parameters']['E']!r}, kPoissonRatio = {d['Parameters']['P']!r};
inline constexpr std::array<std::array<double, 3>, 7> kDatasheet = {{{{  // Np Nf Nfm Dp Df Dfm Efm
""")
for key in ["Np", "Nf", "Nfm", "Dp", "Df", "Dfm", "Efm"]:
    out.append(f"    {{{{{numbers(a[key])}}}}},\n")
out.append("}};\n\n/// markers.txt: rows 0-399 the left view's (u, v), rows 400-799 the right view's.\n")
out.append("inline constexpr std::array<std::array<short, 2>, 800> kReferencePixels = {{\n")
for row in range(0, 800, 8):
    out.append("    " + " ".join(f"{{{int(u)}, {int(v)}}}," for u, v in pixels[row:row + 8]) + "\n")
out.append("}};\n\n/// The recording's reference positions (mm, sensor frame), marker by marker.\n")
out.append("inline constexpr std::array<std::array<double, 3>, 400> kReferencePositionsMm = {{\n")
for x, y, z in reference:
    out.append(f"    {{{x:.6f}, {y:.6f}, {z:.6f}}},\n")
out.append("}};\n\n/// Frames " + " and ".join(str(k) for k in frames) + " of the recording (of its "
           f"{len(displacements)}): 3D_Displacements (mm) and 3D_Forces (N), marker by marker, and "
           "3D_ResultantForce (N).\n")
out.append("struct RecordedFrame {\n  std::array<std::array<double, 3>, 400> displacements_mm;\n"
           "  std::array<std::array<double, 3>, 400> forces_n;\n  std::array<double, 3> resultant_force_n;\n};\n")
out.append(f"inline constexpr std::array<RecordedFrame, {len(frames)}> kRecordedFrames = {{{{\n")
for k in frames:
    out.append("    {{{\n")
    for field, end in ((displacements[k], "     }}, {{\n"), (forces[k], "     }},\n")):
        for x, y, z in field:
            out.append(f"         {{{x:.6f}, {y:.6f}, {z:.6f}}},\n")
        out.append(end)
    x, y, z = resultants[k][0]
    out.append(f"     {{{x:.6f}, {y:.6f}, {z:.6f}}}}},\n")
out.append("}};\n\n}  // namespace tac3d::testing::hdl1_0001\n")
path = os.path.join(root, "src", "tac3d", "vendor", "test_hdl1_0001.h")
open(path, "w").write("".join(out))
print("wrote", path)
