"""scripts/incipient_information.py's comparison (docs/incipient.md, "How much of mu the markers
carry"): two runs compared at equal tangential load over the window, and the part of their
difference that a gain error cannot mimic."""
import importlib.util
import pathlib

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location(
    "incipient_information", REPO / "scripts" / "incipient_information.py")
information = importlib.util.module_from_spec(spec)
spec.loader.exec_module(information)

SIGMA = np.array([0.001, 0.001, 0.002])
RNG = np.random.default_rng(7)
SHEAR = RNG.normal(size=(30, 3))  # the field per newton of tangential load
PRESS = RNG.normal(size=(30, 3))  # the pressed field


def run(ramp_steps, extra=None, gain=(1.0, 1.0, 1.0)):
    """5 steps clear, 5 pressed at P = 1 N, a tangential ramp to Q = 1 N over ramp_steps, 10 steps
    at Q = 1 N; the field u = PRESS + Q (SHEAR + extra), scaled per axis by `gain`."""
    q = np.concatenate([np.zeros(10), np.linspace(0, 1, ramp_steps + 1)[1:], np.ones(10)])
    p = np.concatenate([np.zeros(5), np.ones(len(q) - 5)])
    shear = SHEAR if extra is None else SHEAR + extra
    u = p[:, None, None] * PRESS + q[:, None, None] * shear
    return dict(u=u * np.asarray(gain), P=p, Q=q)


def test_the_difference_at_equal_load_is_measured_over_the_window_only():
    extra = RNG.normal(size=(30, 3)) * 0.01
    a, b = run(40), run(25, extra)  # b ramps faster: its steps are not a's
    whole, free, field, dp = information.compare(a, b, 1.0, SIGMA)
    window = [q for q in a["Q"][10:50] if 0.5 <= q <= 0.9]
    assert len(whole) == len(window) == 17
    expected = [np.linalg.norm(q * extra / SIGMA) for q in window]
    assert whole == pytest.approx(expected, rel=1e-9)
    assert field == pytest.approx([np.linalg.norm((PRESS + q * SHEAR) / SIGMA) for q in window])
    assert not dp.any()
    assert (free > 0.2 * whole).all() and (free <= whole + 1e-12).all()


def test_a_gain_error_is_not_signal():
    a, b = run(40), run(40, gain=(1.05, 0.97, 1.1))
    whole, free, _, _ = information.compare(a, b, 1.0, SIGMA)
    assert (whole > 10).all()
    assert free == pytest.approx(np.zeros_like(free), abs=1e-9)
