//! `pgm plot`: draw one pair of a data set as SVG, current scan coloured by its
//! ground-truth labels, reference scan in grey (see [`pgm::plot`]).

use super::{CliError, CliResult};
use clap::Args;
use pgm::plot::PairPicture;
use std::path::PathBuf;
use std::process::ExitCode;

/// Options of `pgm plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// Data set: a directory written by `pgm sim --out` / `pgm data`, its index.json,
    /// or one pair file.
    pub dataset: PathBuf,
    /// Which pair to draw (index from 0).
    #[arg(long, default_value_t = 0)]
    pub pair: usize,
    /// Output SVG file.
    #[arg(long, default_value = "pair.svg")]
    pub svg: PathBuf,
    /// Region to draw in the reference sensor frame, metres: x_min,x_max,y_min,y_max
    /// (x forward, y left). Default: all points within 60 m ahead and 30 m aside.
    #[arg(long, value_delimiter = ',', num_args = 4)]
    pub view: Option<Vec<f64>>,
    /// Width of the picture in pixels.
    #[arg(long, default_value_t = 900)]
    pub width: u32,
    /// Leave out the boxes around moving clusters.
    #[arg(long)]
    pub no_boxes: bool,
}

/// Runs `pgm plot`.
pub fn run(args: PlotArgs) -> CliResult {
    let pairs = pgm::datasets::read_pairs(&args.dataset).map_err(CliError::from_display)?;
    let pair = pairs.get(args.pair).ok_or_else(|| {
        CliError(format!(
            "{}: --pair {} but the data set has {} pairs",
            args.dataset.display(),
            args.pair,
            pairs.len()
        ))
    })?;
    if !(200..=10_000).contains(&args.width) {
        return Err(CliError(format!(
            "--width {}: expected 200..=10000 pixels",
            args.width
        )));
    }
    let mut picture = PairPicture::new(pair);
    picture.width = args.width;
    picture.boxes = !args.no_boxes;
    if let Some(v) = &args.view {
        let ok = v.len() == 4 && v.iter().all(|x| x.is_finite()) && v[0] < v[1] && v[2] < v[3];
        if !ok {
            return Err(CliError(format!(
                "--view {v:?}: expected x_min,x_max,y_min,y_max with x_min < x_max and y_min < y_max"
            )));
        }
        picture.view = Some([v[0], v[1], v[2], v[3]]);
    }
    picture
        .write_svg(&args.svg)
        .map_err(CliError::from_display)?;
    eprintln!(
        "pgm: drew pair {} ({}) into {}",
        args.pair,
        pair.name,
        args.svg.display()
    );
    Ok(ExitCode::SUCCESS)
}
