"""Single-view marker tracking from Python (tac3d.SingleViewTracker, tac3d.track) against
`tac3d track --json`, on real GelSight Mini frames (the C++ tests' fixture, whose README names
the source)."""
import json
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import tac3d

FIXTURE = pathlib.Path(__file__).resolve().parents[2] / "src/tac3d/tracking/testdata/gelsight_mini"


@pytest.fixture
def still_folder(tmp_path):
    """Frame 0 of the fixture three times (no motion), then frame 80 (a press)."""
    for k, name in enumerate(["frame_000.png"] * 3 + ["frame_080.png"]):
        shutil.copy(FIXTURE / name, tmp_path / f"f{k}.png")
    return tmp_path


def test_tracker_yields_each_frame_with_every_whole_marker_tracked(still_folder):
    tracker = tac3d.SingleViewTracker(str(still_folder), grid=(8, 10), rest_frames=[(1, 2)])
    frames = list(tracker)
    assert [f.index for f in frames] == [0, 1, 2, 3]
    assert (tracker.rows, tracker.cols) == (8, 10)
    first = frames[0]
    assert first.acquired and first.image.shape == (240, 320) and first.xy.shape == (80, 2)
    # The top row's dots are cut by the image's top edge; every other dot is whole.
    assert (first.state[:10] != "tracked").all()
    assert (first.state[10:] == "tracked").all()
    np.testing.assert_array_equal(first.xy, tracker.reference_xy)
    # The same image again: tracked, the dots where they were (a tracked centroid's disk is
    # placed about its prediction, an acquired one's about the detected blob: hundredths of a
    # pixel apart), and the third frame as the second (its predictions from the second's
    # positions: within thousandths of a pixel), so next to no jitter.
    for f in frames[1:3]:
        assert not f.acquired
        assert (f.state == first.state).all()
        np.testing.assert_allclose(f.xy, tracker.reference_xy, atol=0.15)
    np.testing.assert_allclose(frames[1].xy, frames[2].xy, atol=0.01)
    s = tracker.summary
    assert s["frames"] == 4 and s["rest_frames"] == 2 and s["swaps"] == 0
    assert s["jitter_x_px"] < 0.01 and s["jitter_y_px"] < 0.01
    assert s["deepest_frame"] == 3 and s["deepest_max_px"] > 5


def test_track_gives_what_the_cli_prints_line_by_line(still_folder, tac3d_cli):
    result = tac3d.track(str(still_folder), grid=(8, 10), rest_frames=[(1, 2)])
    out = subprocess.run([tac3d_cli, "track", "--source", str(still_folder), "--grid", "8x10", "--json",
                          "--rest-frames", "1:2"], check=True, capture_output=True, text=True, timeout=120).stdout
    lines = [json.loads(line) for line in out.splitlines()]
    assert len(lines) == 5  # a line per frame, then the summary
    assert lines[-1]["summary"] == result.summary
    assert result.xy.shape == (4, 80, 2) and result.state.shape == (4, 80)
    for t, line in enumerate(lines[:-1]):
        assert line["frame"] == result.index[t]
        markers = line["markers"]
        assert [(m["row"], m["col"]) for m in markers] == [(i // 10, i % 10) for i in range(80)]
        assert [m["state"] for m in markers] == list(result.state[t])
        xy = np.array([[np.nan if m["x"] is None else m["x"], np.nan if m["y"] is None else m["y"]]
                       for m in markers])
        np.testing.assert_allclose(xy, result.xy[t], atol=1e-9)
        np.testing.assert_allclose([[m["x0"], m["y0"]] for m in markers], result.reference_xy, atol=1e-9)
        assert line["tracked"] == int((result.state[t] == "tracked").sum())


def test_bad_input_raises(tmp_path):
    with pytest.raises(tac3d.Error, match="holds no image file"):
        tac3d.SingleViewTracker(str(tmp_path))
    shutil.copy(FIXTURE / "frame_000.png", tmp_path / "f.png")
    with pytest.raises(tac3d.Error, match="rows"):
        tac3d.SingleViewTracker(str(tmp_path), grid=(1000, 1000))
    with pytest.raises(tac3d.Error, match="before the reference frame 5"):
        tac3d.SingleViewTracker(str(tmp_path), reference=5)
