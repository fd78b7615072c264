//! The terminal, for every command: writing to stdout, where a closed pipe is an error message and
//! never a panic, and progress bars on stderr, hidden until a run has lasted long enough to want
//! one and never drawn into a pipe or a file. It never formats what it prints.

use crate::CliResult;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};

/// Writes to stdout, turning a closed pipe into an error message instead of a panic.
pub fn print(text: &str) -> CliResult<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes()).and_then(|()| out.flush()).map_err(|e| format!("stdout: {e}"))
}

/// A progress bar on stderr that stays invisible until `reveal` is called.
pub fn progress_bar(total: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    let template = format!("{{bar:40}} {{pos}}/{{len}} {unit} [{{elapsed_precise}} < {{eta_precise}}] {{msg}}");
    // The template is fixed, so this never fails; keeping the default style would be fine anyway.
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style);
    }
    bar
}

/// Starts drawing `bar`, unless stderr is not a terminal (a pipe or a file would fill with
/// control sequences).
pub fn reveal(bar: &ProgressBar) {
    if std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::stderr());
    }
}
