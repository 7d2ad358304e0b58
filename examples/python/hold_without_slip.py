#!/usr/bin/python3
"""Holding an object whose weight grows, with the least normal force that keeps it from slipping
(docs/grasping.md).

A two-finger grasp, by symmetry one finger: the twin's fingertip presses a sphere (the object's
surface) with the normal force a controller commands, and carries half the object's weight as a
tangential load, which grows over the trial (filling a cup). Each step the twin renders the
camera image, the real pipeline turns it into a TactileFrame (tracking, forces, the live slip
estimate: docs/slip.md), and the controller sets the next step's normal force from that frame
only; the twin's truth (its contact solver) says whether the object slid.

Three controllers:

- least-force: N = safety |Q| / mu, |Q| the measured tangential load and mu the live estimate
  (the TactileFrame's `friction`, kept once seen), the design mu until there is one, never under
  a floor; each frame the estimator reports gross slip the grip is raised by a fixed fraction
  (a slip reflex).
- load-proportional: the same rule with the design mu always, no friction estimate: what the
  measured load alone gives.
- fixed threshold: the gripper closes to a fixed normal force, chosen for the worst case it is
  designed for: safety x the heaviest half-weight / the lowest mu (the usual force-threshold
  grasp of a parallel gripper).

Held: the twin's contact never slides as a whole (no step with status 'gross sliding').

    /usr/bin/python3 examples/python/hold_without_slip.py [--plot docs/images/grasping.png]
        [--mu 0.3 0.6 1.0] [--rates 0.5 1.0] [--hold-steps 60] [--trace FRAMES.csv] [--cache DIR]

The first run builds the twin body model and the pipeline's compliance model (about a minute
each at refinement 1) into the cache ($TAC3D_CACHE_DIR by default).
"""
import argparse
import math
import time

import numpy as np

import tac3d

SCENE_YAML = """
name: hold_mu{mu}
sensor: {sensor}
deviation: {{mesh_refinement: 1}}
objects:
  - {{name: object, shape: sphere, radius_mm: {radius}, position_mm: [0, 0, {z}],
     friction: {{default: {mu}}}}}
trajectory:
  steps: {steps}
  keyframes:
    - {{t_s: 0, position_mm: [0, 0, 0]}}
    - {{t_s: {duration}, position_mm: [0, 0, 0]}}
"""


class LoadProportional:
    """N = safety |Q| / design mu: the grip follows the measured tangential load, with the lowest
    mu the gripper is designed for; no friction estimate."""

    name = "load-proportional"

    def __init__(self, safety, floor_n, design_mu):
        self.safety, self.floor_n, self.design_mu = safety, floor_n, design_mu

    def mu(self):
        return self.design_mu

    def grip(self, frame, previous_n):
        if frame is None:
            return self.floor_n
        q = math.hypot(frame.resultant_force[0], frame.resultant_force[1])
        return max(self.floor_n, self.safety * q / self.mu())


class LeastForce(LoadProportional):
    """N = safety |Q| / mu with mu the live estimate (the frame's `friction`, kept once seen, as
    the estimator forgets it in stick), the design mu until there is one; raised by a fixed
    fraction in each frame of gross slip (a slip reflex)."""

    name = "least-force"

    def __init__(self, safety, floor_n, design_mu, reflex):
        super().__init__(safety, floor_n, design_mu)
        self.reflex = reflex
        self.estimate = math.nan  # the last estimate seen

    def mu(self):
        return self.design_mu if math.isnan(self.estimate) else self.estimate

    def grip(self, frame, previous_n):
        if frame is not None and math.isfinite(frame.friction):
            self.estimate = frame.friction
        n = super().grip(frame, previous_n)
        # Partial slip is no warning here: Cattaneo-Mindlin's annulus slips under any tangential
        # load, so a reflex on it only ratchets the grip up (docs/grasping.md).
        if frame is not None and frame.slip_state == "gross_slip":
            n = max(n, (1.0 + self.reflex) * previous_n)
        return n


class FixedThreshold:
    """A fixed normal force, enough for the heaviest load at the lowest mu it is designed for."""

    name = "fixed threshold"

    def __init__(self, safety, max_load_n, design_mu):
        self.force_n = safety * max_load_n / design_mu

    def grip(self, frame, previous_n):
        return self.force_n


def fingertip_thickness_mm(sensor_yaml):
    import yaml

    text = open(sensor_yaml).read() if sensor_yaml else tac3d.default_sensor_yaml()
    return float(yaml.safe_load(text)["elastic_body"]["thickness_mm"])


def weight_at(k_hold, args):
    """The object's weight (N) at hold step k_hold: from the start weight up at the rate."""
    t = k_hold / args.frame_rate
    return min(args.start_weight + args.rate * t, args.max_weight)


def run_trial(mu, rate, controller, args):
    """One trial: the reference, the closing, then the hold under a growing weight."""
    ramp_args = argparse.Namespace(**vars(args))
    ramp_args.rate = rate
    steps = args.reference + args.close_steps + args.hold_steps
    # The object just touches the fingertip's top (z = its thickness) at the identity pose.
    text = SCENE_YAML.format(mu=mu, sensor=args.sensor or "default", radius=args.radius,
                             z=fingertip_thickness_mm(args.sensor) + args.radius, steps=steps,
                             duration=(steps - 1) / args.frame_rate)
    sim = tac3d.TwinSimulation(tac3d.parse_scene(text), cache_dir=args.cache)
    pipeline = tac3d.Pipeline(config=args.sensor, cache_dir=args.cache,
                              reference_frames=args.reference)
    rows = []
    frame, normal_n = None, 0.0
    for k in range(steps):
        if k < args.reference:  # nothing touches: the pipeline's reference
            normal_n, weight = 0.0, 0.0
        elif k < args.reference + args.close_steps:  # the fingers close, nothing lifted yet
            target = controller.grip(None, 0.0)
            normal_n = target * (k - args.reference + 1) / args.close_steps
            weight = 0.0
        else:
            k_hold = k - args.reference - args.close_steps
            normal_n = controller.grip(frame, normal_n)
            weight = weight_at(k_hold, ramp_args)
        step = sim.step(normal_force_n=normal_n, tangential_force_n=(weight / 2.0, 0.0))
        frame = pipeline.process(step["image"], timestamp=step["t"])
        rows.append((step["t"], weight, normal_n, -step["total_force"][2],
                     math.hypot(*step["total_force"][:2]), step["solver"]["status"],
                     frame.slip_state, frame.friction, frame.slip_margin))
    return rows


def summarize(rows, args):
    hold = rows[args.reference + args.close_steps:]
    normal = np.array([r[3] for r in hold])
    slid = sum(r[5] == "gross sliding" for r in hold)
    estimated = [r[7] for r in hold if math.isfinite(r[7])]
    return {"held": slid == 0, "slid_steps": slid, "mean_normal_n": float(normal.mean()),
            "max_normal_n": float(normal.max()),
            "mu_estimate": estimated[-1] if estimated else math.nan}


TRACE_COLUMNS = ("t_s", "weight_n", "commanded_normal_n", "true_normal_n",
                 "true_tangential_n", "solver_status", "slip_state", "friction", "margin")


def write_trace(results, args):
    """Every frame of every trial, the twin's truth beside the pipeline's estimate (CSV)."""
    import csv

    with open(args.trace, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(("mu", "rate_n_per_s", "controller", "step") + TRACE_COLUMNS +
                      ("true_load_ratio",))
        for (mu, rate, name), rows in results.items():
            for k, r in enumerate(rows):
                load_ratio = r[4] / (mu * r[3]) if r[3] > 0 else 0.0
                out.writerow((mu, rate, name, k) + tuple(r) + (load_ratio,))
    print(f"trace: {args.trace}")


def plot(results, args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = sorted({(mu, rate) for (mu, rate, _) in results})
    fig, axes = plt.subplots(len(keys), 1, figsize=(7, 2.2 * len(keys)), sharex=True,
                             squeeze=False)
    for ax, (mu, rate) in zip(axes[:, 0], keys):
        for name, style in (("fixed threshold", "C1"), ("load-proportional", "C2"),
                            ("least-force", "C0")):
            rows = results[(mu, rate, name)]
            t = np.array([r[0] for r in rows])
            t -= t[args.reference + args.close_steps]
            ax.plot(t, [r[3] for r in rows], style, label=f"normal force, {name}")
            slid = [r[0] - rows[args.reference + args.close_steps][0]
                    for r in rows if r[5] == "gross sliding"]
            if slid:
                ax.plot(slid, [0.0] * len(slid), "x", color=style, label=f"slid, {name}")
        ax.plot(t, [r[1] for r in rows], "k--", label="weight")
        ax.set_ylabel("N")
        ax.set_title(f"mu {mu}, weight +{rate} N/s", fontsize=9)
        ax.set_xlim(left=0.0)
    axes[-1, 0].set_xlabel("time since lift-off (s)")
    axes[0, 0].legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(args.plot, dpi=90)
    print(f"plot: {args.plot}")


def main(argv=None):
    """Runs the trials; returns {(mu, rate, controller name): summarize(...)}."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mu", type=float, nargs="+", default=[0.3, 0.6, 1.0],
                   help="the object's friction coefficients, a trial each")
    p.add_argument("--rates", type=float, nargs="+", default=[0.5, 1.0],
                   help="the weight's growth (N/s), a trial each")
    p.add_argument("--start-weight", type=float, default=0.2, help="weight at lift-off (N)")
    p.add_argument("--max-weight", type=float, default=1.2, help="the heaviest weight (N)")
    p.add_argument("--radius", type=float, default=10.0, help="the object's curvature (mm)")
    p.add_argument("--frame-rate", type=float, default=30.0, help="frames a second")
    p.add_argument("--reference", type=int, default=20, help="reference frames")
    p.add_argument("--close-steps", type=int, default=5, help="frames to close the grip")
    p.add_argument("--hold-steps", type=int, default=60, help="frames of the hold")
    p.add_argument("--safety", type=float, default=1.5, help="safety factor of every controller")
    p.add_argument("--design-mu", type=float, default=0.3,
                   help="the lowest mu the gripper is designed for")
    p.add_argument("--floor", type=float, default=0.5,
                   help="load-proportional and least-force: least grip (N)")
    p.add_argument("--reflex", type=float, default=0.25,
                   help="least-force: grip raised by this fraction a frame of gross slip")
    p.add_argument("--sensor", default="", help="sensor YAML ('': the built-in prototype)")
    p.add_argument("--cache", default="", help="model cache ('': $TAC3D_CACHE_DIR ...)")
    p.add_argument("--plot", default="", help="write the figure here (PNG)")
    p.add_argument("--trace", default="",
                   help="write every frame here (CSV): the truth's P, Q and Q / (mu P) beside "
                        "the estimate's state, friction and margin")
    args = p.parse_args(argv)

    controllers = [
        lambda: FixedThreshold(args.safety, args.max_weight / 2.0, args.design_mu),
        lambda: LoadProportional(args.safety, args.floor, args.design_mu),
        lambda: LeastForce(args.safety, args.floor, args.design_mu, args.reflex),
    ]
    results, summaries = {}, {}
    print(f"{'mu':>4} {'N/s':>4} {'controller':<16} {'held':<4} {'slid':>4} "
          f"{'mean N':>7} {'max N':>6} {'mu est':>6} {'time s':>6}")
    for mu in args.mu:
        for rate in args.rates:
            for make in controllers:
                controller = make()
                start = time.monotonic()
                rows = run_trial(mu, rate, controller, args)
                elapsed = time.monotonic() - start
                results[(mu, rate, controller.name)] = rows
                s = summarize(rows, args)
                s["time_s"] = elapsed
                summaries[(mu, rate, controller.name)] = s
                print(f"{mu:4.1f} {rate:4.1f} {controller.name:<16} "
                      f"{'yes' if s['held'] else 'NO':<4} {s['slid_steps']:4d} "
                      f"{s['mean_normal_n']:7.2f} {s['max_normal_n']:6.2f} "
                      f"{s['mu_estimate']:6.2f} {elapsed:6.1f}", flush=True)
    if args.plot:
        plot(results, args)
    if args.trace:
        write_trace(results, args)
    return summaries


if __name__ == "__main__":
    main()
