"""Python against Rust on the same belief propagation, interleaved in one run.

The model is the 100 x 100 Potts grid of ../shared/tools/gen_models.py (K = 5). Each
round runs `pgm map MODEL --stats` (the CLI's "seconds" field times only the BP run)
and `FactorGraph.map` from Python on the same model with the same settings (the Python
time includes building the result dict), alternately, and prints both, the median
of each and their ratio.

    python bench/potts_overhead.py --pgm target/release/pgm --model potts.uai
"""

import argparse
import json
import statistics
import subprocess
import time

import pgm


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
    rust, python = [], []
    for _ in range(args.rounds):
        out = subprocess.run(cli, capture_output=True, text=True, check=True)
        stats = json.loads(out.stderr.strip().splitlines()[-1])
        assert stats["iterations"] == args.iterations, stats
        rust.append(stats["seconds"])
        t = time.perf_counter()
        r = g.map(schedule=args.schedule, tolerance=0.0, max_iterations=args.iterations)
        python.append(time.perf_counter() - t)
        assert r["iterations"] == args.iterations
    rm, pm = statistics.median(rust), statistics.median(python)
    print(json.dumps({"rounds": args.rounds, "iterations": args.iterations, "schedule": args.schedule,
                      "rust_seconds": rust, "python_seconds": python,
                      "rust_median": rm, "python_median": pm, "ratio": pm / rm}, indent=1))


if __name__ == "__main__":
    main()
