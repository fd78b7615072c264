//! Markdown sections: each suite's table lives between its own markers in the markdown file and
//! is replaced there (or appended when the markers are missing), never touching the text around
//! it. Also what every section says about its run: the command, the date, the machine and its
//! 1-minute load average at the start and end of the run, and how runs were pinned.

use crate::common::{io_error, write_file};
use crate::CliResult;
use std::path::Path;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// A section's markers, `<!-- name:begin -->` and `<!-- name:end -->`.
#[derive(Debug, Clone, Copy)]
pub struct Markers {
    pub name: &'static str,
}

impl Markers {
    pub fn begin(self) -> String {
        format!("<!-- {}:begin -->", self.name)
    }
    pub fn end(self) -> String {
        format!("<!-- {}:end -->", self.name)
    }
}

/// Reads the markdown file, or `None` when it does not exist yet.
pub fn read(path: &Path) -> CliResult<Option<String>> {
    match std::fs::read_to_string(path) {
        Ok(text) => Ok(Some(text)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_error(path, e)),
    }
}

/// Replaces the section of `markers` in the file at `path` with `body` (written between the
/// markers), re-reading the file so that sections written by one run one after another all stay.
pub fn write_section(path: &Path, markers: Markers, body: &str) -> CliResult<()> {
    let section = format!("{}\n{body}{}", markers.begin(), markers.end());
    let merged = merge(read(path)?.as_deref(), &section, path, markers)?;
    write_file(path, &merged)
}

/// Checks before a long run that the section can be written (its markers are balanced).
pub fn check(path: &Path, markers: Markers) -> CliResult<()> {
    merge(read(path)?.as_deref(), "", path, markers).map(drop)
}

/// `existing` with its section between the markers replaced by `section`, or `section` appended
/// when there are no markers. Unbalanced markers are an error: guessing could delete user text.
fn merge(existing: Option<&str>, section: &str, path: &Path, markers: Markers) -> CliResult<String> {
    let (begin_marker, end_marker) = (markers.begin(), markers.end());
    let Some(text) = existing else {
        return Ok(format!("# Benchmarks\n\n{section}\n"));
    };
    match (text.find(&begin_marker), text.find(&end_marker)) {
        (Some(begin), Some(end)) if begin < end => {
            Ok(format!("{}{section}{}", &text[..begin], &text[end + end_marker.len()..]))
        }
        (None, None) => {
            let separator = if text.is_empty() || text.ends_with("\n\n") {
                ""
            } else if text.ends_with('\n') {
                "\n"
            } else {
                "\n\n"
            };
            Ok(format!("{text}{separator}{section}\n"))
        }
        _ => Err(format!(
            "{}: the markers {begin_marker} and {end_marker} are unbalanced or out of order; fix them by hand",
            path.display()
        )),
    }
}

/// A child's message made safe inside a markdown table row.
pub fn table_cell(message: &str) -> String {
    message.replace('|', "\\|").replace('\n', " ")
}

/// A link to `file` as seen from the markdown file at `markdown`.
pub fn link(markdown: &Path, file: &Path) -> String {
    let base = markdown.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    file.strip_prefix(base).unwrap_or(file).display().to_string()
}

/// What a suite's sections say about the run: captured at its start, read again at each write.
pub struct RunInfo {
    command: String,
    date: String,
    started: Instant,
    load_at_start: Option<f64>,
    cpu: Option<usize>,
}

impl RunInfo {
    /// Captures the command line, the date and the load average now, at the start of a run whose
    /// children are pinned to `cpu`.
    pub fn start(cpu: Option<usize>) -> RunInfo {
        let command: Vec<String> =
            std::env::args().skip(1).map(|a| if a.contains(' ') { format!("'{a}'") } else { a }).collect();
        RunInfo {
            command: command.join(" "),
            date: utc_now(),
            started: Instant::now(),
            load_at_start: load_average(),
            cpu,
        }
    }

    /// The lines under a section's heading: command, date, duration so far, machine, load and pinning.
    pub fn header(&self) -> String {
        let load = |l: Option<f64>| l.map_or("unknown".to_string(), |l| format!("{l:.2}"));
        let pinned = match self.cpu {
            Some(cpu) => format!("every run a child process pinned to core {cpu} with taskset"),
            None => "runs not pinned (taskset missing)".to_string(),
        };
        format!(
            "Produced by `vadop-bench {}` on {} in {:.1} minutes.  \nMachine: {}; 1-minute load average {} at the start, {} at the end; {pinned}.\n",
            self.command,
            self.date,
            self.started.elapsed().as_secs_f64() / 60.0,
            machine(),
            load(self.load_at_start),
            load(load_average()),
        )
    }

    /// The command line, as the header quotes it.
    pub fn command(&self) -> &str {
        &self.command
    }
}

/// A number from a /proc file: the first field after `key` on its line.
fn proc_number(path: &str, key: &str) -> Option<f64> {
    let text = std::fs::read_to_string(path).ok()?;
    text.lines().find_map(|line| line.strip_prefix(key))?.split_whitespace().next()?.parse().ok()
}

/// The 1-minute load average.
fn load_average() -> Option<f64> {
    proc_number("/proc/loadavg", "")
}

/// Peak resident memory of this process in MiB (VmHWM).
pub fn peak_memory_mib() -> Option<f64> {
    proc_number("/proc/self/status", "VmHWM:").map(|kib| kib / 1024.0)
}

/// CPU model, core count and total memory.
fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|line| line.starts_with("model name"))
        .and_then(|line| line.split(':').nth(1))
        .map_or("unknown CPU".to_string(), |model| model.trim().to_string());
    let cores = std::thread::available_parallelism().map_or("unknown".to_string(), |n| n.to_string());
    let memory = proc_number("/proc/meminfo", "MemTotal:")
        .map_or("unknown".to_string(), |kib| format!("{:.1} GiB", kib / (1024.0 * 1024.0)));
    format!("{cpu}, {cores} cores available, {memory} memory")
}

/// The current UTC date and time, without a date crate.
fn utc_now() -> String {
    let seconds = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    // Howard Hinnant's days-from-civil inverse, for the proleptic Gregorian calendar.
    let z = (seconds / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era = (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let shifted_month = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * shifted_month + 2) / 5 + 1;
    let month = if shifted_month < 10 { shifted_month + 3 } else { shifted_month - 9 };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    let minutes = seconds % 86_400 / 60;
    format!("{year:04}-{month:02}-{day:02} {:02}:{:02} UTC", minutes / 60, minutes % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_replace_only_between_markers() {
        let markers = Markers { name: "core-benchmark" };
        let (begin, end) = (markers.begin(), markers.end());
        let path = Path::new("B.md");
        let section = format!("{begin}\nnew\n{end}");
        let text = format!("# Top\n\n{begin}\nold\n{end}\n\nTail\n");
        assert_eq!(merge(Some(&text), &section, path, markers).unwrap(), format!("# Top\n\n{section}\n\nTail\n"));
        assert_eq!(merge(Some("# Top\n"), &section, path, markers).unwrap(), format!("# Top\n\n{section}\n"));
        assert!(merge(None, &section, path, markers).unwrap().contains(&section));
        assert!(merge(Some(&format!("{end}{begin}")), &section, path, markers).is_err());
    }

    #[test]
    fn proc_numbers_parse() {
        assert!(load_average().is_some_and(|l| l >= 0.0));
        assert!(peak_memory_mib().is_some_and(|m| m > 0.0));
    }
}
