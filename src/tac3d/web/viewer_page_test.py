#!/usr/bin/env python3
"""The viewer page in headless Chromium against a replayed twin dataset (docs/viewer.md).

Simulates a short two_material_slide dataset, replays it with `tac3d run --web`, loads the
page twice in headless Chromium (Debian's `chromium`, installed by scripts/setup.sh): once to
dump the DOM (frames received > 0, the sensor's panel made) and once for a screenshot, whose
3D canvas must hold drawn (non-background) pixels. Exits non-zero on any failure.

usage: viewer_page_test.py TAC3D_BINARY WORK_DIR
"""
import json
import os
import re
import shutil
import socket
import struct
import subprocess
import sys
import time
import urllib.request
import zlib

WINDOW = (1120, 900)
BACKGROUND_3D = (0x10, 0x12, 0x14)  # viewer.js BACKGROUND, the WebGL clear colour


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def read_png_rgb(path):
    """(width, height, rows of RGB bytes) of an 8-bit RGB or RGBA PNG, with the stdlib only."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        fail(path + " is not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, color_type = header[:4]
    if depth != 8 or color_type not in (2, 6):
        fail("unexpected PNG format depth %d colour type %d" % (depth, color_type))
    channels = 3 if color_type == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous, i = [], bytearray(stride), 0
    for _ in range(height):
        kind, line = raw[i], bytearray(raw[i + 1:i + 1 + stride])
        i += 1 + stride
        for x in range(stride):
            a = line[x - channels] if x >= channels else 0
            b = previous[x]
            c = previous[x - channels] if x >= channels else 0
            if kind == 1:
                line[x] = (line[x] + a) & 255
            elif kind == 2:
                line[x] = (line[x] + b) & 255
            elif kind == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line if channels == 3 else bytes(v for k, v in enumerate(line) if k % 4 != 3)))
        previous = line
    return width, height, rows


def drawn_share(path, left, top, width, height):
    """The share of the 3D canvas's pixels (every second one) away from its clear colour."""
    w, h, rows = read_png_rgb(path)
    drawn = total = 0
    for y in range(int(top), int(min(h, top + height)), 2):
        row = rows[y]
        for x in range(int(left), int(min(w, left + width)), 2):
            r, g, b = row[3 * x:3 * x + 3]
            total += 1
            if max(abs(r - BACKGROUND_3D[0]), abs(g - BACKGROUND_3D[1]), abs(b - BACKGROUND_3D[2])) > 24:
                drawn += 1
    return drawn / max(total, 1)


def chromium(args, timeout):
    binary = shutil.which("chromium")
    if binary is None:
        fail("chromium is not installed (scripts/setup.sh installs it)")
    command = [binary, "--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
               "--enable-unsafe-swiftshader", "--window-size=%d,%d" % WINDOW, "--hide-scrollbars",
               "--virtual-time-budget=4000"] + args
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)


def main():
    tac3d, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    dataset = os.path.join(work, "ds")
    subprocess.run([tac3d, "simulate", "--scene", "two_material_slide", "--steps", "30", "--out", dataset],
                   check=True, capture_output=True, timeout=120)
    port = free_port()
    url = "http://127.0.0.1:%d/" % port
    # 30 steps of 20 ms at a fifth of real time: 3 s of live frames, then the last one held.
    run = subprocess.Popen([tac3d, "run", "--source", "dataset:" + dataset, "--speed", "0.2", "--web",
                            "127.0.0.1:%d" % port, "--web-hold", "30"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 90  # a first run may build the compliance model
        while True:
            try:
                page = urllib.request.urlopen(url, timeout=2).read().decode()
                break
            except OSError:
                if run.poll() is not None:
                    fail("tac3d run ended: " + run.stderr.read())
                if time.time() > deadline:
                    fail("the viewer did not come up on " + url)
                time.sleep(0.2)
        if "three.min.js" not in page:
            fail("the page does not load three.js")

        # Chromium's virtual time can run out before a message arrives in real time on a loaded
        # machine, so a load that saw no frame is retried (at most 5 times); the run keeps
        # serving, and a new client gets the last frame at once.
        for attempt in range(5):
            dom = chromium(["--dump-dom", url], timeout=60).stdout
            received = re.search(r'id="received">(\d+)<', dom)
            if received and int(received.group(1)) >= 1:
                break
            print("load %d: no frame yet" % (attempt + 1))
        if not received or int(received.group(1)) < 1:
            fail("no frames arrived in the page in 5 loads: " + (received.group(0) if received else dom[:400]))
        if "TAC3D-TWIN" not in dom or 'id="connection" class="good"' not in dom:
            fail("the sensor's panel or the connection state is missing")
        rect = re.search(r'data-canvas="([^"]+)"', dom)
        if not rect:
            fail("the page did not report its 3D canvas")
        left, top, width, height = json.loads(rect.group(1).replace("&quot;", '"'))

        shot = os.path.join(work, "viewer.png")
        for attempt in range(5):
            chromium(["--screenshot=" + shot, url], timeout=60)
            share = drawn_share(shot, left, top, width, height)
            if share >= 0.05:
                break
        print("frames received in the DOM dump: %s; 3D canvas drawn pixels: %.1f%%" % (received.group(1), 100 * share))
        if share < 0.05:
            fail("the 3D canvas is (nearly) empty: %.2f%% drawn" % (100 * share))
        print("PASS")
    finally:
        run.terminate()
        try:
            run.wait(timeout=10)
        except subprocess.TimeoutExpired:
            run.kill()


if __name__ == "__main__":
    main()
