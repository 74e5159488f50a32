"""PGMax and `pgm map` side by side: max-product flooding BP on the same UAI model,
interleaved in one run, one thread each.

The model is a UAI file (the issue's: `python3 ../shared/tools/gen_models.py potts
--n 100 --k 5 --seed 1 --out potts`): unary and pairwise tables. Each round times:
- PGMax 0.6.1 (JAX on CPU, float32): `bp.run` with temperature 0 (max-product),
  damping 0, `--iterations` iterations, after a warm-up run that compiles it; XLA
  restricted to one thread;
- `pgm map MODEL --schedule flooding --tolerance 0 --max-iters N --stats` on one thread
  (RAYON_NUM_THREADS=1), its `seconds` (the BP run alone): the Potts path (pairwise
  tables that are Potts pass O(K) messages);
- the same on a copy of the model with one entry of every pairwise table nudged by
  1e-9, so that the general dense-table path runs.

Each engine runs `--iterations` and ten times as many; the per-iteration figure is
the difference over the extra iterations, which leaves out what a run costs besides
its iterations (PGMax: about 0.15 s of dispatch and set-up per call; ours: the
schedule's preparation). Prints each engine's per-iteration time, fastest and median
over the rounds, and the ratios of PGMax's to ours. Environment (PGMax needs this JAX, newer ones break it):

    python -m venv /tmp/pgmax && /tmp/pgmax/bin/pip install "jax[cpu]==0.4.30" numba numpy scipy tqdm
    /tmp/pgmax/bin/pip install --no-deps pgmax==0.6.1
    /tmp/pgmax/bin/python python/bench/pgmax_side_by_side.py --pgm target/release/pgm --model potts.uai
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

# One thread for XLA, before JAX is imported.
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import numpy as np  # noqa: E402


def read_uai(path):
    tokens = open(path).read().split()
    at = 0

    def take():
        nonlocal at
        at += 1
        return tokens[at - 1]

    assert take() == "MARKOV", "a MARKOV UAI file"
    n = int(take())
    cards = [int(take()) for _ in range(n)]
    m = int(take())
    scopes = []
    for _ in range(m):
        arity = int(take())
        scopes.append([int(take()) for _ in range(arity)])
    tables = []
    for scope in scopes:
        size = int(take())
        tables.append(np.array([float(take()) for _ in range(size)]).reshape([cards[v] for v in scope]))
    return cards, scopes, tables


def write_nudged(path, out):
    """`path` with one entry of every pairwise table nudged by 1e-9 (relative)."""
    cards, scopes, tables = read_uai(path)
    with open(out, "w") as f:
        f.write(f"MARKOV\n{len(cards)}\n{' '.join(map(str, cards))}\n{len(scopes)}\n")
        for s in scopes:
            f.write(f"{len(s)} {' '.join(map(str, s))}\n")
        for s, t in zip(scopes, tables):
            flat = t.reshape(-1).copy()
            if len(s) == 2:
                flat[1] *= 1.0 + 1e-9
            f.write(f"\n{flat.size}\n{' '.join(repr(float(x)) for x in flat)}\n")


def pgmax_runner(path, iterations):
    from pgmax import fgraph, fgroup, infer, vgroup

    cards, scopes, tables = read_uai(path)
    k = cards[0]
    assert all(c == k for c in cards), "PGMax's NDVarArray: one number of states"
    variables = vgroup.NDVarArray(num_states=k, shape=(len(cards),))
    fg = fgraph.FactorGraph(variable_groups=variables)
    pairs = [(s, t) for s, t in zip(scopes, tables) if len(s) == 2]
    unary = np.zeros((len(cards), k))
    for s, t in zip(scopes, tables):
        if len(s) == 1:
            unary[s[0]] += np.log(t)
    group = fgroup.PairwiseFactorGroup(
        variables_for_factors=[[variables[a], variables[b]] for (a, b), _ in pairs],
        log_potential_matrix=np.log(np.stack([t for _, t in pairs])),
    )
    fg.add_factors(group)
    bp = infer.build_inferer(fg.bp_state, backend="bp")
    arrays = bp.init(evidence_updates={variables: unary})

    def run():
        out = bp.run(arrays, num_iters=iterations, damping=0.0, temperature=0.0)
        beliefs = bp.get_beliefs(out)
        infer.decode_map_states(beliefs)[variables].block_until_ready()

    run()  # compile
    return run


def pgm_seconds(pgm, model, iterations):
    cmd = [pgm, "map", model, "--stats", "--schedule", "flooding", "--tolerance", "0", "--max-iters", str(iterations)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env={**os.environ, "RAYON_NUM_THREADS": "1"})
    stats = json.loads(out.stderr.strip().splitlines()[-1])
    assert stats["iterations"] == iterations, stats
    return stats["seconds"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pgm", required=True)
    ap.add_argument("--model", required=True, help="a MARKOV UAI file")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--iterations", type=int, default=30)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        dense = os.path.join(tmp, "dense.uai")
        write_nudged(args.model, dense)
        short, long = args.iterations, 10 * args.iterations
        runners = {n: pgmax_runner(args.model, n) for n in (short, long)}

        def pgmax_seconds(n):
            t = time.perf_counter()
            runners[n]()
            return time.perf_counter() - t

        engines = {
            "pgmax": pgmax_seconds,
            "pgm_potts": lambda n: pgm_seconds(args.pgm, args.model, n),
            "pgm_dense": lambda n: pgm_seconds(args.pgm, dense, n),
        }
        times = {name: [] for name in engines}
        for _ in range(args.rounds):
            for name, seconds in engines.items():
                times[name].append((seconds(long) - seconds(short)) / (long - short))
    report = {"rounds": args.rounds, "iterations": [args.iterations, 10 * args.iterations]}
    for name, ts in times.items():
        report[name] = {"ms_fastest": 1e3 * min(ts), "ms_median": 1e3 * statistics.median(ts), "ms": [1e3 * t for t in ts]}
    for name in ["pgm_potts", "pgm_dense"]:
        report[f"pgmax_over_{name}_fastest"] = min(times["pgmax"]) / min(times[name])
        report[f"pgmax_over_{name}_median"] = statistics.median(times["pgmax"]) / statistics.median(times[name])
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    sys.exit(main())
