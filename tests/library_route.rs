//! The library route as a new user takes it: a crate outside the workspace that
//! depends on the facade `pgm` alone (by path) builds and runs the README's library
//! example. Doctests cannot show this, since they see every dependency of the crate
//! they document; this crate sees only what `pgm` exports.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The first ```rust block of the README, the library example.
fn readme_example(readme: &str) -> String {
    let start = readme
        .find("```rust\n")
        .expect("README.md has a ```rust block (the library example)")
        + "```rust\n".len();
    let end = start
        + readme[start..]
            .find("```")
            .expect("the README's ```rust block is closed");
    readme[start..end].to_string()
}

#[test]
fn readme_library_example_builds_and_runs_against_the_facade_alone() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let example = readme_example(&readme);
    assert!(
        !example.contains("pgm_"),
        "the README's library example names a workspace crate instead of the facade: {example}"
    );
    let (uses, body): (Vec<&str>, Vec<&str>) = example.lines().partition(|l| l.starts_with("use "));

    // Outside the workspace (no [workspace] above it), beside the build output.
    let dir: PathBuf = std::env::var_os("CARGO_TARGET_TMPDIR")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir)
        .join("readme-example");
    let _ = std::fs::remove_dir_all(dir.join("src"));
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::write(
        dir.join("Cargo.toml"),
        format!(
            "[package]\nname = \"readme-example\"\nversion = \"0.0.0\"\nedition = \"2021\"\n\
             publish = false\n\n[workspace]\n\n[dependencies]\npgm = {{ path = {:?} }}\n",
            root.display().to_string()
        ),
    )
    .unwrap();
    // The workspace's versions of every dependency, so nothing new is resolved.
    std::fs::copy(root.join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
    std::fs::write(
        dir.join("src/main.rs"),
        format!(
            "{}\n\nfn main() {{\n{}\n    println!(\"readme example ok\");\n}}\n",
            uses.join("\n"),
            body.iter()
                .map(|l| format!("    {l}"))
                .collect::<Vec<_>>()
                .join("\n")
        ),
    )
    .unwrap();

    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let output = Command::new(cargo)
        .args(["run", "--quiet"])
        .current_dir(&dir)
        .env("CARGO_TARGET_DIR", dir.join("target"))
        // The debug profile without debug info: the quickest build of the facade.
        .env("CARGO_PROFILE_DEV_DEBUG", "0")
        .output()
        .expect("cargo runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success() && stdout.contains("readme example ok"),
        "the README's library example failed in a crate that depends on `pgm` alone\n\
         --- src/main.rs\n{}\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
        std::fs::read_to_string(dir.join("src/main.rs")).unwrap_or_default()
    );
}
