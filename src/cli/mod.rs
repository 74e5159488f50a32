//! One module per subcommand family. Each exposes clap `Args` structs and a `run`
//! function returning `Result<ExitCode, CliError>`.

pub mod cluster;
pub mod data;
pub mod demo;
pub mod eval;
pub mod eval_clustering;
pub mod eval_ego;
pub mod eval_tracking;
pub mod infer;
pub mod joint;
pub mod matching;
pub mod online;
pub mod plot;
pub mod sim;
pub mod track;
pub mod train;

use std::fmt;

/// Any error a subcommand reports: a message that already names the file, line and
/// value it concerns.
#[derive(Debug)]
pub struct CliError(pub String);

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CliError {}

impl CliError {
    /// Wraps any displayable error.
    pub fn from_display(e: impl fmt::Display) -> Self {
        CliError(e.to_string())
    }
}

/// `x` with `digits` decimals, or `-` where there is no value (a table cell).
pub fn or_dash(x: Option<f64>, digits: usize) -> String {
    x.map_or("-".into(), |x| format!("{x:.digits$}"))
}

/// `value` as one line of JSON, the form of every machine-readable result.
pub fn to_json(value: &impl serde::Serialize) -> Result<String, CliError> {
    serde_json::to_string(value).map_err(CliError::from_display)
}

/// Prints `value` on stdout as one line of JSON (what `--json` asks for).
pub fn print_json(value: &impl serde::Serialize) -> Result<(), CliError> {
    println!("{}", to_json(value)?);
    Ok(())
}

/// Checks before a long run that a file can be written at `path`: its directory
/// exists and `path` is not a directory, so that a run does not print its results and
/// then fail on the output file; and that writing it (beside it, then renamed into
/// place) cannot destroy something that is not a plain file: a device, a pipe, a
/// socket or a symbolic link at `path` is refused. Commands that can stage their
/// output beside its destination before printing (`pgm cluster --svg`, `pgm sim
/// --svg`) do that instead.
pub fn check_output_file(path: &std::path::Path) -> Result<(), CliError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => std::path::Path::new("."),
    };
    if !dir.exists() {
        return Err(CliError(format!(
            "{}: cannot write here: the directory {} does not exist",
            path.display(),
            dir.display()
        )));
    }
    if !dir.is_dir() {
        return Err(CliError(format!(
            "{}: cannot write here: {} is not a directory",
            path.display(),
            dir.display()
        )));
    }
    if path.is_dir() {
        return Err(CliError(format!(
            "{}: is a directory, not a file to write",
            path.display()
        )));
    }
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        let kind = meta.file_type();
        if kind.is_symlink() {
            return Err(CliError(format!(
                "{}: is a symbolic link; writing would replace the link by a file (name the \
                 file it points to)",
                path.display()
            )));
        }
        if !kind.is_file() {
            return Err(CliError(format!(
                "{}: exists and is not a plain file (a device, pipe or socket); refusing to \
                 replace it",
                path.display()
            )));
        }
    }
    Ok(())
}

/// The file an output path names, whether it exists or not: its directory resolved
/// (symbolic links, `.`, `..`) and its file name; `None` when the directory does not
/// exist or the path has no file name.
pub fn resolved_output(path: &std::path::Path) -> Option<std::path::PathBuf> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => std::path::Path::new("."),
    };
    Some(dir.canonicalize().ok()?.join(path.file_name()?))
}

/// Refuses an output file `path` that is one of the `inputs` (files or data set
/// directories) or lies inside an input directory: writing it would replace the data
/// being read (a data set's `index.json`, a log).
pub fn check_not_an_input(
    path: &std::path::Path,
    inputs: &[&std::path::Path],
) -> Result<(), CliError> {
    let Some(target) = resolved_output(path) else {
        return Ok(());
    };
    for input in inputs {
        let Ok(input) = input.canonicalize() else {
            continue;
        };
        if target == input || (input.is_dir() && target.starts_with(&input)) {
            return Err(CliError(format!(
                "{}: is (or lies inside) the input {}; refusing to write over the data \
                 being read",
                path.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// Checks a command's output files before it runs: each one as
/// [`check_output_file`] and [`check_not_an_input`], and no two naming the same file.
/// `outputs` pairs each option (`"--svg"`) with its path, if given.
pub fn check_outputs(
    outputs: &[(&str, Option<&std::path::Path>)],
    inputs: &[&std::path::Path],
) -> Result<(), CliError> {
    let given: Vec<(&str, &std::path::Path)> = outputs
        .iter()
        .filter_map(|(flag, path)| path.map(|p| (*flag, p)))
        .collect();
    for (_, path) in &given {
        check_output_file(path)?;
        check_not_an_input(path, inputs)?;
    }
    for (i, (flag_a, a)) in given.iter().enumerate() {
        for (flag_b, b) in &given[i + 1..] {
            if a == b || resolved_output(a).is_some_and(|r| Some(r) == resolved_output(b)) {
                return Err(CliError(format!(
                    "{flag_a} {} and {flag_b} {} are the same file",
                    a.display(),
                    b.display()
                )));
            }
        }
    }
    Ok(())
}

/// The files a one-pair command (`pgm match`, `pgm cluster`, `pgm joint`) writes
/// besides the JSON it prints.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct PairOutputArgs {
    /// Draw the pair and the command's result (associations, clusters, motions) into
    /// this SVG file.
    #[arg(long)]
    pub svg: Option<std::path::PathBuf>,
    /// Record the pair and the command's result into this MCAP file for Foxglove:
    /// both scans, the sensor's motion, the clusters with their motions, the
    /// association lines (docs/foxglove.md).
    #[arg(long)]
    pub mcap: Option<std::path::PathBuf>,
}

impl PairOutputArgs {
    /// Checks the files before the command runs ([`check_outputs`]), against the
    /// pair's `inputs`.
    pub fn check(&self, inputs: &[&std::path::Path]) -> Result<(), CliError> {
        check_outputs(
            &[
                ("--svg", self.svg.as_deref()),
                ("--mcap", self.mcap.as_deref()),
            ],
            inputs,
        )
    }

    /// Stages the files of `picture` ([`StagedOutputs::of_pair`]).
    pub fn stage(&self, picture: &pgm::plot::PairPicture<'_>) -> Result<StagedOutputs, CliError> {
        StagedOutputs::of_pair(picture, self.svg.as_deref(), self.mcap.as_deref())
    }
}

/// A command's files of one pair (`--svg` picture, `--mcap` recording), staged
/// beside their destinations before the command prints its result and renamed into
/// place after ([`StagedOutputs::commit`]): a command that fails writes nothing.
#[derive(Debug, Default)]
pub struct StagedOutputs(
    Vec<(
        pgm_datasets::format::StagedFile,
        &'static str,
        std::path::PathBuf,
    )>,
);

impl StagedOutputs {
    /// Stages `picture` as an SVG file at `svg` and as an MCAP recording
    /// ([`pgm::foxglove::pair_recording`]) at `mcap`, each when given.
    pub fn of_pair(
        picture: &pgm::plot::PairPicture<'_>,
        svg: Option<&std::path::Path>,
        mcap: Option<&std::path::Path>,
    ) -> Result<Self, CliError> {
        let mut staged = StagedOutputs::default();
        if let Some(path) = svg {
            let text = picture.to_svg_string().map_err(CliError::from_display)?;
            staged.stage(path, text.as_bytes(), "drew")?;
        }
        if let Some(path) = mcap {
            let bytes = pgm::foxglove::pair_recording(picture)
                .map_err(|e| CliError(format!("--mcap {}: {e}", path.display())))?;
            staged.stage(path, &bytes, "recorded")?;
        }
        Ok(staged)
    }

    /// Stages `bytes` for `path`; `verb` says what the commit message reports.
    pub fn stage(
        &mut self,
        path: &std::path::Path,
        bytes: &[u8],
        verb: &'static str,
    ) -> Result<(), CliError> {
        let file =
            pgm_datasets::format::StagedFile::stage(path, bytes).map_err(CliError::from_display)?;
        self.0.push((file, verb, path.to_path_buf()));
        Ok(())
    }

    /// Renames every staged file into place, reporting each on stderr as `what`.
    pub fn commit(self, what: &str) -> Result<(), CliError> {
        for (file, verb, path) in self.0 {
            file.commit().map_err(CliError::from_display)?;
            eprintln!("pgm: {verb} {what} into {}", path.display());
        }
        Ok(())
    }

    /// Renames every staged file into place, for a command that reports them itself.
    pub fn commit_quietly(self) -> Result<(), CliError> {
        for (file, _, _) in self.0 {
            file.commit().map_err(CliError::from_display)?;
        }
        Ok(())
    }
}

/// Result type of subcommands.
pub type CliResult = Result<std::process::ExitCode, CliError>;

/// Parses a scan distance (`--k`): a whole number of scans. A negative one is refused
/// here, naming the value (clap would otherwise read `-3` as an unknown option); 0
/// reaches the command's own check, which says why a pair needs two scans.
pub fn parse_scan_distance(text: &str) -> Result<usize, String> {
    let t = text.trim();
    match t.parse::<i128>() {
        Ok(v) if v < 0 => Err(format!(
            "{v}: a scan distance is a whole number of scans >= 1, not negative"
        )),
        Ok(v) => usize::try_from(v).map_err(|_| format!("{v}: too large a scan distance")),
        Err(_) => Err(format!("{t:?}: expected a whole number of scans >= 1")),
    }
}
