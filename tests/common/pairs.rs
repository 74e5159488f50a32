//! Scan pairs stored another way that must give the same results: beams in reverse
//! order, or angles a whole turn later.

use pgm::datasets::{Association, ScanPair};

/// The pair with both scans' beams stored in reverse order (a scanner mounted upside
/// down), the per-beam ground truth with them.
pub fn reversed(pair: &ScanPair) -> ScanPair {
    let n = pair.reference.len();
    let mut p = pair.clone();
    for scan in [&mut p.reference, &mut p.current] {
        scan.angles.reverse();
        scan.ranges.reverse();
        scan.valid.reverse();
    }
    if let Some(t) = p.truth.as_mut() {
        for l in [t.labels.as_mut(), t.reference_labels.as_mut()]
            .into_iter()
            .flatten()
        {
            l.reverse();
        }
        if let Some(a) = t.associations.as_mut() {
            a.reverse();
            for x in a.iter_mut().flatten() {
                if let Association::Point(r) = x {
                    *r = n - 1 - *r;
                }
            }
        }
    }
    p
}

/// The pair with every beam angle of both scans a whole turn later (a full-turn
/// scanner reporting `0 … 2π`).
pub fn turned(pair: &ScanPair) -> ScanPair {
    let mut p = pair.clone();
    for scan in [&mut p.reference, &mut p.current] {
        for a in &mut scan.angles {
            *a += std::f64::consts::TAU;
        }
    }
    p
}
