//! Conventions about beams that every laser reader follows (ROS 1 and ROS 2 bags,
//! leigh-gtm1 text logs, CARMEN logs), in one place so the readers cannot drift apart.
//!
//! - **Special ranges** (ROS REP 117): `-Inf` (an object closer than `range_min`),
//!   `+Inf` (nothing within `range_max`) and `NaN` (an erroneous reading) are beams
//!   without a usable return, stored as range 0 and invalid, exactly like a 0 or a
//!   range outside `range_min < r < range_max`. A finite negative range is an error.
//! - **Declared span**: a scan that states its last beam angle as well as its first
//!   angle and increment (`angle_max` of `sensor_msgs/LaserScan`, `fov` of CARMEN's
//!   `ROBOTLASER1`) must agree with `(n − 1) · increment` to within one increment
//!   (plus [`span_tolerance`] for rounding). Within that, the increment wins: beam `k`
//!   lies at `angle_min + k · increment`, whatever the declared end says (the common
//!   driver off-by-one, an end one increment too far, reads as the consistent scan).
//!   Beyond it the scan is refused: the ranges do not fill the declared field of view,
//!   and no choice of angles would be right.

/// Whether a range reading is one of REP 117's special values (`-Inf`, `+Inf`,
/// `NaN`): a beam without a usable return.
pub fn is_special_range(r: f64) -> bool {
    !r.is_finite()
}

/// Checks `n` beams `increment` rad apart: several beams 0 rad apart would all lie on
/// one ray, and together they must not span more than
/// [`MAX_SPAN`](crate::error::limits::MAX_SPAN). `Err` with the problem.
pub fn check_increment(n: usize, increment: f64) -> Result<(), String> {
    if n > 1 && increment == 0.0 {
        return Err(format!("{n} beams 0 rad apart would all lie on one ray"));
    }
    if increment.abs() * n.saturating_sub(1) as f64 > crate::error::limits::MAX_SPAN {
        return Err(format!(
            "{n} beams {increment} rad apart span more than a full turn"
        ));
    }
    Ok(())
}

/// The angles of `n` beams, beam `k` at `first + k · increment` (the increment wins
/// over a declared end, see the module docs).
pub fn beam_angles(first: f64, increment: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| first + k as f64 * increment).collect()
}

/// What a reader stores for a reading `r` that is not a finite negative: a special
/// range is range 0 and invalid; any other is itself, valid when
/// `range_min < r < range_max`. Returns (range, valid).
pub fn stored_beam(r: f64, range_min: f64, range_max: f64) -> (f64, bool) {
    if is_special_range(r) {
        (0.0, false)
    } else {
        (r, r > range_min && r < range_max)
    }
}

/// How far beyond one increment a declared span may be off for rounding: the three
/// angles are `float32` in a bag and may be printed with 6 decimals in a text log, so
/// `1e-6` rad for the end angles plus, per beam, `1e-6` rad and a relative `1e-5` of
/// the increment.
pub fn span_tolerance(n: usize, increment: f64) -> f64 {
    1e-6 + n.saturating_sub(1) as f64 * (1e-6 + 1e-5 * increment.abs())
}

/// Checks a declared span (last beam angle minus first, or a field of view) against
/// `n` beams `increment` apart: `Err` with the span the beams give, `(n − 1) ·
/// increment`, when the two differ by more than one increment plus
/// [`span_tolerance`].
pub fn check_span(declared: f64, n: usize, increment: f64) -> Result<(), f64> {
    let given = n.saturating_sub(1) as f64 * increment;
    let off = (declared - given).abs();
    if off > increment.abs() + span_tolerance(n, increment) {
        return Err(given);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::approx_constant)] // 3.141593: the field of view as intel-lab prints it
    fn a_span_within_one_increment_is_accepted() {
        let inc = 1f64.to_radians();
        // 181 beams over 180 degrees; one increment too far or short; intel-lab's
        // ROBOTLASER1 (fov 3.141593, 180 beams at 0.017453, printed with 6 decimals).
        assert_eq!(check_span(180f64.to_radians(), 181, inc), Ok(()));
        assert_eq!(check_span(181f64.to_radians(), 181, inc), Ok(()));
        assert_eq!(check_span(179f64.to_radians(), 181, inc), Ok(()));
        assert_eq!(check_span(3.141593, 180, 0.017453), Ok(()));
        // Clockwise scans: negative increment and span.
        assert_eq!(check_span(-180f64.to_radians(), 181, -inc), Ok(()));
        // Half the increment: the ranges reach only half the span.
        let half = 0.5f64.to_radians();
        assert_eq!(
            check_span(180f64.to_radians(), 181, half),
            Err(180.0 * half)
        );
        assert!(check_span(182.1f64.to_radians(), 181, inc).is_err());
        assert!(check_span(177.9f64.to_radians(), 181, inc).is_err());
        // One beam: any span up to its increment.
        assert_eq!(check_span(0.0, 1, 0.0), Ok(()));
        assert!(check_span(0.1, 1, 0.0).is_err());
    }

    #[test]
    fn special_ranges() {
        for r in [f64::NEG_INFINITY, f64::INFINITY, f64::NAN] {
            assert!(is_special_range(r));
        }
        for r in [0.0, -1.0, 3.5] {
            assert!(!is_special_range(r));
        }
    }
}
