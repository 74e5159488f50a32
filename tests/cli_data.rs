//! Issue 16 from the command line: malformed or meaningless logs exit with status 2
//! and a message naming file, line and field; CARMEN scan geometry comes from the log;
//! `--out` never deletes a file it did not write and a killed write leaves the old data
//! set or the new one; a failing command writes nothing. Every input is built here.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

fn pgm(args: &[&str]) -> (String, String, bool, Option<i32>) {
    let out = Command::new(env!("CARGO_BIN_EXE_pgm"))
        .args(args)
        .output()
        .unwrap();
    (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
        out.status.success(),
        out.status.code(),
    )
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-hardening-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// Asserts exit status 2, nothing on stdout and `needles` in the message.
fn refused(args: &[&str], needles: &[&str]) {
    let (out, err, ok, code) = pgm(args);
    assert!(!ok && code == Some(2), "{args:?}: status {code:?}\n{err}");
    assert!(out.is_empty(), "{args:?}: {out}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: expected {n:?} in\n{err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

/// Ranges of `n` beams from `start` (rad) every `step` (rad) of a laser at `pose` (x, y,
/// heading) in the rectangular room [-3, 7] × [-4, 5].
fn room_ranges(pose: (f64, f64, f64), n: usize, start: f64, step: f64) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let a = pose.2 + start + k as f64 * step;
            let (s, c) = a.sin_cos();
            let tx = if c > 1e-12 {
                (7.0 - pose.0) / c
            } else if c < -1e-12 {
                (-3.0 - pose.0) / c
            } else {
                f64::INFINITY
            };
            let ty = if s > 1e-12 {
                (5.0 - pose.1) / s
            } else if s < -1e-12 {
                (-4.0 - pose.1) / s
            } else {
                f64::INFINITY
            };
            tx.min(ty)
        })
        .collect()
}

fn flaser_line(ranges: &[f64], pose: (f64, f64, f64), t: f64) -> String {
    let r: Vec<String> = ranges.iter().map(|r| format!("{r:.4}")).collect();
    let p = format!("{} {} {}", pose.0, pose.1, pose.2);
    format!(
        "FLASER {} {} {p} {p} {t} host {t}",
        ranges.len(),
        r.join(" ")
    )
}

/// A CARMEN log of a 401-beam scanner at 0.25° whose first beam points to the right
/// (CARMEN's convention), two scans 0.2 s apart, odometry off the truth; and its
/// relation. With `params` the log says its field of view and resolution.
fn lms401(dir: &Path, params: bool) -> (String, String) {
    let deg = std::f64::consts::PI / 180.0;
    let truth = (0.25, 0.08, 0.06);
    let a = room_ranges((0.0, 0.0, 0.0), 401, -90.0 * deg, 0.25 * deg);
    let b = room_ranges(truth, 401, -90.0 * deg, 0.25 * deg);
    let mut text = String::new();
    if params {
        text += "PARAM laser_front_laser_fov 100\nPARAM laser_front_laser_resolution 0.25\n";
    }
    text += &flaser_line(&a, (0.0, 0.0, 0.0), 100.0);
    text += "\n";
    text += &flaser_line(&b, (0.2, 0.1, 0.03), 100.2);
    text += "\n";
    let name = if params { "params.clf" } else { "rule.clf" };
    (
        write(dir, name, &text),
        write(dir, "lms.relations", "100.0 100.2 0.25 0.08 0 0 0 0.06\n"),
    )
}

fn icp_translation_error(log: &str, relations: &str, extra: &[&str]) -> f64 {
    let mut args = vec![
        "eval",
        "matching",
        "--method",
        "icp",
        "--carmen",
        log,
        "--relations",
        relations,
        "--json",
    ];
    args.extend_from_slice(extra);
    let (out, err, ok, _) = pgm(&args);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["pairs"], 1);
    v["translation_median"].as_f64().unwrap()
}

#[test]
fn carmen_beam_angles_come_from_the_log() {
    // L01: PARAM lines say 100° at 0.25°; without them CARMEN's rule for 401 beams says
    // the same. ICP from a rough prior then lands at the noise level (4-decimal ranges).
    let dir = temp_dir("lms401");
    let (with_params, relations) = lms401(&dir, true);
    let (by_rule, _) = lms401(&dir, false);
    for log in [&with_params, &by_rule] {
        let e = icp_translation_error(log, &relations, &[]);
        assert!(e < 0.01, "{log}: {e} m");
    }
    // The override options are used: the first beam at -50° instead of -90° turns the
    // scans by 40° and ICP away from the truth.
    let e = icp_translation_error(&with_params, &relations, &["--laser-start", "-50"]);
    assert!(e > 0.05, "{e}");
    // An override that contradicts the beam count is an error naming the line.
    refused(
        &[
            "eval",
            "matching",
            "--method",
            "icp",
            "--carmen",
            &with_params,
            "--relations",
            &relations,
            "--laser-fov",
            "180",
            "--laser-resolution",
            "1",
        ],
        &["params.clf:3:", "`n`", "gives 181"],
    );
}

#[test]
fn malformed_carmen_lines_exit_2_naming_file_line_and_field() {
    let dir = temp_dir("carmen");
    let good = flaser_line(&[2.0; 181], (0.0, 0.0, 0.0), 1.0);
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        // carmen-n-overflow
        (
            "overflow.clf",
            "FLASER 18446744073709551615 1 2 3 4 5 6 7 8\n".into(),
            vec!["overflow.clf:1:", "`n`"],
        ),
        // carmen-zero-beam
        (
            "zero.clf",
            format!("FLASER 0  0 0 0 0 0 0 1.0 host 1.0\n{good}\n"),
            vec!["zero.clf:1:", "`n`", "at least one beam"],
        ),
        // carmen-huge-pose
        (
            "huge.clf",
            format!("{good}\n{}\n", flaser_line(&[2.0; 181], (1e300, 0.0, 0.0), 1.5)),
            vec!["huge.clf:2:", "`x`", "position"],
        ),
        // rl-res-zero
        (
            "res.clf",
            format!(
                "ROBOTLASER1 0 -1.57 3.14 0.0 80.0 0.01 0 3 1 2 3 0 0 0 0 0 0 0 0 0 0 0 0 1.0 x 1.0\n{good}\n"
            ),
            vec!["res.clf:1:", "`angular_res`", "one ray"],
        ),
    ];
    for (name, text, needles) in &cases {
        let log = write(&dir, name, text);
        refused(
            &[
                "cluster",
                "--carmen",
                &log,
                "--reference",
                "0",
                "--current",
                "1",
            ],
            needles,
        );
        refused(
            &[
                "data",
                "pairs",
                "--log",
                &log,
                "--out",
                dir.join("out").to_str().unwrap(),
            ],
            needles,
        );
        assert!(
            !dir.join("out").exists(),
            "a failing command writes nothing"
        );
    }
    // nan and inf are beams without a return, not errors.
    let mut ranges = vec![2.0; 181];
    ranges[3] = f64::NAN;
    ranges[4] = f64::INFINITY;
    let nan = flaser_line(&ranges, (0.0, 0.0, 0.0), 1.0).replace("NaN", "nan");
    let log = write(&dir, "nan.clf", &format!("{good}\n{nan}\n"));
    let (out, err, ok, _) = pgm(&[
        "cluster",
        "--carmen",
        &log,
        "--reference",
        "0",
        "--current",
        "1",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["labels"][3], serde_json::Value::Null);
    assert_eq!(v["labels"][4], serde_json::Value::Null);
}

/// A leigh-gtm1 style log: scans 0..12 of 60 beams in front of a wall, odometry, and
/// two people annotated on every scan (person 1 walks). `scan_head` replaces the
/// fields `angle_min angle_increment range_min range_max` of scan 0; `person` the
/// centre of person 2 on scan 5.
fn leigh(dir: &Path, scan_head: &str, person: &str) -> [String; 3] {
    let mut scans = String::new();
    let mut odometry = String::new();
    let mut people = String::new();
    for i in 0..12 {
        let head = if i == 0 {
            scan_head
        } else {
            "-1.0 0.0333 0.05 20.0"
        };
        let ranges: Vec<String> = (0..60)
            .map(|k| format!("{:.3}", 4.0 + 0.01 * k as f64))
            .collect();
        scans += &format!(
            "SCAN {i} {t} {t} laser {head} 60 {}\n",
            ranges.join(" "),
            t = 10.0 + 0.1 * i as f64
        );
        odometry += &format!(
            "ODOM {i} {} {} 0 0\n",
            10.0 + 0.1 * i as f64,
            0.05 * i as f64
        );
        people += &format!("PERSON {i} 1 {} 0.5\n", 2.0 + 0.2 * i as f64);
        let p2 = if i == 5 {
            person.to_string()
        } else {
            "3.0 -1.0".into()
        };
        people += &format!("PERSON {i} 2 {p2}\n");
    }
    [
        write(dir, "scans.txt", &scans),
        write(dir, "people.txt", &people),
        write(dir, "odom.txt", &odometry),
    ]
}

#[test]
fn malformed_leigh_logs_and_arguments_exit_2() {
    let dir = temp_dir("leigh");
    let out = dir.join("ds");
    let out = out.to_str().unwrap();
    let ok_head = "-1.0 0.0333 0.05 20.0";
    let [s, p, o] = leigh(&dir, ok_head, "3.0 -1.0");
    let (_, err, ok, _) = pgm(&[
        "data",
        "summary",
        "--scans",
        &s,
        "--people",
        &p,
        "--odometry",
        &o,
    ]);
    assert!(ok, "{err}");
    // leigh-k-wrap: i + k wrapped to i - 1; now an error, and nothing written.
    for k in ["18446744073709551615", "18446744073709551606", "12"] {
        refused(
            &[
                "data",
                "pairs",
                "--scans",
                &s,
                "--people",
                &p,
                "--odometry",
                &o,
                "--k",
                k,
                "--out",
                out,
            ],
            &["scans.txt", "that far apart"],
        );
        assert!(!Path::new(out).exists());
        refused(
            &[
                "data",
                "summary",
                "--scans",
                &s,
                "--people",
                &p,
                "--odometry",
                &o,
                "--k",
                k,
            ],
            &["that far apart"],
        );
    }
    let (_, err, ok, _) = pgm(&[
        "data",
        "pairs",
        "--scans",
        &s,
        "--people",
        &p,
        "--odometry",
        &o,
        "--k",
        "11",
        "--out",
        out,
    ]);
    assert!(ok, "{err}");
    // leigh-rmin-neg, a zero angle increment.
    let [s, p, o] = leigh(&dir, "-1.0 0.0333 -5 20.0", "3.0 -1.0");
    refused(
        &[
            "data",
            "summary",
            "--scans",
            &s,
            "--people",
            &p,
            "--odometry",
            &o,
        ],
        &["scans.txt:1:", "`range_min`", "-5"],
    );
    let [s, p, o] = leigh(&dir, "-1.0 0 0.05 20.0", "3.0 -1.0");
    refused(
        &[
            "eval",
            "clustering",
            "--method",
            "crf",
            "--scans",
            &s,
            "--people",
            &p,
            "--odometry",
            &o,
            "--k",
            "1",
        ],
        &["scans.txt:1:", "`angle_increment`"],
    );
    // people-huge.
    let [s, p, o] = leigh(&dir, ok_head, "1e300 1.0");
    refused(
        &[
            "eval",
            "clustering",
            "--method",
            "crf",
            "--scans",
            &s,
            "--people",
            &p,
            "--odometry",
            &o,
            "--k",
            "1",
        ],
        &["people.txt:12:", "`x`", "1e300"],
    );
}

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
    let ds = dir.join("ds");
    let ds = ds.to_str().unwrap();
    assert!(pgm(&["sim", "--pairs", "3", "--out", ds]).2);
    write(Path::new(ds), "notes.txt", "mine");
    assert!(pgm(&["sim", "--pairs", "2", "--seed", "2", "--out", ds]).2);
    assert_eq!(
        std::fs::read_to_string(Path::new(ds).join("notes.txt")).unwrap(),
        "mine"
    );
    // A command that fails writes nothing: the SVG cannot be written, so neither is the
    // data set.
    let fresh = dir.join("fresh");
    refused(
        &[
            "sim",
            "--pairs",
            "2",
            "--out",
            fresh.to_str().unwrap(),
            "--svg",
            dir.join("no/such/dir/x.svg").to_str().unwrap(),
        ],
        &["x.svg"],
    );
    assert!(!fresh.exists());
}

/// The pair names of the data set at `dir`, through `pgm eval` (which reads and checks
/// every pair against the index).
fn seeds_of(dir: &str) -> Vec<String> {
    let (out, err, ok, _) = pgm(&[
        "eval",
        "clustering",
        "--method",
        "one-cluster",
        "--pairs",
        dir,
        "--json",
    ]);
    assert!(ok, "the data set must read back whole: {err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["pairs"], 40);
    let index: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(dir).join("index.json")).unwrap())
            .unwrap();
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
    let ds = dir.join("ds");
    let ds = ds.to_str().unwrap();
    let sim = |seed: &str| {
        Command::new(env!("CARGO_BIN_EXE_pgm"))
            .args(["sim", "--pairs", "40", "--seed", seed, "--out", ds])
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let started = Instant::now();
    assert!(sim("1").wait().unwrap().success());
    let full = started.elapsed();
    for step in 0..12 {
        let seed = if step % 2 == 0 { "2" } else { "3" };
        let before = seeds_of(ds);
        assert_eq!(before.len(), 1, "one seed per data set: {before:?}");
        let mut child = sim(seed);
        std::thread::sleep(full.mul_f64(0.3 + 0.07 * step as f64));
        let _ = child.kill();
        let finished = child.wait().unwrap().success();
        let after = seeds_of(ds);
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
    let names: Vec<String> = std::fs::read_dir(ds)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 41, "{names:?}");
    assert!(names.iter().all(|n| !n.starts_with('.')), "{names:?}");
}

#[test]
fn plot_view_takes_negative_numbers() {
    let dir = temp_dir("plot");
    let ds = dir.join("ds");
    let ds = ds.to_str().unwrap();
    assert!(pgm(&["sim", "--pairs", "1", "--out", ds]).2);
    let svg = dir.join("v.svg");
    let svg = svg.to_str().unwrap();
    for view in [vec!["--view", "-5,5,-3.5,3"], vec!["--view=-5,5,-3.5,3"]] {
        let mut args = vec!["plot", ds, "--svg", svg];
        args.extend(view);
        let (_, err, ok, _) = pgm(&args);
        assert!(ok, "{err}");
        assert!(std::fs::read_to_string(svg).unwrap().contains("<svg"));
    }
    for bad in ["5,-5,-3,3", "-5,5,-3", "nan,1,2,3"] {
        let (_, err, ok, code) = pgm(&["plot", ds, "--svg", svg, "--view", bad]);
        assert!(!ok && code == Some(2), "{bad}: {err}");
        assert!(err.contains("--view"), "{err}");
    }
}

/// `pgm … | head`: the reader closes the pipe early; pgm ends quietly with status 0
/// instead of panicking on the closed stdout (the output, marginals of 20000
/// variables, is far larger than a pipe's buffer).
#[test]
fn a_closed_stdout_ends_quietly() {
    use std::fmt::Write as _;
    use std::io::Read;
    use std::process::Stdio;
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
    let dir = std::env::temp_dir().join(format!("pgm-closed-stdout-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("wide.uai");
    std::fs::write(&model, uai).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_pgm"))
        .args(["marginals", model.to_str().unwrap()])
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
