//! The simulator's ground truth is right: true motions put current points onto their
//! associated reference points, hidden or unseen surfaces are outliers, labels and
//! motions are consistent, and everything is a function of the seed.

use nalgebra::Point2;
use pgm_datasets::sim::{
    association_tolerance, pair_rng, simulate_pair, simulate_pairs, simulate_scene, MovingObject,
    Preset, Primitive, Scene, SimConfig, SimError, Trajectory, ValidSimConfig,
};
use pgm_datasets::ParamGuard;
use pgm_datasets::{Association, ScanPair};
use pgm_scan::Pose2;
use std::collections::BTreeSet;

/// The preset's default configuration, its own laser included (person-following's
/// 245 beams over 86°; the urban presets' 361 over 180°).
fn config(preset: Preset) -> ValidSimConfig {
    SimConfig::for_preset(preset).check().unwrap()
}

fn noise_free(preset: Preset) -> ValidSimConfig {
    SimConfig {
        range_noise: 0.0,
        dropout: 0.0,
        ..SimConfig::for_preset(preset)
    }
    .check()
    .unwrap()
}

/// Angle between neighbouring beams of `config`'s laser.
fn spacing_of(config: &ValidSimConfig) -> f64 {
    let c = config.params();
    c.field_of_view / (c.beams - 1) as f64
}

fn motion_of(pair: &ScanPair, label: u32) -> Pose2 {
    let truth = pair.truth.as_ref().unwrap();
    truth
        .motions
        .iter()
        .find(|m| m.label == label)
        .unwrap_or_else(|| panic!("{}: no motion for label {label}", pair.name))
        .motion
}

/// (current beam, reference beam, label, distance between `m_label · s_i` and `g_j`,
/// range of `m_label · s_i` from the reference sensor).
fn associated_distances(pair: &ScanPair) -> Vec<(usize, usize, u32, f64, f64)> {
    let truth = pair.truth.as_ref().unwrap();
    let labels = truth.labels.as_ref().unwrap();
    let associations = truth.associations.as_ref().unwrap();
    let mut out = Vec::new();
    for (i, a) in associations.iter().enumerate() {
        if let Some(Association::Point(j)) = a {
            let label = labels[i].unwrap();
            let moved = motion_of(pair, label).transform_point(&pair.current.beam_point(i));
            let d = (moved - pair.reference.beam_point(*j)).norm();
            out.push((i, *j, label, d, moved.coords.norm()));
        }
    }
    out
}

#[test]
fn every_preset_gives_valid_consistent_pairs() {
    for preset in Preset::ALL {
        let c = config(preset);
        let (beams, half_view) = (c.params().beams, c.params().field_of_view / 2.0);
        assert_eq!(
            beams,
            if preset == Preset::PersonFollowing {
                245
            } else {
                361
            }
        );
        for pair in simulate_pairs(&c, 11, 15) {
            pair.validate()
                .unwrap_or_else(|v| panic!("{}: {v}", pair.name));
            assert_eq!(pair.current.len(), beams);
            assert!((pair.current.angles[0] + half_view).abs() < 1e-12);
            assert!((pair.current.angles[beams - 1] - half_view).abs() < 1e-12);
            assert!(pair.time_gap() > 0.0);
            let truth = pair.truth.as_ref().unwrap();
            let labels = truth.labels.as_ref().unwrap();
            let reference_labels = truth.reference_labels.as_ref().unwrap();
            for (k, l) in labels.iter().enumerate() {
                assert_eq!(l.is_some(), pair.current.valid[k], "{} beam {k}", pair.name);
            }
            for (k, l) in reference_labels.iter().enumerate() {
                assert_eq!(
                    l.is_some(),
                    pair.reference.valid[k],
                    "{} beam {k}",
                    pair.name
                );
            }
            // Labels are 0..=K without gaps, and exactly those have motions.
            let used: BTreeSet<u32> = labels
                .iter()
                .chain(reference_labels)
                .flatten()
                .copied()
                .collect();
            let expected: BTreeSet<u32> = (0..used.len() as u32).collect();
            assert_eq!(used, expected, "{}", pair.name);
            let with_motion: BTreeSet<u32> = truth.motions.iter().map(|m| m.label).collect();
            assert_eq!(used, with_motion, "{}", pair.name);
            assert_eq!(truth.motions[0].label, 0);
            assert_eq!(truth.motions[0].kind, "background");
            for m in &truth.motions[1..] {
                assert!(m.kind == "car" || m.kind == "pedestrian", "{}", m.kind);
            }
            // The background's motion is the ego-motion; the pair is 2-4 m apart (a
            // following robot's at most 0.8 s at 1 m/s).
            let ego = truth.ego_motion.unwrap();
            assert_eq!(truth.motions[0].motion, ego);
            let travel = ego.translation().norm();
            let apart = if preset == Preset::PersonFollowing {
                0.0..=0.8
            } else {
                2.0..=4.0
            };
            assert!(apart.contains(&travel), "{}: {travel}", pair.name);
            // Associated points carry the same label in both scans.
            for (i, j, label, _, _) in associated_distances(&pair) {
                assert_eq!(
                    reference_labels[j],
                    Some(label),
                    "{}: {i} -> {j}",
                    pair.name
                );
            }
        }
    }
}

#[test]
fn true_motions_put_points_on_their_partners_within_noise() {
    for preset in Preset::ALL {
        let spacing = spacing_of(&config(preset));
        // Noise-free: the distance is only the sampling offset, at most one beam
        // spacing on the surface (the documented tolerance), and typically half of it.
        let mut ratios = Vec::new();
        for pair in simulate_pairs(&noise_free(preset), 5, 10) {
            for (i, j, _, d, r) in associated_distances(&pair) {
                let worst = association_tolerance(r, 0.0, spacing);
                assert!(
                    d <= worst + 1e-9,
                    "{}: {i} -> {j}: {d} m > {worst} m",
                    pair.name
                );
                ratios.push(d / (r * spacing));
            }
        }
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        assert!(
            median <= 0.6,
            "{preset}: median offset {median} beam spacings"
        );

        // With 3 cm range noise on both points, add at most 5 standard deviations each.
        for pair in simulate_pairs(&config(preset), 5, 10) {
            for (i, j, _, d, r) in associated_distances(&pair) {
                // The moved noisy point's range is within 5 σ of the true one.
                let bound = association_tolerance(r + 5.0 * 0.03, 0.0, spacing) + 2.0 * 5.0 * 0.03;
                assert!(d <= bound, "{}: {i} -> {j}: {d} m > {bound} m", pair.name);
            }
        }
    }
}

#[test]
fn associations_on_a_wall_ahead_are_the_nearest_beam() {
    // Ego drives 3 m straight towards a wall 20 m ahead: a point seen at bearing a
    // from 17 m lies at bearing atan(17 tan a / 20) from 20 m, and the nearest beam
    // there is the association.
    let wall = Primitive::segment(Point2::new(20.0, -30.0), Point2::new(20.0, 30.0));
    let pair = simulate_noise_free(&driving_3m_ahead(vec![wall], vec![]), "wall");
    let truth = pair.truth.as_ref().unwrap();
    let associations = truth.associations.as_ref().unwrap();
    let step = std::f64::consts::PI / 360.0;
    let mut checked = 0;
    for (i, a) in associations.iter().enumerate() {
        let Some(a) = a else { continue };
        let y = pair.current.beam_point(i).y;
        let bearing = y.atan2(20.0);
        let nearest = ((bearing + std::f64::consts::FRAC_PI_2) / step).round() as usize;
        assert_eq!(*a, Association::Point(nearest), "beam {i}");
        checked += 1;
    }
    assert!(checked > 100, "only {checked} wall points");
}

/// A wall 15 m ahead, a car crossing at x = 9 (centre y = 0 at the reference scan,
/// y = 3 at the current scan), ego driving 3 m forward.
fn crossing_scene() -> Scene {
    driving_3m_ahead(
        vec![Primitive::segment(
            Point2::new(15.0, -40.0),
            Point2::new(15.0, 40.0),
        )],
        vec![MovingObject::car(
            4.5,
            1.8,
            Trajectory {
                start: Pose2::new(9.0, 0.0, std::f64::consts::FRAC_PI_2),
                speed: 10.0,
                yaw_rate: 0.0,
                lateral_speed: 0.0,
            },
        )],
    )
}

/// A scene of `background` and `objects` in which the ego vehicle drives 3 m straight
/// ahead from the origin (10 m/s for 0.3 s).
fn driving_3m_ahead(background: Vec<Primitive>, objects: Vec<MovingObject>) -> Scene {
    Scene {
        background,
        objects,
        ego: Trajectory {
            start: Pose2::identity(),
            speed: 10.0,
            yaw_rate: 0.0,
            lateral_speed: 0.0,
        },
        interval: 0.3,
    }
}

/// The pair of `scene` without range noise or dropout (preset `mixed`'s laser, seed 0).
fn simulate_noise_free(scene: &Scene, name: &str) -> ScanPair {
    let c = noise_free(Preset::Mixed);
    simulate_scene(scene, &c, &mut pair_rng(0, 0), name.into())
}

#[test]
fn surfaces_hidden_at_the_reference_time_are_outliers() {
    let pair = simulate_noise_free(&crossing_scene(), "crossing");
    let truth = pair.truth.as_ref().unwrap();
    let labels = truth.labels.as_ref().unwrap();
    let associations = truth.associations.as_ref().unwrap();
    let sensor = Pose2::new(3.0, 0.0, 0.0);
    let (mut hidden, mut open, mut car_associated, mut car_points) = (0, 0, 0, 0);
    for i in 0..pair.current.len() {
        let Some(label) = labels[i] else { continue };
        let world = sensor.transform_point(&pair.current.beam_point(i));
        if label == 0 {
            // Wall points behind the car's reference-time position (the ray from the
            // origin to (15, y) crosses x = 9 at 0.6 y, inside |y| < 2.25 for
            // |y| < 3.75) are hidden in the reference scan.
            if (-2.0..=0.5).contains(&world.y) {
                assert_eq!(
                    associations[i],
                    Some(Association::Outlier),
                    "wall y = {}",
                    world.y
                );
                hidden += 1;
            } else if world.y < -5.0 && world.y > -30.0 {
                assert!(
                    matches!(associations[i], Some(Association::Point(_))),
                    "open wall y = {} is {:?}",
                    world.y,
                    associations[i]
                );
                open += 1;
            }
        } else {
            assert_eq!(label, 1);
            car_points += 1;
            if matches!(associations[i], Some(Association::Point(_))) {
                car_associated += 1;
            }
        }
    }
    assert!(hidden >= 10, "{hidden} hidden wall points");
    assert!(open >= 20, "{open} open wall points");
    // The car's near side was seen at both times (it moved 3 m along itself).
    assert!(car_points >= 10, "{car_points} car points");
    assert!(
        car_associated * 2 >= car_points,
        "{car_associated} of {car_points}"
    );
    // Its motion is exactly its own displacement seen from the two sensor poses.
    let m = truth.motions.iter().find(|m| m.label == 1).unwrap();
    assert_eq!(m.kind, "car");
    assert!(
        m.motion.translation_error(&Pose2::new(3.0, -3.0, 0.0)) < 1e-9,
        "{:?}",
        m.motion
    );
}

#[test]
fn surfaces_outside_the_reference_view_are_outliers() {
    // A car overtaking from behind: at the reference time it is entirely behind the
    // sensor (x < 0, outside the 180° field of view), at the current time beside it.
    let scene = driving_3m_ahead(
        vec![Primitive::segment(
            Point2::new(-40.0, -6.0),
            Point2::new(60.0, -6.0),
        )],
        vec![MovingObject::car(
            4.5,
            1.8,
            Trajectory {
                start: Pose2::new(-3.0, 3.3, 0.0),
                speed: 20.0,
                yaw_rate: 0.0,
                lateral_speed: 0.0,
            },
        )],
    );
    let pair = simulate_noise_free(&scene, "behind");
    let truth = pair.truth.as_ref().unwrap();
    let labels = truth.labels.as_ref().unwrap();
    let associations = truth.associations.as_ref().unwrap();
    let car: Vec<usize> = (0..labels.len())
        .filter(|&i| labels[i] == Some(1))
        .collect();
    assert!(car.len() >= 5, "car seen by {} beams", car.len());
    for &i in &car {
        assert_eq!(associations[i], Some(Association::Outlier), "car beam {i}");
    }
    // The reference scan never saw the car, but its label and motion exist.
    let reference_labels = truth.reference_labels.as_ref().unwrap();
    assert!(reference_labels.iter().all(|l| *l != Some(1)));
    assert!(truth.motions.iter().any(|m| m.label == 1));
}

#[test]
fn same_seed_same_bytes_and_pairs_do_not_depend_on_the_count() {
    let c = config(Preset::Mixed);
    let a = serde_json::to_string(&simulate_pairs(&c, 42, 6)).unwrap();
    let b = serde_json::to_string(&simulate_pairs(&c, 42, 6)).unwrap();
    assert_eq!(a, b);
    let other = serde_json::to_string(&simulate_pairs(&c, 43, 6)).unwrap();
    assert_ne!(a, other);
    let short = simulate_pairs(&c, 42, 3);
    let long = simulate_pairs(&c, 42, 6);
    assert_eq!(short[..], long[..3]);
    assert_eq!(simulate_pair(&c, 42, 4), long[4]);
    assert_eq!(long[4].name, "sim:mixed:42:4");
}

#[test]
fn odometry_is_the_true_motion_plus_distance_scaled_noise() {
    let exact = SimConfig {
        odometry_translation_noise: 0.0,
        odometry_rotation_noise: 0.0,
        ..SimConfig::default()
    }
    .check()
    .unwrap();
    for pair in simulate_pairs(&exact, 2, 5) {
        let ego = pair.truth.as_ref().unwrap().ego_motion.unwrap();
        let odometry = pair.odometry.unwrap();
        assert!(odometry.translation_error(&ego) < 1e-12);
        assert!(odometry.rotation_error(&ego) < 1e-12);
    }
    let noisy = config(Preset::Mixed);
    let pairs = simulate_pairs(&noisy, 2, 200);
    let mut errors = Vec::new();
    for pair in &pairs {
        let ego = pair.truth.as_ref().unwrap().ego_motion.unwrap();
        let odometry = pair.odometry.unwrap();
        let d = ego.translation().norm();
        let e = (odometry.x() - ego.x()) / (0.02 * d);
        errors.push(e);
        // Scan odometry agrees with the pair's prior.
        let between = pair
            .reference
            .odometry
            .unwrap()
            .between(&pair.current.odometry.unwrap());
        assert!(between.translation_error(&odometry) < 1e-9);
    }
    // Normalised x errors are standard normal: sample deviation near 1.
    let sd = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    assert!(
        (0.8..1.2).contains(&sd),
        "normalised odometry error deviation {sd}"
    );
}

#[test]
fn noise_and_dropout_follow_the_configuration() {
    // No pair selection: it depends on dropouts, so it could redraw one scene and not
    // the other.
    let c = SimConfig {
        dropout: 0.2,
        min_object_returns: 0,
        ..SimConfig::default()
    }
    .check()
    .unwrap();
    let clean = SimConfig {
        min_object_returns: 0,
        ..noise_free(Preset::Mixed).params().clone()
    }
    .check()
    .unwrap();
    let noisy_pairs = simulate_pairs(&c, 9, 10);
    let clean_pairs = simulate_pairs(&clean, 9, 10);
    let (mut dropped, mut hits) = (0usize, 0usize);
    for (noisy, clean) in noisy_pairs.iter().zip(&clean_pairs) {
        // Same scene for the same seed: the laser parameters draw after the scene.
        assert_eq!(
            noisy.truth.as_ref().unwrap().ego_motion,
            clean.truth.as_ref().unwrap().ego_motion
        );
        for k in 0..clean.current.len() {
            if clean.current.valid[k] {
                hits += 1;
                if !noisy.current.valid[k] {
                    dropped += 1;
                }
            }
        }
    }
    let rate = dropped as f64 / hits as f64;
    assert!((0.17..0.23).contains(&rate), "dropout rate {rate}");
}

#[test]
fn configuration_errors_name_the_offending_value() {
    let bad = |c: SimConfig| c.check().unwrap_err();
    let e = bad(SimConfig {
        beams: 1,
        ..SimConfig::default()
    });
    assert!(
        matches!(&e, SimError::InvalidParameter { name: "beams", value, .. } if value == "1"),
        "{e}"
    );
    let e = bad(SimConfig {
        dropout: 1.5,
        ..SimConfig::default()
    });
    assert!(
        e.to_string().contains("dropout") && e.to_string().contains("1.5"),
        "{e}"
    );
    let e = bad(SimConfig {
        pair_distance: [4.0, 2.0],
        ..SimConfig::default()
    });
    assert!(
        e.to_string().contains("pair_distance") && e.to_string().contains("[4.0, 2.0]"),
        "{e}"
    );
    let e = bad(SimConfig {
        range_noise: f64::NAN,
        ..SimConfig::default()
    });
    assert!(
        e.to_string().contains("range_noise") && e.to_string().contains("NaN"),
        "{e}"
    );
    let e = bad(SimConfig {
        ego_speed: [0.0, 10.0],
        ..SimConfig::default()
    });
    assert!(e.to_string().contains("ego_speed"), "{e}");
    // 181 beams is a valid sensor too.
    let c = SimConfig {
        beams: 181,
        ..SimConfig::default()
    }
    .check()
    .unwrap();
    let pair = simulate_pair(&c, 1, 0);
    assert_eq!(pair.reference.len(), 181);
    pair.validate().unwrap();
}

/// The label of each tracking-truth object of `pair` (the label of the labelled current
/// return nearest its centre), after checking the truth is consistent with the labels:
/// unique ids, one object for every label with a current return, `returns` the count of
/// that label's returns, and every return within a leg pair (pedestrian) or a box
/// (car) of the centre.
fn object_labels(pair: &ScanPair) -> Vec<u32> {
    let truth = pair.truth.as_ref().unwrap();
    let labels = truth.labels.as_ref().unwrap();
    let objects = truth
        .objects
        .as_ref()
        .unwrap_or_else(|| panic!("{}: no tracking truth", pair.name));
    let mut counts = std::collections::BTreeMap::<u32, usize>::new();
    for l in labels.iter().flatten().filter(|&&l| l > 0) {
        *counts.entry(*l).or_default() += 1;
    }
    let ids: BTreeSet<u64> = objects.iter().map(|o| o.id).collect();
    assert_eq!(ids.len(), objects.len(), "{}: repeated ids", pair.name);
    assert!(objects.iter().all(|o| o.id >= 1), "{}", pair.name);
    let mut found = Vec::new();
    for o in objects {
        let centre = Point2::new(o.x, o.y);
        let nearest = (0..labels.len())
            .filter(|&k| labels[k].is_some_and(|l| l > 0))
            .min_by(|&a, &b| {
                let da = (pair.current.beam_point(a) - centre).norm();
                let db = (pair.current.beam_point(b) - centre).norm();
                da.total_cmp(&db)
            })
            .unwrap_or_else(|| panic!("{}: object {} without returns", pair.name, o.id));
        let label = labels[nearest].unwrap();
        assert_eq!(
            o.returns,
            Some(counts[&label]),
            "{}: object {} and label {label}",
            pair.name,
            o.id
        );
        let kind = &truth
            .motions
            .iter()
            .find(|m| m.label == label)
            .unwrap()
            .kind;
        // Legs: half a stride (≤ 0.175 m) and 0.09 m apart sideways, radius ≤ 0.08 m;
        // a car's half diagonal ≤ 2.64 m; and five standard deviations of noise.
        let reach = if kind == "pedestrian" { 0.45 } else { 2.8 };
        for k in (0..labels.len()).filter(|&k| labels[k] == Some(label)) {
            let d = (pair.current.beam_point(k) - centre).norm();
            assert!(
                d <= reach,
                "{}: {kind} {}'s return {k} {d} m from its centre",
                pair.name,
                o.id
            );
        }
        found.push(label);
    }
    let distinct: BTreeSet<u32> = found.iter().copied().collect();
    assert_eq!(distinct.len(), found.len(), "{}: {found:?}", pair.name);
    assert_eq!(
        distinct,
        counts.keys().copied().collect::<BTreeSet<u32>>(),
        "{}: every object seen in the current scan is in the tracking truth",
        pair.name
    );
    found
}

#[test]
fn tracking_truth_lists_every_object_seen_with_its_centre_and_returns() {
    for preset in Preset::ALL {
        let c = config(preset);
        let mut objects = 0;
        for pair in simulate_pairs(&c, 12, 12) {
            objects += object_labels(&pair).len();
            pair.validate()
                .unwrap_or_else(|v| panic!("{}: {v}", pair.name));
        }
        assert!(objects >= 12, "{preset}: {objects} objects");
    }
    // The urban presets' objects all move (the slowest, a person keeping pace with a
    // robot, at 0.76 m/s).
    for preset in [Preset::Mixed, Preset::Following, Preset::Pedestrians] {
        for pair in simulate_pairs(&config(preset), 13, 10) {
            let truth = pair.truth.unwrap();
            assert!(truth
                .objects
                .unwrap()
                .iter()
                .all(|o| o.moving == Some(true)));
        }
    }
}

#[test]
fn tracking_ids_follow_one_body_along_a_sequence() {
    use pgm_datasets::sim::simulate_sequence;
    // Pair a's current scan is pair a + 1's reference scan; an object's centre is a
    // point of its body, so the true motion of its label in pair a + 1 puts its centre
    // there onto its centre in pair a.
    for preset in [
        Preset::Overtaking,
        Preset::Pedestrians,
        Preset::Mixed,
        Preset::Following,
    ] {
        let pairs = simulate_sequence(&config(preset), 21, 0, 16, 1);
        let mut followed = 0;
        for w in pairs.windows(2) {
            let before = w[0].truth.as_ref().unwrap().objects.clone().unwrap();
            let labels = object_labels(&w[1]);
            let truth = w[1].truth.as_ref().unwrap();
            for (o, label) in truth.objects.as_ref().unwrap().iter().zip(labels) {
                let Some(p) = before.iter().find(|p| p.id == o.id) else {
                    continue;
                };
                let moved = motion_of(&w[1], label).transform_point(&Point2::new(o.x, o.y));
                let d = (moved - Point2::new(p.x, p.y)).norm();
                assert!(d < 1e-6, "{}: object {} off by {d} m", w[1].name, o.id);
                followed += 1;
            }
        }
        assert!(followed >= 10, "{preset}: {followed} objects followed");
    }
}
