//! Where an object is from the returns that happen to be visible: the centre of a box
//! oriented along its heading (along the principal axis of its returns when it is
//! slow), completed to the extent the track has seen it have, on the side away from
//! the sensor. A laser sees the near side of an object only: the mean of the visible
//! returns of a car lies on its near side, not at the centre of its box; the returns
//! of a person are the front arcs of the legs, in front of the body's centre.

use nalgebra::{Matrix2, Point2, Vector2};

/// The extent (m) of an object along its heading and across it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Extent {
    /// Along the axis.
    pub length: f64,
    /// Across it.
    pub width: f64,
}

/// The principal axis of `points` (unit), the x axis for fewer than two.
pub fn principal_axis(points: &[Point2<f64>]) -> Vector2<f64> {
    if points.len() < 2 {
        return Vector2::x();
    }
    let n = points.len() as f64;
    let mean = points.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / n;
    let mut c = Matrix2::zeros();
    for p in points {
        let d = p.coords - mean;
        c += d * d.transpose();
    }
    let eig = c.symmetric_eigen();
    let k = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        0
    } else {
        1
    };
    let axis = eig.eigenvectors.column(k).into_owned();
    if axis.norm() > 0.0 {
        axis.normalize()
    } else {
        Vector2::x()
    }
}

/// The box of `points` along `axis` (unit): its centre and its extent.
pub fn visible_box(points: &[Point2<f64>], axis: &Vector2<f64>) -> (Point2<f64>, Extent) {
    let across = Vector2::new(-axis.y, axis.x);
    let (mut lo_a, mut hi_a, mut lo_c, mut hi_c) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in points {
        let (a, c) = (p.coords.dot(axis), p.coords.dot(&across));
        lo_a = lo_a.min(a);
        hi_a = hi_a.max(a);
        lo_c = lo_c.min(c);
        hi_c = hi_c.max(c);
    }
    let centre = axis * (lo_a + hi_a) / 2.0 + across * (lo_c + hi_c) / 2.0;
    (
        Point2::from(centre),
        Extent {
            length: hi_a - lo_a,
            width: hi_c - lo_c,
        },
    )
}

/// The centre of an object whose visible returns are `points` (sensor at the origin),
/// its box along `axis` completed to `extent` (the largest the track has seen) on the
/// side away from the sensor along each of its axes within 60° of the line of sight,
/// and at least `min_depth` (m) behind the visible surface
/// along the line of sight (a return lies on the surface, the centre behind it).
pub fn centre(
    points: &[Point2<f64>],
    axis: &Vector2<f64>,
    extent: &Extent,
    min_depth: f64,
) -> Point2<f64> {
    let (mut c, seen) = visible_box(points, axis);
    let across = Vector2::new(-axis.y, axis.x);
    let sight = if c.coords.norm() > 0.0 {
        c.coords.normalize()
    } else {
        *axis
    };
    let mut moved = Vector2::zeros();
    for (e, full, visible) in [
        (*axis, extent.length, seen.length),
        (across, extent.width, seen.width),
    ] {
        // Only along an axis within 60° of the line of sight: across it, the part
        // not seen is as likely on either side (a walker's occluded leg).
        let cos = e.dot(&sight);
        if cos.abs() >= 0.5 {
            moved += e * cos.signum() * ((full - visible).max(0.0) / 2.0);
        }
    }
    // Along the line of sight at least `min_depth`.
    let along = moved.dot(&sight);
    if along < min_depth {
        moved += sight * (min_depth - along);
    }
    c += moved;
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The returns a sensor at the origin sees of an axis-aligned box centred at
    /// `centre`, `l` × `w` (the two near sides).
    fn near_sides(centre: Point2<f64>, l: f64, w: f64) -> Vec<Point2<f64>> {
        let (x0, y0) = (centre.x - l / 2.0, centre.y - w / 2.0);
        let mut out = Vec::new();
        for k in 0..=20 {
            let t = k as f64 / 20.0;
            out.push(Point2::new(x0 + t * l, y0)); // the side facing -y
            out.push(Point2::new(x0, y0 + t * w)); // the side facing -x
        }
        out
    }

    #[test]
    fn a_car_seen_from_a_corner_is_centred_in_its_box() {
        let truth = Point2::new(3.0, 2.0);
        let pts = near_sides(truth, 0.43, 0.19);
        let extent = Extent {
            length: 0.43,
            width: 0.19,
        };
        let c = centre(&pts, &Vector2::x(), &extent, 0.0);
        assert!((c - truth).norm() < 1e-9, "{c}");
        // The mean of the returns is well off.
        let mean = pts.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / pts.len() as f64;
        assert!((Point2::from(mean) - truth).norm() > 0.1);
    }

    #[test]
    fn one_visible_side_is_completed_away_from_the_sensor() {
        // Only the side facing the sensor (x = 2.785) of a box centred at (3, 0).
        let pts: Vec<Point2<f64>> = (0..=10)
            .map(|k| Point2::new(2.785, -0.095 + 0.019 * k as f64))
            .collect();
        let extent = Extent {
            length: 0.43,
            width: 0.19,
        };
        let c = centre(&pts, &Vector2::x(), &extent, 0.05);
        assert!((c - Point2::new(3.0, 0.0)).norm() < 1e-9, "{c}");
    }

    #[test]
    fn the_principal_axis_of_a_line() {
        let pts: Vec<Point2<f64>> = (0..10)
            .map(|k| Point2::new(k as f64, 2.0 * k as f64))
            .collect();
        let a = principal_axis(&pts);
        assert!((a.x.abs() - 1.0 / 5f64.sqrt()).abs() < 1e-9);
    }
}
