"""Single-view marker tracking in one call: ``tac3d.track`` (docs/real-images.md)."""

from typing import NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ._core import SingleViewTracker


class TrackResult(NamedTuple):
    """A whole track: T frames of N markers (row-major, index = row * cols + col)."""

    rows: int
    cols: int
    index: np.ndarray         # (T,) the source's frame indices
    timestamp_s: np.ndarray   # (T,)
    xy: np.ndarray            # (T, N, 2) px, NaN where lost
    state: np.ndarray         # (T, N) 'tracked', 'cut', 'estimated' or 'lost'
    reference_xy: np.ndarray  # (N, 2) px, the positions in the reference frame
    summary: dict             # tac3d track's summary figures


def track(
    source: str,
    grid: Optional[Tuple[int, int]] = None,
    reference: int = 0,
    rest_frames: Sequence[Tuple[int, int]] = (),
    max_frames: Optional[int] = None,
    **camera,
) -> TrackResult:
    """Tracks a single-view sensor's markers through ``source`` (a video, an image folder,
    ``camera:N``) from the reference frame on, to its end or ``max_frames`` frames (a camera
    has no end). The other arguments are ``SingleViewTracker``'s."""
    tracker = SingleViewTracker(source, grid=grid, reference=reference, rest_frames=list(rest_frames), **camera)
    index, timestamps, xy, state = [], [], [], []
    for frame in tracker:
        index.append(frame.index)
        timestamps.append(frame.timestamp_s)
        xy.append(frame.xy)
        state.append(frame.state)
        if max_frames is not None and len(index) >= max_frames:
            break
    n = tracker.rows * tracker.cols
    return TrackResult(
        rows=tracker.rows,
        cols=tracker.cols,
        index=np.array(index, dtype=np.int64),
        timestamp_s=np.array(timestamps, dtype=np.float64),
        xy=np.array(xy, dtype=np.float64).reshape(len(index), n, 2),
        state=np.array(state).reshape(len(index), n),
        reference_xy=tracker.reference_xy,
        summary=tracker.summary,
    )
