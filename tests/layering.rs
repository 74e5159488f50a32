//! The layering of docs/architecture.md, held to the manifests: each workspace crate
//! depends (normal dependencies) on no workspace crate but the ones the table there
//! allows, so a model never reaches the readers, the tracker or another model.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// What each crate may use of the workspace (docs/architecture.md, "The crates and
/// what each may use").
fn allowed() -> BTreeMap<&'static str, Vec<&'static str>> {
    let models = vec!["pgm-core", "pgm-scan", "pgm-features"];
    BTreeMap::from([
        ("pgm-core", vec![]),
        ("pgm-scan", vec!["pgm-core"]),
        ("pgm-features", vec!["pgm-core", "pgm-scan"]),
        ("pgm-tracking", vec!["pgm-core", "pgm-scan"]),
        ("pgm-datasets", vec!["pgm-core", "pgm-scan"]),
        ("pgm-eval", vec!["pgm-scan", "pgm-datasets"]),
        ("pgm-baselines", models.clone()),
        ("pgm-crf-clustering", models.clone()),
        ("pgm-crf-matching", models.clone()),
        ("pgm-joint", models),
    ])
}

#[test]
fn every_crate_uses_only_the_layers_below_it() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let output = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let metadata: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let packages = metadata["packages"].as_array().unwrap();
    let workspace: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    let allowed = allowed();
    let mut problems = Vec::new();
    for package in packages {
        let name = package["name"].as_str().unwrap();
        if name == "pgm" || name == "pgm-tools" {
            continue; // the facade and the developers' experiments use everything
        }
        let Some(may_use) = allowed.get(name) else {
            problems.push(format!(
                "{name}: not in the layering (add it to docs/architecture.md and here)"
            ));
            continue;
        };
        for dependency in package["dependencies"].as_array().unwrap() {
            let used = dependency["name"].as_str().unwrap();
            let normal = dependency["kind"].is_null();
            if normal && workspace.contains(used) && !may_use.contains(&used) {
                problems.push(format!("{name} uses {used}"));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "the layering is broken: {}",
        problems.join("; ")
    );
}
