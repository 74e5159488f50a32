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
    #[arg(long, allow_hyphen_values = true, value_parser = parse_view, value_name = "X_MIN,X_MAX,Y_MIN,Y_MAX")]
    pub view: Option<[f64; 4]>,
    /// Width of the picture in pixels.
    #[arg(long, default_value_t = 900)]
    pub width: u32,
    /// Leave out the boxes around moving clusters.
    #[arg(long)]
    pub no_boxes: bool,
}

/// Runs `pgm plot`.
pub fn run(args: PlotArgs) -> CliResult {
    super::check_output_file(&args.svg)?;
    if !(200..=10_000).contains(&args.width) {
        return Err(CliError(format!(
            "--width {}: expected 200..=10000 pixels",
            args.width
        )));
    }
    // Only the pair asked for is read: a damaged file of another pair does not matter.
    let (pair, count) = pgm::datasets::read_chosen_pair(&args.dataset, |_| Some(args.pair))
        .map_err(CliError::from_display)?;
    let pair = pair.ok_or_else(|| {
        CliError(format!(
            "{}: --pair {} but the data set has {count} pairs",
            args.dataset.display(),
            args.pair,
        ))
    })?;
    let mut picture = PairPicture::new(&pair);
    picture.width = args.width;
    picture.boxes = !args.no_boxes;
    picture.view = args.view;
    let svg = picture.to_svg_string().map_err(CliError::from_display)?;
    pgm::datasets::format::write_atomically(&args.svg, svg.as_bytes())
        .map_err(CliError::from_display)?;
    eprintln!(
        "pgm: drew pair {} ({}) into {}",
        args.pair,
        pair.name,
        args.svg.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Parses `--view x_min,x_max,y_min,y_max` (negative numbers included: the value is
/// one token, so `--view -5,5,-3,3` and `--view=-5,5,-3,3` both work).
pub fn parse_view(text: &str) -> Result<[f64; 4], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{text:?}: {e}; expected x_min,x_max,y_min,y_max in metres"))?;
    match values[..] {
        [x0, x1, y0, y1] => pgm::plot::check_view([x0, x1, y0, y1])
            .map(|()| [x0, x1, y0, y1])
            .map_err(|e| format!("{text:?}: {e}")),
        _ => Err(format!(
            "{text:?}: expected four numbers x_min,x_max,y_min,y_max (metres)"
        )),
    }
}
