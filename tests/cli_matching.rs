//! Scan matching from the command line (`pgm match`, `pgm eval matching`): too few
//! correspondences keep the prior and say so in every scan matcher (and in
//! CRF-Clustering's background motion), evaluation counts such a pair as not
//! converged, and the text report does not repeat a subset that holds every pair.

mod common;

use common::logs::sparse_log;
use common::*;

const MATCHERS: [&str; 3] = ["icp", "icp+csm", "crf-matching"];

#[test]
fn l05_too_few_correspondences_keep_the_prior_and_say_so() {
    let dir = temp_dir("l05");
    for returns in [1, 5] {
        let (log, rel) = sparse_log(&dir, returns);
        for method in MATCHERS {
            let (out, err) = ok(&eval(
                "matching",
                method,
                &["--carmen", &log, "--relations", &rel, "--json"],
            ));
            let v = json(&out);
            assert_eq!(v["method"], method, "names as typed");
            assert_eq!(v["not_converged"], 1, "{method}, {returns} returns: {err}");
            // The prior is exact, so keeping it is an error of zero; ICP on one return
            // had ended 0.55 m off, CRF-Matching 0.76 m, icp+csm 0.47 m.
            let error = v["translation_median"].as_f64().unwrap();
            assert!(error < 1e-9, "{method}, {returns} returns: {error} m off");
            assert!(v["rotation_median"].as_f64().unwrap() < 1e-9);
            assert!(
                err.contains("did not converge on 1 of 1 pairs") && err.contains("kept the prior"),
                "{method}: {err}"
            );
        }
        // pgm match says the same in its JSON.
        let m = ok_json(&one_pair("match", "--carmen", &log, "0", "1"));
        assert_eq!(m["converged"], false);
        assert!(
            m["note"].as_str().unwrap().contains("kept the prior"),
            "{m}"
        );
        assert!((m["motion"]["x"].as_f64().unwrap() - 0.25).abs() < 1e-12);
        assert!((m["motion"]["theta"].as_f64().unwrap() - 0.06).abs() < 1e-12);
        // CRF-Clustering's background motion is a registration too (eq. 3 on one
        // association had put it 0.4 m off and called it converged).
        for associations in ["icp", "segment-icp", "crf-matching"] {
            let cluster = one_pair("cluster", "--carmen", &log, "0", "1");
            let (out, err) = ok(&[&cluster[..], &["--associations", associations]].concat());
            let c = json(&out);
            assert_eq!(c["background_choice"], "prior-kept", "{associations}: {c}");
            assert_eq!(c["converged"], false);
            let motion = &c["background_motion"];
            assert!((motion["x"].as_f64().unwrap() - 0.25).abs() < 1e-12);
            assert!((motion["y"].as_f64().unwrap() - 0.08).abs() < 1e-12);
            assert!(err.contains("the background motion is the prior"), "{err}");
        }
    }
    // A rigid fit needs two matched returns: fewer is not an option.
    let (log, rel) = sparse_log(&dir, 1);
    for n in ["0", "1"] {
        refused(
            &eval(
                "matching",
                "icp",
                &[
                    "--carmen",
                    &log,
                    "--relations",
                    &rel,
                    "--icp-min-correspondences",
                    n,
                ],
            ),
            &["--icp-min-correspondences", "at least 2"],
        );
    }
}

/// `pgm eval matching`: a time subset holding every pair (simulated pairs are all
/// less than 1.5 s apart) is named in one line, not printed as a copy of the `all`
/// row; the JSON keeps the subset.
#[test]
fn eval_matching_does_not_repeat_a_subset_that_holds_every_pair() {
    let dir = temp_dir("near-subset");
    let (ds, _) = simulated(&dir, "ds", 9, 3);
    let (text, _) = ok(&eval("matching", "icp", &["--pairs", &ds]));
    assert!(
        text.contains("(every pair is near (< 1.5 s apart))"),
        "{text}"
    );
    assert!(!text.contains("\nnear ("), "{text}");
    let report = ok_json(&eval("matching", "icp", &["--pairs", &ds, "--json"]));
    assert_eq!(report["subsets"]["near"]["pairs"], report["pairs"]);
}
