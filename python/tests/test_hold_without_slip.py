"""The twin stepped under a controller's loads (tac3d.TwinSimulation). The grasp example that
drives it (examples/python/hold_without_slip.py) runs shortened as docs/grasping.md's example,
on the models the docs' examples share."""
import pytest

import tac3d
from conftest import SMALL_TWIN

SPHERE_HELD = """
name: held
sensor: {sensor}
deviation: {{mesh_refinement: 1.0, youngs_modulus_factor: 1.0, poisson_ratio_factor: 1.0}}
objects:
  - {{name: ball, shape: sphere, radius_mm: 5, position_mm: [0, 0, 8.0], friction: {{default: 0.3}}}}
trajectory:
  steps: 4
  keyframes:
    - {{t_s: 0, position_mm: [0, 0, 0]}}
    - {{t_s: 1, position_mm: [0, 0, 0]}}
"""


def test_twin_simulation_steps_under_the_callers_forces(small_sensor_yaml, cache_dir):
    scene = tac3d.parse_scene(SPHERE_HELD.format(sensor=small_sensor_yaml))
    sim = tac3d.TwinSimulation(scene, cache_dir=cache_dir, images=False, twin_options=SMALL_TWIN)
    assert (sim.num_steps, sim.steps_done) == (4, 0)
    free = sim.step(normal_force_n=0.0)
    assert free["solver"]["status"] == "separated" and not free["total_force"].any()
    held = sim.step(normal_force_n=0.5, tangential_force_n=(0.1, 0.0))  # mu P = 0.15 N
    assert held["solver"]["status"] == "converged"
    assert held["total_force"] == pytest.approx([0.1, 0.0, -0.5], abs=2e-3)
    assert "image" not in held and sim.steps_done == 2
    slid = sim.step(normal_force_n=0.5, tangential_force_n=(0.2, 0.0))
    assert slid["solver"]["status"] == "gross sliding"
    assert slid["total_force"][0] == pytest.approx(0.3 * -slid["total_force"][2], rel=1e-2)
    with pytest.raises(tac3d.Error, match="needs a normal_force_n"):
        sim.step(tangential_force_n=(0.1, 0.0))
    with pytest.raises(tac3d.Error, match=r"normal_force_n must be in \[0, 1000\] N, got -1"):
        sim.step(normal_force_n=-1.0)
    # 1e160 N overflowed into a zero tangential force and no slip: refused.
    with pytest.raises(tac3d.Error, match="tangential_force_n must be at most 1000 N long"):
        sim.step(normal_force_n=1.0, tangential_force_n=(1e160, 0.0))
    sim.step()  # the trajectory's own step: the sphere only touches
    with pytest.raises(tac3d.Error, match="all 4 steps"):
        sim.step()
    with pytest.raises(tac3d.Error, match="all 4 steps"):
        sim.step(normal_force_n=0.5)


def test_twin_simulation_solves_on_a_window_unless_told_not_to(small_sensor_yaml, cache_dir):
    scene = tac3d.parse_scene(SPHERE_HELD.format(sensor=small_sensor_yaml))
    steps = {}
    for window in (True, False):
        sim = tac3d.TwinSimulation(scene, cache_dir=cache_dir, images=False,
                                   twin_options=SMALL_TWIN, window=window)
        steps[window] = sim.step(normal_force_n=0.05, tangential_force_n=(0.01, 0.0))
        assert steps[window]["solver"]["status"] == "converged"
    # A light press touches a few nodes: its window is a part of the grid the whole-grid solve
    # covers (13 x 13 against 8 x 8 here), and the solution is the same.
    (wx, wy), (gx, gy) = steps[True]["solver"]["window"], steps[False]["solver"]["window"]
    assert wx <= gx and wy <= gy and wx * wy < gx * gy
    assert steps[True]["total_force"] == pytest.approx(steps[False]["total_force"], abs=1e-7)
