//! CRF-Matching (pruned, the defaults) of the matching bench's pair (simulated, preset
//! mixed, seed 1, pair 0) a given number of times, for profilers whose counts should
//! not depend on the machine's speed (`valgrind --tool=callgrind`, `perf`); prints a
//! digest of the result so that two builds can be compared for the same answers.
//!
//! Run: `cargo run --release -p pgm-crf-matching --example matching_pair -- 200`.

use pgm_crf_matching::Matcher;
use pgm_datasets::sim::{simulate_pair, SimConfig};
use pgm_scan::ParamGuard;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let runs: usize = std::env::args().nth(1).map_or(Ok(100), |a| a.parse())?;
    let pair = simulate_pair(&SimConfig::default().check()?, 1, 0);
    let matcher = Matcher::default();
    let mut last = None;
    for _ in 0..runs {
        last = Some(std::hint::black_box(matcher.match_pair(&pair)?));
    }
    if let Some(m) = last {
        println!(
            "{} sweeps, {} rounds, motion {:?}, groups {:?}",
            m.sweeps, m.rounds, m.motion, m.group_motions
        );
        println!("associations {:?}", m.associations);
        println!("confidence {:?}", m.confidence);
    }
    Ok(())
}
