//! The subcommands of the `lash` binary, one file each, and the one place that turns their
//! results into messages and exit codes.

pub mod bench;
pub mod design;
pub mod diagnose;
pub mod model;
pub mod mr2120;
pub mod progress;
pub mod validate;

use std::process::ExitCode;

/// What a subcommand reports when it ran to the end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Output {
    /// A check or target the command runs failed (a validation limit, the suite's targets).
    pub check_failed: bool,
}

impl Output {
    /// Ran, and every check it makes passed (or it makes none).
    pub const OK: Output = Output { check_failed: false };

    /// Ran; `passed` tells whether its checks passed.
    pub fn checked(passed: bool) -> Output {
        Output {
            check_failed: !passed,
        }
    }
}

/// Why a subcommand stopped.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input: an invalid value, a missing or malformed file, an unknown name.
    #[error("{0}")]
    Input(String),
    /// The run itself failed (a solver gave up, an output could not be written).
    #[error("{0}")]
    Run(String),
}

impl CliError {
    /// Bad input, from anything printable.
    pub fn input(e: impl std::fmt::Display) -> Self {
        CliError::Input(e.to_string())
    }
    /// A failed run, from anything printable.
    pub fn run(e: impl std::fmt::Display) -> Self {
        CliError::Run(e.to_string())
    }
}

/// The exit code of a subcommand's result: 0 success, 1 a check or target failed or the run
/// failed, 2 bad input (clap's usage errors exit with 2 too).
pub fn exit_code(result: &Result<Output, CliError>) -> u8 {
    match result {
        Ok(o) if o.check_failed => 1,
        Ok(_) => 0,
        Err(CliError::Run(_)) => 1,
        Err(CliError::Input(_)) => 2,
    }
}

/// Prints the error, if any, as "error: …" on stderr and returns the exit code.
pub fn exit(result: Result<Output, CliError>) -> ExitCode {
    if let Err(e) = &result {
        eprintln!("error: {e}");
    }
    ExitCode::from(exit_code(&result))
}

/// Splits a comma-separated list into its trimmed, non-empty items.
pub fn items(s: &str) -> impl Iterator<Item = &str> {
    s.split(',').map(str::trim).filter(|x| !x.is_empty())
}

/// The MR2120 points a comma-separated `--points` names (M1, M2, M3), or an input error.
pub fn mr2120_points(s: &str) -> Result<Vec<lash::mechanisms::mr2120::paper::Table2Point>, CliError> {
    items(s)
        .map(|n| {
            lash::mechanisms::mr2120::paper::table2_point(n).ok_or_else(|| {
                CliError::Input(format!("--points: unknown point '{n}'; expected M1, M2 or M3"))
            })
        })
        .collect()
}

/// Pretty JSON of a result the library serialises.
pub fn json(v: &impl serde::Serialize) -> String {
    serde_json::to_string_pretty(v).expect("lash's results serialise")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_separate_failed_checks_from_bad_input() {
        assert_eq!(exit_code(&Ok(Output::OK)), 0);
        assert_eq!(exit_code(&Ok(Output::checked(true))), 0);
        assert_eq!(exit_code(&Ok(Output::checked(false))), 1);
        assert_eq!(exit_code(&Err(CliError::run("solver gave up"))), 1);
        assert_eq!(exit_code(&Err(CliError::input("unknown model"))), 2);
    }

    #[test]
    fn lists_drop_blanks() {
        assert_eq!(items(" a, ,b,").collect::<Vec<_>>(), ["a", "b"]);
    }
}
