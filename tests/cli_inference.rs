//! `pgm map` and `pgm marginals` on UAI files, checked against brute force, plus their
//! error messages and `--stats` line.

use pgm_core::exact::{brute_force, BruteForceLimit};
use pgm_core::uai::{Evidence, UaiModel};
use pgm_core::{FactorGraph, TableFactor, VariableId};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::process::Command;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A random tree with shuffled scope orders, some zero potentials, and cardinalities 1-4.
fn random_tree(seed: u64) -> FactorGraph {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rng.random_range(2..11);
    let cards: Vec<usize> = (0..n).map(|_| rng.random_range(1..5)).collect();
    let mut g = FactorGraph::with_variables(&cards).unwrap();
    let draw = |size: usize, rng: &mut ChaCha8Rng| -> Vec<f64> {
        let mut t: Vec<f64> = (0..size)
            .map(|_| {
                if rng.random::<f64>() < 0.1 {
                    f64::NEG_INFINITY
                } else {
                    rng.random_range(-3.0..3.0)
                }
            })
            .collect();
        if t.iter().all(|x| *x == f64::NEG_INFINITY) {
            t[0] = 0.0;
        }
        t
    };
    for (v, &k) in cards.iter().enumerate() {
        let t = draw(k, &mut rng);
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![k], t).unwrap())
            .unwrap();
    }
    for v in 1..n {
        let p = rng.random_range(0..v);
        let (a, b) = if rng.random::<bool>() { (p, v) } else { (v, p) };
        let t = draw(cards[a] * cards[b], &mut rng);
        g.add_factor(
            TableFactor::new(
                vec![VariableId(a), VariableId(b)],
                vec![cards[a], cards[b]],
                t,
            )
            .unwrap(),
        )
        .unwrap();
    }
    g
}

fn pgm(args: &[&str]) -> (String, String, bool) {
    let out = Command::new(env!("CARGO_BIN_EXE_pgm"))
        .args(args)
        .output()
        .unwrap();
    (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
        out.status.success(),
    )
}

fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect()
}

fn check(model: &Path, evidence: Option<&Path>, schedule: &str) {
    let uai = UaiModel::read(model).unwrap();
    let mut graph = uai.to_factor_graph().unwrap();
    let mut args = vec![model.to_str().unwrap(), "--schedule", schedule];
    if let Some(e) = evidence {
        Evidence::read(e, &uai.cardinalities)
            .unwrap()
            .apply(&mut graph)
            .unwrap();
        args.extend(["--evidence", e.to_str().unwrap()]);
    }
    let Ok(exact) = brute_force(&graph, BruteForceLimit::default()) else {
        return;
    };
    let (out, err, ok) = pgm(&[&["map"], &args[..]].concat());
    assert!(ok, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "MPE");
    let values = numbers(lines[1]);
    assert_eq!(values[0] as usize, graph.num_variables());
    let assignment: Vec<usize> = values[1..].iter().map(|&x| x as usize).collect();
    let score = graph.log_score(&assignment).unwrap();
    assert!(
        (score - exact.map_log_score).abs() < 1e-9,
        "{schedule}: {score} vs {}",
        exact.map_log_score
    );

    let (out, err, ok) = pgm(&[&["marginals"], &args[..]].concat());
    assert!(ok, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "MAR");
    let values = numbers(lines[1]);
    assert_eq!(values[0] as usize, graph.num_variables());
    let mut at = 1;
    for m in &exact.marginals {
        assert_eq!(values[at] as usize, m.len());
        for (p, q) in values[at + 1..at + 1 + m.len()].iter().zip(m) {
            assert!((p - q).abs() < 1e-6, "{schedule}: {p} vs {q}");
        }
        at += 1 + m.len();
    }
}

#[test]
fn map_and_marginals_are_exact_on_trees() {
    let dir = temp_dir("trees");
    for seed in 0..12 {
        let graph = random_tree(seed);
        let model = dir.join(format!("tree{seed}.uai"));
        UaiModel::from_factor_graph(&graph).write(&model).unwrap();
        let evid = dir.join(format!("tree{seed}.evid"));
        let v = seed as usize % graph.num_variables();
        let x = seed as usize % graph.cardinalities()[v];
        std::fs::write(&evid, format!("1 {v} {x}\n")).unwrap();
        for schedule in ["flooding", "sequential", "residual"] {
            check(&model, None, schedule);
            check(&model, Some(&evid), schedule);
        }
    }
}

#[test]
fn stats_line_is_json_on_stderr() {
    let dir = temp_dir("stats");
    let model = dir.join("m.uai");
    UaiModel::from_factor_graph(&random_tree(99))
        .write(&model)
        .unwrap();
    let (out, err, ok) = pgm(&["map", model.to_str().unwrap(), "--stats"]);
    assert!(ok);
    assert!(out.starts_with("MPE\n"));
    let stats: serde_json::Value = serde_json::from_str(err.trim()).unwrap();
    assert!(stats["iterations"].as_u64().unwrap() >= 1);
    assert_eq!(stats["converged"], serde_json::json!(true));
    assert!(stats["residual"].as_f64().unwrap() <= 1e-9);
    assert!(stats["seconds"].as_f64().unwrap() >= 0.0);
}

#[test]
fn malformed_input_names_file_line_and_expectation() {
    let dir = temp_dir("bad");
    let model = dir.join("bad.uai");
    std::fs::write(&model, "MARKOV\n2\n2 2\n1\n2 0 1\n\n4\n0.5 1 nope 2\n").unwrap();
    let (out, err, ok) = pgm(&["map", model.to_str().unwrap()]);
    assert!(!ok && out.is_empty());
    assert!(
        err.contains("bad.uai:8:") && err.contains("entry 2 of the table of function 0"),
        "{err}"
    );
    std::fs::write(&model, "MARKOV\n2\n2 2\n1\n2 0 1\n\n4\n0.5 1 1 2\n").unwrap();
    let evid = dir.join("e.evid");
    std::fs::write(&evid, "1 1 7\n").unwrap();
    let (_, err, ok) = pgm(&[
        "map",
        model.to_str().unwrap(),
        "--evidence",
        evid.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("e.evid:1:") && err.contains("state 7 of variable 1"),
        "{err}"
    );
    let (_, err, ok) = pgm(&["map", model.to_str().unwrap(), "--damping", "1.5"]);
    assert!(!ok && err.contains("damping"), "{err}");
}

/// Writes `text` to `dir/name` and returns the path as a string.
fn file(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn models_and_evidence_without_positive_assignment_exit_2_with_the_reason() {
    let dir = temp_dir("infeasible");
    // B04: one binary variable whose only table is zero (Z = 0).
    let zero = file(&dir, "zero.uai", "MARKOV\n1\n2\n1\n1 0\n\n2\n0 0\n");
    for task in ["map", "marginals"] {
        let (out, err, ok) = pgm(&[task, &zero]);
        assert!(!ok && out.is_empty(), "{task}: {out}");
        assert!(err.contains("zero.uai") && err.contains("Z = 0"), "{err}");
    }
    // B10: the evidence observes a state of probability 0.
    let skew = file(&dir, "skew.uai", "MARKOV\n1\n2\n1\n1 0\n\n2\n1 0\n");
    let bad = file(&dir, "bad.evid", "1 0 1\n");
    for task in ["map", "marginals"] {
        let (out, err, ok) = pgm(&[task, &skew, "--evidence", &bad]);
        assert!(!ok && out.is_empty(), "{task}: {out}");
        assert!(
            err.contains("P(evidence) = 0") && err.contains("x0 = 1"),
            "{err}"
        );
    }
    // ev-contradict: x0 = x1 = x2, evidence x0 = 0 and x2 = 1.
    let chain = file(
        &dir,
        "chain.uai",
        "MARKOV\n3\n2 2 2\n2\n2 0 1\n2 1 2\n\n4\n1 0 0 1\n\n4\n1 0 0 1\n",
    );
    let apart = file(&dir, "apart.evid", "2 0 0 2 1\n");
    for task in ["map", "marginals"] {
        let (out, err, ok) = pgm(&[task, &chain, "--evidence", &apart]);
        assert!(!ok && out.is_empty(), "{task}: {out}");
        assert!(err.contains("x0 = 0, x2 = 1"), "{err}");
    }
    // Consistent evidence: observed variables are reported at their observed value,
    // with marginals that are exactly their observed state.
    let together = file(&dir, "together.evid", "2 0 1 2 1\n");
    let (out, err, ok) = pgm(&["map", &chain, "--evidence", &together]);
    assert!(ok, "{err}");
    assert_eq!(out, "MPE\n3 1 1 1\n");
    let (out, err, ok) = pgm(&["marginals", &chain, "--evidence", &together]);
    assert!(ok, "{err}");
    assert_eq!(out, "MAR\n3 2 0 1 2 0 1 2 0 1\n");
}

#[test]
fn uai_2010_evidence_with_several_samples_uses_the_first_or_the_chosen_one() {
    let dir = temp_dir("samples");
    // B09: x0 prefers 1 only when observed; x1, x2 follow x0 through equal-preferring
    // tables.
    let model = file(
        &dir,
        "m.uai",
        "MARKOV\n3\n2 2 2\n3\n1 0\n2 0 1\n2 1 2\n\n2\n4 1\n\n4\n3 1 1 3\n\n4\n2 1 1 2\n",
    );
    let evid = file(&dir, "m.evid", "2\n1 0 1\n0\n");
    let (out, err, ok) = pgm(&["map", &model, "--evidence", &evid]);
    assert!(ok, "{err}");
    assert_eq!(out, "MPE\n3 1 1 1\n");
    assert!(
        err.contains("holds 2 evidence samples") && err.contains("--sample"),
        "{err}"
    );
    let (out, err, ok) = pgm(&["map", &model, "--evidence", &evid, "--sample", "1"]);
    assert!(ok, "{err}");
    assert_eq!(out, "MPE\n3 0 0 0\n");
    assert!(!err.contains("note"), "{err}");
    let (out, err, ok) = pgm(&["map", &model, "--evidence", &evid, "--sample", "2"]);
    assert!(!ok && out.is_empty());
    assert!(
        err.contains("--sample 2") && err.contains("2 evidence samples"),
        "{err}"
    );
}

#[test]
fn sizes_in_a_model_file_are_checked_before_they_are_used() {
    let dir = temp_dir("sizes");
    // uai-prodoverflow: 64 binary variables, the product wraps to the table size 0.
    let scope: Vec<String> = (0..64).map(|v| v.to_string()).collect();
    let wrap = file(
        &dir,
        "wrap.uai",
        &format!(
            "MARKOV\n64\n{}\n1\n64 {}\n\n0\n",
            vec!["2"; 64].join(" "),
            scope.join(" ")
        ),
    );
    let (out, err, ok) = pgm(&["map", &wrap]);
    assert!(!ok && out.is_empty());
    assert!(
        err.contains("wrap.uai:7:") && err.contains("overflows"),
        "{err}"
    );
    // uai-bigtable-prealloc: a 2^36-entry table declared, two entries given.
    let scope: Vec<String> = (0..36).map(|v| v.to_string()).collect();
    let big = file(
        &dir,
        "big.uai",
        &format!(
            "MARKOV\n36\n{}\n1\n36 {}\n\n68719476736\n1 1\n",
            vec!["2"; 36].join(" "),
            scope.join(" ")
        ),
    );
    let (out, err, ok) = pgm(&["map", &big]);
    assert!(!ok && out.is_empty());
    assert!(
        err.contains("big.uai:") && err.contains("unexpected end of file"),
        "{err}"
    );
}

/// An 8×8 Potts grid with three labels and couplings of both signs: loopy and
/// frustrated, so neither BP nor TRW-S settles in one iteration.
fn frustrated_grid() -> FactorGraph {
    let side = 8;
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let mut g = FactorGraph::with_variables(&[3; 64]).unwrap();
    for v in 0..side * side {
        let t = (0..3).map(|_| rng.random_range(-1.0..1.0)).collect();
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![3], t).unwrap())
            .unwrap();
    }
    for r in 0..side {
        for c in 0..side {
            let v = r * side + c;
            let mut pairs = Vec::new();
            if c + 1 < side {
                pairs.push(v + 1);
            }
            if r + 1 < side {
                pairs.push(v + side);
            }
            for u in pairs {
                let w: f64 = rng.random_range(-2.0..2.0);
                let t = (0..9)
                    .map(|i| if i / 3 == i % 3 { w } else { 0.0 })
                    .collect();
                g.add_factor(
                    TableFactor::new(vec![VariableId(v), VariableId(u)], vec![3, 3], t).unwrap(),
                )
                .unwrap();
            }
        }
    }
    g
}

#[test]
fn a_run_stopped_by_its_iteration_limit_says_so_on_stderr() {
    let dir = temp_dir("unconverged");
    let model = dir.join("grid.uai");
    UaiModel::from_factor_graph(&frustrated_grid())
        .write(&model)
        .unwrap();
    let model = model.to_str().unwrap();
    for command in ["map", "marginals"] {
        for schedule in ["flooding", "sequential", "residual"] {
            let (out, err, ok) = pgm(&[command, model, "--schedule", schedule, "--max-iters", "1"]);
            assert!(ok, "{err}");
            assert!(!out.is_empty());
            assert!(
                err.contains("warning")
                    && err.contains("iteration limit")
                    && err.contains(schedule),
                "{command} {schedule}: {err:?}"
            );
        }
    }
    let (_, err, ok) = pgm(&["map", model, "--algorithm", "trws", "--max-iters", "1"]);
    assert!(ok, "{err}");
    assert!(
        err.contains("warning") && err.contains("TRW-S") && err.contains("iteration limit"),
        "{err:?}"
    );
    // A converged run prints nothing on stderr.
    let tree = dir.join("tree.uai");
    UaiModel::from_factor_graph(&random_tree(5))
        .write(&tree)
        .unwrap();
    for command in ["map", "marginals"] {
        for schedule in ["flooding", "sequential", "residual"] {
            let (_, err, ok) = pgm(&[command, tree.to_str().unwrap(), "--schedule", schedule]);
            assert!(ok && err.is_empty(), "{command} {schedule}: {err:?}");
        }
    }
}

#[test]
fn damping_changes_no_fixed_point_under_any_schedule() {
    // A star: x0 with ten leaves copying it with probability 0.9, three leaves
    // observed in state 1 (the shape of hardening case B15).
    let mut g = FactorGraph::with_variables(&[2; 11]).unwrap();
    g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, 0.0]).unwrap())
        .unwrap();
    let (hi, lo) = (0.9f64.ln(), 0.1f64.ln());
    for leaf in 1..11 {
        g.add_factor(
            TableFactor::new(
                vec![VariableId(0), VariableId(leaf)],
                vec![2, 2],
                vec![hi, lo, lo, hi],
            )
            .unwrap(),
        )
        .unwrap();
    }
    let dir = temp_dir("damping");
    let model = dir.join("star.uai");
    UaiModel::from_factor_graph(&g).write(&model).unwrap();
    let evid = dir.join("star.uai.evid");
    std::fs::write(&evid, "3 1 1 2 1 3 1\n").unwrap();
    Evidence::read(&evid, g.cardinalities())
        .unwrap()
        .apply(&mut g)
        .unwrap();
    let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
    for damping in ["0", "0.5", "0.9"] {
        for schedule in ["flooding", "sequential", "residual"] {
            let (out, err, ok) = pgm(&[
                "marginals",
                model.to_str().unwrap(),
                "--evidence",
                evid.to_str().unwrap(),
                "--schedule",
                schedule,
                "--damping",
                damping,
                "--stats",
            ]);
            assert!(ok, "{err}");
            let stats: serde_json::Value = serde_json::from_str(err.trim()).unwrap();
            assert_eq!(
                stats["converged"],
                serde_json::json!(true),
                "{schedule} {damping}"
            );
            let values = numbers(out.lines().nth(1).unwrap());
            let p1 = values[3];
            let q1 = exact.marginals[0][1];
            assert!(
                (p1 - q1).abs() < 1e-6,
                "{schedule}, damping {damping}: P(x0 = 1) = {p1}, exact {q1}"
            );
        }
    }
}

#[test]
fn trws_map_is_exact_on_trees_and_reports_its_bound() {
    let dir = temp_dir("trws");
    for seed in 0..8 {
        let graph = random_tree(seed);
        let model = dir.join(format!("tree{seed}.uai"));
        UaiModel::from_factor_graph(&graph).write(&model).unwrap();
        let Ok(exact) = brute_force(&graph, BruteForceLimit::default()) else {
            continue;
        };
        let (out, err, ok) = pgm(&[
            "map",
            model.to_str().unwrap(),
            "--algorithm",
            "trws",
            "--stats",
        ]);
        assert!(ok, "{err}");
        let values = numbers(out.lines().nth(1).unwrap());
        let assignment: Vec<usize> = values[1..].iter().map(|&x| x as usize).collect();
        let score = graph.log_score(&assignment).unwrap();
        assert!((score - exact.map_log_score).abs() < 1e-9, "seed {seed}");
        let stats: serde_json::Value = serde_json::from_str(err.trim()).unwrap();
        assert_eq!(stats["algorithm"], "trws");
        assert_eq!(stats["converged"], serde_json::json!(true));
        let bound = stats["bound"].as_f64().unwrap();
        let reported = stats["score"].as_f64().unwrap();
        let gap = stats["gap"].as_f64().unwrap();
        assert!((reported - score).abs() < 1e-9);
        assert!(
            (bound - exact.map_log_score).abs() < 1e-6,
            "seed {seed}: bound {bound}"
        );
        assert!((0.0..1e-6).contains(&gap), "seed {seed}: gap {gap}");
        assert!(stats["iterations"].as_u64().unwrap() >= 1);
    }
    let model = dir.join("tree0.uai");
    let (out, err, ok) = pgm(&["marginals", model.to_str().unwrap(), "--algorithm", "trws"]);
    assert!(!ok && out.is_empty());
    assert!(
        err.contains("--algorithm trws") && err.contains("MAP"),
        "{err}"
    );
}
