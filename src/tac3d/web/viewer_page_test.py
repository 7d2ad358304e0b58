#!/usr/bin/env python3
"""The viewer page in headless Chromium against a replayed twin dataset (docs/viewer.md).

Simulates a short slide on a small twin sensor, replays it with `tac3d run --web --record`, loads
the page twice in headless Chromium (Debian's `chromium`, installed by scripts/setup.sh): once to
dump the DOM (frames received > 0, the sensor's panel made) and once for a screenshot, whose
3D canvas must hold drawn (non-background) pixels. Then serves that recording and a small
friction map with `tac3d view`: the page must show the time slider over every recorded frame,
the first frame fetched by index, the map's band counts and a drawn friction canvas. Last,
serves the dataset with `tac3d view --dataset`: the camera image in the page must show the
tracked markers (green). Exits non-zero on any failure.

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
VIEW_WINDOW = (1120, 1400)  # `tac3d view`: the friction map's panel below the sensor's
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


def marker_pixels(path, left, top, width, height):
    """Pixels of the camera image clearly green (a tracked marker's ring) and clearly red (a
    lost marker's cross), as the server draws them (src/tac3d/web/camera_image.cc)."""
    w, h, rows = read_png_rgb(path)
    green = red = 0
    for y in range(int(top), int(min(h, top + height))):
        row = rows[y]
        for x in range(int(left), int(min(w, left + width))):
            r, g, b = row[3 * x:3 * x + 3]
            green += g >= r + 40 and g >= b + 40
            red += r >= g + 40 and r >= b + 40
    return green, red


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


def chromium(args, timeout, window=WINDOW):
    binary = shutil.which("chromium")
    if binary is None:
        fail("chromium is not installed (scripts/setup.sh installs it)")
    command = [binary, "--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
               "--enable-unsafe-swiftshader", "--window-size=%d,%d" % window, "--hide-scrollbars",
               "--virtual-time-budget=4000"] + args
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)


def wait_for_page(url, process):
    deadline = time.time() + 90  # a first run may build the compliance model
    while True:
        try:
            return urllib.request.urlopen(url, timeout=2).read().decode()
        except OSError:
            if process.poll() is not None:
                fail("tac3d ended: " + process.stderr.read())
            if time.time() > deadline:
                fail("the viewer did not come up on " + url)
            time.sleep(0.2)


def dump_dom_until(url, pattern, what):
    """The DOM of the first of 5 loads in which `pattern` matches (virtual time can run out)."""
    for attempt in range(5):
        dom = chromium(["--dump-dom", url], timeout=60, window=VIEW_WINDOW).stdout
        if re.search(pattern, dom):
            return dom
        print("load %d: %s not yet" % (attempt + 1, what))
    fail("%s did not show in 5 loads: %s" % (what, dom[:400]))


def write_friction_ply(path):
    """Two triangles, one vertex in each of the paper's bands (mu 0.3, 0.65, 0.95, unknown)."""
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
                "property double z\nproperty double mu\nproperty double confidence\n"
                "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                "0 0 0 0.3 1\n10 0 0 0.65 1\n0 10 0 0.95 1\n10 10 2 nan 0\n3 0 1 2\n3 1 3 2\n")


def check_view(tac3d, work, recording):
    """`tac3d view`: the recording's frames on the time slider, and a friction map."""
    ply = os.path.join(work, "map.ply")
    write_friction_ply(ply)
    port = free_port()
    url = "http://127.0.0.1:%d/" % port
    view = subprocess.Popen([tac3d, "view", "--recording", recording, "--friction-map", ply, "--web",
                             "127.0.0.1:%d" % port, "--web-hold", "60"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_page(url, view)
        dom = dump_dom_until(url, r'data-shown="0"', "frame 0 fetched by index")
        slider = re.search(r'id="slider" min="0" max="(\d+)"', dom)
        if not slider or int(slider.group(1)) != 29:
            fail("the time slider does not span the 30 recorded frames: " + (slider.group(0) if slider else "none"))
        # A recording is said to be one, at the rate it was recorded (not the server's 0 fps).
        if 'id="mode">recording<' not in dom or not re.search(r'recorded at \d+\.\d</span> fps', dom):
            fail("the page does not say it shows a recording at its recorded rate")
        if "0.5: 1 vertices" not in dom or "unknown: 1" not in dom:
            fail("the friction map's band counts are missing")
        rect = re.search(r'data-friction-canvas="([^"]+)"', dom)
        if not rect:
            fail("the page did not report the friction canvas")
        left, top, width, height = json.loads(rect.group(1).replace("&quot;", '"'))
        shot = os.path.join(work, "view.png")
        for attempt in range(5):
            chromium(["--screenshot=" + shot, url], timeout=60, window=VIEW_WINDOW)
            share = drawn_share(shot, left, top, width, height)
            if share >= 0.02:
                break
        print("tac3d view: slider over %d frames, friction canvas drawn pixels %.1f%%" % (int(slider.group(1)) + 1, 100 * share))
        if share < 0.02:
            fail("the friction canvas is (nearly) empty: %.2f%% drawn" % (100 * share))
    finally:
        view.terminate()
        view.wait(timeout=10)


def check_view_dataset(tac3d, work, dataset, sensor):
    """`tac3d view --dataset`: the dataset's images through the pipeline, each with the
    tracker's markers drawn on it; the twin at rest and sliding tracks every marker, so the
    camera image shows hundreds of green ring pixels. (Served from memory, so unlike the live
    stream no image can be missed for want of a client at the moment it was published.)"""
    port = free_port()
    url = "http://127.0.0.1:%d/" % port
    view = subprocess.Popen([tac3d, "view", "--dataset", dataset, "--config", sensor, "--web", "127.0.0.1:%d" % port,
                             "--web-hold", "60"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_page(url, view)
        dom = dump_dom_until(url, r'data-camera="', "frame 0's camera image")
        left, top, width, height = json.loads(re.search(r'data-camera="([^"]+)"', dom).group(1).replace("&quot;", '"'))
        shot = os.path.join(work, "view_dataset.png")
        for attempt in range(5):
            chromium(["--screenshot=" + shot, url], timeout=60, window=VIEW_WINDOW)
            green, red = marker_pixels(shot, left, top, width, height)
            if green >= 500:
                break
        print("tac3d view --dataset: camera image with %d green (tracked) and %d red (lost) marker pixels" % (green, red))
        if green < 500:
            fail("the camera image shows no tracked markers: %d green pixels" % green)
    finally:
        view.terminate()
        view.wait(timeout=10)


def write_small_scene(tac3d, work):
    """A sphere pressed into and slid over a small fingertip (6 x 6 markers on a 12 mm dome, as
    python/tests/conftest.py's small sensor), 30 steps: its twin body and compliance model
    build in seconds into the test's cache (TAC3D_CACHE_DIR), where the built-in sensor's
    would take minutes and gigabytes."""
    import yaml

    sensor_path = os.path.join(work, "small_sensor.yaml")
    subprocess.run([tac3d, "design", "--out", sensor_path], check=True, capture_output=True, timeout=60)
    with open(sensor_path) as f:
        sensor = yaml.safe_load(f)
    sensor["markers"]["rows"] = sensor["markers"]["cols"] = 6
    sensor["elastic_body"].update(base_diameter_mm=12.0, thickness_mm=3.0, outer_radius_mm=20.0)
    with open(sensor_path, "w") as f:
        yaml.safe_dump(sensor, f)
    scene_path = os.path.join(work, "small_slide.yaml")
    with open(scene_path, "w") as f:
        f.write("""name: small_slide
sensor: %s
deviation: {mesh_refinement: 1.0, youngs_modulus_factor: 1.1, poisson_ratio_factor: 0.99}
objects:
  - {name: ball, shape: sphere, radius_mm: 5, position_mm: [0, 0, 8.0], friction: {default: 0.3}}
trajectory:
  steps: 30
  keyframes:
    - {t_s: 0, position_mm: [0, 0, -0.05]}
    - {t_s: 0.2, position_mm: [0, 0, -0.05]}
    - {t_s: 0.4, position_mm: [0, 0, 0.15]}
    - {t_s: 0.58, position_mm: [0.5, 0, 0.15]}
""" % sensor_path)
    return scene_path, sensor_path


def main():
    tac3d, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    dataset = os.path.join(work, "ds")
    scene, sensor = write_small_scene(tac3d, work)
    subprocess.run([tac3d, "simulate", "--scene", scene, "--out", dataset],
                   check=True, capture_output=True, timeout=120)
    port = free_port()
    url = "http://127.0.0.1:%d/" % port
    # 30 steps of 20 ms at a fifth of real time: 3 s of live frames, then the last one held.
    recording = os.path.join(work, "run.rec")
    run = subprocess.Popen([tac3d, "run", "--source", "dataset:" + dataset, "--config", sensor, "--speed", "0.2", "--web",
                            "127.0.0.1:%d" % port, "--web-hold", "30", "--record", recording],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        page = wait_for_page(url, run)
        source_ends = time.time() + 4  # 30 steps of 20 ms at 0.2x: 3 s after the page is up
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
        # The margin estimate (docs/viewer.md): labelled with its measured error, no gauge; its
        # text "-" or "0.42 +- 0.03, ...".
        if re.search(r'<meter', dom) or "margin estimate (median error 0.2)" not in dom or not re.search(
                r'class="margin-text">(-|\d\.\d\d)', dom):
            fail("the margin estimate's label or text is missing, or a gauge is back")
        # The 3D surface's colour scale, with its top in N.
        if 'id="mode">live viewer<' not in dom or not re.search(r'class="colour-max">\d\.\d{3}</span> N', dom):
            fail("the live label or the surface's colour scale is missing")
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
        time.sleep(max(0.0, source_ends - time.time()))  # every frame recorded
    finally:
        run.terminate()
        try:
            run.wait(timeout=10)
        except subprocess.TimeoutExpired:
            run.kill()
    check_view(tac3d, work, recording)
    check_view_dataset(tac3d, work, dataset, sensor)
    print("PASS")


if __name__ == "__main__":
    main()
