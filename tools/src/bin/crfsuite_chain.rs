//! Our side of the CRFsuite comparison (`python/bench/crfsuite_side_by_side.py`): a
//! linear-chain CRF with CRFsuite's features, trained by maximum likelihood with the
//! core's learner (L-BFGS), on a CRFsuite item file.
//!
//! The model is CRFsuite's `crf1d` with `feature.possible_states=1` and
//! `feature.possible_transitions=1`: a state feature for every (attribute, label) pair,
//! valued by the attribute's value, and a transition feature for every ordered label
//! pair between neighbouring items; no start or end features. CRFsuite minimises
//! `−log L + c2 ‖w‖²`; the core's learner `−log L + ‖w‖² / (2σ²)`, so `σ² = 1 / (2 c2)`.
//!
//! ```text
//! crfsuite_chain --data train.crfsuite.txt --c2 0.1 [--weights crfsuite.json] [--max-iterations N]
//! crfsuite_chain --data train.crfsuite.txt --c2 0.1 --time-passes N
//! ```
//!
//! Item file: one item a line, `LABEL<TAB>ATTR[:VALUE]<TAB>…`, a blank line between
//! sequences (CRFsuite's format, without escapes). `--weights`: CRFsuite's learned
//! weights as JSON (`{"state": [[attr, label, w], …], "transitions": [[from, to, w], …]}`),
//! evaluated under our objective. `--time-passes N`: no learning, only N passes
//! (objective and gradient) at zero weights, timed one by one (median and minimum).
//! Prints one JSON object.

use pgm_core::learning::{
    FeatureSet, FnFeatures, LabelledInstance, LearnerParams, LearningObjective, Likelihood,
    LikelihoodKind, LogLinearModel,
};
use pgm_core::{ParamGuard, VariableId};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

/// One sequence: per item its label and its (attribute, value) pairs.
type Sequence = Vec<(String, Vec<(String, f64)>)>;

fn read_items(path: &str) -> Result<Vec<Sequence>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut sequences = Vec::new();
    let mut current: Sequence = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            if !current.is_empty() {
                sequences.push(std::mem::take(&mut current));
            }
            continue;
        }
        let mut fields = line.split('\t');
        let label = fields.next().unwrap_or_default().to_string();
        let mut attributes = Vec::new();
        for field in fields {
            let (name, value) = match field.rsplit_once(':') {
                Some((name, value)) => (
                    name,
                    value
                        .parse::<f64>()
                        .map_err(|e| format!("{path}:{}: attribute {field:?}: {e}", n + 1))?,
                ),
                None => (field, 1.0),
            };
            attributes.push((name.to_string(), value));
        }
        current.push((label, attributes));
    }
    if !current.is_empty() {
        sequences.push(current);
    }
    Ok(sequences)
}

struct Options {
    data: String,
    c2: f64,
    weights: Option<String>,
    max_iterations: u64,
    /// Only time this many passes at zero weights (no learning).
    time_passes: Option<usize>,
}

fn options() -> Result<Options, String> {
    let mut args = std::env::args().skip(1);
    let mut o = Options {
        data: String::new(),
        c2: 1.0,
        weights: None,
        max_iterations: 1000,
        time_passes: None,
    };
    while let Some(flag) = args.next() {
        let mut value = || {
            args.next()
                .ok_or_else(|| format!("{flag}: a value is missing"))
        };
        match flag.as_str() {
            "--data" => o.data = value()?,
            "--c2" => o.c2 = value()?.parse().map_err(|e| format!("--c2: {e}"))?,
            "--weights" => o.weights = Some(value()?),
            "--time-passes" => {
                o.time_passes = Some(
                    value()?
                        .parse()
                        .map_err(|e| format!("--time-passes: {e}"))?,
                )
            }
            "--max-iterations" => {
                o.max_iterations = value()?
                    .parse()
                    .map_err(|e| format!("--max-iterations: {e}"))?
            }
            other => return Err(format!("{other}: unknown option")),
        }
    }
    if o.data.is_empty() {
        return Err("--data FILE is required".into());
    }
    if !(o.c2 > 0.0 && o.c2.is_finite()) {
        return Err(format!("--c2 {}: a positive number", o.c2));
    }
    Ok(o)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("crfsuite_chain: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let o = options()?;
    let started = Instant::now();
    let sequences = read_items(&o.data)?;
    let labels: Vec<String> = {
        let mut l: Vec<String> = sequences.iter().flatten().map(|(y, _)| y.clone()).collect();
        l.sort();
        l.dedup();
        l
    };
    let attributes: Vec<String> = {
        let mut a: Vec<String> = sequences
            .iter()
            .flatten()
            .flat_map(|(_, x)| x.iter().map(|(name, _)| name.clone()))
            .collect();
        a.sort();
        a.dedup();
        a
    };
    let k = labels.len();
    let label_index: BTreeMap<&str, usize> = labels
        .iter()
        .enumerate()
        .map(|(i, l)| (l.as_str(), i))
        .collect();
    let attribute_index: BTreeMap<&str, usize> = attributes
        .iter()
        .enumerate()
        .map(|(i, a)| (a.as_str(), i))
        .collect();
    // One template per attribute (its weight per label), then the transitions.
    let mut features = FeatureSet::new("crfsuite-chain", 1);
    let label_names: Vec<&str> = labels.iter().map(String::as_str).collect();
    for a in &attributes {
        features
            .add_template(&format!("attr={a}"), &label_names)
            .map_err(|e| e.to_string())?;
    }
    let pair_names: Vec<String> = labels
        .iter()
        .flat_map(|a| labels.iter().map(move |b| format!("{a}>{b}")))
        .collect();
    let pair_refs: Vec<&str> = pair_names.iter().map(String::as_str).collect();
    let transitions = features
        .add_template("trans", &pair_refs)
        .map_err(|e| e.to_string())?;
    let features = Arc::new(features);
    let mut data = Vec::with_capacity(sequences.len());
    let mut items = 0;
    for seq in &sequences {
        let n = seq.len();
        items += n;
        let mut model =
            LogLinearModel::new(Arc::clone(&features), &vec![k; n]).map_err(|e| e.to_string())?;
        for (t, (_, attrs)) in seq.iter().enumerate() {
            for (name, value) in attrs {
                let template = pgm_core::learning::TemplateId(attribute_index[name.as_str()]);
                let value = *value;
                let clique = FnFeatures::new([VariableId(t)], [k], move |s, out| out[s[0]] = value);
                model
                    .add_clique(template, clique)
                    .map_err(|e| e.to_string())?;
            }
            if t > 0 {
                let clique =
                    FnFeatures::new([VariableId(t - 1), VariableId(t)], [k, k], move |s, out| {
                        out[s[0] * k + s[1]] = 1.0
                    });
                model
                    .add_clique(transitions, clique)
                    .map_err(|e| e.to_string())?;
            }
        }
        let y = seq.iter().map(|(l, _)| label_index[l.as_str()]).collect();
        data.push(LabelledInstance::new(model, y));
    }
    let built = started.elapsed().as_secs_f64();
    let prior_variance = 1.0 / (2.0 * o.c2);
    if let Some(passes) = o.time_passes {
        let t = Instant::now();
        let objective = Likelihood::new(
            LikelihoodKind::Exact,
            Arc::clone(&features),
            &data,
            prior_variance,
        )
        .map_err(|e| e.to_string())?;
        let objective_seconds = t.elapsed().as_secs_f64();
        let zeros = vec![0.0; features.num_weights()];
        let mut times = Vec::with_capacity(passes);
        let mut value = 0.0;
        for _ in 0..passes.max(1) {
            let t = Instant::now();
            value = objective
                .value_and_gradient(&zeros)
                .map_err(|e| e.to_string())?
                .0;
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let out = serde_json::json!({
            "items": items,
            "objective_seconds": objective_seconds,
            "passes": times.len(),
            "pass_seconds_median": times[times.len() / 2],
            "pass_seconds_min": times[0],
            "objective_at_zero": value,
        });
        println!("{out}");
        return Ok(());
    }
    let learner = LearnerParams::default()
        .prior_variance(prior_variance)
        .objective(LearningObjective::Likelihood)
        .max_iterations(o.max_iterations)
        .gradient_tolerance(1e-6)
        .cost_tolerance(1e-12)
        .check()
        .map_err(|e| e.to_string())?;
    let t = Instant::now();
    let result = learner
        .learn(&features, &data, &mut ())
        .map_err(|e| e.to_string())?;
    let learn_seconds = t.elapsed().as_secs_f64();
    let objective = Likelihood::new(
        LikelihoodKind::Exact,
        Arc::clone(&features),
        &data,
        prior_variance,
    )
    .map_err(|e| e.to_string())?;
    // One pass (objective and gradient) timed alone, at the optimum.
    let t = Instant::now();
    let passes = 5;
    for _ in 0..passes {
        objective
            .value_and_gradient(result.weights.values())
            .map_err(|e| e.to_string())?;
    }
    let pass_seconds = t.elapsed().as_secs_f64() / passes as f64;
    let theirs = match &o.weights {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
            let json: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
            let mut w = vec![0.0; features.num_weights()];
            for entry in json["state"].as_array().into_iter().flatten() {
                let (a, l, v) = (entry[0].as_str(), entry[1].as_str(), entry[2].as_f64());
                if let (Some(a), Some(l), Some(v)) = (a, l, v) {
                    if let (Some(&ai), Some(&li)) = (attribute_index.get(a), label_index.get(l)) {
                        w[ai * k + li] = v;
                    }
                }
            }
            let offset = attributes.len() * k;
            for entry in json["transitions"].as_array().into_iter().flatten() {
                let (a, b, v) = (entry[0].as_str(), entry[1].as_str(), entry[2].as_f64());
                if let (Some(a), Some(b), Some(v)) = (a, b, v) {
                    if let (Some(&ai), Some(&bi)) = (label_index.get(a), label_index.get(b)) {
                        w[offset + ai * k + bi] = v;
                    }
                }
            }
            Some(
                objective
                    .value_and_gradient(&w)
                    .map_err(|e| e.to_string())?
                    .0,
            )
        }
        None => None,
    };
    let out = serde_json::json!({
        "sequences": sequences.len(),
        "items": items,
        "labels": k,
        "attributes": attributes.len(),
        "weights": features.num_weights(),
        "build_seconds": built,
        "learn_seconds": learn_seconds,
        "iterations": result.iterations,
        "evaluations": result.evaluations,
        "converged": result.converged,
        "termination": result.termination,
        "objective": result.objective,
        "gradient_norm": result.gradient_norm,
        "pass_seconds": pass_seconds,
        "objective_at_their_weights": theirs,
    });
    println!("{out}");
    Ok(())
}
