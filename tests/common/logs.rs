//! Small CARMEN logs built by the tests: FLASER lines, scans of rectangular rooms and
//! mostly blind scans with their relations.

use super::write;
use std::path::Path;

/// A FLASER line: `ranges` (4 decimals) from a laser at `pose` (x, y, heading; the
/// odometry and the laser pose of the line), at time `t`.
pub fn flaser_line(ranges: &[f64], pose: (f64, f64, f64), t: f64) -> String {
    let r: Vec<String> = ranges.iter().map(|r| format!("{r:.4}")).collect();
    let p = format!("{} {} {}", pose.0, pose.1, pose.2);
    format!(
        "FLASER {} {} {p} {p} {t} host {t}",
        ranges.len(),
        r.join(" ")
    )
}

/// Ranges of `n` beams from `start` (rad) every `step` (rad) of a laser at `pose` (x, y,
/// heading) in the rectangular room `[x0, x1] × [y0, y1]` (`room`; `f64::INFINITY`
/// for an open side).
pub fn room_ranges(
    room: [f64; 4],
    pose: (f64, f64, f64),
    n: usize,
    start: f64,
    step: f64,
) -> Vec<f64> {
    let [x0, x1, y0, y1] = room;
    (0..n)
        .map(|k| {
            let a = pose.2 + start + k as f64 * step;
            let (s, c) = a.sin_cos();
            let tx = to_wall(pose.0, c, x0, x1);
            let ty = to_wall(pose.1, s, y0, y1);
            tx.min(ty)
        })
        .collect()
}

/// Along one axis: how far a ray from `from` with direction component `d` goes
/// before it meets the wall `lo` (going down) or `hi` (going up); infinite for a ray
/// across the axis.
fn to_wall(from: f64, d: f64, lo: f64, hi: f64) -> f64 {
    if d > 1e-12 {
        (hi - from) / d
    } else if d < -1e-12 {
        (lo - from) / d
    } else {
        f64::INFINITY
    }
}

/// A CARMEN log `dir/room.clf` of two 181-beam FLASER scans (one a degree, the first
/// to the right) 0.2 m apart in front of the walls x = 4 and y = ±4, the robot pose on
/// each line; `header` comes first.
pub fn square_room(dir: &Path, header: &str) -> String {
    let deg = std::f64::consts::PI / 180.0;
    let room = [f64::NEG_INFINITY, 4.0, -4.0, 4.0];
    let line = |x: f64| {
        let ranges = room_ranges(room, (x, 0.0, 0.0), 181, -90.0 * deg, deg);
        flaser_line(&ranges, (x, 0.0, 0.0), 100.0 + x) + "\n"
    };
    write(
        dir,
        "room.clf",
        &format!("{header}{}{}", line(0.0), line(0.2)),
    )
}

/// A CARMEN log of two 181-beam FLASER scans 0.2 s apart in which only `returns` beams
/// see anything (the rest read 81.91 m, beyond CARMEN's 80 m maximum range), with
/// exact odometry on the lines, and the relation between them.
pub fn sparse_log(dir: &Path, returns: usize) -> (String, String) {
    let line = |pose: (f64, f64, f64), t: f64, shift: usize| {
        let ranges: Vec<f64> = (0..181)
            .map(|k| {
                if (40 + shift..40 + shift + returns).contains(&k) {
                    5.2 + 0.01 * k as f64
                } else {
                    81.91
                }
            })
            .collect();
        flaser_line(&ranges, pose, t) + "\n"
    };
    let text = line((0.0, 0.0, 0.0), 300.0, 0) + &line((0.25, 0.08, 0.06), 300.2, 3);
    (
        write(dir, &format!("sparse{returns}.clf"), &text),
        write(
            dir,
            "sparse.relations",
            "300.0 300.2 0.25 0.08 0 0 0 0.06\n",
        ),
    )
}
