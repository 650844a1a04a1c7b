//! `r2p`: the R2P host tool. See `r2p --help`.

use std::process::ExitCode;

use clap::Parser;
use r2p_cli::cli::{run, Cli};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli, &mut std::io::stdout().lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("r2p: error: {e}");
            ExitCode::FAILURE
        }
    }
}
