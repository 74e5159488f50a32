"""Python against Rust on the same belief propagation, interleaved in one run.

The model is the 100 x 100 Potts grid of ../shared/tools/gen_models.py (K = 5). Each
round runs `pgm map MODEL --stats` (the CLI's "seconds" field times only the BP run,
right after the CLI has read the model), then `FactorGraph.map` from Python twice on
the same model with the same settings. Each Python call is timed from before the call
to after it returns (checking the arguments, releasing the GIL, building the result
dict included), and its result's "seconds" times the run alone as the CLI times it.

Printed, as medians over the rounds and with the fastest round of each:
- `first`: the call right after the CLI's process, whose run evicted the model from
  the caches; `second`: the next call, its caches warm as the CLI's are (the CLI
  reads the model just before its run);
- `call_overhead`: a call's wall time over its run's "seconds" (the cost of calling
  from Python);
- ratios of each Python time to the CLI's.

    python bench/potts_overhead.py --pgm target/release/pgm --model potts.uai
"""

import argparse
import json
import statistics
import subprocess
import time

import pgm


def timed(g, args):
    t = time.perf_counter()
    r = g.map(schedule=args.schedule, tolerance=0.0, max_iterations=args.iterations)
    wall = time.perf_counter() - t
    assert r["iterations"] == args.iterations
    return wall, r["seconds"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pgm", required=True, help="the pgm binary")
    ap.add_argument("--model", required=True, help="a UAI model")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--iterations", type=int, default=30)
    ap.add_argument("--schedule", default="flooding")
    args = ap.parse_args()
    # Tolerance 0: both run exactly --iterations iterations.
    cli = [args.pgm, "map", args.model, "--stats", "--tolerance", "0", "--max-iters", str(args.iterations), "--schedule", args.schedule]
    g = pgm.FactorGraph.from_uai(args.model)
    g.map(schedule=args.schedule, tolerance=0.0, max_iterations=1)  # specialise once
    rust, first, second = [], [], []
    for _ in range(args.rounds):
        out = subprocess.run(cli, capture_output=True, text=True, check=True)
        stats = json.loads(out.stderr.strip().splitlines()[-1])
        assert stats["iterations"] == args.iterations, stats
        rust.append(stats["seconds"])
        first.append(timed(g, args))
        second.append(timed(g, args))
    med = statistics.median
    rm = med(rust)
    report = {"rounds": args.rounds, "iterations": args.iterations, "schedule": args.schedule,
              "rust_seconds": rust, "rust_median": rm, "rust_fastest": min(rust)}
    for name, calls in [("first", first), ("second", second)]:
        wall = [w for w, _ in calls]
        report[name] = {
            "wall_seconds": wall,
            "wall_median": med(wall),
            "wall_fastest": min(wall),
            "run_median": med(s for _, s in calls),
            "call_overhead_median": med(w / s for w, s in calls),
            "ratio_median": med(wall) / rm,
            "ratio_fastest": min(wall) / min(rust),
        }
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
