//! Progress of a suite: an indicatif bar on a terminal, and one line per finished run either way
//! (a log file of a long run shows where it is; the bar alone would be hidden there).

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

pub struct Progress {
    bar: ProgressBar,
    terminal: bool,
}

impl Progress {
    pub fn new(total: usize) -> Progress {
        let bar = ProgressBar::new(total as u64);
        // The template is fixed, so this never fails; the default style would do anyway.
        if let Ok(style) =
            ProgressStyle::with_template("{bar:40} {pos}/{len} runs [{elapsed_precise} < {eta_precise}] {msg}")
        {
            bar.set_style(style);
        }
        Progress { bar, terminal: std::io::stderr().is_terminal() }
    }

    /// Names the run under way.
    pub fn start(&self, what: &str) {
        self.bar.set_message(what.to_string());
    }

    /// Counts one run as done and prints `line` about it.
    pub fn done(&self, line: &str) {
        self.bar.inc(1);
        if self.terminal {
            self.bar.println(line);
        } else {
            eprintln!("[{}/{}] {line}", self.bar.position(), self.bar.length().unwrap_or(0));
        }
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
