//! Inference from the command line: `pgm map` and `pgm marginals` on UAI files,
//! checked against brute force under every schedule and TRW-S, their `--stats` line
//! and warnings, and the errors on malformed or infeasible models and evidence
//! (status 2, naming file, line and value).

mod common;

use common::{ok, refused, refused_all, temp_dir, write};
use pgm_core::exact::{brute_force, BruteForceLimit};
use pgm_core::uai::{Evidence, UaiModel};
use pgm_core::{FactorGraph, TableFactor, VariableId};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

const SCHEDULES: [&str; 3] = ["flooding", "sequential", "residual"];

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

fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect()
}

/// `pgm map` and `pgm marginals` on `model` (with `evidence`) under `schedule` agree
/// with brute force.
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
    let (out, _) = ok(&[&["map"], &args[..]].concat());
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

    let (out, _) = ok(&[&["marginals"], &args[..]].concat());
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

/// `graph` written as a UAI file `dir/name`; returns the path.
fn uai_file(dir: &Path, name: &str, graph: &FactorGraph) -> String {
    let path = dir.join(name);
    UaiModel::from_factor_graph(graph).write(&path).unwrap();
    path.to_str().unwrap().to_string()
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
        for schedule in SCHEDULES {
            check(&model, None, schedule);
            check(&model, Some(&evid), schedule);
        }
    }
}

#[test]
fn stats_line_is_json_on_stderr() {
    let dir = temp_dir("stats");
    let model = uai_file(&dir, "m.uai", &random_tree(99));
    let (out, err) = ok(&["map", &model, "--stats"]);
    assert!(out.starts_with("MPE\n"));
    let stats = common::json(&err);
    assert!(stats["iterations"].as_u64().unwrap() >= 1);
    assert_eq!(stats["converged"], serde_json::json!(true));
    assert!(stats["residual"].as_f64().unwrap() <= 1e-9);
    assert!(stats["seconds"].as_f64().unwrap() >= 0.0);
}

#[test]
fn malformed_input_names_file_line_and_expectation() {
    let dir = temp_dir("bad");
    let bad = write(
        &dir,
        "bad.uai",
        "MARKOV\n2\n2 2\n1\n2 0 1\n\n4\n0.5 1 nope 2\n",
    );
    let model = write(
        &dir,
        "good.uai",
        "MARKOV\n2\n2 2\n1\n2 0 1\n\n4\n0.5 1 1 2\n",
    );
    let evid = write(&dir, "e.evid", "1 1 7\n");
    refused_all(&[
        (
            vec!["map", &bad],
            vec!["bad.uai:8:", "entry 2 of the table of function 0"],
        ),
        (
            vec!["map", &model, "--evidence", &evid],
            vec!["e.evid:1:", "state 7 of variable 1"],
        ),
        (vec!["map", &model, "--damping", "1.5"], vec!["damping"]),
    ]);
}

#[test]
fn models_and_evidence_without_positive_assignment_exit_2_with_the_reason() {
    let dir = temp_dir("infeasible");
    // B04: one binary variable whose only table is zero (Z = 0).
    let zero = write(&dir, "zero.uai", "MARKOV\n1\n2\n1\n1 0\n\n2\n0 0\n");
    // B10: the evidence observes a state of probability 0.
    let skew = write(&dir, "skew.uai", "MARKOV\n1\n2\n1\n1 0\n\n2\n1 0\n");
    let bad = write(&dir, "bad.evid", "1 0 1\n");
    // ev-contradict: x0 = x1 = x2, evidence x0 = 0 and x2 = 1.
    let chain = write(
        &dir,
        "chain.uai",
        "MARKOV\n3\n2 2 2\n2\n2 0 1\n2 1 2\n\n4\n1 0 0 1\n\n4\n1 0 0 1\n",
    );
    let apart = write(&dir, "apart.evid", "2 0 0 2 1\n");
    let cases: [(&str, &[&str], &[&str]); 3] = [
        (&zero, &[], &["zero.uai", "Z = 0"]),
        (&skew, &["--evidence", &bad], &["P(evidence) = 0", "x0 = 1"]),
        (&chain, &["--evidence", &apart], &["x0 = 0, x2 = 1"]),
    ];
    for (model, evidence, needles) in cases {
        for task in ["map", "marginals"] {
            refused(&[&[task, model][..], evidence].concat(), needles);
        }
    }
    // Consistent evidence: observed variables are reported at their observed value,
    // with marginals that are exactly their observed state.
    let together = write(&dir, "together.evid", "2 0 1 2 1\n");
    let (out, _) = ok(&["map", &chain, "--evidence", &together]);
    assert_eq!(out, "MPE\n3 1 1 1\n");
    let (out, _) = ok(&["marginals", &chain, "--evidence", &together]);
    assert_eq!(out, "MAR\n3 2 0 1 2 0 1 2 0 1\n");
}

#[test]
fn uai_2010_evidence_with_several_samples_uses_the_first_or_the_chosen_one() {
    let dir = temp_dir("samples");
    // B09: x0 prefers 1 only when observed; x1, x2 follow x0 through equal-preferring
    // tables.
    let model = write(
        &dir,
        "m.uai",
        "MARKOV\n3\n2 2 2\n3\n1 0\n2 0 1\n2 1 2\n\n2\n4 1\n\n4\n3 1 1 3\n\n4\n2 1 1 2\n",
    );
    let evid = write(&dir, "m.evid", "2\n1 0 1\n0\n");
    let (out, err) = ok(&["map", &model, "--evidence", &evid]);
    assert_eq!(out, "MPE\n3 1 1 1\n");
    assert!(
        err.contains("holds 2 evidence samples") && err.contains("--sample"),
        "{err}"
    );
    let (out, err) = ok(&["map", &model, "--evidence", &evid, "--sample", "1"]);
    assert_eq!(out, "MPE\n3 0 0 0\n");
    assert!(!err.contains("note"), "{err}");
    refused(
        &["map", &model, "--evidence", &evid, "--sample", "2"],
        &["--sample 2", "2 evidence samples"],
    );
}

/// A UAI model of `n` binary variables and one table over all of them that declares
/// `entries` entries and gives `given`.
fn one_table(n: usize, entries: &str, given: &str) -> String {
    let scope: Vec<String> = (0..n).map(|v| v.to_string()).collect();
    format!(
        "MARKOV\n{n}\n{}\n1\n{n} {}\n\n{entries}\n{given}",
        vec!["2"; n].join(" "),
        scope.join(" ")
    )
}

#[test]
fn sizes_in_a_model_file_are_checked_before_they_are_used() {
    let dir = temp_dir("sizes");
    // uai-prodoverflow: 64 binary variables, the product wraps to the table size 0.
    let wrap = write(&dir, "wrap.uai", &one_table(64, "0", ""));
    // uai-bigtable-prealloc: a 2^36-entry table declared, two entries given.
    let big = write(&dir, "big.uai", &one_table(36, "68719476736", "1 1\n"));
    refused_all(&[
        (vec!["map", &wrap], vec!["wrap.uai:7:", "overflows"]),
        (
            vec!["map", &big],
            vec!["big.uai:", "unexpected end of file"],
        ),
    ]);
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
    // Each variable to its right and lower neighbour, row by row.
    for v in 0..side * side {
        let right = (v % side + 1 < side).then_some(v + 1);
        let below = (v / side + 1 < side).then_some(v + side);
        for u in right.into_iter().chain(below) {
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
    g
}

#[test]
fn a_run_stopped_by_its_iteration_limit_says_so_on_stderr() {
    let dir = temp_dir("unconverged");
    let model = uai_file(&dir, "grid.uai", &frustrated_grid());
    let tree = uai_file(&dir, "tree.uai", &random_tree(5));
    for command in ["map", "marginals"] {
        for schedule in SCHEDULES {
            let (out, err) = ok(&[command, &model, "--schedule", schedule, "--max-iters", "1"]);
            assert!(!out.is_empty());
            assert!(
                err.contains("warning")
                    && err.contains("iteration limit")
                    && err.contains(schedule),
                "{command} {schedule}: {err:?}"
            );
            // A converged run prints nothing on stderr.
            let (_, err) = ok(&[command, &tree, "--schedule", schedule]);
            assert!(err.is_empty(), "{command} {schedule}: {err:?}");
        }
    }
    let (_, err) = ok(&["map", &model, "--algorithm", "trws", "--max-iters", "1"]);
    assert!(
        err.contains("warning") && err.contains("TRW-S") && err.contains("iteration limit"),
        "{err:?}"
    );
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
    let model = uai_file(&dir, "star.uai", &g);
    let evid = write(&dir, "star.uai.evid", "3 1 1 2 1 3 1\n");
    Evidence::read(Path::new(&evid), g.cardinalities())
        .unwrap()
        .apply(&mut g)
        .unwrap();
    let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
    for damping in ["0", "0.5", "0.9"] {
        for schedule in SCHEDULES {
            let (out, err) = ok(&[
                "marginals",
                &model,
                "--evidence",
                &evid,
                "--schedule",
                schedule,
                "--damping",
                damping,
                "--stats",
            ]);
            let stats = common::json(&err);
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
        let model = uai_file(&dir, &format!("tree{seed}.uai"), &graph);
        let Ok(exact) = brute_force(&graph, BruteForceLimit::default()) else {
            continue;
        };
        let (out, err) = ok(&["map", &model, "--algorithm", "trws", "--stats"]);
        let values = numbers(out.lines().nth(1).unwrap());
        let assignment: Vec<usize> = values[1..].iter().map(|&x| x as usize).collect();
        let score = graph.log_score(&assignment).unwrap();
        assert!((score - exact.map_log_score).abs() < 1e-9, "seed {seed}");
        let stats = common::json(&err);
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
    let model = common::path(&dir, "tree0.uai");
    refused(
        &["marginals", &model, "--algorithm", "trws"],
        &["--algorithm trws", "MAP"],
    );
}

/// Hardening case `uai-infeasible-loop`: hard "not equal" tables on a triangle with two
/// colours and on K4 with three (no assignment of positive probability, Z = 0), and
/// on a 6-cycle with two (feasible).
const TRIANGLE_2COL: &str = "MARKOV\n3\n2 2 2\n3\n2 0 1\n2 1 2\n2 0 2\n\n\
                             4\n0 1 1 0\n\n4\n0 1 1 0\n\n4\n0 1 1 0\n";
const K4_3COL: &str = "MARKOV\n4\n3 3 3 3\n6\n2 0 1\n2 0 2\n2 0 3\n2 1 2\n2 1 3\n2 2 3\n\n\
                       9\n0 1 1 1 0 1 1 1 0\n\n9\n0 1 1 1 0 1 1 1 0\n\n9\n0 1 1 1 0 1 1 1 0\n\n\
                       9\n0 1 1 1 0 1 1 1 0\n\n9\n0 1 1 1 0 1 1 1 0\n\n9\n0 1 1 1 0 1 1 1 0\n";
const CYCLE6_2COL: &str = "MARKOV\n6\n2 2 2 2 2 2\n6\n2 0 1\n2 1 2\n2 2 3\n2 3 4\n2 4 5\n2 5 0\n\n\
                           4\n0 1 1 0\n\n4\n0 1 1 0\n\n4\n0 1 1 0\n\n4\n0 1 1 0\n\n4\n0 1 1 0\n\n\
                           4\n0 1 1 0\n";

/// Every command of the case on one model, with `--stats`: BP map under each schedule,
/// TRW-S map, marginals under each schedule.
fn every_inference(model: &str) -> Vec<Vec<&str>> {
    let mut out = Vec::new();
    for schedule in SCHEDULES {
        out.push(vec!["map", model, "--schedule", schedule, "--stats"]);
    }
    out.push(vec!["map", model, "--algorithm", "trws", "--stats"]);
    for schedule in SCHEDULES {
        out.push(vec!["marginals", model, "--schedule", schedule, "--stats"]);
    }
    out
}

/// A model without positive assignments is refused by every command (status 2,
/// nothing on stdout) with the file, `Z = 0`, the proof and a factor that the
/// method's own assignment violates, checked against the model.
fn refused_by_every_inference(model: &str) {
    let graph = UaiModel::read(model).unwrap().to_factor_graph().unwrap();
    let name = Path::new(model).file_name().unwrap().to_str().unwrap();
    for args in every_inference(model) {
        let consequence = if args[0] == "map" {
            "there is no MAP assignment"
        } else {
            "the marginals cannot be normalised"
        };
        let err = refused(
            &args,
            &[
                name,
                "no assignment has positive probability (Z = 0)",
                consequence,
                "complete search",
            ],
        );
        // The violated factor named is really 0 at the assignment named.
        let before = &err[..err.find("] has probability 0").unwrap()];
        let assignment: Vec<usize> = before[before.rfind('[').unwrap() + 1..]
            .split(", ")
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(
            graph.log_score(&assignment).unwrap(),
            f64::NEG_INFINITY,
            "{args:?}: {err}"
        );
        let violation = pgm_core::support::first_violation(&graph, &assignment).unwrap();
        assert!(err.contains(&violation.to_string()), "{args:?}: {err}");
    }
}

/// The feasible even cycle succeeds for every command: MAP of log-score 0 (a proper
/// colouring), TRW-S with the gap closed, uniform marginals that sum to one.
fn succeeds_in_every_inference(model: &str) {
    let graph = UaiModel::read(model).unwrap().to_factor_graph().unwrap();
    for args in every_inference(model) {
        let (out, err) = ok(&args);
        let lines: Vec<&str> = out.lines().collect();
        let stats = common::json(&err);
        assert_eq!(stats["converged"], serde_json::json!(true), "{args:?}");
        let values = numbers(lines[1]);
        if args[0] == "map" {
            assert_eq!(lines[0], "MPE");
            let assignment: Vec<usize> = values[1..].iter().map(|&x| x as usize).collect();
            assert_eq!(
                graph.log_score(&assignment).unwrap(),
                0.0,
                "{args:?}: {out}"
            );
            if args.contains(&"trws") {
                assert_eq!(stats["score"].as_f64(), Some(0.0));
                assert_eq!(stats["bound"].as_f64(), Some(0.0));
                assert_eq!(stats["gap"].as_f64(), Some(0.0));
            }
        } else {
            assert_eq!(lines[0], "MAR");
            assert_eq!(values[0] as usize, 6);
            for v in 0..6 {
                let p = &values[1 + 3 * v..4 + 3 * v];
                assert_eq!(p[0] as usize, 2);
                assert!((p[1] + p[2] - 1.0).abs() < 1e-12 && (p[1] - 0.5).abs() < 1e-12);
            }
        }
    }
}

#[test]
fn uai_infeasible_loop_case_files_are_refused_by_every_command_and_the_even_cycle_succeeds() {
    let case = "uai-infeasible-loop";
    let Some(triangle) =
        pgm_datasets::testdata::shared_case_file(&format!("{case}/triangle_2col.uai"))
    else {
        return;
    };
    let dir = triangle.parent().unwrap().to_path_buf();
    refused_by_every_inference(triangle.to_str().unwrap());
    refused_by_every_inference(&common::path(&dir, "k4_3col.uai"));
    succeeds_in_every_inference(&common::path(&dir, "cycle6_2col.uai"));
}

#[test]
fn odd_cycles_and_complete_graphs_written_here_are_refused_by_every_command() {
    let dir = temp_dir("infeasible-loop");
    refused_by_every_inference(&write(&dir, "triangle_2col.uai", TRIANGLE_2COL));
    refused_by_every_inference(&write(&dir, "k4_3col.uai", K4_3COL));
    succeeds_in_every_inference(&write(&dir, "cycle6_2col.uai", CYCLE6_2COL));
    // Same kinds, larger: a 9-cycle with two colours, K6 with five; and an odd cycle
    // as dense non-Potts tables (a soft preference inside the "not equal" entries).
    let odd = |n: usize, table: &str| {
        let scopes: String = (0..n).map(|i| format!("2 {i} {}\n", (i + 1) % n)).collect();
        let tables: String = (0..n).map(|_| format!("\n4\n{table}\n")).collect();
        format!(
            "MARKOV\n{n}\n{}\n{n}\n{scopes}{tables}",
            vec!["2"; n].join(" ")
        )
    };
    refused_by_every_inference(&write(&dir, "cycle9.uai", &odd(9, "0 1 1 0")));
    refused_by_every_inference(&write(&dir, "cycle5_soft.uai", &odd(5, "0 2 0.5 0")));
    let k6: FactorGraph = {
        let mut g = FactorGraph::with_variables(&[5; 6]).unwrap();
        for a in 0..6 {
            for b in a + 1..6 {
                let t = (0..25)
                    .map(|i| {
                        if i / 5 == i % 5 {
                            f64::NEG_INFINITY
                        } else {
                            0.0
                        }
                    })
                    .collect();
                g.add_factor(
                    TableFactor::new(vec![VariableId(a), VariableId(b)], vec![5, 5], t).unwrap(),
                )
                .unwrap();
            }
        }
        g
    };
    refused_by_every_inference(&uai_file(&dir, "k6_5col.uai", &k6));
}

#[test]
fn evidence_that_leaves_only_an_odd_cycle_is_refused_with_p_evidence_zero() {
    // A triangle with three colours and a switch x3: with x3 = 1 colour 2 is
    // forbidden everywhere, leaving two colours on the triangle.
    let dir = temp_dir("infeasible-evidence");
    let not_equal = "9\n0 1 1 1 0 1 1 1 0\n";
    let switch = "6\n1 1 1 1 1 0\n";
    let model = write(
        &dir,
        "switch.uai",
        &format!(
            "MARKOV\n4\n3 3 3 2\n6\n2 0 1\n2 1 2\n2 0 2\n2 3 0\n2 3 1\n2 3 2\n\n\
             {not_equal}\n{not_equal}\n{not_equal}\n{switch}\n{switch}\n{switch}"
        ),
    );
    let on = write(&dir, "on.evid", "1 3 1\n");
    let off = write(&dir, "off.evid", "1 3 0\n");
    for mut args in every_inference(&model) {
        args.extend(["--evidence", &on]);
        refused(
            &args,
            &[
                "switch.uai with",
                "on.evid",
                "Z = 0",
                "factors 6 and above",
                "P(evidence) = 0",
            ],
        );
        args.pop();
        args.push(&off);
        let (out, _) = ok(&args);
        if args[0] == "map" {
            let values = numbers(out.lines().nth(1).unwrap());
            let mut colours: Vec<usize> = values[1..4].iter().map(|&x| x as usize).collect();
            colours.sort_unstable();
            assert_eq!(
                (colours, values[4] as usize),
                (vec![0, 1, 2], 0),
                "{args:?}"
            );
        }
    }
}

#[test]
fn a_zero_probability_decoding_of_a_feasible_model_is_never_printed() {
    // x0 = x1 = x2 = x3 (hard), x3 = 1 (hard), x0 prefers 0: one flooding iteration
    // decodes all zeros, of probability 0; the only positive assignment is all ones.
    let dir = temp_dir("zero-decoding");
    let model = write(
        &dir,
        "chain.uai",
        "MARKOV\n4\n2 2 2 2\n5\n1 0\n2 0 1\n2 1 2\n2 2 3\n1 3\n\n\
         2\n1 0.5\n\n4\n1 0 0 1\n\n4\n1 0 0 1\n\n4\n1 0 0 1\n\n2\n0 1\n",
    );
    let (out, err) = ok(&["map", &model, "--schedule", "flooding", "--max-iters", "1"]);
    assert_eq!(out, "MPE\n4 1 1 1 1\n");
    assert!(
        err.contains("decoded [0, 0, 0, 0], which has probability 0")
            && err.contains("factor ")
            && err.contains("positive probability"),
        "{err}"
    );
    // A converged run decodes it directly, without the warning.
    let (out, err) = ok(&["map", &model, "--schedule", "flooding"]);
    assert_eq!(out, "MPE\n4 1 1 1 1\n");
    assert!(err.is_empty(), "{err}");
    // TRW-S decodes greedily in its order: here [0, 1, 2, 1] and then nothing is left
    // for x4 (adjacent to colours 0, 2 and 1); the optimum (log-score 1) is printed.
    let model = write(
        &dir,
        "greedy.uai",
        "MARKOV\n5\n3 3 3 3 3\n6\n2 0 1\n2 0 4\n2 1 2\n2 2 3\n2 2 4\n2 3 4\n\n\
         9\n0 1 0.1353352832366127 0.6065306597126334 0 0.22313016014842982 2.718281828459045 0.1353352832366127 0\n\n\
         9\n0 0.6065306597126334 1.6487212707001282 0.1353352832366127 0 0.36787944117144233 2.718281828459045 0.6065306597126334 0\n\n\
         9\n0 4.4816890703380645 0.1353352832366127 0.36787944117144233 0 1.6487212707001282 0.6065306597126334 1 0\n\n\
         9\n0 1.6487212707001282 0.6065306597126334 0.22313016014842982 0 0.1353352832366127 0.1353352832366127 1 0\n\n\
         9\n0 1.6487212707001282 0.1353352832366127 4.4816890703380645 0 1 1 2.718281828459045 0\n\n\
         9\n0 2.718281828459045 0.36787944117144233 1.6487212707001282 0 0.1353352832366127 0.1353352832366127 1 0\n",
    );
    let graph = UaiModel::read(&model).unwrap().to_factor_graph().unwrap();
    let exact = brute_force(&graph, BruteForceLimit::default()).unwrap();
    let (out, err) = ok(&["map", &model, "--algorithm", "trws", "--stats"]);
    let values = numbers(out.lines().nth(1).unwrap());
    let assignment: Vec<usize> = values[1..].iter().map(|&x| x as usize).collect();
    let score = graph.log_score(&assignment).unwrap();
    assert!((score - exact.map_log_score).abs() < 1e-12, "{score}");
    assert!(
        err.contains("TRW-S decoded [0, 1, 2, 1, 0], which has probability 0"),
        "{err}"
    );
    let stats = common::json(err.lines().last().unwrap());
    assert!((stats["score"].as_f64().unwrap() - score).abs() < 1e-12);
    assert!(stats["gap"].as_f64().unwrap() >= 0.0);
}
