//! The presets look like the papers' data: cars as 4.2-4.9 m rectangles seen as
//! segments and L-shapes, several moving objects in the mixed preset, plausible speeds.

use pgm_datasets::sim::{pair_rng, simulate_pairs, DatasetStats, ObjectKind, Preset, SimConfig};
use pgm_datasets::ParamGuard;

#[test]
fn mixed_pairs_have_several_moving_objects() {
    let c = SimConfig::default().check().unwrap();
    let pairs = simulate_pairs(&c, 1, 60);
    let stats = DatasetStats::from_pairs(&pairs);
    assert!(
        stats.moving_objects_per_pair.mean >= 2.0,
        "{} moving objects per pair",
        stats.moving_objects_per_pair.mean
    );
    assert!(
        stats.dynamic_points_per_pair.min >= 1.0,
        "{:?}",
        stats.dynamic_points_per_pair
    );
    assert!(
        stats.points_per_scan.mean > 300.0,
        "{:?}",
        stats.points_per_scan
    );
    assert!(
        (0.01..0.4).contains(&stats.outlier_share),
        "outlier share {}",
        stats.outlier_share
    );
    let table = stats.to_markdown();
    assert!(table.contains("| valid points per scan |"), "{table}");
}

#[test]
fn object_speeds_and_sizes_are_plausible() {
    let c = SimConfig::default().check().unwrap();
    for preset in Preset::ALL {
        for i in 0..20 {
            let scene = preset.scene(&c, &mut pair_rng(5, i));
            let travel = scene.ego.speed * scene.interval;
            assert!((2.0..=4.0).contains(&travel), "{preset}: {travel}");
            for o in &scene.objects {
                let v = o.trajectory.speed.abs();
                match o.kind {
                    ObjectKind::Car => {
                        assert!((3.0..=18.0).contains(&v), "{preset}: car at {v} m/s");
                        assert_eq!(o.shape.len(), 4);
                    }
                    ObjectKind::Pedestrian => {
                        assert!((1.0..=1.8).contains(&v), "{preset}: pedestrian at {v} m/s")
                    }
                }
            }
        }
    }
}

#[test]
fn preset_situations_contain_their_objects() {
    let c = SimConfig::default().check().unwrap();
    let count = |preset: Preset, kind: ObjectKind| -> usize {
        (0..20)
            .map(|i| {
                preset
                    .scene(&c, &mut pair_rng(8, i))
                    .objects
                    .iter()
                    .filter(|o| o.kind == kind)
                    .count()
            })
            .sum()
    };
    for preset in [Preset::Overtaking, Preset::Intersection, Preset::Oncoming] {
        assert!(
            count(preset, ObjectKind::Car) >= 20,
            "{preset}: too few cars"
        );
    }
    assert!(count(Preset::Pedestrians, ObjectKind::Pedestrian) >= 60);
    // Oncoming cars drive against the ego direction, overtaking ones with it, faster.
    for i in 0..10 {
        let scene = Preset::Oncoming.scene(&c, &mut pair_rng(8, i));
        assert!(scene
            .objects
            .iter()
            .any(|o| o.trajectory.start.theta().cos() < -0.9));
        let scene = Preset::Overtaking.scene(&c, &mut pair_rng(8, i));
        assert!(scene.objects.iter().any(|o| {
            o.trajectory.start.theta().cos() > 0.9 && o.trajectory.speed > scene.ego.speed
        }));
    }
}

#[test]
fn cars_appear_as_segments_and_l_shapes() {
    // Among the cars seen in the current scans, some show two sides (an L): their
    // points do not all lie on one line.
    let c = SimConfig {
        range_noise: 0.0,
        preset: Preset::Intersection,
        ..SimConfig::default()
    }
    .check()
    .unwrap();
    let mut l_shapes = 0;
    for pair in simulate_pairs(&c, 4, 30) {
        let truth = pair.truth.unwrap();
        let labels = truth.labels.unwrap();
        for m in truth.motions.iter().filter(|m| m.kind == "car") {
            let pts: Vec<_> = (0..labels.len())
                .filter(|&k| labels[k] == Some(m.label))
                .map(|k| pair.current.beam_point(k))
                .collect();
            if pts.len() < 6 {
                continue;
            }
            let (a, b) = (pts[0], pts[pts.len() - 1]);
            let dir = (b - a).normalize();
            let off_line = pts
                .iter()
                .map(|p| ((p - a).x * dir.y - (p - a).y * dir.x).abs())
                .fold(0.0, f64::max);
            if off_line > 0.3 {
                l_shapes += 1;
            }
        }
    }
    assert!(l_shapes >= 5, "{l_shapes} L-shaped cars");
}

#[test]
fn situation_presets_always_show_a_moving_object() {
    for preset in [
        Preset::Overtaking,
        Preset::Intersection,
        Preset::Oncoming,
        Preset::Pedestrians,
        Preset::Mixed,
    ] {
        let c = SimConfig {
            preset,
            ..SimConfig::default()
        }
        .check()
        .unwrap();
        let stats = DatasetStats::from_pairs(&simulate_pairs(&c, 1, 100));
        assert!(
            stats.moving_objects_per_pair.min >= 1.0,
            "{preset}: a pair without a visible moving object"
        );
    }
}
