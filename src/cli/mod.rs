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

/// Result type of subcommands.
pub type CliResult = Result<std::process::ExitCode, CliError>;
