//! Synthetic scenes shared by the integration tests and, through `#[path]` in
//! `src/lib.rs`, the unit tests: rays cast on wall segments, and a deterministic
//! stream of numbers.

/// A segment of a wall or of an obstacle's outline, `(x1, y1, x2, y2)` in metres.
pub type Segment = (f64, f64, f64, f64);

/// A room 8 m × 5 m around the origin, four walls, with a pillar's face.
#[allow(dead_code)] // not every test target looks into the room
pub const ROOM: [Segment; 5] = [
    (-4.0, -2.5, 4.0, -2.5),
    (4.0, -2.5, 4.0, 2.5),
    (4.0, 2.5, -4.0, 2.5),
    (-4.0, 2.5, -4.0, -2.5),
    (1.0, 0.5, 1.5, 1.2),
];

/// The distance along the ray from `(x, y)` in direction `heading` (rad) to the
/// nearest segment it crosses, `None` when it crosses none.
pub fn first_hit((x, y): (f64, f64), heading: f64, segments: &[Segment]) -> Option<f64> {
    let (dy, dx) = heading.sin_cos();
    segments
        .iter()
        .filter_map(|&(x1, y1, x2, y2)| {
            let (ex, ey) = (x2 - x1, y2 - y1);
            let den = dx * ey - dy * ex;
            let t = ((x1 - x) * ey - (y1 - y) * ex) / den;
            let u = ((x1 - x) * dy - (y1 - y) * dx) / den;
            (den.abs() > 1e-12 && t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
        })
        .reduce(f64::min)
}

/// A deterministic stream of numbers in [0, 1) (a 64-bit LCG).
#[allow(dead_code)] // not every test target draws from it
pub fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}
