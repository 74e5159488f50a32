//! SVG pictures of scan pairs: the reference scan in grey, the current scan coloured
//! by cluster label, optional motion arrows and boxes around the labelled clusters,
//! in the style of Fig. 4 and 5 of the CRF-Clustering paper.
//!
//! The picture is drawn in the **reference sensor frame**, forward pointing up and
//! left pointing left. Current-scan points are brought into that frame by an
//! alignment motion (by default the true ego-motion, else the odometry prior), so
//! static surfaces of both scans overlap and moving objects stand out. The labels
//! can be the ground truth (the default) or any clustering result, so the same
//! function draws the simulator's truth and a model's output.
//!
//! ```no_run
//! use pgm::datasets::sim::{simulate_pair, SimConfig};
//! use pgm::datasets::ParamGuard;
//! use pgm::plot::PairPicture;
//!
//! let config = SimConfig::default().check().unwrap();
//! let pair = simulate_pair(&config, 1, 0);
//! PairPicture::new(&pair).write_svg("pair.svg").unwrap();
//! ```

use nalgebra::Point2;
use pgm_datasets::{ClusterMotion, ScanPair};
use pgm_scan::Pose2;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Errors while drawing or writing a picture.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The drawing backend failed.
    #[error("drawing failed: {0}")]
    Drawing(String),
    /// The per-point labels do not match the current scan.
    #[error("{labels} labels given for the {beams} beams of the current scan")]
    LabelCount {
        /// Number of labels given.
        labels: usize,
        /// Number of beams of the current scan.
        beams: usize,
    },
    /// The region to draw means nothing (see [`check_view`]).
    #[error("view {view:?}: {problem}")]
    View {
        /// The region asked for, `[x_min, x_max, y_min, y_max]` metres.
        view: [f64; 4],
        /// What is wrong with it.
        problem: String,
    },
    /// The SVG file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Largest distance (m) from the sensor a drawn region may reach: the readers' limit
/// on ranges ([`pgm_datasets::error::limits::MAX_RANGE`]); no return lies farther.
pub const MAX_VIEW_DISTANCE: f64 = pgm_datasets::error::limits::MAX_RANGE;

/// Largest ratio between the two sides of a drawn region: the picture keeps a 1:1
/// scale, so its height is the width times the ratio of the sides.
pub const MAX_VIEW_ASPECT: f64 = 100.0;

/// Checks a region to draw, `[x_min, x_max, y_min, y_max]` metres in the reference
/// sensor frame: four finite numbers within [`MAX_VIEW_DISTANCE`] of the sensor,
/// `x_min < x_max`, `y_min < y_max`, and sides at most [`MAX_VIEW_ASPECT`] times each
/// other (a region of ±1e308 m would make the axis ticks run forever, and a region
/// 10 km long and 1 m wide a picture millions of pixels high).
///
/// ```
/// use pgm::plot::check_view;
/// assert!(check_view([-5.0, 5.0, -3.0, 3.0]).is_ok());
/// assert!(check_view([-1e308, 1e308, -1e308, 1e308]).is_err());
/// assert!(check_view([0.0, 1e4, 0.0, 1.0]).is_err());
/// assert!(check_view([1.0, 0.0, 0.0, 1.0]).is_err());
/// ```
pub fn check_view(view: [f64; 4]) -> Result<(), PlotError> {
    let bad = |problem: String| Err(PlotError::View { view, problem });
    if let Some(v) = view.iter().find(|v| !v.is_finite()) {
        return bad(format!("{v:?} is not a finite number of metres"));
    }
    if let Some(v) = view.iter().find(|v| v.abs() > MAX_VIEW_DISTANCE) {
        return bad(format!(
            "{v:e} m lies beyond {MAX_VIEW_DISTANCE:e} m of the sensor, the largest range \
             the readers accept (no return lies farther)"
        ));
    }
    let [x0, x1, y0, y1] = view;
    if !(x0 < x1 && y0 < y1) {
        return bad("expected x_min < x_max and y_min < y_max".into());
    }
    let (length, width) = (x1 - x0, y1 - y0);
    if length > MAX_VIEW_ASPECT * width || width > MAX_VIEW_ASPECT * length {
        return bad(format!(
            "the region is {length:?} m long and {width:?} m wide: its sides may differ by \
             a factor of at most {MAX_VIEW_ASPECT}"
        ));
    }
    Ok(())
}

/// Colours of clusters `1, 2, …` (cycled); cluster 0 (background) is dark blue-grey.
pub const CLUSTER_COLOURS: [RGBColor; 9] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
const BACKGROUND_COLOUR: RGBColor = RGBColor(45, 55, 72);
const REFERENCE_COLOUR: RGBColor = RGBColor(190, 190, 190);

/// The colour of cluster `label` (0 = background).
pub fn cluster_colour(label: u32) -> RGBColor {
    if label == 0 {
        BACKGROUND_COLOUR
    } else {
        CLUSTER_COLOURS[(label as usize - 1) % CLUSTER_COLOURS.len()]
    }
}

/// What to draw for one pair. Build with [`PairPicture::new`] and adjust the fields.
#[derive(Clone, Debug)]
pub struct PairPicture<'a> {
    /// The pair.
    pub pair: &'a ScanPair,
    /// Cluster label of every current-scan beam (`None`: no return, or unlabelled,
    /// drawn black). Default: the ground-truth labels, if any.
    pub labels: Option<&'a [Option<u32>]>,
    /// Motion taking current-scan points into the reference frame. Default: true
    /// ego-motion, else the odometry prior, else identity.
    pub alignment: Pose2,
    /// Motions drawn as arrows from where a cluster was at the reference time to
    /// where it is at the current time (only for labels present in `labels`, not
    /// for the background). Default: the ground-truth motions.
    pub motions: &'a [ClusterMotion],
    /// Draw a box around every labelled cluster other than 0 (default true).
    pub boxes: bool,
    /// Title above the picture (default: the pair's name).
    pub title: String,
    /// Width of the picture in pixels (the height follows from the view, 1:1 scale).
    pub width: u32,
    /// Region drawn, in the reference sensor frame: `[x_min, x_max, y_min, y_max]`
    /// metres. Default: all points, clipped to 60 m ahead and 30 m to either side.
    pub view: Option<[f64; 4]>,
    /// Associations (one per current beam) drawn as lines from each aligned current
    /// point to its reference partner, like Fig. 3 of the joint-model paper (outliers
    /// get no line). Default: none.
    pub associations: Option<&'a [Option<pgm_scan::Association>]>,
}

impl<'a> PairPicture<'a> {
    /// The default picture of `pair`: ground-truth labels, motions and boxes.
    pub fn new(pair: &'a ScanPair) -> Self {
        let truth = pair.truth.as_ref();
        let alignment = truth
            .and_then(|t| t.ego_motion)
            .or(pair.odometry)
            .unwrap_or_default();
        PairPicture {
            pair,
            labels: truth.and_then(|t| t.labels.as_deref()),
            alignment,
            motions: truth.map_or(&[], |t| t.motions.as_slice()),
            boxes: true,
            title: pair.name.clone(),
            width: 900,
            view: None,
            associations: None,
        }
    }

    /// Draws the picture and returns the SVG text.
    pub fn to_svg_string(&self) -> Result<String, PlotError> {
        let current = &self.pair.current;
        if let Some(labels) = self.labels {
            if labels.len() != current.len() {
                return Err(PlotError::LabelCount {
                    labels: labels.len(),
                    beams: current.len(),
                });
            }
        }
        let (reference_points, _) = self.pair.reference.points();
        let (current_points, current_beams) = current.points();
        let aligned: Vec<Point2<f64>> = current_points
            .iter()
            .map(|p| self.alignment.transform_point(p))
            .collect();
        if let Some(a) = self.associations {
            if a.len() != current.len() {
                return Err(PlotError::LabelCount {
                    labels: a.len(),
                    beams: current.len(),
                });
            }
        }
        let label_of = |k: usize| self.labels.and_then(|l| l[k]);

        // Points of every moving cluster, in the current sensor frame, by label.
        let mut clusters: BTreeMap<u32, Vec<Point2<f64>>> = BTreeMap::new();
        for (p, &k) in current_points.iter().zip(&current_beams) {
            if let Some(l) = label_of(k).filter(|&l| l != 0) {
                clusters.entry(l).or_default().push(*p);
            }
        }

        if let Some(view) = self.view {
            check_view(view)?;
        }
        let [x0, x1, y0, y1] = self.view.unwrap_or_else(|| {
            let mut b = [0.0f64, 1.0, -1.0, 1.0];
            for p in reference_points.iter().chain(&aligned) {
                b[0] = b[0].min(p.x);
                b[1] = b[1].max(p.x);
                b[2] = b[2].min(p.y);
                b[3] = b[3].max(p.y);
            }
            [
                (b[0] - 1.0).max(-5.0),
                (b[1] + 1.0).min(60.0),
                (b[2] - 1.0).max(-30.0),
                (b[3] + 1.0).min(30.0),
            ]
        });
        // Screen axes: u = −y (left is left), v = x (forward is up).
        let region = [x0, x1, y0, y1];
        let height = picture_height(self.width, region, f64::INFINITY);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (self.width, height)).into_drawing_area();
            let mut chart = sensor_chart(&root, &self.title, region, "← left   lateral (m)")?;
            let screen = |p: &Point2<f64>| (-p.y, p.x);
            let inside = |p: &Point2<f64>| p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1;

            if let Some(associations) = self.associations {
                let reference = &self.pair.reference;
                let lines = aligned
                    .iter()
                    .zip(&current_beams)
                    .filter_map(|(p, &k)| match associations[k] {
                        Some(pgm_scan::Association::Point(r))
                            if r < reference.len() && reference.valid[r] =>
                        {
                            Some((*p, reference.beam_point(r)))
                        }
                        _ => None,
                    })
                    .filter(|(p, g)| inside(p) || inside(g))
                    .map(|(p, g)| {
                        PathElement::new(vec![screen(&p), screen(&g)], RGBColor(120, 170, 120))
                    });
                chart.draw_series(lines).map_err(drawing)?;
            }
            chart
                .draw_series(
                    reference_points
                        .iter()
                        .filter(|p| inside(p))
                        .map(|p| Circle::new(screen(p), 3, REFERENCE_COLOUR.filled())),
                )
                .map_err(drawing)?;
            chart
                .draw_series(
                    aligned
                        .iter()
                        .zip(&current_beams)
                        .filter(|(p, _)| inside(p))
                        .map(|(p, &k)| {
                            let colour = label_of(k).map_or(BLACK, cluster_colour);
                            let size = if label_of(k).is_some_and(|l| l != 0) {
                                2
                            } else {
                                1
                            };
                            Circle::new(screen(p), size, colour.filled())
                        }),
                )
                .map_err(drawing)?;

            // Sensors: reference at the origin (grey), current at the alignment (black).
            for (pose, colour) in [
                (Pose2::identity(), REFERENCE_COLOUR),
                (self.alignment, BLACK),
            ] {
                let tip = pose.transform_point(&Point2::new(1.2, 0.0));
                let left = pose.transform_point(&Point2::new(-0.6, 0.6));
                let right = pose.transform_point(&Point2::new(-0.6, -0.6));
                chart
                    .draw_series(std::iter::once(Polygon::new(
                        vec![screen(&tip), screen(&left), screen(&right)],
                        colour.filled(),
                    )))
                    .map_err(drawing)?;
            }

            for (&label, points) in &clusters {
                let colour = cluster_colour(label);
                let aligned_cluster: Vec<Point2<f64>> = points
                    .iter()
                    .map(|p| self.alignment.transform_point(p))
                    .collect();
                if self.boxes {
                    let (mut bx0, mut bx1, mut by0, mut by1) =
                        (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                    for p in &aligned_cluster {
                        bx0 = bx0.min(p.x);
                        bx1 = bx1.max(p.x);
                        by0 = by0.min(p.y);
                        by1 = by1.max(p.y);
                    }
                    let pad = 0.4;
                    chart
                        .draw_series(std::iter::once(Rectangle::new(
                            [(-(by1 + pad), bx1 + pad), (-(by0 - pad), bx0 - pad)],
                            colour.stroke_width(2),
                        )))
                        .map_err(drawing)?;
                    let kind = self
                        .motions
                        .iter()
                        .find(|m| m.label == label)
                        .map_or(String::new(), |m| format!(" {}", m.kind));
                    chart
                        .draw_series(std::iter::once(Text::new(
                            format!("{label}{kind}"),
                            (-(by1 + pad), bx1 + pad + 0.3),
                            ("sans-serif", 13).into_font().color(&colour),
                        )))
                        .map_err(drawing)?;
                }
                if let Some(m) = self.motions.iter().find(|m| m.label == label) {
                    let n = points.len() as f64;
                    let centroid = Point2::from(
                        points
                            .iter()
                            .map(|p| p.coords)
                            .sum::<nalgebra::Vector2<f64>>()
                            / n,
                    );
                    let from = m.motion.transform_point(&centroid);
                    let to = self.alignment.transform_point(&centroid);
                    draw_arrow(&mut chart, screen(&from), screen(&to), colour)?;
                }
            }
            root.present().map_err(drawing)?;
        }
        Ok(svg)
    }

    /// Draws the picture into the SVG file `path`.
    pub fn write_svg(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        write_svg_file(path.as_ref(), &self.to_svg_string()?)
    }
}

/// One scan of a [`TrackPicture`]: its returns, where it was, and its moving objects.
#[derive(Clone, Debug)]
pub struct TrackedScan<'a> {
    /// The scan.
    pub scan: &'a pgm_scan::Scan,
    /// Its sensor frame in the picture's frame (maps its points there).
    pub pose: Pose2,
    /// Its moving objects: track number and centre (m, its own sensor frame).
    pub objects: Vec<(usize, Point2<f64>)>,
}

/// A picture of one tracked sequence (`pgm track --svg`): the returns of every scan
/// in the frame of the first (grey, static and moving alike), the sensor's path
/// (black) and each track's path through its objects' centres (coloured, numbered at
/// its last position).
#[derive(Clone, Debug)]
pub struct TrackPicture<'a> {
    /// The scans in time order.
    pub scans: Vec<TrackedScan<'a>>,
    /// Title above the picture.
    pub title: String,
    /// Width of the picture in pixels (the height follows from the region, 1:1).
    pub width: u32,
}

impl TrackPicture<'_> {
    /// Draws the picture and returns the SVG text.
    pub fn to_svg_string(&self) -> Result<String, PlotError> {
        // At most about 200 scans' returns: a long log would bury its tracks.
        let stride = self.scans.len().div_ceil(200).max(1);
        let returns: Vec<Point2<f64>> = self
            .scans
            .iter()
            .step_by(stride)
            .flat_map(|s| {
                let (points, _) = s.scan.points();
                points.into_iter().map(move |p| s.pose.transform_point(&p))
            })
            .collect();
        let path: Vec<Point2<f64>> = self
            .scans
            .iter()
            .map(|s| Point2::from(s.pose.translation()))
            .collect();
        let mut tracks: BTreeMap<usize, Vec<Point2<f64>>> = BTreeMap::new();
        for s in &self.scans {
            for (track, centre) in &s.objects {
                tracks
                    .entry(*track)
                    .or_default()
                    .push(s.pose.transform_point(centre));
            }
        }
        // The region: the sensor's path and the tracks, with the returns within 30 m.
        let mut b = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let near_path = |p: &Point2<f64>| path.iter().any(|q| (p - q).norm() <= 30.0);
        for p in path
            .iter()
            .chain(tracks.values().flatten())
            .chain(returns.iter().filter(|p| near_path(p)))
        {
            b[0] = b[0].min(p.x);
            b[1] = b[1].max(p.x);
            b[2] = b[2].min(p.y);
            b[3] = b[3].max(p.y);
        }
        if !b.iter().all(|v| v.is_finite()) {
            b = [-1.0, 1.0, -1.0, 1.0];
        }
        let [x0, x1, y0, y1] = [b[0] - 1.0, b[1] + 1.0, b[2] - 1.0, b[3] + 1.0];
        let region = [x0, x1, y0, y1];
        let height = picture_height(self.width, region, 4.0 * self.width as f64);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (self.width, height)).into_drawing_area();
            let mut chart = sensor_chart(
                &root,
                &self.title,
                region,
                "← left   lateral (m), first scan's frame",
            )?;
            let screen = |p: &Point2<f64>| (-p.y, p.x);
            let inside = |p: &Point2<f64>| p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1;
            chart
                .draw_series(
                    returns
                        .iter()
                        .filter(|p| inside(p))
                        .map(|p| Circle::new(screen(p), 1, REFERENCE_COLOUR.filled())),
                )
                .map_err(drawing)?;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    path.iter().map(screen).collect::<Vec<_>>(),
                    BLACK.stroke_width(2),
                )))
                .map_err(drawing)?;
            for (track, centres) in &tracks {
                let colour = cluster_colour(*track as u32 + 1);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        centres.iter().map(screen).collect::<Vec<_>>(),
                        colour.stroke_width(2),
                    )))
                    .map_err(drawing)?;
                chart
                    .draw_series(
                        centres
                            .iter()
                            .map(|c| Circle::new(screen(c), 3, colour.filled())),
                    )
                    .map_err(drawing)?;
                if let Some(last) = centres.last() {
                    chart
                        .draw_series(std::iter::once(Text::new(
                            format!("track {track}"),
                            screen(last),
                            ("sans-serif", 12).into_font().color(&colour),
                        )))
                        .map_err(drawing)?;
                }
            }
            root.present().map_err(drawing)?;
        }
        Ok(svg)
    }

    /// Draws the picture into the SVG file `path`.
    pub fn write_svg(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        write_svg_file(path.as_ref(), &self.to_svg_string()?)
    }
}

/// Layout of the pictures (pixels): title band, margin, axis label areas.
const TITLE: u32 = 28;
const MARGIN: u32 = 12;
const X_LABELS: u32 = 36;
const Y_LABELS: u32 = 44;

/// The height (pixels) of a `width`-pixel picture of the region `[x_min, x_max,
/// y_min, y_max]` (m) at one scale on both axes, the plot at least 50 and at most
/// `max_plot` pixels high.
fn picture_height(width: u32, region: [f64; 4], max_plot: f64) -> u32 {
    let [x0, x1, y0, y1] = region;
    let plot_width = width.saturating_sub(2 * MARGIN + Y_LABELS).max(100);
    let plot_height = ((x1 - x0) / (y1 - y0) * plot_width as f64)
        .round()
        .clamp(50.0, max_plot.max(50.0)) as u32;
    plot_height + TITLE + 2 * MARGIN + X_LABELS
}

/// A white picture with `title` above a chart of the region `[x_min, x_max, y_min,
/// y_max]` (m) of a sensor frame, forward pointing up and left pointing left: screen
/// coordinates `(−y, x)`, the x axis described by `x_desc`.
fn sensor_chart<'b>(
    root: &DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    title: &str,
    region: [f64; 4],
    x_desc: &str,
) -> Result<Chart<'b, 'b>, PlotError> {
    let [x0, x1, y0, y1] = region;
    root.fill(&WHITE).map_err(drawing)?;
    let (top, body) = root.split_vertically(TITLE);
    top.draw(&Text::new(
        title.to_string(),
        (MARGIN as i32, 6),
        ("sans-serif", 16).into_font(),
    ))
    .map_err(drawing)?;
    let mut chart = ChartBuilder::on(&body)
        .margin(MARGIN)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(-y1..-y0, x0..x1)
        .map_err(drawing)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("forward (m)")
        .x_label_formatter(&|u| format!("{:.0}", (-u).round() + 0.0))
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(225, 225, 225))
        .draw()
        .map_err(drawing)?;
    Ok(chart)
}

/// Writes `svg` to `path`, beside it first and then renamed into place: never half a
/// picture.
fn write_svg_file(path: &Path, svg: &str) -> Result<(), PlotError> {
    pgm_datasets::format::write_atomically(path, svg.as_bytes()).map_err(|e| PlotError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    })
}

fn drawing(e: impl std::fmt::Display) -> PlotError {
    PlotError::Drawing(e.to_string())
}

type Chart<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A line from `from` to `to` with a head at `to` (screen coordinates in metres).
fn draw_arrow(
    chart: &mut Chart<'_, '_>,
    from: (f64, f64),
    to: (f64, f64),
    colour: RGBColor,
) -> Result<(), PlotError> {
    let (dx, dy) = (to.0 - from.0, to.1 - from.1);
    let length = (dx * dx + dy * dy).sqrt();
    if length < 1e-6 {
        return Ok(());
    }
    let (ux, uy) = (dx / length, dy / length);
    let head = length.min(0.8) * 0.6;
    let wing = |side: f64| {
        (
            to.0 - head * ux + side * head * 0.5 * -uy,
            to.1 - head * uy + side * head * 0.5 * ux,
        )
    };
    let style = colour.stroke_width(2);
    chart
        .draw_series(std::iter::once(PathElement::new(vec![from, to], style)))
        .map_err(drawing)?;
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![wing(1.0), to, wing(-1.0)],
            style,
        )))
        .map_err(drawing)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use pgm_datasets::sim::{simulate_pair, SimConfig};
    use pgm_datasets::ParamGuard;

    #[test]
    fn draws_every_point_and_box() {
        let config = SimConfig::default().check().unwrap();
        let pair = simulate_pair(&config, 1, 0);
        let mut picture = PairPicture::new(&pair);
        picture.view = Some([-100.0, 100.0, -100.0, 100.0]);
        let svg = picture.to_svg_string().unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..50]);
        let circles = svg.matches("<circle").count();
        let expected = pair.reference.valid_count() + pair.current.valid_count();
        assert_eq!(circles, expected);
        let truth = pair.truth.as_ref().unwrap();
        let labels = truth.labels.as_ref().unwrap();
        let moving: std::collections::BTreeSet<u32> = labels
            .iter()
            .flatten()
            .copied()
            .filter(|&l| l != 0)
            .collect();
        assert!(!moving.is_empty());
        for m in truth.motions.iter().filter(|m| moving.contains(&m.label)) {
            let caption = format!("{} {}", m.label, m.kind);
            assert!(svg.contains(&caption), "no box caption {caption}");
        }
    }

    #[test]
    fn wrong_label_count_is_an_error() {
        let config = SimConfig::default().check().unwrap();
        let pair = simulate_pair(&config, 1, 0);
        let labels = vec![Some(0); 3];
        let mut picture = PairPicture::new(&pair);
        picture.labels = Some(&labels);
        let err = picture.to_svg_string().unwrap_err();
        assert!(err.to_string().contains("3 labels"), "{err}");
    }
}
