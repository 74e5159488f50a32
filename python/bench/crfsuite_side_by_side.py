"""CRFsuite (python-crfsuite) and pgm's learner side by side on the same linear-chain
CRF, interleaved in one run.

The generator writes sequence-labelling data as a CRFsuite item file
(`LABEL<TAB>ATTR…`, a blank line between sequences): sequences of 20 items, 5 labels
from a sticky Markov chain (stay with probability 0.7), each item with 4 attributes: a
word drawn from its label's 40-word vocabulary (15 % of the time from the whole one),
the previous and next words, and the word's first letter, so that the model needs its
transitions. Sizes in items: --sizes (default 1000 10000 100000), seed --seed.

Each round and size trains CRFsuite (L-BFGS, `feature.possible_states=1`,
`feature.possible_transitions=1`, L2 coefficient c2, epsilon 1e-10, delta 1e-10) and
then `tools/src/bin/crfsuite_chain` (the core's learner, maximum likelihood with exact
chain marginals, L-BFGS, sigma^2 = 1 / (2 c2); on one thread, RAYON_NUM_THREADS=1, as
CRFsuite runs), on the same file. It prints, per size,
both objectives at their optima (each side's `-log L + c2 |w|^2`), ours evaluated at
CRFsuite's weights, iterations, objective evaluations, the time to convergence and per
evaluation (one pass over the data: value and gradient).

    pip install python-crfsuite
    cargo build --release -p pgm-tools --bin crfsuite_chain
    python python/bench/crfsuite_side_by_side.py --ours target/release/crfsuite_chain --out /tmp/crfsuite
"""

import argparse
import json
import os
import random
import statistics
import subprocess
import time

import pycrfsuite

LABELS = ["A", "B", "C", "D", "E"]


def generate(n_items, seed, path):
    rng = random.Random(seed)
    vocab = {y: [f"{y.lower()}{i}" for i in range(40)] for y in LABELS}
    everything = [w for ws in vocab.values() for w in ws]
    sequences = []
    items = 0
    while items < n_items:
        length = min(20, n_items - items)
        y = [rng.choice(LABELS)]
        for _ in range(length - 1):
            y.append(y[-1] if rng.random() < 0.7 else rng.choice(LABELS))
        words = [rng.choice(vocab[l]) if rng.random() < 0.85 else rng.choice(everything) for l in y]
        xseq = []
        for t, w in enumerate(words):
            prev = words[t - 1] if t > 0 else "<s>"
            nxt = words[t + 1] if t + 1 < len(words) else "</s>"
            xseq.append([f"w={w}", f"prev={prev}", f"next={nxt}", f"first={w[0]}"])
        sequences.append((xseq, y))
        items += length
    with open(path, "w") as f:
        for xseq, y in sequences:
            for x, label in zip(xseq, y):
                f.write(label + "\t" + "\t".join(x) + "\n")
            f.write("\n")
    return sequences


def train_crfsuite(sequences, c2, model_path):
    trainer = pycrfsuite.Trainer(verbose=False)
    for xseq, y in sequences:
        trainer.append(xseq, y)
    trainer.set_params({
        "c1": 0.0, "c2": c2, "max_iterations": 1000, "epsilon": 1e-10, "delta": 1e-10,
        "period": 10, "feature.possible_states": True, "feature.possible_transitions": True,
        "feature.minfreq": 0,
    })
    t = time.perf_counter()
    trainer.train(model_path)
    seconds = time.perf_counter() - t
    log = trainer.logparser
    last = log.last_iteration
    evaluations = sum(it.get("linesearch_trials", 1) for it in log.iterations)
    tagger = pycrfsuite.Tagger()
    tagger.open(model_path)
    info = tagger.info()
    weights = {
        "state": [[a, l, w] for (a, l), w in info.state_features.items()],
        "transitions": [[a, b, w] for (a, b), w in info.transitions.items()],
    }
    return {
        "seconds": seconds,
        "iterations": len(log.iterations),
        "evaluations": evaluations,
        "objective": last["loss"],
        "features": log.featgen_num_features if hasattr(log, "featgen_num_features") else None,
        "iteration_seconds": sum(it["time"] for it in log.iterations),
    }, weights


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ours", required=True, help="tools' crfsuite_chain binary")
    ap.add_argument("--out", required=True, help="a directory for the data and models")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--c2", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for size in args.sizes:
        data = os.path.join(args.out, f"train-{size}.txt")
        sequences = generate(size, args.seed, data)
        theirs, ours = [], []
        for _ in range(args.rounds):
            c, weights = train_crfsuite(sequences, args.c2, os.path.join(args.out, f"model-{size}.crfsuite"))
            wpath = os.path.join(args.out, f"weights-{size}.json")
            with open(wpath, "w") as f:
                json.dump(weights, f)
            theirs.append(c)
            out = subprocess.run([args.ours, "--data", data, "--c2", str(args.c2), "--weights", wpath],
                                 capture_output=True, text=True, check=True,
                                 env={**os.environ, "RAYON_NUM_THREADS": "1"})
            ours.append(json.loads(out.stdout))
        med = statistics.median
        c, o = theirs[-1], ours[-1]
        row = {
            "items": size, "sequences": len(sequences), "weights_ours": o["weights"],
            "objective_crfsuite": c["objective"], "objective_ours": o["objective"],
            "ours_at_crfsuite_weights": o["objective_at_their_weights"],
            "relative_difference": (o["objective"] - c["objective"]) / abs(c["objective"]),
            "iterations_crfsuite": c["iterations"], "iterations_ours": o["iterations"],
            "evaluations_crfsuite": c["evaluations"], "evaluations_ours": o["evaluations"],
            "seconds_crfsuite": med(t["seconds"] for t in theirs),
            "seconds_ours": med(t["learn_seconds"] for t in ours),
            # CRFsuite logs each iteration's time to the millisecond: the whole training
            # over its evaluations (its feature generation included) is the fairer figure.
            "per_evaluation_crfsuite": med(t["seconds"] / t["evaluations"] for t in theirs),
            "per_evaluation_crfsuite_logged": med(t["iteration_seconds"] / t["evaluations"] for t in theirs),
            "per_evaluation_ours": med(t["pass_seconds"] for t in ours),
            # The same whole-training figure on our side (building the objective, the
            # optimiser and any instance sent to the general path included).
            "per_evaluation_ours_in_training": med(t["learn_seconds"] / t["evaluations"] for t in ours),
            "converged_ours": o["converged"],
        }
        rows.append(row)
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
