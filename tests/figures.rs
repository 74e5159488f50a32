//! Every figure the command line writes (`pgm demo`, `pgm sim --svg`, `pgm plot`,
//! `pgm cluster --svg`, `pgm match --svg`, `pgm joint --svg`, `pgm track --svg`) on
//! small simulated inputs: each has a legend naming what it draws (issue 27), the
//! demo figures are landscape, the sensor is drawn under the returns, and one object
//! keeps its number and colour across the figures of a pair.

mod common;

use common::{ok, temp_dir};
use std::path::Path;

/// What the tests read of a picture.
struct Figure {
    width: u32,
    height: u32,
    /// The legend's entries: text and the colour of the mark.
    entries: Vec<(String, String)>,
    /// The legend's notes.
    notes: Vec<String>,
    /// The SVG before the legend.
    chart: String,
}

impl Figure {
    fn read(path: &Path) -> Figure {
        let svg =
            std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(svg.starts_with("<svg"), "{}: not an SVG", path.display());
        assert!(
            svg.trim_end().ends_with("</svg>"),
            "{}: cut short",
            path.display()
        );
        let attribute = |name: &str| -> u32 {
            let head = &svg[..svg.find('>').unwrap()];
            let start = head.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
            head[start..start + head[start..].find('"').unwrap()]
                .parse()
                .unwrap()
        };
        let start = svg
            .find(r#"<g id="legend""#)
            .unwrap_or_else(|| panic!("{}: no <g id=\"legend\">", path.display()));
        let legend = &svg[start..svg.rfind("</svg>").unwrap()];
        assert_eq!(
            legend.matches("<g").count(),
            legend.matches("</g>").count(),
            "{}: the legend's groups do not close",
            path.display()
        );
        let text_of = |chunk: &str| -> String {
            let open = chunk.find("<text").expect("a text");
            let body = &chunk[open..];
            let from = body.find('>').unwrap() + 1;
            unescape(&body[from..body.find("</text>").unwrap()])
        };
        let entries = legend
            .split(r#"<g class="legend-entry">"#)
            .skip(1)
            .map(|chunk| {
                let colour = ["fill=\"#", "stroke=\"#"]
                    .iter()
                    .filter_map(|a| chunk.find(a).map(|i| (i, i + a.len())))
                    .min()
                    .map(|(_, i)| chunk[i..i + 6].to_string())
                    .expect("a coloured mark");
                (text_of(chunk), colour)
            })
            .collect();
        let notes = legend
            .split(r#"<text class="legend-note""#)
            .skip(1)
            .map(|chunk| text_of(&format!("<text{chunk}")))
            .collect();
        Figure {
            width: attribute("width"),
            height: attribute("height"),
            entries,
            notes,
            chart: svg[..start].to_string(),
        }
    }

    /// Asserts an entry starting with each of `items`.
    fn has(&self, what: &str, items: &[&str]) -> &Self {
        for item in items {
            assert!(
                self.entries.iter().any(|(t, _)| t.starts_with(item)),
                "{what}: no legend entry {item:?} in {:?}",
                self.entries
            );
        }
        self
    }

    /// The numbered clusters of the legend: number and colour.
    fn clusters(&self) -> Vec<(u32, String)> {
        self.entries
            .iter()
            .filter_map(|(t, c)| {
                let rest = t
                    .strip_prefix("cluster ")
                    .or_else(|| t.strip_prefix("true object "))?;
                Some((rest.split(':').next()?.parse().ok()?, c.clone()))
            })
            .collect()
    }

    /// Asserts the sensor glyphs are drawn before (under) every return.
    fn sensor_under_returns(&self, what: &str) -> &Self {
        let sensor = self.chart.find("<polygon").expect("a sensor glyph");
        let first_return = self.chart.find("<circle").expect("returns");
        assert!(
            sensor < first_return,
            "{what}: the sensor is drawn over the returns"
        );
        self
    }
}

fn unescape(text: &str) -> String {
    text.replace("&apos;", "'")
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
        .trim()
        .to_string()
}

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().unwrap().to_string()
}

#[test]
fn demo_figures_are_landscape_with_legends_and_agree_on_objects() {
    let dir = temp_dir("figures-demo");
    let (crf, joint) = (path(&dir, "crf.svg"), path(&dir, "joint.svg"));
    ok(&["demo", "--pairs", "2", "--svg", &crf, "--joint-svg", &joint]);
    let crf = Figure::read(Path::new(&crf));
    let joint = Figure::read(Path::new(&joint));
    for (what, f) in [("demo CRF-Clustering", &crf), ("demo joint", &joint)] {
        assert!(
            f.width > f.height,
            "{what}: {} x {} is not landscape",
            f.width,
            f.height
        );
        f.has(
            what,
            &[
                "reference scan",
                "current scan: static background",
                "cluster 1",
                "a cluster's motion, reference → current",
                "box around a moving cluster",
                "sensor at the reference scan",
                "sensor at the current scan",
            ],
        )
        .sensor_under_returns(what);
        assert!(
            f.notes.iter().any(|n| n.contains("ground-truth object")),
            "{what}: no note on how clusters are numbered: {:?}",
            f.notes
        );
    }
    joint.has("demo joint", &["outlier cluster", "association"]);
    // The static background and the outlier cluster look different.
    let colour = |f: &Figure, item: &str| {
        f.entries
            .iter()
            .find(|(t, _)| t.starts_with(item))
            .unwrap()
            .1
            .clone()
    };
    assert_ne!(
        colour(&joint, "current scan: static background"),
        colour(&joint, "outlier cluster")
    );
    // Both methods find the pair's two moving objects: the same numbers and colours.
    assert_eq!(crf.clusters().len(), 2, "{:?}", crf.entries);
    assert_eq!(crf.clusters(), joint.clusters());
}

#[test]
fn every_pair_figure_has_a_legend() {
    let dir = temp_dir("figures-pairs");
    let data = path(&dir, "pairs");
    let sim = path(&dir, "sim.svg");
    ok(&[
        "sim",
        "--pairs",
        "2",
        "--seed",
        "5",
        "--out",
        &data,
        "--svg",
        &sim,
        "--svg-pair",
        "1",
    ]);
    let truth = Figure::read(Path::new(&sim));
    truth
        .has(
            "pgm sim",
            &[
                "reference scan",
                "current scan: static background",
                "true object",
                "an object's motion",
                "box around a moving object",
                "sensor at the reference scan",
                "sensor at the current scan",
            ],
        )
        .sensor_under_returns("pgm sim");
    assert!(
        truth.width > truth.height,
        "{} x {}",
        truth.width,
        truth.height
    );

    let plot = path(&dir, "plot.svg");
    ok(&["plot", &data, "--pair", "1", "--svg", &plot]);
    let plotted = Figure::read(Path::new(&plot));
    plotted.has("pgm plot", &["reference scan", "true object", "sensor at"]);
    assert_eq!(plotted.clusters(), truth.clusters());

    // The one-pair commands: each picture's legend, and the sensors under the returns.
    let one_pair: [(&str, &[&str]); 3] = [
        (
            "cluster",
            &[
                "reference scan",
                "current scan: static background",
                "cluster ",
                "box around a moving cluster",
                "sensor at the current scan",
            ],
        ),
        (
            "match",
            &[
                "reference scan",
                "current scan",
                "association",
                "sensor at the reference scan",
                "sensor at the current scan",
            ],
        ),
        (
            "joint",
            &[
                "reference scan",
                "current scan: static background",
                "outlier cluster",
                "association",
                "sensor at the current scan",
            ],
        ),
    ];
    for (command, legend) in one_pair {
        let svg = path(&dir, &format!("{command}.svg"));
        ok(&[command, "--pairs", &data, "--pair", "1", "--svg", &svg]);
        let name = format!("pgm {command}");
        Figure::read(Path::new(&svg))
            .has(&name, legend)
            .sensor_under_returns(&name);
    }
}

#[test]
fn the_track_figure_has_a_legend() {
    let dir = temp_dir("figures-track");
    let data = path(&dir, "sequence");
    ok(&[
        "sim",
        "--pairs",
        "1",
        "--sequence",
        "5",
        "--seed",
        "3",
        "--out",
        &data,
    ]);
    let svg = path(&dir, "tracks.svg");
    ok(&["track", "--method", "crf", "--pairs", &data, "--svg", &svg]);
    let figure = Figure::read(Path::new(&svg));
    figure
        .has(
            "pgm track",
            &[
                "returns of every",
                "the sensor's path",
                "sensor at the last scan",
            ],
        )
        .sensor_under_returns("pgm track");
    for (text, _) in figure
        .entries
        .iter()
        .filter(|(t, _)| t.starts_with("track "))
    {
        assert!(text.contains("object's centre"), "{text}");
    }
}
