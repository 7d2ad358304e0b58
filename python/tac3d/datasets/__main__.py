"""`python3 -m tac3d.datasets` (what `tac3d dataset` runs): generate, verify."""
import argparse
import json
import logging
import os
import sys

from .. import _core
from .generate import KEPT, WORKER_TIMEOUT_S, generate
from .store import verify


def main(argv=None):
    parser = argparse.ArgumentParser(prog="tac3d dataset",
                                     description="Randomized twin datasets on Dask, stored as zarr "
                                                 "(docs/datasets.md).")
    commands = parser.add_subparsers(dest="command", required=True)
    g = commands.add_parser("generate", help="generate (or complete) a dataset")
    g.add_argument("--spec", required=True, help="the dataset spec (YAML)")
    g.add_argument("--out", required=True, help="the dataset folder (its parent must exist)")
    g.add_argument("--episodes", type=int, required=True, help="episodes 0 .. N-1")
    where = g.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=1,
                       help="worker processes of the local cluster (default 1)")
    where.add_argument("--scheduler", help="an existing cluster's scheduler, tcp://HOST:PORT")
    g.add_argument("--worker-timeout", type=float, default=WORKER_TIMEOUT_S, metavar="SECONDS",
                   help="how long to wait for a worker when the cluster has none, at the start or "
                        f"after every worker left (default {WORKER_TIMEOUT_S})")
    g.add_argument("--cache-dir", default=os.environ.get("TAC3D_CACHE_DIR", ""),
                   help="the twin body model cache (default $TAC3D_CACHE_DIR, else ~/.cache/tac3d)")
    g.add_argument("--measured", action="store_true", default=None,
                   help="also store what the sensor's pipeline measures on the rendered images "
                        "beside the truth (default: the spec's `measured`)")
    g.add_argument("--json", action="store_true", help="print the summary as JSON")
    g.add_argument("--verbose", action="store_true",
                   help="print a failed episode's traceback from its worker, and the local "
                        "cluster's warnings")
    v = commands.add_parser("verify", help="check a dataset's manifest and checksums")
    v.add_argument("folder")
    args = parser.parse_args(argv)
    if args.command == "generate" and not args.verbose:
        # This process's Dask logs what generate reports itself in its error line (a lost
        # scheduler, with tracebacks): --verbose shows them.
        logging.disable(logging.ERROR)
    try:
        if args.command == "generate":
            result = generate(args.spec, args.out, args.episodes, workers=args.workers,
                              scheduler=args.scheduler, cache_dir=args.cache_dir,
                              measured=args.measured, worker_timeout=args.worker_timeout,
                              verbose=args.verbose)
            if args.json:
                print(json.dumps(result))
            else:
                print(f"{result['episodes']} episodes in {args.out} ({result['generated']} generated, "
                      f"{result['skipped']} already complete)")
            return 0
        result = verify(args.folder)
        for problem in result["problems"]:
            print(f"problem: {problem}")
        print(f"{result['verified']}/{result['episodes']} episodes verified")
        return 0 if not result["problems"] else 1
    except _core.Error as e:
        print(f"tac3d: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        # generate has listed the episodes complete in the manifest; a traceback says nothing more.
        what = f"; {KEPT}" if args.command == "generate" else ""
        print(f"tac3d: interrupted{what}", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
