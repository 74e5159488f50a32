//! The `person-following` preset: its own laser (10 Hz, 245 beams over 86°, 5.6 m),
//! no odometry, a followed person (tracking id 1) 1-1.5 m ahead who stops, turns and
//! walks on, pedestrians passing by, and a sparse background that is still seen.

use nalgebra::Point2;
use pgm_datasets::sim::{
    objects_observable, pair_rng, simulate_pair, simulate_pairs_report, simulate_sequence,
    ObjectKind, Preset, Primitive, SimConfig, ValidSimConfig,
};
use pgm_datasets::{ParamGuard, ScanPair};
use pgm_scan::Pose2;

const PRESET: Preset = Preset::PersonFollowing;

fn config() -> ValidSimConfig {
    SimConfig::for_preset(PRESET).check().unwrap()
}

/// Sequences `0..count` of `seed`, each of 200 scans in pairs of consecutive scans.
fn walks(seed: u64, count: u64) -> impl Iterator<Item = Vec<ScanPair>> {
    let c = config();
    (0..count).map(move |index| simulate_sequence(&c, seed, index, 200, 1))
}

#[test]
fn the_preset_is_named_and_brings_its_own_laser() {
    assert_eq!(PRESET.name(), "person-following");
    assert_eq!("person-following".parse::<Preset>().unwrap(), PRESET);
    assert!(Preset::ALL.contains(&PRESET) && !Preset::URBAN.contains(&PRESET));
    let laser = PRESET.default_laser().expect("a laser of its own");
    assert_eq!(laser.beams, 245);
    assert!((laser.field_of_view.to_degrees() - 86.0).abs() < 1e-9);
    assert_eq!(laser.max_range, 5.6);
    assert!(!PRESET.wheel_odometry());
    assert_eq!(PRESET.scan_period(), Some(0.1));
    let c = SimConfig::for_preset(PRESET);
    assert_eq!(
        (c.beams, c.field_of_view, c.max_range),
        (laser.beams, laser.field_of_view, laser.max_range)
    );
    // The urban presets keep the default laser, odometry and timing exactly.
    for p in Preset::URBAN {
        assert_eq!(p.default_laser(), None);
        assert!(p.wheel_odometry());
        assert_eq!(p.scan_period(), None);
        assert_eq!(
            SimConfig::for_preset(p),
            SimConfig {
                preset: p,
                ..SimConfig::default()
            }
        );
    }
}

/// Checks the scans of `pair` against the preset's laser and the absence of odometry.
fn check_laser_and_no_odometry(pair: &ScanPair) {
    pair.validate()
        .unwrap_or_else(|v| panic!("{}: {v}", pair.name));
    assert_eq!(pair.odometry, None, "{}", pair.name);
    let half_view = 43f64.to_radians();
    for scan in [&pair.reference, &pair.current] {
        assert_eq!(scan.odometry, None, "{}", pair.name);
        assert_eq!(scan.len(), 245, "{}", pair.name);
        assert!((scan.angles[0] + half_view).abs() < 1e-9);
        assert!((scan.angles[244] - half_view).abs() < 1e-9);
        assert_eq!(scan.max_range, 5.6);
        for (r, v) in scan.ranges.iter().zip(&scan.valid) {
            assert!(!v || *r < 5.6, "{}: a return at {r} m", pair.name);
        }
    }
    // The data format has no odometry to write either.
    let json = serde_json::to_string(pair).unwrap();
    assert!(!json.contains("odometry"), "{}", pair.name);
}

#[test]
fn sequences_are_scanned_at_10_hz_without_odometry() {
    let c = config();
    for k in [1, 3] {
        let pairs = simulate_sequence(&c, 4, 1, 40, k);
        assert_eq!(pairs.len(), 40 - k);
        for (a, p) in pairs.iter().enumerate() {
            check_laser_and_no_odometry(p);
            assert_eq!(p.name, format!("sim:person-following:4:1:{a}-{}", a + k));
            let t0 = 1000.0 + a as f64 * 0.1;
            assert!((p.reference.timestamp - t0).abs() < 1e-9, "{}", p.name);
            assert!(
                (p.current.timestamp - p.reference.timestamp - k as f64 * 0.1).abs() < 1e-9,
                "{}",
                p.name
            );
        }
    }
}

#[test]
fn pairs_span_a_few_scans_and_meet_the_selection() {
    let c = config();
    let report = simulate_pairs_report(&c, 1, 40);
    assert!(report.unmet.is_empty(), "{:?}", report.unmet);
    for p in &report.pairs {
        check_laser_and_no_odometry(p);
        assert!(objects_observable(p, c.params().min_object_returns));
        let gap = p.time_gap();
        let periods = gap / 0.1;
        assert!(
            (3.0 - 1e-9..=8.0 + 1e-9).contains(&periods)
                && (periods - periods.round()).abs() < 1e-6,
            "{}: {gap} s",
            p.name
        );
        let objects = p.truth.as_ref().unwrap().objects.as_ref().unwrap();
        assert!(
            objects.iter().any(|o| o.id == 1),
            "{}: no followed person",
            p.name
        );
    }
    assert_eq!(report.pairs[3], simulate_pair(&c, 1, 3));
}

/// The sensor's world pose at each pair's current scan (the first reference scan at
/// the origin), from the true ego-motions of a sequence with k = 1.
fn sensor_poses(pairs: &[ScanPair]) -> Vec<Pose2> {
    let mut pose = Pose2::identity();
    pairs
        .iter()
        .map(|p| {
            pose = pose.compose(&p.truth.as_ref().unwrap().ego_motion.unwrap());
            pose
        })
        .collect()
}

/// The followed person in one scan.
#[derive(Clone, Copy)]
struct Followed {
    /// Centre in the sensor frame.
    local: Point2<f64>,
    /// Centre in the world (the first reference scan's sensor frame).
    world: Point2<f64>,
    /// The tracking truth's `moving`.
    moving: Option<bool>,
}

/// Per scan of a k = 1 sequence (the current scan of each pair): the followed
/// person's centre in the sensor frame and in the world, if present.
fn followed(pairs: &[ScanPair]) -> Vec<Option<Followed>> {
    let poses = sensor_poses(pairs);
    pairs
        .iter()
        .zip(&poses)
        .map(|(p, pose)| {
            let objects = p.truth.as_ref().unwrap().objects.as_ref().unwrap();
            objects.iter().find(|o| o.id == 1).map(|o| {
                let local = Point2::new(o.x, o.y);
                Followed {
                    local,
                    world: pose.transform_point(&local),
                    moving: o.moving,
                }
            })
        })
        .collect()
}

#[test]
fn the_followed_person_walks_ahead_stops_turns_and_walks_on() {
    for pairs in walks(2, 6) {
        let name = &pairs[0].name;
        let person = followed(&pairs);
        let present = person.iter().flatten().count();
        assert!(
            present * 100 >= 95 * pairs.len(),
            "{name}: the followed person in {present} of {} scans",
            pairs.len()
        );
        // 1-1.5 m ahead, 0.8-2 m while the robot turns after the person.
        let mut close = 0;
        for Followed { local, .. } in person.iter().flatten() {
            let d = local.coords.norm();
            assert!(
                local.x > 0.0 && (0.8..=2.0).contains(&d),
                "{name}: at {local:?}"
            );
            close += usize::from((1.0..=1.5).contains(&d));
        }
        assert!(
            close * 10 >= 9 * present,
            "{name}: {close} of {present} within 1-1.5 m"
        );

        // Speeds over each scan period: the person's from its world centre, the robot's
        // from the true ego-motion.
        let mut person_speed = vec![None; pairs.len()];
        for a in 1..pairs.len() {
            if let (Some(p0), Some(p1)) = (person[a - 1], person[a]) {
                person_speed[a] = Some((p1.world - p0.world).norm() / 0.1);
            }
        }
        let robot_speed: Vec<f64> = pairs
            .iter()
            .map(|p| {
                p.truth
                    .as_ref()
                    .unwrap()
                    .ego_motion
                    .unwrap()
                    .translation()
                    .norm()
                    / 0.1
            })
            .collect();
        assert!(
            robot_speed.iter().all(|&v| v <= 1.0 + 1e-9),
            "{name}: too fast"
        );
        // A stop: at least 1 s with the person standing, the robot standing too.
        let (mut run, mut longest, mut robot_still) = (0, 0, 0);
        for (a, v) in person_speed.iter().enumerate() {
            if v.is_some_and(|v| v < 0.02) {
                run += 1;
                robot_still += usize::from(robot_speed[a] < 0.05);
            } else {
                run = 0;
            }
            longest = longest.max(run);
        }
        assert!(longest >= 10, "{name}: the longest stop is {longest} scans");
        let standing = person_speed.iter().flatten().filter(|&&v| v < 0.02).count();
        assert!(robot_still * 2 >= standing, "{name}: the robot drives on");
        // Walking: mostly at the robot's speed, which is 0.4-0.8 m/s.
        let walking: Vec<usize> = (0..pairs.len())
            .filter(|&a| person_speed[a].is_some_and(|v| v > 0.3))
            .collect();
        assert!(walking.len() >= 50, "{name}: walks {} scans", walking.len());
        let pace = walking
            .iter()
            .filter(|&&a| (person_speed[a].unwrap() - robot_speed[a]).abs() < 0.1)
            .count();
        assert!(
            pace * 2 >= walking.len(),
            "{name}: {pace} of {} at pace",
            walking.len()
        );
        for &a in &walking {
            assert!(
                person_speed[a].unwrap() <= 0.8 + 1e-6,
                "{name}: person too fast"
            );
        }
        let cruising = robot_speed
            .iter()
            .filter(|&&v| (0.4..=0.8).contains(&v))
            .count();
        assert!(
            cruising >= 50,
            "{name}: the robot cruises for {cruising} scans"
        );
        // The tracking truth calls the person standing during the stop.
        let flags: Vec<Option<bool>> = person.iter().flatten().map(|p| p.moving).collect();
        assert!(flags.contains(&Some(false)) && flags.contains(&Some(true)));

        // It walks on in a new direction: the walking direction 1 s before the first
        // long stop and 1.5-2.5 s after its end differ by 30° or more.
        let mut run = 0;
        let mut stop = None;
        for (a, v) in person_speed.iter().enumerate() {
            run = if v.is_some_and(|v| v < 0.02) {
                run + 1
            } else {
                0
            };
            if run >= 10 {
                let start = a + 1 - run;
                let end = (a..pairs.len())
                    .find(|&b| person_speed[b].is_some_and(|v| v > 0.1))
                    .unwrap_or(pairs.len());
                stop = Some((start, end));
                break;
            }
        }
        let (start, end) = stop.unwrap();
        let world = |a: usize| person[a].map(|p| p.world);
        if let (true, Some(b0), Some(b1), Some(a0), Some(a1)) = (
            start >= 12 && end + 25 < pairs.len(),
            world(start.saturating_sub(12)),
            world(start.saturating_sub(2)),
            world(end + 15),
            world(end + 25),
        ) {
            let (before, after) = (b1 - b0, a1 - a0);
            let turn = (before.x * after.y - before.y * after.x)
                .atan2(before.dot(&after))
                .abs();
            assert!(turn >= 30f64.to_radians(), "{name}: turned {turn} rad");
        } else {
            panic!("{name}: the stop at scans {start}-{end} leaves no walk around it");
        }
    }
}

#[test]
fn other_pedestrians_pass_by_in_some_sequences() {
    let mut with_passers = 0;
    for pairs in walks(6, 10) {
        let mut others = std::collections::BTreeSet::new();
        for p in &pairs {
            let truth = p.truth.as_ref().unwrap();
            for o in truth.objects.as_ref().unwrap() {
                if o.id != 1 {
                    others.insert(o.id);
                    assert!((o.x * o.x + o.y * o.y).sqrt() < 6.5, "{}: {o:?}", p.name);
                }
            }
            for m in &truth.motions[1..] {
                assert_eq!(m.kind, "pedestrian");
            }
        }
        assert!(others.len() <= 3, "{}: {others:?}", pairs[0].name);
        with_passers += usize::from(!others.is_empty());
    }
    assert!(
        with_passers >= 4,
        "{with_passers} of 10 sequences with passers-by"
    );
}

#[test]
fn the_background_is_sparse_trees_posts_and_walls_but_seen() {
    let c = config();
    let mut shares = 0.0;
    for pairs in walks(8, 6) {
        let name = &pairs[0].name;
        let mut seen = 0;
        let mut valid = 0;
        for p in &pairs {
            let labels = p.truth.as_ref().unwrap().labels.as_ref().unwrap();
            seen += usize::from(labels.contains(&Some(0)));
            valid += p.current.valid.iter().filter(|&&v| v).count();
        }
        assert!(
            seen * 100 >= 95 * pairs.len(),
            "{name}: background in {seen} scans"
        );
        // Most of the view is empty.
        let share = valid as f64 / (pairs.len() * 245) as f64;
        assert!(share < 0.6, "{name}: {share} of the beams return");
        shares += share;
    }
    assert!(shares / 6.0 < 0.4, "{} of the beams return", shares / 6.0);
    // The obstacles: trunks and posts of 0.05-0.3 m, and some walls.
    let (mut trunks, mut posts, mut walls) = (0, 0, 0);
    for i in 0..10 {
        let script = PRESET.script(&c, &mut pair_rng(8, i), 200, 1);
        assert_eq!(script.period, 0.1);
        assert_eq!(script.objects[0].kind, ObjectKind::Pedestrian);
        for p in &script.background {
            match *p {
                Primitive::Circle { radius, .. } => {
                    assert!((0.05..=0.3).contains(&radius), "radius {radius}");
                    if radius >= 0.1 {
                        trunks += 1;
                    } else {
                        posts += 1;
                    }
                }
                Primitive::Segment { .. } => walls += 1,
            }
        }
    }
    assert!(
        trunks >= 50 && posts >= 30 && walls >= 3,
        "{trunks} trunks, {posts} posts, {walls} walls"
    );
}
