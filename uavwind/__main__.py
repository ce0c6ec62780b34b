"""Command line: run experiments into the result cache.

    python -m uavwind list
    python -m uavwind run exp1 exp2 --profile paper --jobs -1
    python -m uavwind run all --profile quick
"""

from __future__ import annotations

import argparse
import sys
import time

from .experiments import EXPERIMENTS, PROFILES, get_experiment, run_experiment, summary_table


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m uavwind", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the experiments")
    run = sub.add_parser("run", help="run experiments (cached; resumes where it stopped)")
    run.add_argument("experiments", nargs="+", help=f"ids ({', '.join(EXPERIMENTS)}) or 'all'")
    run.add_argument("--profile", default="quick", choices=sorted(PROFILES))
    run.add_argument("--jobs", type=int, default=-1, help="worker processes (-1 = all cores)")
    run.add_argument("--seed", type=int, default=None)
    run.add_argument("--engine", default=None, help="clustering engine (fast or tslearn)")
    run.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)

    if args.command == "list":
        for e in EXPERIMENTS.values():
            print(f"{e.id:8s} {e.title:24s} {e.paper_table:22s} {len(e.cases()):3d} cases  "
                  f"{e.notebook}")
        return 0
    ids = list(EXPERIMENTS) if args.experiments == ["all"] else args.experiments
    try:
        for i in ids:  # validate every name before any work starts
            get_experiment(i)
    except (ValueError, TypeError) as exc:
        parser.error(str(exc))
    for i in ids:
        t0 = time.perf_counter()
        kw = {} if args.seed is None else {"seed": args.seed}
        df = run_experiment(i, profile=args.profile, n_jobs=args.jobs, engine=args.engine,
                            progress=not args.no_progress, **kw)
        print(f"{i}: {len(df)} rows, {df.attrs['cached']}/{df.attrs['chunks']} chunks from the "
              f"cache, {time.perf_counter() - t0:.1f} s")
        print(summary_table(df).round(2).to_string(), "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
