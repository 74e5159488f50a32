//! `pgm sim`: simulate scan pairs (urban streets, or a robot following a person) with
//! complete ground truth, write them as a data set, print their statistics, draw one of them.

use super::{CliError, CliResult};
use clap::Args;
use pgm::datasets::format::StagedFile;
use pgm::datasets::sim::{
    simulate_pairs_report, simulate_sequence, DatasetStats, Preset, SimConfig, SCENE_ATTEMPTS,
};
use pgm::plot::PairPicture;
use pgm::scan::ParamGuard;
use std::path::PathBuf;
use std::process::ExitCode;

/// Options of `pgm sim`.
#[derive(Args, Debug)]
pub struct SimArgs {
    /// Scene preset: overtaking, intersection, oncoming, pedestrians, mixed, random,
    /// following (urban streets, 361 beams over 180°, 80 m, wheel odometry), or
    /// person-following (a robot following a walking person outdoors, with its own
    /// laser: 10 Hz, 245 beams over 86°, 5.6 m; no odometry in its pairs or scans).
    #[arg(long, default_value = "mixed")]
    pub preset: String,
    /// Seed of the random streams (pair i uses ChaCha8 stream i of this seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of pairs.
    #[arg(long, default_value_t = 100)]
    pub pairs: usize,
    /// Write the pairs as a data set into this directory (index.json + pair files): a
    /// new or empty directory, or one holding a data set, which is replaced (see
    /// datasets/FORMAT.md; other files are never removed).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the data set statistics as a Markdown table on stdout (the default when
    /// neither --out nor --svg is given).
    #[arg(long)]
    pub stats: bool,
    /// Draw one pair, coloured by ground truth, into this SVG file.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Which pair --svg draws (index from 0).
    #[arg(long, default_value_t = 0)]
    pub svg_pair: usize,
    /// Number of laser beams over the field of view [default: the preset's laser: 361,
    /// person-following 245].
    #[arg(long, hide_short_help = true)]
    pub beams: Option<usize>,
    /// Field of view of the laser in degrees, centred ahead [default: the preset's
    /// laser: 180, person-following 86].
    #[arg(long, value_name = "DEGREES", hide_short_help = true)]
    pub field_of_view: Option<f64>,
    /// Maximum range of the laser in metres [default: the preset's laser: 80,
    /// person-following 5.6].
    #[arg(long, value_name = "METRES", hide_short_help = true)]
    pub max_range: Option<f64>,
    /// Standard deviation of the range noise in metres.
    #[arg(long, default_value_t = 0.03, hide_short_help = true)]
    pub range_noise: f64,
    /// Probability of a missing return.
    #[arg(long, default_value_t = 0.01, hide_short_help = true)]
    pub dropout: f64,
    /// Smallest ego travel between the two scans of a pair, in metres (not used by
    /// person-following, whose pairs are 0.3-0.8 s of its 10 Hz scans apart).
    #[arg(long, default_value_t = 2.0, hide_short_help = true)]
    pub min_distance: f64,
    /// Largest ego travel between the two scans of a pair, in metres (not used by
    /// person-following).
    #[arg(long, default_value_t = 4.0, hide_short_help = true)]
    pub max_distance: f64,
    /// Odometry noise: standard deviation of the x and y error per metre travelled
    /// (person-following has no odometry).
    #[arg(long, default_value_t = 0.02, hide_short_help = true)]
    pub odometry_translation_noise: f64,
    /// Odometry noise: standard deviation of the heading error (rad) per metre travelled
    /// (person-following has no odometry).
    #[arg(long, default_value_t = 0.003, hide_short_help = true)]
    pub odometry_rotation_noise: f64,
    /// Pair selection: every moving object in the current scan must have at least this
    /// many returns seen in the reference scan (true associations), else the scene is
    /// drawn again; 0 keeps every pair.
    #[arg(long, default_value_t = 3, hide_short_help = true)]
    pub min_object_returns: usize,
    /// Sequences instead of independent pairs: each of the --pairs draws becomes a
    /// sequence of this many scans of one scene, written as the pairs --k scans apart
    /// (for `pgm eval clustering --track` and `pgm track`; no pair selection).
    #[arg(long)]
    pub sequence: Option<usize>,
    /// With --sequence: the scan distance of the pairs (1; each pair spans the
    /// preset's interval between two scans; person-following scans every 0.1 s
    /// whatever --k, so its pairs span k × 0.1 s).
    #[arg(long, requires = "sequence", allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: Option<usize>,
}

/// Runs `pgm sim`.
pub fn run(args: SimArgs) -> CliResult {
    if let Some(svg) = &args.svg {
        super::check_output_file(svg)?;
    }
    let preset: Preset = args.preset.parse().map_err(CliError::from_display)?;
    // The preset's own laser unless a flag says otherwise.
    let base = SimConfig::for_preset(preset);
    let config = SimConfig {
        preset,
        beams: args.beams.unwrap_or(base.beams),
        field_of_view: args
            .field_of_view
            .map_or(base.field_of_view, f64::to_radians),
        max_range: args.max_range.unwrap_or(base.max_range),
        range_noise: args.range_noise,
        dropout: args.dropout,
        pair_distance: [args.min_distance, args.max_distance],
        odometry_translation_noise: args.odometry_translation_noise,
        odometry_rotation_noise: args.odometry_rotation_noise,
        min_object_returns: args.min_object_returns,
        ..base
    }
    .check()
    .map_err(CliError::from_display)?;
    let k = args.k.unwrap_or(1);
    let total = match args.sequence {
        Some(scans) => {
            if k == 0 || k >= scans {
                return Err(CliError(format!(
                    "--sequence {scans} --k {k}: pairs k scans apart need 1 <= k < the \
                     number of scans"
                )));
            }
            args.pairs.checked_mul(scans - k).ok_or_else(|| {
                CliError(format!(
                    "--pairs {} --sequence {scans}: too many pairs",
                    args.pairs
                ))
            })?
        }
        None => args.pairs,
    };
    config.check_pairs(total).map_err(CliError::from_display)?;
    if args.svg.is_some() && args.svg_pair >= total {
        return Err(CliError(format!(
            "--svg-pair {} is not one of the {total} simulated pairs (0..{total})",
            args.svg_pair
        )));
    }
    let pairs = match args.sequence {
        Some(scans) => (0..args.pairs as u64)
            .flat_map(|index| simulate_sequence(&config, args.seed, index, scans, k))
            .collect::<Vec<_>>(),
        None => {
            let report = simulate_pairs_report(&config, args.seed, args.pairs);
            if !report.unmet.is_empty() {
                let shown: Vec<String> =
                    report.unmet.iter().take(5).map(|u| u.to_string()).collect();
                eprintln!(
                    "note: {} of {} pairs (preset {preset}, seed {}) do not meet the pair \
                     selection --min-object-returns {} in {SCENE_ATTEMPTS} draws and keep \
                     their last draw: {}{}",
                    report.unmet.len(),
                    args.pairs,
                    args.seed,
                    args.min_object_returns,
                    shown.join(", "),
                    if report.unmet.len() > 5 { ", …" } else { "" }
                );
            }
            report.pairs
        }
    };
    // Both outputs or neither: the picture is staged beside its destination, the data
    // set written, then the picture renamed into place.
    let staged = match &args.svg {
        Some(path) => {
            let svg = PairPicture::new(&pairs[args.svg_pair])
                .to_svg_string()
                .map_err(CliError::from_display)?;
            Some(StagedFile::stage(path, svg.as_bytes()).map_err(CliError::from_display)?)
        }
        None => None,
    };
    if let Some(dir) = &args.out {
        pgm::datasets::write_pairs(dir, &pairs).map_err(CliError::from_display)?;
        eprintln!("pgm: wrote {} pairs to {}", pairs.len(), dir.display());
    }
    if let (Some(staged), Some(path)) = (staged, &args.svg) {
        staged.commit().map_err(CliError::from_display)?;
        eprintln!("pgm: drew pair {} into {}", args.svg_pair, path.display());
    }
    if args.stats || (args.out.is_none() && args.svg.is_none()) {
        print!("{}", DatasetStats::from_pairs(&pairs).to_markdown());
    }
    Ok(ExitCode::SUCCESS)
}
