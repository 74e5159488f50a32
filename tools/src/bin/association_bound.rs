//! How far can association accuracy go on the simulator? Oracles that know more than
//! any method can, each told less than the one before, on the pairs of one seed.
//!
//! Every oracle decides the outliers perfectly (a return whose true association is the
//! outlier state is counted correct) and associates every true inlier with the
//! reference return nearest to it under a motion, on surface points
//! ([`pgm_scan::scan::surface_points`]); they differ in the motion of each true
//! object (the background included):
//!
//! 1. **true motion**: the simulator's;
//! 2. **fit to the true associations**: eq. 6 of the joint paper (closed-form rigid
//!    fit) on the object's returns and their true partners;
//! 3. **ICP on the true object**: point-to-point ICP from the true motion, with only
//!    the object's own returns in both scans (a perfect segmentation and a perfect
//!    start; it settles where the returns of the two scans overlap best).
//!
//! Then the models themselves: CRF-Matching and the joint model with their shipped
//! weights, each also started from better motion hypotheses than segment-wise ICP
//! finds (`Matcher::match_pair_with_hypotheses`, `Joint::estimate_with_hypotheses`;
//! the ego-motion stays the model's own, the segments are the gap segments):
//!
//! - **true motions (its segments)**: the segments the model's hypotheses call
//!   moving start from the true motion of the object most of their returns belong
//!   to (the background's: they follow the ego-motion);
//! - **true motions (all segments)**: every segment whose returns mostly belong to a
//!   moving object starts from its true motion, the others follow the ego-motion.
//!
//! The gap between a model and its rows with true motions is what better motion
//! hypotheses can give it. The second table says why the hypotheses are off: per
//! preset, the segments that segment-wise ICP calls moving and whose returns mostly
//! belong to a moving object, how many start within 0.1 m of the truth (mean
//! displacement of their returns), and how the others are off: mainly along the
//! segment's principal axis (more than twice across: sliding along a straight side,
//! which two scans show only at the segment's ends) or mainly across it (more than
//! twice along); the rest, off both ways alike, are in neither column. Both models'
//! hypotheses come from their segment-wise ICP parameters, which are the same (the
//! example checks).
//!
//! The exact association accuracy is over every return with a true association (as
//! `pgm eval association`).
//!
//! ```text
//! cargo run --release -p pgm-tools --bin association_bound [-- --seed 7 --pairs 30]
//! ```
//! Defaults: seed 3 (the design seed of CRF-Matching and the joint model), 30 pairs per
//! preset, every simulator preset.

use pgm_crf_matching::Matcher;
use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
use pgm_features::shape_features::ScanShape;
use pgm_joint::Joint;
use pgm_scan::alignment::RigidAlignment;
use pgm_scan::association::{segment_motions, SegmentIcp, SegmentMotions};
use pgm_scan::{Association, ParamGuard, Pose2, ScanPair};
use rayon::prelude::*;

/// Point-to-point ICP iterations of oracle 3.
const ICP_ITERATIONS: usize = 30;
/// Correspondences farther apart than this (m) are left out of oracle 3's ICP.
const ICP_DISTANCE: f64 = 0.3;

/// Correct and scored returns.
#[derive(Clone, Copy, Default)]
struct Count {
    correct: usize,
    scored: usize,
}

impl Count {
    fn add(&mut self, other: Count) {
        self.correct += other.correct;
        self.scored += other.scored;
    }

    fn percent(&self) -> f64 {
        100.0 * self.correct as f64 / self.scored.max(1) as f64
    }
}

/// The nearest reference surface point to `q` (its index among the valid returns).
fn nearest(reference: &ScanShape, q: &nalgebra::Point2<f64>) -> usize {
    (0..reference.len())
        .min_by(|&a, &b| {
            (reference.surface[a] - q)
                .norm_squared()
                .total_cmp(&(reference.surface[b] - q).norm_squared())
        })
        .unwrap_or(0)
}

/// A hypothesis is good when it moves a segment's returns within this mean
/// distance (m) of where the true motion moves them.
const GOOD_HYPOTHESIS: f64 = 0.1;

/// Segments that segment-wise ICP calls moving and whose returns mostly belong to a
/// moving object: all, within [`GOOD_HYPOTHESIS`] of the truth, and of the others
/// those off mainly along their principal axis (more than twice across) and mainly
/// across it.
#[derive(Clone, Copy, Default)]
struct Hypotheses {
    moving: usize,
    good: usize,
    along: usize,
    across: usize,
}

impl Hypotheses {
    fn add(&mut self, o: Hypotheses) {
        self.moving += o.moving;
        self.good += o.good;
        self.along += o.along;
        self.across += o.across;
    }
}

/// The object most returns of each segment belong to (`None`: no labelled return).
fn majority(h: &SegmentMotions, beams: &[usize], labels: &[Option<u32>]) -> Vec<Option<u32>> {
    let mut votes: Vec<Vec<(u32, usize)>> = vec![Vec::new(); h.moved.len()];
    for (i, &b) in beams.iter().enumerate() {
        if let Some(l) = labels[b] {
            let v = &mut votes[h.segment_of[i]];
            match v.iter_mut().find(|(x, _)| *x == l) {
                Some((_, n)) => *n += 1,
                None => v.push((l, 1)),
            }
        }
    }
    votes
        .iter()
        .map(|v| v.iter().max_by_key(|(_, n)| *n).map(|(l, _)| *l))
        .collect()
}

/// `h` with the true motion of each segment's object: only for the segments `h`
/// calls moving (`all_segments` false), or for every segment of a moving object.
fn true_hypotheses(
    h: &SegmentMotions,
    beams: &[usize],
    pair: &ScanPair,
    all_segments: bool,
) -> SegmentMotions {
    let truth = pair
        .truth
        .as_ref()
        .expect("simulated pairs carry their truth");
    let labels = truth.labels.as_ref().expect("true labels");
    let object = majority(h, beams, labels);
    let motion_of = |l: u32| {
        truth
            .motions
            .iter()
            .find(|m| m.label == l)
            .map(|m| m.motion)
    };
    let moved: Vec<bool> = (0..h.moved.len())
        .map(|s| {
            (all_segments || h.moved[s])
                && matches!(object[s], Some(l) if l != 0 && motion_of(l).is_some())
        })
        .collect();
    let motions = (0..beams.len())
        .map(|i| {
            let s = h.segment_of[i];
            match object[s] {
                Some(l) if moved[s] => motion_of(l).expect("checked above"),
                _ => h.ego,
            }
        })
        .collect();
    SegmentMotions {
        ego: h.ego,
        motion_of: motions,
        segment_of: h.segment_of.clone(),
        moved,
    }
}

/// How segment-wise ICP's hypotheses of moving segments compare with the truth.
fn hypothesis_errors(h: &SegmentMotions, shape: &ScanShape, pair: &ScanPair) -> Hypotheses {
    let truth = pair
        .truth
        .as_ref()
        .expect("simulated pairs carry their truth");
    let labels = truth.labels.as_ref().expect("true labels");
    let object = majority(h, &shape.beams, labels);
    let mut count = Hypotheses::default();
    for (s, object) in object.iter().enumerate() {
        let Some(l) = object.filter(|&l| l != 0 && h.moved[s]) else {
            continue;
        };
        let Some(t) = truth
            .motions
            .iter()
            .find(|m| m.label == l)
            .map(|m| m.motion)
        else {
            continue;
        };
        let members: Vec<usize> = (0..shape.len()).filter(|&i| h.segment_of[i] == s).collect();
        let Some(&first) = members.first() else {
            continue;
        };
        let hypothesis = h.motion_of[first];
        count.moving += 1;
        let points: Vec<_> = members.iter().map(|&i| shape.points[i]).collect();
        let off = points
            .iter()
            .map(|p| (hypothesis.transform_point(p) - t.transform_point(p)).norm())
            .sum::<f64>()
            / points.len() as f64;
        if off < GOOD_HYPOTHESIS {
            count.good += 1;
            continue;
        }
        // The principal axis of the segment, moved by the true motion.
        let n = points.len() as f64;
        let mean = points
            .iter()
            .fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords)
            / n;
        let mut scatter = nalgebra::Matrix2::zeros();
        for p in &points {
            let d = p.coords - mean;
            scatter += d * d.transpose();
        }
        let e = scatter.symmetric_eigen();
        let major = if e.eigenvalues[0] >= e.eigenvalues[1] {
            0
        } else {
            1
        };
        let axis = t.isometry().rotation * e.eigenvectors.column(major).into_owned();
        let centre = nalgebra::Point2::from(mean);
        let delta = hypothesis.transform_point(&centre) - t.transform_point(&centre);
        let along = axis.dot(&delta).abs();
        let across = (delta - axis * axis.dot(&delta)).norm();
        if along > 2.0 * across {
            count.along += 1;
        } else if across > 2.0 * along {
            count.across += 1;
        }
    }
    count
}

/// The three oracles' counts, the two models' and theirs from true motions
/// (CRF-Matching, its segments, all segments; the joint model, the same) on one pair;
/// and how the hypotheses compare with the truth.
fn score_pair(
    pair: &ScanPair,
    joint: &Joint,
    matcher: &Matcher,
    segments: &SegmentIcp,
) -> ([Count; 9], Hypotheses) {
    let truth = pair
        .truth
        .as_ref()
        .expect("simulated pairs carry their truth");
    let associations = truth.associations.as_ref().expect("true associations");
    let labels = truth.labels.as_ref().expect("true labels");
    let reference_labels = truth.reference_labels.as_ref().expect("reference labels");
    let current = ScanShape::new(&pair.current);
    let reference = ScanShape::new(&pair.reference);
    let mut reference_index = vec![None; pair.reference.len()];
    for (j, &b) in reference.beams.iter().enumerate() {
        reference_index[b] = Some(j);
    }
    // The three oracle motions of every true object.
    let mut motions: Vec<(u32, [Pose2; 3])> = Vec::new();
    for object in &truth.motions {
        let own = |i: usize| labels[current.beams[i]] == Some(object.label);
        let mut fit = RigidAlignment::new();
        for i in (0..current.len()).filter(|&i| own(i)) {
            if let Some(Association::Point(b)) = associations[current.beams[i]] {
                if let Some(j) = reference_index[b] {
                    fit.add(&current.surface[i], &reference.surface[j], 1.0);
                }
            }
        }
        let fitted = fit.solve().map_or(object.motion, |a| a.motion);
        let sources: Vec<_> = (0..current.len())
            .filter(|&i| own(i))
            .map(|i| current.surface[i])
            .collect();
        let targets: Vec<_> = (0..reference.len())
            .filter(|&j| reference_labels[reference.beams[j]] == Some(object.label))
            .map(|j| reference.surface[j])
            .collect();
        let mut icp = object.motion;
        if !targets.is_empty() && sources.len() >= 3 {
            for _ in 0..ICP_ITERATIONS {
                let mut step = RigidAlignment::new();
                for s in &sources {
                    let q = icp.transform_point(s);
                    let g = targets
                        .iter()
                        .min_by(|a, b| (*a - q).norm().total_cmp(&(*b - q).norm()))
                        .expect("targets is not empty");
                    if (g - q).norm() < ICP_DISTANCE {
                        step.add(s, g, 1.0);
                    }
                }
                match step.solve() {
                    Some(a) => icp = a.motion,
                    None => break,
                }
            }
        }
        motions.push((object.label, [object.motion, fitted, icp]));
    }
    let mut counts = [Count::default(); 9];
    for (i, &b) in current.beams.iter().enumerate() {
        let (Some(truth_i), Some(label)) = (associations[b], labels[b]) else {
            continue;
        };
        let oracle = motions.iter().find(|(l, _)| *l == label).map(|(_, m)| m);
        for (k, count) in counts.iter_mut().enumerate().take(3) {
            count.scored += 1;
            let correct = match (truth_i, oracle) {
                (Association::Outlier, _) => true,
                (Association::Point(t), Some(m)) => {
                    let q = m[k].transform_point(&current.surface[i]);
                    reference.beams[nearest(&reference, &q)] == t
                }
                (Association::Point(_), None) => false,
            };
            count.correct += usize::from(correct);
        }
    }
    let runs = "the models run on simulated pairs";
    let hypotheses = segment_motions(pair, segments).expect(runs);
    let own = true_hypotheses(&hypotheses, &current.beams, pair, false);
    let all = true_hypotheses(&hypotheses, &current.beams, pair, true);
    // The models as shipped, from the hypotheses they would find themselves (made
    // once here: `estimate` and `match_pair` would each make them again).
    let by_joint = |h: &SegmentMotions| {
        joint
            .estimate_with_hypotheses(pair, h)
            .expect(runs)
            .associations
    };
    let by_matcher = |h: &SegmentMotions| {
        matcher
            .match_pair_with_hypotheses(pair, h)
            .expect(runs)
            .associations
    };
    let predicted = [
        by_joint(&hypotheses),
        by_matcher(&hypotheses),
        by_matcher(&own),
        by_matcher(&all),
        by_joint(&own),
        by_joint(&all),
    ];
    for (k, predicted) in predicted.iter().enumerate() {
        for (t, p) in associations.iter().zip(predicted) {
            if let Some(t) = t {
                counts[3 + k].scored += 1;
                counts[3 + k].correct += usize::from(p.as_ref() == Some(t));
            }
        }
    }
    (counts, hypothesis_errors(&hypotheses, &current, pair))
}

/// One row of the accuracy table.
fn row(name: &str, c: &[Count; 9]) -> String {
    let p: Vec<f64> = c.iter().map(Count::percent).collect();
    format!(
        "{:<14} {:>7.1} {:>7.1} {:>7.1} | {:>7.1} {:>7.1} {:>7.1} | {:>7.1} {:>7.1} {:>7.1}",
        name, p[0], p[1], p[2], p[4], p[5], p[6], p[3], p[7], p[8]
    )
}

fn main() {
    let mut seed = 3u64;
    let mut pairs = 30usize;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let value = args.next();
        let parsed = value.as_deref().and_then(|v| v.parse::<u64>().ok());
        match (arg.as_str(), parsed) {
            ("--seed", Some(v)) => seed = v,
            ("--pairs", Some(v)) if v > 0 => pairs = v as usize,
            _ => {
                eprintln!(
                    "association_bound: unknown argument or bad value `{arg} {}` (use --seed S --pairs N)",
                    value.unwrap_or_default()
                );
                std::process::exit(2);
            }
        }
    }
    let joint = Joint::default();
    let matcher = Matcher::default();
    // Both models make their hypotheses with these parameters.
    assert_eq!(
        joint.params().segments,
        matcher.params().segments,
        "the models' segment-wise ICP parameters"
    );
    let segments = matcher
        .params()
        .segments
        .check()
        .expect("the default segment parameters are valid");
    println!(
        "Association accuracy (exact, %), simulated pairs: {pairs} per preset, seed {seed}; oracles decide every outlier perfectly"
    );
    println!(
        "{:<14} {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7}",
        "", "oracles", "", "", "CRF-M", "", "", "joint", "", ""
    );
    println!(
        "{:<14} {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7}",
        "preset",
        "true",
        "fit",
        "ICP obj",
        "as is",
        "true M1",
        "true M2",
        "as is",
        "true M1",
        "true M2"
    );
    let mut all = [Count::default(); 9];
    let mut table = Vec::new();
    // The urban presets (person-following brings a laser of its own).
    for preset in Preset::URBAN {
        let config = SimConfig {
            preset,
            ..SimConfig::default()
        }
        .check()
        .expect("the default configuration is valid");
        let simulated = simulate_pairs(&config, seed, pairs);
        let (counts, hypotheses) = simulated
            .par_iter()
            .map(|p| score_pair(p, &joint, &matcher, &segments))
            .reduce(
                || ([Count::default(); 9], Hypotheses::default()),
                |(mut a, mut h), (b, g)| {
                    for (x, y) in a.iter_mut().zip(b) {
                        x.add(y);
                    }
                    h.add(g);
                    (a, h)
                },
            );
        for (x, y) in all.iter_mut().zip(counts) {
            x.add(y);
        }
        println!("{}", row(preset.name(), &counts));
        table.push((preset.name(), hypotheses));
    }
    println!("{}", row("all", &all));
    println!(
        "true: true motion; fit: fit to the true associations; ICP obj: ICP on the true object; \
         true M1: the model started from the true motions of the segments its hypotheses call \
         moving; true M2: of every segment of a moving object"
    );
    println!();
    println!(
        "Moving segments' hypotheses (segment-wise ICP) against the truth, {GOOD_HYPOTHESIS} m:"
    );
    println!(
        "{:<14} {:>8} {:>8} {:>14} {:>14}",
        "preset", "segments", "good %", "off, along %", "off, across %"
    );
    println!(
        "(along and across: shares of the segments off by {GOOD_HYPOTHESIS} m or more, off more \
         than twice as far that way as the other; the rest are in neither)"
    );
    let mut total = Hypotheses::default();
    for (name, h) in table {
        total.add(h);
        print_hypotheses(name, &h);
    }
    print_hypotheses("all", &total);
}

/// One row of the hypothesis table (shares of the bad ones for along and across).
fn print_hypotheses(name: &str, h: &Hypotheses) {
    let bad = (h.moving - h.good).max(1) as f64;
    println!(
        "{:<14} {:>8} {:>8.1} {:>14.1} {:>14.1}",
        name,
        h.moving,
        100.0 * h.good as f64 / h.moving.max(1) as f64,
        100.0 * h.along as f64 / bad,
        100.0 * h.across as f64 / bad
    );
}
