//! SVG pictures of scan pairs: the reference scan in grey, the current scan coloured
//! by cluster label, optional motion arrows and boxes around the labelled clusters,
//! in the style of Fig. 4 and 5 of the CRF-Clustering paper, and of tracked
//! sequences. Every picture has a legend (`<g id="legend">`) naming each colour and
//! mark it draws.
//!
//! The picture is drawn in the **reference sensor frame** at one scale on both axes,
//! its longer side across (forward pointing right and left up, or forward up and left
//! left for a region wider than deep). Current-scan points are brought into that
//! frame by an alignment motion (by default the true ego-motion, else the odometry
//! prior), so static surfaces of both scans overlap and moving objects stand out.
//! The labels can be the ground truth (the default) or any clustering result, so
//! the same function draws the simulator's truth and a model's output.
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
use std::collections::{BTreeMap, BTreeSet};
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

/// Colours of clusters `1, 2, …` (cycled); cluster 0 (the static background) is a
/// blue-grey ([`cluster_colour`]).
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
/// The current scan's static background (cluster 0): small blue-grey dots.
const BACKGROUND_COLOUR: RGBColor = RGBColor(105, 117, 138);
/// Current returns in no cluster (the joint model's outlier cluster): black crosses.
const OUTLIER_COLOUR: RGBColor = RGBColor(0, 0, 0);
const REFERENCE_COLOUR: RGBColor = RGBColor(190, 190, 190);
const ASSOCIATION_COLOUR: RGBColor = RGBColor(150, 200, 150);
const REFERENCE_SENSOR_COLOUR: RGBColor = RGBColor(150, 150, 150);
const CURRENT_SENSOR_COLOUR: RGBColor = RGBColor(0, 0, 0);
/// Legend marks that stand for every cluster's colour (arrows, boxes).
const GUIDE_COLOUR: RGBColor = RGBColor(90, 90, 90);

/// Length of the sensor glyph as a fraction of the picture's width in metres.
pub const SENSOR_GLYPH_FRACTION: f64 = 0.015;

/// The colour of cluster `label` (0 = background).
pub fn cluster_colour(label: u32) -> RGBColor {
    if label == 0 {
        BACKGROUND_COLOUR
    } else {
        CLUSTER_COLOURS[(label as usize - 1) % CLUSTER_COLOURS.len()]
    }
}

/// One moving cluster of a [`PairPicture`], as drawn ([`PairPicture::moving_clusters`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DrawnCluster {
    /// Its label in [`PairPicture::labels`].
    pub label: u32,
    /// The number the picture shows for it (after the true object it mostly covers, or
    /// by bearing).
    pub number: u32,
    /// Its colour ([`cluster_colour`] of `number`).
    pub colour: RGBColor,
    /// Its kind, from its motion ("moving" when none is given).
    pub kind: String,
    /// The current-scan beams of its returns.
    pub beams: Vec<usize>,
    /// Those returns in the reference sensor frame (m), aligned by
    /// [`PairPicture::alignment`].
    pub points: Vec<Point2<f64>>,
    /// Its centre at the reference time and at the current time (reference frame,
    /// m), when the picture has its motion.
    pub arrow: Option<(Point2<f64>, Point2<f64>)>,
}

/// How a [`PairPicture`] chooses the region it draws when [`PairPicture::view`] is
/// `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Framing {
    /// Every return, clipped to 5 m behind, 60 m ahead and 30 m to either side.
    #[default]
    Scene,
    /// The moving objects (the drawn moving clusters, where they were at the
    /// reference time, and the pair's true moving objects when it has ground truth)
    /// and both sensors, with a margin, widened to a landscape picture; the scene when
    /// nothing moves. Pictures of one pair made by different methods share the
    /// region when they find the same objects.
    MovingObjects,
}

/// What to draw for one pair. Build with [`PairPicture::new`] and adjust the fields.
///
/// The picture keeps one scale on both axes and puts the longer side of the region
/// across: forward points right (left up) when the region is deeper than wide, else
/// up (left left). A legend under the chart (`<g id="legend">`) names every colour
/// and mark drawn. Moving clusters are numbered and coloured by the pair's geometry,
/// not by the method's label ids, so one object has the same number and colour in
/// every picture of the pair: after the ground-truth object a cluster mostly covers
/// when the pair has ground truth, else (and for clusters covering no true object,
/// numbered after the true ones) by the bearing of the cluster's centre, right to
/// left.
#[derive(Clone, Debug)]
pub struct PairPicture<'a> {
    /// The pair.
    pub pair: &'a ScanPair,
    /// Cluster label of every current-scan beam (`None`: no return, or in no cluster,
    /// drawn as a black cross, see [`PairPicture::unlabelled`]). Default: the
    /// ground-truth labels, if any; without labels the current scan is drawn in one
    /// colour.
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
    /// metres. Default: chosen by [`PairPicture::framing`].
    pub view: Option<[f64; 4]>,
    /// How the region is chosen when `view` is `None` (default: the whole scene).
    pub framing: Framing,
    /// Associations (one per current beam) drawn as lines from each aligned current
    /// point to its reference partner, like Fig. 3 of the joint-model paper (outliers
    /// get no line). Default: none.
    pub associations: Option<&'a [Option<pgm_scan::Association>]>,
    /// What the legend calls current returns labelled `None` (such as "outlier
    /// cluster"); given, the entry is there even when no return is in it. Default:
    /// "return in no cluster", listed only when there is one.
    pub unlabelled: Option<String>,
}

/// How the moving clusters of a picture are numbered (for the legend's note).
enum Numbering {
    /// The labels are the ground truth.
    Truth,
    /// After the true object each cluster mostly covers; the others from this number.
    Overlap(u32),
    /// By bearing, right to left.
    Bearing,
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
            width: 1200,
            view: None,
            framing: Framing::Scene,
            associations: None,
            unlabelled: None,
        }
    }

    /// The pair's ground-truth labels of the current scan, if it has them.
    fn truth_labels(&self) -> Option<&'a [Option<u32>]> {
        self.pair
            .truth
            .as_ref()
            .and_then(|t| t.labels.as_deref())
            .filter(|t| t.len() == self.pair.current.len())
    }

    /// Every moving cluster (a label other than 0 in [`PairPicture::labels`]) as the
    /// picture shows it: its number and colour, its returns, and the arrow of its
    /// motion. The same numbers and colours as [`PairPicture::to_svg_string`] (used by
    /// the MCAP recordings of [`crate::foxglove`]).
    ///
    /// # Errors
    /// [`PlotError::LabelCount`] when the labels do not match the current scan.
    pub fn moving_clusters(&self) -> Result<Vec<DrawnCluster>, PlotError> {
        let current = &self.pair.current;
        self.check_per_beam(self.labels.map(<[_]>::len))?;
        let (current_points, current_beams) = current.points();
        let aligned: Vec<Point2<f64>> = current_points
            .iter()
            .map(|p| self.alignment.transform_point(p))
            .collect();
        let (clusters, numbers, _, arrows) = self.cluster_layout(&current_beams, &aligned);
        Ok(clusters
            .iter()
            .map(|(&label, members)| DrawnCluster {
                label,
                number: numbers[&label],
                colour: cluster_colour(numbers[&label]),
                kind: self
                    .motions
                    .iter()
                    .find(|m| m.label == label && !m.kind.is_empty())
                    .map_or("moving", |m| m.kind.as_str())
                    .to_string(),
                beams: members.iter().map(|&i| current_beams[i]).collect(),
                points: members.iter().map(|&i| aligned[i]).collect(),
                arrow: arrows.get(&label).copied(),
            })
            .collect())
    }

    /// [`PlotError::LabelCount`] unless `given` (the length of a per-beam slice, if
    /// any) is the current scan's beam count.
    fn check_per_beam(&self, given: Option<usize>) -> Result<(), PlotError> {
        let beams = self.pair.current.len();
        match given {
            Some(labels) if labels != beams => Err(PlotError::LabelCount { labels, beams }),
            _ => Ok(()),
        }
    }

    /// The moving clusters (indices into `beams` and `aligned`, by label), their
    /// numbers, how those were chosen, and each one's arrow: its centre at the
    /// reference time, then at the current time (reference frame).
    #[allow(clippy::type_complexity)]
    fn cluster_layout(
        &self,
        beams: &[usize],
        aligned: &[Point2<f64>],
    ) -> (
        BTreeMap<u32, Vec<usize>>,
        BTreeMap<u32, u32>,
        Numbering,
        BTreeMap<u32, (Point2<f64>, Point2<f64>)>,
    ) {
        let label_of = |k: usize| self.labels.and_then(|l| l[k]);
        let mut clusters: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
        for (i, &k) in beams.iter().enumerate() {
            if let Some(l) = label_of(k).filter(|&l| l != 0) {
                clusters.entry(l).or_default().push(i);
            }
        }
        let (numbers, numbering) = self.numbering(&clusters, beams, aligned);
        let current_points: Vec<Point2<f64>> = beams
            .iter()
            .map(|&k| self.pair.current.beam_point(k))
            .collect();
        let arrows = clusters
            .iter()
            .filter_map(|(&label, members)| {
                let m = self.motions.iter().find(|m| m.label == label)?;
                let c = centroid(members.iter().map(|&i| current_points[i]));
                Some((
                    label,
                    (
                        m.motion.transform_point(&c),
                        self.alignment.transform_point(&c),
                    ),
                ))
            })
            .collect();
        (clusters, numbers, numbering, arrows)
    }

    /// The number shown for every moving cluster (by label), and how they were
    /// chosen. `clusters` holds each cluster's indices into `beams` and `aligned`
    /// (the current points in the reference frame).
    fn numbering(
        &self,
        clusters: &BTreeMap<u32, Vec<usize>>,
        beams: &[usize],
        aligned: &[Point2<f64>],
    ) -> (BTreeMap<u32, u32>, Numbering) {
        let mut numbers = BTreeMap::new();
        let mut next = 1u32;
        let mut how = Numbering::Bearing;
        if let Some(truth) = self.truth_labels() {
            let mut overlap: BTreeMap<(u32, u32), usize> = BTreeMap::new();
            for (&label, members) in clusters {
                for &i in members {
                    if let Some(t) = truth[beams[i]].filter(|&t| t != 0) {
                        *overlap.entry((label, t)).or_default() += 1;
                    }
                }
            }
            let mut candidates: Vec<((u32, u32), usize)> = overlap.into_iter().collect();
            candidates.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
            let mut taken = BTreeSet::new();
            for ((label, t), count) in candidates {
                // A cluster takes a true object's number only when that object is
                // most of the cluster.
                if numbers.contains_key(&label)
                    || taken.contains(&t)
                    || 2 * count < clusters[&label].len()
                {
                    continue;
                }
                numbers.insert(label, t);
                taken.insert(t);
            }
            next = truth
                .iter()
                .flatten()
                .copied()
                .max()
                .unwrap_or(0)
                .saturating_add(1)
                .max(1);
            // The truth itself (the same slice), not a method that happens to agree.
            how = if self.labels.is_some_and(|l| std::ptr::eq(l, truth)) {
                Numbering::Truth
            } else {
                Numbering::Overlap(next)
            };
        }
        let mut rest: Vec<(f64, u32)> = clusters
            .iter()
            .filter(|(l, _)| !numbers.contains_key(l))
            .map(|(&l, members)| {
                let c = centroid(members.iter().map(|&i| aligned[i]));
                (c.y.atan2(c.x), l)
            })
            .collect();
        rest.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, label) in rest {
            numbers.insert(label, next);
            next = next.saturating_add(1);
        }
        (numbers, how)
    }

    /// The region of [`Framing::MovingObjects`]: `moving` (points of moving objects in
    /// the reference frame) and both sensors with a margin, in landscape; `None` when
    /// nothing moves.
    fn moving_region(&self, moving: &[Point2<f64>]) -> Option<[f64; 4]> {
        if moving.is_empty() {
            return None;
        }
        let sensors = [Point2::origin(), Point2::from(self.alignment.translation())];
        let mut b = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in moving.iter().chain(&sensors) {
            b[0] = b[0].min(p.x);
            b[1] = b[1].max(p.x);
            b[2] = b[2].min(p.y);
            b[3] = b[3].max(p.y);
        }
        let margin = (0.08 * (b[1] - b[0]).max(b[3] - b[2])).clamp(2.0, 4.0);
        let region = landscape([b[0] - margin, b[1] + margin, b[2] - margin, b[3] + margin]);
        check_view(region).ok().map(|()| region)
    }

    /// Draws the picture and returns the SVG text.
    pub fn to_svg_string(&self) -> Result<String, PlotError> {
        let current = &self.pair.current;
        self.check_per_beam(self.labels.map(<[_]>::len))?;
        self.check_per_beam(self.associations.map(<[_]>::len))?;
        if let Some(view) = self.view {
            check_view(view)?;
        }
        let (reference_points, reference_beams) = self.pair.reference.points();
        let (current_points, current_beams) = current.points();
        let aligned: Vec<Point2<f64>> = current_points
            .iter()
            .map(|p| self.alignment.transform_point(p))
            .collect();
        let label_of = |k: usize| self.labels.and_then(|l| l[k]);
        let (clusters, numbers, numbering, arrows) = self.cluster_layout(&current_beams, &aligned);
        let kind_of = |label: u32| {
            self.motions
                .iter()
                .find(|m| m.label == label && !m.kind.is_empty())
                .map_or("moving", |m| m.kind.as_str())
        };

        let region = match self.view {
            Some(view) => view,
            None => {
                let scene = || scene_region(reference_points.iter().chain(&aligned));
                match self.framing {
                    Framing::Scene => scene(),
                    Framing::MovingObjects => {
                        let mut moving: Vec<Point2<f64>> = clusters
                            .values()
                            .flatten()
                            .map(|&i| aligned[i])
                            .chain(arrows.values().map(|a| a.0))
                            .collect();
                        if let Some(truth) = self.pair.truth.as_ref() {
                            if let Some(t) = self.truth_labels() {
                                moving.extend(labelled_moving(&current_beams, &aligned, t));
                            }
                            if let Some(t) = truth
                                .reference_labels
                                .as_deref()
                                .filter(|t| t.len() == self.pair.reference.len())
                            {
                                moving.extend(labelled_moving(
                                    &reference_beams,
                                    &reference_points,
                                    t,
                                ));
                            }
                        }
                        self.moving_region(&moving).unwrap_or_else(scene)
                    }
                }
            }
        };
        let frame = Frame::new(region);

        // What is drawn, for the legend.
        let unlabelled_count = match self.labels {
            Some(labels) => current_beams
                .iter()
                .filter(|&&k| labels[k].is_none())
                .count(),
            None => 0,
        };
        let partnerless = |k: usize| {
            self.labels.is_none()
                && self
                    .associations
                    .is_some_and(|a| a[k] == Some(pgm_scan::Association::Outlier))
        };
        let partnerless_count = current_beams.iter().filter(|&&k| partnerless(k)).count();
        let mut legend = Legend::default();
        legend.push(
            Mark::Dot(REFERENCE_COLOUR, 3),
            "reference scan (the earlier one)",
        );
        if self.labels.is_some() {
            legend.push(
                Mark::Dot(BACKGROUND_COLOUR, 2),
                "current scan: static background",
            );
        } else {
            legend.push(Mark::Dot(BACKGROUND_COLOUR, 2), "current scan");
        }
        if partnerless_count > 0 {
            legend.push(
                Mark::Cross(OUTLIER_COLOUR),
                format!("current return with no partner, an outlier ({partnerless_count})"),
            );
        }
        if unlabelled_count > 0 || self.unlabelled.is_some() {
            let name = self.unlabelled.as_deref().unwrap_or("return in no cluster");
            legend.push(
                Mark::Cross(OUTLIER_COLOUR),
                format!(
                    "{name} ({unlabelled_count} return{})",
                    if unlabelled_count == 1 { "" } else { "s" }
                ),
            );
        }
        let (thing, noun) = match numbering {
            Numbering::Truth => ("an object", "object"),
            _ => ("a cluster", "cluster"),
        };
        let mut by_number: Vec<(u32, u32)> = numbers.iter().map(|(&l, &n)| (n, l)).collect();
        by_number.sort();
        for &(number, label) in &by_number {
            legend.push(
                Mark::Dot(cluster_colour(number), 3),
                match numbering {
                    Numbering::Truth => format!("true object {number}: {}", kind_of(label)),
                    _ => format!("cluster {number}: {}", kind_of(label)),
                },
            );
        }
        if self.associations.is_some() {
            legend.push(
                Mark::Line(ASSOCIATION_COLOUR, 1),
                "association: current return to its reference partner",
            );
        }
        if !arrows.is_empty() {
            legend.push(
                Mark::Arrow(GUIDE_COLOUR),
                format!("{thing}'s motion, reference → current (its colour)"),
            );
        }
        if self.boxes && !clusters.is_empty() {
            legend.push(
                Mark::Box(GUIDE_COLOUR),
                format!("box around a moving {noun}, with its number"),
            );
        }
        legend.push(
            Mark::Sensor(REFERENCE_SENSOR_COLOUR),
            "sensor at the reference scan (origin)",
        );
        legend.push(
            Mark::Sensor(CURRENT_SENSOR_COLOUR),
            "sensor at the current scan",
        );
        legend.note(
            "Current returns are moved into the reference sensor's frame by the ego-motion, \
             so static surfaces of both scans overlap.",
        );
        if !clusters.is_empty() {
            legend.note(match numbering {
                Numbering::Truth => {
                    "Colours and numbers are the ground truth's moving objects (the \
                                     same in every figure of this pair)."
                        .into()
                }
                Numbering::Overlap(next) => format!(
                    "Each cluster has the number and colour of the ground-truth object it mostly \
                     covers (the same in every figure of this pair); others from {next} up, right \
                     to left."
                ),
                Numbering::Bearing => {
                    "Clusters are numbered by bearing from the sensor, right to left \
                                       (not by the method's label ids)."
                        .into()
                }
            });
        }

        let layout = Layout::new(self.width, &frame, f64::INFINITY, &legend);
        let px = layout.metres_per_pixel(&frame);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (layout.width, layout.height()))
                .into_drawing_area();
            let mut chart = sensor_chart(&root, &self.title, &frame, &layout, "")?;
            let screen = |p: &Point2<f64>| frame.screen(p);
            let inside = |p: &Point2<f64>| frame.inside(p);

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
                        PathElement::new(vec![screen(&p), screen(&g)], ASSOCIATION_COLOUR)
                    });
                chart.draw_series(lines).map_err(drawing)?;
            }
            // Sensors under the returns, small: reference at the origin, current at
            // the alignment.
            let glyph = SENSOR_GLYPH_FRACTION * frame.horizontal();
            for (pose, colour) in [
                (Pose2::identity(), REFERENCE_SENSOR_COLOUR),
                (self.alignment, CURRENT_SENSOR_COLOUR),
            ] {
                draw_sensor(&mut chart, &frame, &pose, glyph, colour)?;
            }
            draw_dots(&mut chart, &frame, &reference_points, 3, REFERENCE_COLOUR)?;
            // Current returns: the background (or the whole scan without labels)
            // as dots, returns in no cluster as crosses, then the moving clusters.
            let in_view = |(p, _): &(&Point2<f64>, &usize)| inside(p);
            let plain = |k: usize| match self.labels {
                None => !partnerless(k),
                Some(_) => label_of(k) == Some(0),
            };
            let background = aligned
                .iter()
                .zip(&current_beams)
                .filter(|(_, &k)| plain(k))
                .map(|(p, _)| p);
            draw_dots(&mut chart, &frame, background, 2, BACKGROUND_COLOUR)?;
            chart
                .draw_series(
                    aligned
                        .iter()
                        .zip(&current_beams)
                        .filter(in_view)
                        .filter(|(_, &k)| {
                            partnerless(k) || (self.labels.is_some() && label_of(k).is_none())
                        })
                        .map(|(p, _)| Cross::new(screen(p), 3, OUTLIER_COLOUR.stroke_width(1))),
                )
                .map_err(drawing)?;
            for (&label, members) in &clusters {
                let colour = cluster_colour(numbers[&label]);
                let points = members.iter().map(|&i| &aligned[i]);
                draw_dots(&mut chart, &frame, points, 3, colour)?;
            }

            for (&label, members) in &clusters {
                let number = numbers[&label];
                let colour = cluster_colour(number);
                if self.boxes {
                    let corners: Vec<(f64, f64)> =
                        members.iter().map(|&i| screen(&aligned[i])).collect();
                    let pad = 6.0 * px;
                    let (mut u0, mut u1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                    for (u, v) in corners {
                        u0 = u0.min(u);
                        u1 = u1.max(u);
                        v0 = v0.min(v);
                        v1 = v1.max(v);
                    }
                    chart
                        .draw_series(std::iter::once(Rectangle::new(
                            [(u0 - pad, v1 + pad), (u1 + pad, v0 - pad)],
                            colour.stroke_width(2),
                        )))
                        .map_err(drawing)?;
                    chart
                        .draw_series(std::iter::once(Text::new(
                            format!("{number} {}", kind_of(label)),
                            (u0 - pad, v1 + pad + 17.0 * px),
                            ("sans-serif", 13).into_font().color(&colour),
                        )))
                        .map_err(drawing)?;
                }
                if let Some((from, to)) = arrows.get(&label) {
                    draw_arrow(&mut chart, screen(from), screen(to), colour, px)?;
                }
            }
            root.present().map_err(drawing)?;
        }
        Ok(legend.insert_into(svg, layout.width, layout.legend_top()))
    }

    /// Draws the picture into the SVG file `path`.
    pub fn write_svg(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        write_svg_file(path.as_ref(), &self.to_svg_string()?)
    }
}

/// The centre of `points` (the origin for none).
fn centroid(points: impl Iterator<Item = Point2<f64>>) -> Point2<f64> {
    let (mut sum, mut n) = (nalgebra::Vector2::zeros(), 0usize);
    for p in points {
        sum += p.coords;
        n += 1;
    }
    Point2::from(sum / n.max(1) as f64)
}

/// The region of [`Framing::Scene`]: every point (and the sensor), 1 m of margin,
/// clipped to 5 m behind, 60 m ahead and 30 m to either side.
fn scene_region<'p>(points: impl Iterator<Item = &'p Point2<f64>>) -> [f64; 4] {
    let mut b = [0.0f64, 1.0, -1.0, 1.0];
    for p in points {
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
}

/// `region` grown about its centre to a landscape shape: the longer side at least
/// 10 m (room for the surroundings of an object next to the sensor) and 1.4 times the
/// shorter, the shorter at least half the longer.
fn landscape(region: [f64; 4]) -> [f64; 4] {
    let [x0, x1, y0, y1] = region;
    let (forward, lateral) = (x1 - x0, y1 - y0);
    let long = forward.max(lateral).max(10.0);
    let short = forward.min(lateral).max(long / 2.0);
    let long = long.max(1.4 * short);
    let (forward, lateral) = if forward >= lateral {
        (long, short)
    } else {
        (short, long)
    };
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    [
        cx - forward / 2.0,
        cx + forward / 2.0,
        cy - lateral / 2.0,
        cy + lateral / 2.0,
    ]
}

/// One scan of a [`TrackPicture`]: its returns, where it was, and its moving objects.
#[derive(Clone, Debug)]
pub struct TrackedScan<'a> {
    /// The scan.
    pub scan: &'a pgm_scan::Scan,
    /// Its sensor frame in the picture's frame (maps its points there).
    pub pose: Pose2,
    /// Its objects: track number, centre (m, its own sensor frame) and state.
    pub objects: Vec<(usize, Point2<f64>, ObjectState)>,
}

/// How a tracked object is drawn in one scan of a [`TrackPicture`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectState {
    /// Found and moving: a filled dot.
    Moving,
    /// Found, slower than the speed that counts as moving: a filled square.
    Stopped,
    /// Not found: where its filter predicts it, a hollow ring.
    Coasting,
}

/// A picture of one tracked sequence (`pgm track --svg`): the returns of every scan
/// in the frame of the first (grey, static and moving alike), the sensor's path
/// (black, the sensor drawn small at the last scan) and each track's path through its
/// objects' centres (coloured, numbered at its last position), with a legend.
#[derive(Clone, Debug)]
pub struct TrackPicture<'a> {
    /// The scans in time order.
    pub scans: Vec<TrackedScan<'a>>,
    /// Title above the picture.
    pub title: String,
    /// Width of the picture in pixels (the height follows from the region, 1:1).
    pub width: u32,
}

/// Tracks a [`TrackPicture`]'s legend lists one by one; the others are counted.
const LEGEND_TRACKS: usize = 12;

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
        let mut tracks: BTreeMap<usize, Vec<(Point2<f64>, ObjectState)>> = BTreeMap::new();
        for s in &self.scans {
            for (track, centre, state) in &s.objects {
                tracks
                    .entry(*track)
                    .or_default()
                    .push((s.pose.transform_point(centre), *state));
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
            .chain(tracks.values().flatten().map(|(c, _)| c))
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
        let frame = Frame::new([b[0] - 1.0, b[1] + 1.0, b[2] - 1.0, b[3] + 1.0]);

        let mut legend = Legend::default();
        legend.push(
            Mark::Dot(REFERENCE_COLOUR, 2),
            if stride > 1 {
                format!("returns of every {stride}th scan, static and moving")
            } else {
                "returns of every scan, static and moving".into()
            },
        );
        legend.push(Mark::Line(CURRENT_SENSOR_COLOUR, 2), "the sensor's path");
        legend.push(
            Mark::Sensor(CURRENT_SENSOR_COLOUR),
            "sensor at the last scan",
        );
        for &track in tracks.keys().take(LEGEND_TRACKS) {
            legend.push(
                Mark::Track(cluster_colour(track as u32 + 1)),
                format!("track {track}: its object's centre, scan by scan"),
            );
        }
        let states: std::collections::BTreeSet<u8> =
            tracks.values().flatten().map(|(_, s)| *s as u8).collect();
        if states.contains(&(ObjectState::Stopped as u8)) {
            legend.push(
                Mark::Square(CURRENT_SENSOR_COLOUR),
                "stopped: found, slower than the speed that counts as moving",
            );
        }
        if states.contains(&(ObjectState::Coasting as u8)) {
            legend.push(
                Mark::Ring(CURRENT_SENSOR_COLOUR),
                "coasting: not found, where its track predicts it",
            );
        }
        if tracks.len() > LEGEND_TRACKS {
            legend.note(format!(
                "… and {} more tracks, each numbered at its last position.",
                tracks.len() - LEGEND_TRACKS
            ));
        }
        legend.note(
            "Everything is in the first scan's sensor frame; a track is one moving object \
             followed over the scans.",
        );

        let layout = Layout::new(self.width, &frame, 4.0 * self.width as f64, &legend);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (layout.width, layout.height()))
                .into_drawing_area();
            let mut chart =
                sensor_chart(&root, &self.title, &frame, &layout, ", first scan's frame")?;
            let screen = |p: &Point2<f64>| frame.screen(p);
            if let Some(last) = self.scans.last() {
                let glyph = SENSOR_GLYPH_FRACTION * frame.horizontal();
                draw_sensor(&mut chart, &frame, &last.pose, glyph, CURRENT_SENSOR_COLOUR)?;
            }
            draw_dots(&mut chart, &frame, &returns, 1, REFERENCE_COLOUR)?;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    path.iter().map(screen).collect::<Vec<_>>(),
                    CURRENT_SENSOR_COLOUR.stroke_width(2),
                )))
                .map_err(drawing)?;
            for (track, centres) in &tracks {
                let colour = cluster_colour(*track as u32 + 1);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        centres.iter().map(|(c, _)| screen(c)).collect::<Vec<_>>(),
                        colour.stroke_width(2),
                    )))
                    .map_err(drawing)?;
                for (state, style) in [
                    (ObjectState::Moving, colour.filled()),
                    (ObjectState::Coasting, colour.stroke_width(1)),
                ] {
                    chart
                        .draw_series(
                            centres
                                .iter()
                                .filter(|(_, s)| *s == state)
                                .map(|(c, _)| Circle::new(screen(c), 3, style)),
                        )
                        .map_err(drawing)?;
                }
                let square = |c: &Point2<f64>| {
                    let (x, y) = screen(c);
                    let h = 3.5 * frame.horizontal() / layout.plot_width as f64;
                    Rectangle::new([(x - h, y - h), (x + h, y + h)], colour.filled())
                };
                chart
                    .draw_series(
                        centres
                            .iter()
                            .filter(|(_, s)| *s == ObjectState::Stopped)
                            .map(|(c, _)| square(c)),
                    )
                    .map_err(drawing)?;
                if let Some((last, _)) = centres.last() {
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
        Ok(legend.insert_into(svg, layout.width, layout.legend_top()))
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

/// A region of a sensor frame `[x_min, x_max, y_min, y_max]` (m) and how it lies on
/// the screen: its longer side across, forward pointing right (left up) for a region
/// deeper than wide, else forward up (left left).
struct Frame {
    region: [f64; 4],
    forward_right: bool,
}

impl Frame {
    fn new(region: [f64; 4]) -> Self {
        let [x0, x1, y0, y1] = region;
        Frame {
            region,
            forward_right: x1 - x0 >= y1 - y0,
        }
    }

    /// Chart coordinates (m) of `p`.
    fn screen(&self, p: &Point2<f64>) -> (f64, f64) {
        if self.forward_right {
            (p.x, p.y)
        } else {
            (-p.y, p.x)
        }
    }

    fn inside(&self, p: &Point2<f64>) -> bool {
        let [x0, x1, y0, y1] = self.region;
        p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1
    }

    /// The region's extents (m) across and up the screen.
    fn extents(&self) -> (f64, f64) {
        let [x0, x1, y0, y1] = self.region;
        let (forward, sideways) = (x1 - x0, y1 - y0);
        if self.forward_right {
            (forward, sideways)
        } else {
            (sideways, forward)
        }
    }

    /// The region's extent across the screen (m).
    fn horizontal(&self) -> f64 {
        self.extents().0
    }

    /// The region's extent up the screen (m).
    fn vertical(&self) -> f64 {
        self.extents().1
    }
}

/// Sizes of a picture (pixels): the title band, the chart (plot, margins, axis
/// labels), the legend band.
struct Layout {
    width: u32,
    plot_width: u32,
    body: u32,
    legend: u32,
}

impl Layout {
    /// A `width`-pixel picture of `frame` at one scale on both axes, the plot at least
    /// 50 and at most `max_plot` pixels high, with room for `legend`.
    fn new(width: u32, frame: &Frame, max_plot: f64, legend: &Legend) -> Self {
        let plot_width = width.saturating_sub(2 * MARGIN + Y_LABELS).max(100);
        let plot_height = (frame.vertical() / frame.horizontal() * plot_width as f64)
            .round()
            .clamp(50.0, max_plot.max(50.0)) as u32;
        Layout {
            width,
            plot_width,
            body: plot_height + 2 * MARGIN + X_LABELS,
            legend: legend.height(width),
        }
    }

    fn height(&self) -> u32 {
        TITLE + self.body + self.legend
    }

    fn legend_top(&self) -> u32 {
        TITLE + self.body
    }

    /// Metres of the frame per pixel across.
    fn metres_per_pixel(&self, frame: &Frame) -> f64 {
        frame.horizontal() / self.plot_width as f64
    }
}

/// A white picture with `title` above a chart of `frame`, the axes described in
/// metres (`note` after the description of the horizontal axis), and a white band
/// left under it for the legend.
fn sensor_chart<'b>(
    root: &DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    title: &str,
    frame: &Frame,
    layout: &Layout,
    note: &str,
) -> Result<Chart<'b, 'b>, PlotError> {
    let [x0, x1, y0, y1] = frame.region;
    root.fill(&WHITE).map_err(drawing)?;
    let (top, rest) = root.split_vertically(TITLE);
    let (body, _legend) = rest.split_vertically(layout.body);
    top.draw(&Text::new(
        title.to_string(),
        (MARGIN as i32, 6),
        ("sans-serif", 16).into_font(),
    ))
    .map_err(drawing)?;
    let mut builder = ChartBuilder::on(&body);
    builder
        .margin(MARGIN)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS);
    let mut chart = if frame.forward_right {
        builder.build_cartesian_2d(x0..x1, y0..y1)
    } else {
        builder.build_cartesian_2d(-y1..-y0, x0..x1)
    }
    .map_err(drawing)?;
    let (across, up) = (frame.horizontal(), frame.vertical());
    let flip = !frame.forward_right;
    let x_ticks = move |u: &f64| tick(if flip { -u } else { *u }, across);
    let y_ticks = move |v: &f64| tick(*v, up);
    let (x_desc, y_desc) = if frame.forward_right {
        (format!("forward (m){note}"), "left (m)")
    } else {
        (format!("← left   lateral (m){note}"), "forward (m)")
    };
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&x_ticks)
        .y_label_formatter(&y_ticks)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(225, 225, 225))
        .draw()
        .map_err(drawing)?;
    Ok(chart)
}

/// An axis tick of `value` metres on an axis `extent` metres long: whole metres,
/// tenths on short axes.
fn tick(value: f64, extent: f64) -> String {
    if extent < 8.0 {
        format!("{:.1}", (value * 10.0).round() / 10.0 + 0.0)
    } else {
        format!("{:.0}", value.round() + 0.0)
    }
}

/// The sensor at `pose`: a filled triangle `length` metres long pointing where the
/// sensor looks.
fn draw_sensor(
    chart: &mut Chart<'_, '_>,
    frame: &Frame,
    pose: &Pose2,
    length: f64,
    colour: RGBColor,
) -> Result<(), PlotError> {
    let corners = [(0.6, 0.0), (-0.4, 0.4), (-0.4, -0.4)]
        .map(|(x, y)| frame.screen(&pose.transform_point(&Point2::new(x * length, y * length))));
    chart
        .draw_series(std::iter::once(Polygon::new(
            corners.to_vec(),
            colour.filled(),
        )))
        .map_err(drawing)?;
    Ok(())
}

/// The points (of beams `beams`) that `labels`, per beam, puts in a moving cluster
/// (a label other than 0).
fn labelled_moving<'a>(
    beams: &'a [usize],
    points: &'a [Point2<f64>],
    labels: &'a [Option<u32>],
) -> impl Iterator<Item = Point2<f64>> + 'a {
    beams
        .iter()
        .zip(points)
        .filter(|(&k, _)| labels[k].is_some_and(|l| l != 0))
        .map(|(_, p)| *p)
}

/// Filled dots `radius` pixels across at those of `points` inside the frame.
fn draw_dots<'p>(
    chart: &mut Chart<'_, '_>,
    frame: &Frame,
    points: impl IntoIterator<Item = &'p Point2<f64>>,
    radius: u32,
    colour: RGBColor,
) -> Result<(), PlotError> {
    chart
        .draw_series(
            points
                .into_iter()
                .filter(|p| frame.inside(p))
                .map(|p| Circle::new(frame.screen(p), radius, colour.filled())),
        )
        .map_err(drawing)?;
    Ok(())
}

/// A mark of the legend, drawn in a 24 × 14 pixel cell.
enum Mark {
    /// A filled dot of this radius.
    Dot(RGBColor, u32),
    /// A cross (×).
    Cross(RGBColor),
    /// A line of this width.
    Line(RGBColor, u32),
    /// An arrow pointing right.
    Arrow(RGBColor),
    /// A box outline.
    Box(RGBColor),
    /// The sensor glyph, pointing right.
    Sensor(RGBColor),
    /// A track: a line through dots.
    Track(RGBColor),
    /// A filled square.
    Square(RGBColor),
    /// A hollow ring.
    Ring(RGBColor),
}

impl Mark {
    /// The SVG of the mark centred at `(x, y)`.
    fn svg(&self, x: f64, y: f64) -> String {
        let hex = |c: &RGBColor| format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        match self {
            Mark::Dot(c, r) => format!(r#"<circle cx="{x}" cy="{y}" r="{r}" fill="{}"/>"#, hex(c)),
            Mark::Cross(c) => format!(
                r#"<path d="M{} {} L{} {} M{} {} L{} {}" stroke="{}" stroke-width="1.5" fill="none"/>"#,
                x - 4.0,
                y - 4.0,
                x + 4.0,
                y + 4.0,
                x - 4.0,
                y + 4.0,
                x + 4.0,
                y - 4.0,
                hex(c)
            ),
            Mark::Line(c, w) => format!(
                r#"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="{}" stroke-width="{w}"/>"#,
                x - 11.0,
                x + 11.0,
                hex(c)
            ),
            Mark::Arrow(c) => format!(
                r#"<path d="M{} {y} L{} {y} M{} {} L{} {y} L{} {}" stroke="{}" stroke-width="2" fill="none"/>"#,
                x - 11.0,
                x + 10.0,
                x + 4.0,
                y - 4.0,
                x + 10.0,
                x + 4.0,
                y + 4.0,
                hex(c)
            ),
            Mark::Box(c) => format!(
                r#"<rect x="{}" y="{}" width="20" height="12" fill="none" stroke="{}" stroke-width="2"/>"#,
                x - 10.0,
                y - 6.0,
                hex(c)
            ),
            Mark::Sensor(c) => format!(
                r#"<polygon points="{},{y} {},{} {},{}" fill="{}"/>"#,
                x + 7.0,
                x - 5.0,
                y - 5.0,
                x - 5.0,
                y + 5.0,
                hex(c)
            ),
            Mark::Track(c) => format!(
                r#"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="{h}" stroke-width="2"/><circle cx="{}" cy="{y}" r="3" fill="{h}"/><circle cx="{}" cy="{y}" r="3" fill="{h}"/>"#,
                x - 11.0,
                x + 11.0,
                x - 7.0,
                x + 7.0,
                h = hex(c)
            ),
            Mark::Square(c) => format!(
                r#"<rect x="{}" y="{}" width="7" height="7" fill="{}"/>"#,
                x - 3.5,
                y - 3.5,
                hex(c)
            ),
            Mark::Ring(c) => format!(
                r#"<circle cx="{x}" cy="{y}" r="3" fill="none" stroke="{}" stroke-width="1"/>"#,
                hex(c)
            ),
        }
    }
}

/// The legend of a picture: a mark and a text per entry, in columns, and notes
/// under them, drawn in a band under the chart as `<g id="legend">` with one
/// `<g class="legend-entry">` per entry.
#[derive(Default)]
struct Legend {
    entries: Vec<(Mark, String)>,
    notes: Vec<String>,
}

const LEGEND_ROW: u32 = 20;
const LEGEND_NOTE_ROW: u32 = 16;
const LEGEND_MARK: f64 = 32.0;
/// Width of a character of the legend's 12-pixel font, generously (pixels).
const LEGEND_CHAR: f64 = 6.8;

impl Legend {
    fn push(&mut self, mark: Mark, text: impl Into<String>) {
        self.entries.push((mark, text.into()));
    }

    fn note(&mut self, text: impl Into<String>) {
        self.notes.push(text.into());
    }

    /// Columns, rows and column width (pixels) of the entries in a `width`-pixel
    /// picture.
    fn grid(&self, width: u32) -> (usize, usize, f64) {
        let longest = self
            .entries
            .iter()
            .map(|(_, t)| t.chars().count())
            .max()
            .unwrap_or(0);
        let column = LEGEND_MARK + longest as f64 * LEGEND_CHAR + 20.0;
        let room = width.saturating_sub(2 * MARGIN + 16) as f64;
        let columns = ((room / column).floor() as usize).clamp(1, self.entries.len().max(1));
        let rows = self.entries.len().div_ceil(columns);
        (columns, rows, column)
    }

    /// The notes, wrapped to a `width`-pixel picture.
    fn note_lines(&self, width: u32) -> Vec<String> {
        let room = (width.saturating_sub(2 * MARGIN + 16) as f64 / LEGEND_CHAR) as usize;
        let mut lines = Vec::new();
        for note in &self.notes {
            let mut line = String::new();
            for word in note.split_whitespace() {
                if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > room {
                    lines.push(std::mem::take(&mut line));
                }
                if !line.is_empty() {
                    line.push(' ');
                }
                line.push_str(word);
            }
            if !line.is_empty() {
                lines.push(line);
            }
        }
        lines
    }

    /// Height of the legend band (pixels) in a `width`-pixel picture.
    fn height(&self, width: u32) -> u32 {
        let (_, rows, _) = self.grid(width);
        let notes = self.note_lines(width).len() as u32;
        14 + rows as u32 * LEGEND_ROW + notes * LEGEND_NOTE_ROW + 4
    }

    /// `svg` with the legend drawn in its band (from `top` pixels down in a
    /// `width`-pixel picture) before the closing tag.
    fn insert_into(&self, mut svg: String, width: u32, top: u32) -> String {
        use std::fmt::Write;
        let (_, rows, column) = self.grid(width);
        let left = MARGIN as f64;
        let top = top as f64;
        let mut g = String::new();
        let _ = write!(
            g,
            r##"<g id="legend" font-family="sans-serif" font-size="12"><rect x="{left}" y="{}" width="{}" height="{}" fill="#FAFAFA" stroke="#CCCCCC"/>"##,
            top + 2.0,
            width.saturating_sub(2 * MARGIN),
            self.height(width).saturating_sub(6)
        );
        for (i, (mark, text)) in self.entries.iter().enumerate() {
            let (col, row) = (i / rows.max(1), i % rows.max(1));
            let x = left + 8.0 + col as f64 * column;
            let y = top + 10.0 + row as f64 * LEGEND_ROW as f64 + LEGEND_ROW as f64 / 2.0;
            let _ = write!(
                g,
                r##"<g class="legend-entry">{}<text x="{}" y="{y}" dy="0.35em" fill="#000000">{}</text></g>"##,
                mark.svg(x + 12.0, y),
                x + LEGEND_MARK,
                escape(text)
            );
        }
        let notes_top = top + 10.0 + (rows as u32 * LEGEND_ROW) as f64 + 4.0;
        for (j, line) in self.note_lines(width).iter().enumerate() {
            let _ = write!(
                g,
                r##"<text class="legend-note" x="{}" y="{}" dy="0.35em" fill="#444444">{}</text>"##,
                left + 8.0,
                notes_top + (j as u32 * LEGEND_NOTE_ROW) as f64 + LEGEND_NOTE_ROW as f64 / 2.0,
                escape(line)
            );
        }
        g.push_str("</g>\n");
        match svg.rfind("</svg>") {
            Some(end) => svg.insert_str(end, &g),
            None => svg.push_str(&g),
        }
        svg
    }
}

/// `text` with the characters XML gives a meaning escaped.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
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

/// A line from `from` to `to` with a head at `to` (chart coordinates in metres;
/// `px` metres per pixel).
fn draw_arrow(
    chart: &mut Chart<'_, '_>,
    from: (f64, f64),
    to: (f64, f64),
    colour: RGBColor,
    px: f64,
) -> Result<(), PlotError> {
    let (dx, dy) = (to.0 - from.0, to.1 - from.1);
    let length = (dx * dx + dy * dy).sqrt();
    if length < 1e-6 {
        return Ok(());
    }
    let (ux, uy) = (dx / length, dy / length);
    let head = (length * 0.6).min(12.0 * px);
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
        let legend = svg.find(r#"<g id="legend""#).expect("a legend");
        let circles = svg[..legend].matches("<circle").count();
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
