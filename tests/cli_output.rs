//! What the commands write and where: `--out` never deletes a file it did not write
//! and a killed write leaves the old data set or the new one; a failing command writes
//! nothing, not even its result; results go to stdout and diagnostics to stderr, with
//! method names as typed; a closed stdout ends quietly and a full one is an error.

mod common;

use common::logs::sparse_log;
use common::*;
use std::path::Path;
use std::process::Stdio;
use std::time::Instant;

#[test]
fn out_never_deletes_files_it_did_not_write() {
    // out-stale-delete: a directory that holds no data set is refused, its files kept.
    let dir = temp_dir("stale");
    let mine = dir.join("mydir");
    std::fs::create_dir_all(&mine).unwrap();
    write(&mine, "pair-notes.json", "x\n");
    refused(
        &["sim", "--pairs", "1", "--out", mine.to_str().unwrap()],
        &["mydir", "no pgm data set"],
    );
    assert_eq!(
        std::fs::read_to_string(mine.join("pair-notes.json")).unwrap(),
        "x\n"
    );
    // Replacing a data set keeps the files a user put beside it.
    let ds = path(&dir, "ds");
    ok(&["sim", "--pairs", "3", "--out", &ds]);
    write(Path::new(&ds), "notes.txt", "mine");
    ok(&["sim", "--pairs", "2", "--seed", "2", "--out", &ds]);
    assert_eq!(
        std::fs::read_to_string(Path::new(&ds).join("notes.txt")).unwrap(),
        "mine"
    );
    // A command that fails writes nothing: the SVG cannot be written, so neither is the
    // data set.
    let fresh = path(&dir, "fresh");
    let svg = path(&dir, "no/such/dir/x.svg");
    refused(
        &["sim", "--pairs", "2", "--out", &fresh, "--svg", &svg],
        &["x.svg"],
    );
    assert!(!Path::new(&fresh).exists());
}

/// The pair names of the data set at `dir`, through `pgm eval` (which reads and checks
/// every pair against the index).
fn seeds_of(dir: &str) -> Vec<String> {
    let (out, err, code) = pgm(&eval(
        "clustering",
        "one-cluster",
        &["--pairs", dir, "--json"],
    ));
    assert_eq!(code, Some(0), "the data set must read back whole: {err}");
    assert_eq!(json(&out)["pairs"], 40);
    let index = read_json(Path::new(dir).join("index.json"));
    let mut seeds: Vec<String> = index["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            p["name"]
                .as_str()
                .unwrap()
                .split(':')
                .nth(2)
                .unwrap()
                .to_string()
        })
        .collect();
    seeds.dedup();
    seeds
}

#[test]
fn a_write_killed_at_any_moment_leaves_the_old_data_set_or_the_new_one() {
    // out-kill-midwrite: kill -9 during `pgm sim --out` over an existing data set.
    let dir = temp_dir("kill");
    let ds = path(&dir, "ds");
    let sim = |seed: &str| {
        command(&["sim", "--pairs", "40", "--seed", seed, "--out", &ds])
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let started = Instant::now();
    assert!(sim("1").wait().unwrap().success());
    let full = started.elapsed();
    for step in 0..12 {
        let seed = if step % 2 == 0 { "2" } else { "3" };
        let before = seeds_of(&ds);
        assert_eq!(before.len(), 1, "one seed per data set: {before:?}");
        let mut child = sim(seed);
        std::thread::sleep(full.mul_f64(0.3 + 0.07 * step as f64));
        let _ = child.kill();
        let finished = child.wait().unwrap().success();
        let after = seeds_of(&ds);
        assert_eq!(after.len(), 1, "never a mix: {after:?}");
        assert!(
            after == before || after == [seed.to_string()],
            "{before:?} -> {after:?}"
        );
        if finished {
            assert_eq!(after, [seed.to_string()]);
        }
    }
    // A complete write afterwards leaves only the data set (and no temporary files).
    assert!(sim("4").wait().unwrap().success());
    let names: Vec<String> = std::fs::read_dir(&ds)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 41, "{names:?}");
    assert!(names.iter().all(|n| !n.starts_with('.')), "{names:?}");
}

/// Every entry of `dir` (hidden ones included), sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// Starts `pgm sim --out ds` with `pairs` pairs, waits until `writing(dir)` says its
/// write has begun, sends `signal` (`INT`, `TERM`) and returns the exit status and
/// stderr; `None` when the run ended before it was caught writing.
#[cfg(unix)]
fn stopped_while_writing(
    dir: &Path,
    pairs: &str,
    signal: &str,
    writing: impl Fn(&Path) -> bool,
) -> Option<(Option<i32>, String)> {
    let ds = dir.join("ds");
    let mut child = command(&[
        "sim",
        "--pairs",
        pairs,
        "--seed",
        "5",
        "--out",
        ds.to_str().unwrap(),
    ])
    .stdout(Stdio::null())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let started = Instant::now();
    while !writing(dir) {
        if child.try_wait().unwrap().is_some() || started.elapsed().as_secs() > 120 {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let sent = std::process::Command::new("kill")
        .args([format!("-{signal}"), child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let out = child.wait_with_output().unwrap();
    Some((
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    ))
}

#[cfg(unix)]
#[test]
fn ctrl_c_and_sigterm_remove_what_the_write_had_started() {
    // sim-interrupt: `pgm sim --out` stopped by Ctrl-C left ~1,300 partial pair files,
    // a journal and a temporary file behind until the next write.
    let dir = temp_dir("signals");
    let ds = dir.join("ds");
    // A fresh data set: stopped while its temporary directory fills, nothing is left.
    let temporary_has_files = |d: &Path| {
        entries(d)
            .iter()
            .any(|n| n.starts_with(".ds.pgm-tmp") && entries(&d.join(n)).len() > 20)
    };
    let mut caught = false;
    for pairs in ["3000", "12000"] {
        if let Some((code, stderr)) = stopped_while_writing(&dir, pairs, "INT", temporary_has_files)
        {
            assert_eq!(code, Some(130), "{stderr}");
            assert!(stderr.contains("stopped by SIGINT: removed"), "{stderr}");
            assert_eq!(entries(&dir), Vec::<String>::new(), "nothing left");
            caught = true;
            break;
        }
        let _ = std::fs::remove_dir_all(&ds);
    }
    assert!(caught, "never caught pgm sim writing");
    // A replacement: stopped while its new pair files appear, the old data set is
    // whole and alone (no new pair file, no journal, no temporary file).
    let write_old = || {
        ok(&[
            "sim",
            "--pairs",
            "30",
            "--seed",
            "1",
            "--out",
            ds.to_str().unwrap(),
        ])
    };
    write_old();
    let old = entries(&ds);
    let old_index = std::fs::read(ds.join("index.json")).unwrap();
    let new_files = |d: &Path| {
        entries(&d.join("ds"))
            .iter()
            .filter(|n| n.starts_with("pair-g"))
            .count()
            > 20
    };
    let mut caught = false;
    for pairs in ["3000", "12000"] {
        match stopped_while_writing(&dir, pairs, "TERM", new_files) {
            Some((code, stderr)) => {
                assert_eq!(code, Some(143), "{stderr}");
                assert!(stderr.contains("stopped by SIGTERM: removed"), "{stderr}");
                assert_eq!(entries(&ds), old);
                assert_eq!(std::fs::read(ds.join("index.json")).unwrap(), old_index);
                caught = true;
                break;
            }
            None => {
                let _ = std::fs::remove_dir_all(&ds);
                write_old();
            }
        }
    }
    assert!(caught, "never caught pgm sim replacing");
    // A signal while nothing is written yet ends the command at once, writing nothing.
    let start = Instant::now();
    let waiting = |_: &Path| start.elapsed().as_millis() > 300;
    let (code, _) = stopped_while_writing(&dir, "20000", "INT", waiting).unwrap();
    assert_eq!(code, Some(130));
    assert_eq!(entries(&ds), old);
}

#[test]
fn a_failing_command_writes_nothing_not_even_its_result() {
    let dir = temp_dir("writes");
    let (ds, _) = simulated(&dir, "sim", 15, 1);
    // A file where a directory is needed: every output below is impossible.
    let file = write(&dir, "file", "not a directory\n");
    let inside = |name: &str| format!("{file}/{name}");
    let (c, m, d, w) = (
        inside("c.svg"),
        inside("m.svg"),
        inside("d.svg"),
        inside("w.json"),
    );
    refused_all(&[
        (vec!["cluster", "--pairs", &ds, "--svg", &c], vec!["c.svg"]),
        (vec!["match", "--pairs", &ds, "--svg", &m], vec!["m.svg"]),
        (vec!["demo", "--pairs", "1", "--svg", &d], vec!["d.svg"]),
        (
            vec!["train", "clustering", "--data", &ds, "--out", &w],
            vec!["w.json"],
        ),
        (
            vec!["train", "matching", "--data", &ds, "--out", &w],
            vec!["w.json"],
        ),
    ]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a directory\n");
}

/// Every stderr line of a successful run is a diagnostic: `pgm: …` or `note: …`.
fn diagnostics_only(err: &str) {
    for line in err.lines() {
        assert!(
            line.starts_with("pgm: ") || line.starts_with("note: "),
            "not a diagnostic on stderr: {line:?}"
        );
    }
}

#[test]
fn results_on_stdout_diagnostics_on_stderr_names_as_typed() {
    let dir = temp_dir("streams");
    let ds = path(&dir, "ds");
    let ds = ds.as_str();
    // Commands that write files print nothing on stdout; what they wrote is a note.
    let (out, err) = ok(&["sim", "--pairs", "3", "--seed", "16", "--out", ds]);
    assert!(out.is_empty(), "{out}");
    assert!(err.contains("wrote 3 pairs"), "{err}");
    diagnostics_only(&err);
    let svg = path(&dir, "p.svg");
    let (out, err) = ok(&["plot", ds, "--svg", &svg, "--view", "-5,20,-10,10"]);
    assert!(out.is_empty() && err.contains("drew"), "{out}{err}");
    let (log, rel) = sparse_log(&dir, 30);
    let carmen_ds = path(&dir, "carmen");
    let (out, err) = ok(&[
        "data",
        "pairs",
        "--carmen",
        &log,
        "--relations",
        &rel,
        "--out",
        &carmen_ds,
    ]);
    assert!(
        out.is_empty() && err.contains("wrote 1 pairs"),
        "{out}{err}"
    );
    diagnostics_only(&err);
    // Results are on stdout, and the method names are as typed.
    for method in ["odometry", "icp", "icp+csm", "crf-matching"] {
        let (out, err) = ok(&eval("matching", method, &["--pairs", ds, "--json"]));
        assert_eq!(json(&out)["method"], method);
        diagnostics_only(&err);
        let (out, _) = ok(&eval("matching", method, &["--pairs", ds]));
        assert!(out.starts_with(&format!("method {method}:")), "{out}");
    }
    for method in ["true", "icp", "segment-icp", "crf-matching"] {
        let v = ok_json(&eval("association", method, &["--pairs", ds, "--json"]));
        assert_eq!(v["method"], method);
        let v = ok_json(&["cluster", "--pairs", ds, "--associations", method]);
        assert_eq!(v["associations"], method);
    }
    for (method, takes_associations) in [
        ("crf", true),
        ("kmeans", true),
        ("cbd", false),
        ("one-cluster", false),
    ] {
        let (out, err) = ok(&eval(
            "clustering",
            method,
            &["--associations", "segment-icp", "--pairs", ds, "--json"],
        ));
        let v = json(&out);
        assert_eq!(v["method"], method);
        if takes_associations {
            assert_eq!(v["associations"], "segment-icp");
        } else {
            assert!(v["associations"].is_null(), "{v}");
        }
        diagnostics_only(&err);
    }
    let (out, err) = ok(&["match", "--pairs", ds]);
    assert!(json(&out)["associations"].is_array());
    diagnostics_only(&err);
    // pgm train prints one JSON object on stdout, for every model (on two simulated
    // pairs of the training seed; three pairs of seed 16 teach no usable weights, and
    // training refuses them).
    for model in ["clustering", "matching"] {
        let w = path(&dir, &format!("{model}.json"));
        let (out, err) = ok(&[
            "train",
            model,
            "--simulate",
            "2",
            "--seed",
            "1000",
            "--out",
            &w,
        ]);
        let v = json(&out);
        assert_eq!(v["out"], w.as_str());
        assert!(v["weights"].is_object(), "{v}");
        assert!(Path::new(&w).exists());
        diagnostics_only(&err);
    }
    // The demo's table is its result; the picture it drew is a note.
    let (demo_svg, joint_svg) = (path(&dir, "demo.svg"), path(&dir, "demo-joint.svg"));
    let (out, err) = ok(&[
        "demo",
        "--pairs",
        "2",
        "--svg",
        &demo_svg,
        "--joint-svg",
        &joint_svg,
    ]);
    assert!(out.contains("V") && !out.contains("drew"), "{out}");
    assert!(err.contains("drew pair 0"), "{err}");
    diagnostics_only(&err);
}

/// `pgm … | head`: the reader closes the pipe early; pgm ends quietly with status 0
/// instead of panicking on the closed stdout (the output, marginals of 20000
/// variables, is far larger than a pipe's buffer).
#[test]
fn a_closed_stdout_ends_quietly() {
    use std::fmt::Write as _;
    use std::io::Read;
    let n = 20_000;
    let mut uai = format!("MARKOV\n{n}\n");
    uai += &"2 ".repeat(n);
    let _ = write!(uai, "\n{n}\n");
    for i in 0..n {
        let _ = writeln!(uai, "1 {i}");
    }
    for _ in 0..n {
        uai += "2\n0.3 0.7\n";
    }
    let dir = temp_dir("closed-stdout");
    let model = write(&dir, "wide.uai", &uai);
    let mut child = command(&["marginals", &model])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut first = [0u8; 16];
    stdout.read_exact(&mut first).unwrap();
    drop(stdout);
    let out = child.wait_with_output().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}

#[test]
fn a_full_stdout_is_an_error_not_a_panic() {
    // Linux only: writes to /dev/full fail with "no space left on device".
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        return;
    };
    let out = command(&["sim", "--pairs", "1"])
        .stdout(full)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("cannot write the result to standard output"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// An output file in a directory that does not exist is refused up front by every
/// command that writes one, with one message, nothing printed and nothing written
/// (`pgm joint --svg` printed its whole JSON and then failed).
#[test]
fn an_output_file_in_a_missing_directory_is_refused_the_same_way_everywhere() {
    let dir = temp_dir("missing-output-dir");
    let (ds, _) = simulated(&dir, "ds", 3, 1);
    let missing = path(&dir, "no/such/dir/x.svg");
    let expected = format!(
        "{missing}: cannot write here: the directory {} does not exist",
        path(&dir, "no/such/dir")
    );
    let cases: Vec<Refusal> = vec![
        (
            vec!["joint", "--pairs", &ds, "--svg", &missing],
            vec![&expected],
        ),
        (
            vec![
                "cluster",
                "--pairs",
                &ds,
                "--associations",
                "icp",
                "--svg",
                &missing,
            ],
            vec![&expected],
        ),
        (
            vec!["match", "--pairs", &ds, "--svg", &missing],
            vec![&expected],
        ),
        (vec!["plot", &ds, "--svg", &missing], vec![&expected]),
        (
            vec!["sim", "--pairs", "1", "--svg", &missing],
            vec![&expected],
        ),
        (
            vec![
                "track", "--method", "crf", "--pairs", &ds, "--svg", &missing,
            ],
            vec![&expected],
        ),
        (
            vec![
                "track", "--method", "crf", "--pairs", &ds, "--out", &missing,
            ],
            vec![&expected],
        ),
        (
            vec!["demo", "--pairs", "2", "--svg", &missing],
            vec![&expected],
        ),
    ];
    refused_all(&cases);
    // `--mcap` (every command that records for Foxglove) the same way.
    let missing = path(&dir, "no/such/dir/x.mcap");
    let expected = format!(
        "{missing}: cannot write here: the directory {} does not exist",
        path(&dir, "no/such/dir")
    );
    let track = ["track", "--method", "crf"];
    refused_all(&[
        (
            vec!["joint", "--pairs", &ds, "--mcap", &missing],
            vec![&expected],
        ),
        (
            vec!["match", "--pairs", &ds, "--mcap", &missing],
            vec![&expected],
        ),
        (
            vec!["cluster", "--pairs", &ds, "--mcap", &missing],
            vec![&expected],
        ),
        (
            [&track[..], &["--pairs", &ds, "--mcap", &missing]].concat(),
            vec![&expected],
        ),
    ]);
    assert!(!dir.join("no").exists());
}
