//! One module per subcommand family. Each exposes clap `Args` structs and a `run`
//! function returning `Result<ExitCode, CliError>`.

pub mod cluster;
pub mod data;
pub mod demo;
pub mod eval;
pub mod eval_clustering;
pub mod infer;
pub mod joint;
pub mod matching;
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

/// Checks before a long run that a file can be written at `path`: its directory
/// exists and `path` is not a directory, so that a run does not print its results and
/// then fail on the output file. Commands that can stage their output beside its
/// destination before printing (`pgm cluster --svg`, `pgm sim --svg`) do that instead.
pub fn check_output_file(path: &std::path::Path) -> Result<(), CliError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => std::path::Path::new("."),
    };
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
    Ok(())
}

/// Result type of subcommands.
pub type CliResult = Result<std::process::ExitCode, CliError>;
