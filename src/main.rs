//! The `pgm` command-line tool. Results go to stdout, diagnostics to stderr; every
//! error names the file, line and value it came from and exits with status 2.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cli;

/// Conditional random fields and hybrid factor graphs for 2D laser data.
#[derive(Parser)]
#[command(name = "pgm", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// MAP (MPE) assignment of a UAI model by loopy max-product belief propagation.
    Map(cli::infer::InferArgs),
    /// Single-variable marginals of a UAI model by loopy sum-product belief propagation.
    Marginals(cli::infer::InferArgs),
    /// Build scan-pair data sets from real laser logs and summarise them.
    Data(cli::data::DataArgs),
    /// Evaluate methods against ground truth (`pgm eval matching …`).
    Eval(cli::eval::EvalArgs),
    /// Simulate scan pairs and sequences (urban streets, person following) with complete ground truth (`pgm sim --preset mixed --pairs 100 --out DIR`).
    Sim(cli::sim::SimArgs),
    /// Draw one pair of a data set as SVG, coloured by ground truth.
    Plot(cli::plot::PlotArgs),
    /// CRF-Clustering of one scan pair: JSON clusters and motions, optional SVG.
    Cluster(cli::cluster::ClusterArgs),
    /// CRF-Matching of one scan pair: JSON associations and motion, optional SVG.
    Match(cli::matching::MatchArgs),
    /// The joint model on one scan pair: JSON associations, clusters and motions, optional SVG.
    Joint(cli::joint::JointArgs),
    /// Moving objects tracked over a whole log or bag (`pgm track --method crf --bag FILE --scan-topic T`): JSON per scan, no ground truth needed.
    Track(cli::track::TrackArgs),
    /// Learn model weights from labelled pairs (`pgm train clustering …`).
    Train(cli::train::TrainArgs),
    /// CRF-Clustering, the joint model and the joint paper's methods on the built-in
    /// simulator: summary tables and two SVGs (crf-clustering.svg, joint.svg).
    Demo(cli::demo::DemoArgs),
}

fn main() -> ExitCode {
    quiet_on_closed_stdout();
    clean_up_on_signals();
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Map(args) => cli::infer::run(args, cli::infer::Task::Map),
        Command::Marginals(args) => cli::infer::run(args, cli::infer::Task::Marginals),
        Command::Data(args) => cli::data::run(args),
        Command::Eval(args) => cli::eval::run(args),
        Command::Sim(args) => cli::sim::run(args),
        Command::Plot(args) => cli::plot::run(args),
        Command::Cluster(args) => cli::cluster::run(args),
        Command::Match(args) => cli::matching::run_match(args),
        Command::Joint(args) => cli::joint::run_joint(args),
        Command::Track(args) => cli::track::run(args),
        Command::Train(args) => cli::train::run(args),
        Command::Demo(args) => cli::demo::run(args),
    };
    match outcome {
        Ok(code) => code,
        Err(err) => {
            eprintln!("pgm: error: {err}");
            ExitCode::from(2)
        }
    }
}

/// On SIGINT (Ctrl-C) or SIGTERM: remove every output file this process has started
/// and not finished ([`pgm_core::fsutil::remove_unfinished`]: temporary files, a data
/// set half-written by `pgm sim --out` or `pgm data pairs --out`), say so on stderr,
/// and exit with status 128 + the signal (130, 143), as a shell reports a process
/// stopped by it. Without this, the default action would stop the process wherever
/// it is and leave its temporary files behind. If the handler cannot be installed,
/// the default action stays (and the next write cleans up after it).
#[cfg(unix)]
fn clean_up_on_signals() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let name = if signal == SIGINT {
                "SIGINT"
            } else {
                "SIGTERM"
            };
            let removed = pgm_core::fsutil::remove_unfinished();
            let what = match removed {
                0 => String::new(),
                1 => ": removed 1 unfinished output".to_string(),
                n => format!(": removed {n} unfinished outputs (files and directories)"),
            };
            eprintln!("pgm: stopped by {name}{what}");
            std::process::exit(128 + signal);
        }
    });
}

#[cfg(not(unix))]
fn clean_up_on_signals() {}

/// Rust ignores SIGPIPE, so printing to a closed pipe (`pgm … | head`) panics with
/// "failed printing to stdout: Broken pipe". The reader has what it wanted: end
/// quietly (status 0), as Unix filters do. Any other failure to print the result (a
/// full disk, `> /dev/full`) is an error like every other: a message on stderr and
/// status 2, not a panic; a failure to print to stderr ends with status 2 too. Every
/// other panic keeps its report.
fn quiet_on_closed_stdout() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to stderr") {
            // Nowhere left to say it: the status says it.
            std::process::exit(2);
        }
        if message.starts_with("failed printing to stdout") {
            if message.contains("Broken pipe") {
                std::process::exit(0);
            }
            eprintln!("pgm: error: cannot write the result to standard output: {message}");
            std::process::exit(2);
        }
        report(info);
    }));
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::CommandFactory;

    /// The CLI reference in the book, generated from the clap definitions above.
    fn reference() -> String {
        let options = clap_markdown::MarkdownOptions::new()
            .title("The `pgm` command line".to_string())
            .show_footer(false);
        let body = clap_markdown::help_markdown_custom::<Cli>(&options);
        format!(
            "<!-- Generated from the clap definitions by `PGM_BLESS=1 cargo test --release --bin pgm cli_reference`; do not edit. -->\n\n{body}"
        )
    }

    /// docs/cli.md is the generated reference: a change to an option that is not
    /// written there fails here (regenerate with `PGM_BLESS=1 cargo test --release
    /// --bin pgm cli_reference`).
    #[test]
    fn cli_reference_is_current() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/cli.md");
        let expected = reference();
        if std::env::var_os("PGM_BLESS").is_some() {
            std::fs::write(path, &expected).unwrap();
        }
        let written = std::fs::read_to_string(path).unwrap_or_default();
        assert!(
            written == expected,
            "docs/cli.md is stale: regenerate it with `PGM_BLESS=1 cargo test --release --bin pgm cli_reference`"
        );
    }

    /// `pgm CMD -h` fits on a screen: at most 40 lines for every command and
    /// subcommand (the long help, `--help`, says everything).
    #[test]
    fn short_help_fits_on_a_screen() {
        fn walk(command: &mut clap::Command, path: &str, long: &mut Vec<String>) {
            let text = command.render_help().to_string();
            let lines = text.lines().count();
            if lines > 40 {
                long.push(format!("`{path} -h`: {lines} lines"));
            }
            let names: Vec<String> = command
                .get_subcommands()
                .map(|c| c.get_name().to_string())
                .collect();
            for name in names {
                if let Some(sub) = command.find_subcommand_mut(&name) {
                    walk(sub, &format!("{path} {name}"), long);
                }
            }
        }
        let mut command = Cli::command();
        command.build();
        let mut long = Vec::new();
        walk(&mut command, "pgm", &mut long);
        assert!(long.is_empty(), "short help too long: {}", long.join(", "));
    }

    /// Every registered method is reachable from every command that takes
    /// `--method` (or `--associations`): the command offers exactly the names of its
    /// interface's table in `pgm::methods`, and each name builds with the default
    /// options.
    #[test]
    fn every_registered_method_is_reachable_from_every_command() {
        use pgm::methods::{
            association_source, clusterer, joint_estimator, scan_matcher, MethodOptions,
            ASSOCIATION_SOURCES, CLUSTERERS, JOINT_ESTIMATORS, SCAN_MATCHERS,
        };
        let options = MethodOptions::default();
        fn names<B>(table: &[pgm::methods::Method<B>]) -> Vec<String> {
            table.iter().map(|m| m.name.to_string()).collect()
        }
        for name in ASSOCIATION_SOURCES.iter().map(|m| m.name) {
            assert!(association_source(name, &options).is_ok(), "{name}");
        }
        for name in CLUSTERERS.iter().map(|m| m.name) {
            let icp = association_source("icp", &options).unwrap();
            assert!(clusterer(name, icp, &options).is_ok(), "{name}");
        }
        for name in SCAN_MATCHERS.iter().map(|m| m.name) {
            assert!(scan_matcher(name, &options).is_ok(), "{name}");
        }
        for name in JOINT_ESTIMATORS.iter().map(|m| m.name) {
            assert!(joint_estimator(name, &options).is_ok(), "{name}");
        }
        // Which table each command's `--method` offers.
        let expected: &[(&str, Vec<String>)] = &[
            ("pgm eval matching", names(SCAN_MATCHERS)),
            ("pgm eval clustering", names(CLUSTERERS)),
            ("pgm eval association", names(ASSOCIATION_SOURCES)),
            ("pgm eval joint", names(JOINT_ESTIMATORS)),
            ("pgm track", names(CLUSTERERS)),
            ("pgm eval tracking", names(CLUSTERERS)),
            ("pgm eval ego-motion", names(CLUSTERERS)),
        ];
        fn walk(
            command: &clap::Command,
            path: &str,
            found: &mut Vec<(String, String, Vec<String>)>,
        ) {
            for arg in command.get_arguments() {
                let id = arg.get_id().as_str();
                if id == "method" || id == "associations" {
                    let values = arg
                        .get_possible_values()
                        .iter()
                        .map(|v| v.get_name().to_string())
                        .collect();
                    found.push((path.to_string(), id.to_string(), values));
                }
            }
            for sub in command.get_subcommands() {
                walk(sub, &format!("{path} {}", sub.get_name()), found);
            }
        }
        let mut command = Cli::command();
        command.build();
        let mut found = Vec::new();
        walk(&command, "pgm", &mut found);
        for (path, id, values) in &found {
            if path.starts_with("pgm train") {
                // Training chooses which associations to learn from (`both` included),
                // not a method to run.
                continue;
            }
            let table = if id == "associations" {
                names(ASSOCIATION_SOURCES)
            } else {
                expected
                    .iter()
                    .find(|(p, _)| p == path)
                    .unwrap_or_else(|| {
                        panic!("`{path} --method`: add the command to this test's table")
                    })
                    .1
                    .clone()
            };
            assert_eq!(values, &table, "`{path} --{id}`");
        }
        for (path, _) in expected {
            assert!(
                found.iter().any(|(p, id, _)| p == path && id == "method"),
                "`{path}` has no --method"
            );
        }
    }
}
