//! Which "moving" labels of leigh-gtm1 pairs belong to people who walk.
//!
//! The motion labels of the data README count a person as moving when they moved at
//! least the threshold between the two scans; a person annotated in the current scan
//! but not in the reference one counts as moving too (the default of
//! `LeighPairOptions::unannotated`). This example carries every annotation into the
//! odometry frame (odometry ∘ laser offset) and measures each person's whole track: a
//! person **walks** when the straight-line distance from their first to their last
//! annotation, per `k` scans, is at least the threshold. Per pair `(i, i + k)` it
//! prints the labelled movers and whether each walks, then counts the pairs with no
//! mover, with a walker, and with standing people only.
//!
//! Run: `cargo run --release -p pgm-datasets --example leigh_labels -- [DATA_DIR] [k] [threshold]`
//! (defaults `../shared/data/leigh-gtm1`, 5, 0.2 m).

use pgm_datasets::leigh;
use std::collections::BTreeMap;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(
        args.get(1)
            .cloned()
            .unwrap_or_else(|| "../shared/data/leigh-gtm1".into()),
    );
    let k: usize = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(5);
    let threshold: f64 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(0.2);
    let mut log = leigh::read_scans(dir.join("scans.txt"))?;
    let odometry_path = dir.join("odom_at_scan.txt");
    let odometry = leigh::read_odometry(&odometry_path)?;
    leigh::attach_odometry(&mut log, &odometry, &odometry_path)?;
    let people = leigh::read_people(dir.join("people_gt.txt"))?;

    let tracks = pgm_datasets::builders::leigh_track_displacements(&log, &people, k)?;
    println!("person  annotations  scans      net displacement per {k} scans");
    for (person, t) in &tracks {
        println!(
            "{person:<7} {:<12} {:>3}-{:<6} {:.2} m{}",
            t.annotations,
            t.scans[0],
            t.scans[1],
            t.per_k_scans,
            if t.per_k_scans >= threshold {
                "  walks"
            } else {
                ""
            }
        );
    }
    let per_k: BTreeMap<u32, f64> = tracks.iter().map(|(p, t)| (*p, t.per_k_scans)).collect();
    // Annotated centres in the odometry frame: scan -> person -> position.
    let world = pgm_datasets::builders::leigh_annotations_in_odometry_frame(&log, &people)?;

    let (mut none, mut walking, mut standing) = (0, 0, 0);
    println!("\npair       labelled movers (person: displacement or 'unannotated in reference')");
    for (&i, reference) in &world {
        let Some(current) = world.get(&(i + k)) else {
            continue;
        };
        let movers: Vec<(u32, String)> = current
            .iter()
            .filter_map(|(person, position)| match reference.get(person) {
                None => Some((*person, "unannotated in reference".to_string())),
                Some(before) => {
                    let d = (position - before).norm();
                    (d >= threshold).then(|| (*person, format!("{d:.2} m")))
                }
            })
            .collect();
        if movers.is_empty() {
            none += 1;
            continue;
        }
        let walks = movers.iter().any(|(p, _)| per_k[p] >= threshold);
        if walks {
            walking += 1;
        } else {
            standing += 1;
        }
        println!(
            "{i}-{:<6} {} -> {}",
            i + k,
            movers
                .iter()
                .map(|(p, why)| format!("{p}: {why}"))
                .collect::<Vec<_>>()
                .join(", "),
            if walks {
                "a walker"
            } else {
                "standing people only"
            }
        );
    }
    let total = none + walking + standing;
    println!(
        "\n{total} pairs (k = {k}, threshold {threshold} m): {none} with no labelled mover, \
         {walking} with a walker, {standing} whose labelled movers all stand \
         (net displacement below the threshold per {k} scans)"
    );
    if total > 0 {
        println!(
            "one cluster scores {:.3}; perfect on the no-mover and walker pairs and 0 on \
             the standing-only pairs: {:.3}",
            none as f64 / total as f64,
            (none + walking) as f64 / total as f64
        );
    }
    Ok(())
}
