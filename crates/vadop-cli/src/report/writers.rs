//! The files a run writes as it goes: the per-frame row (one frame's counters and cost split, in
//! the CSV's column order), the per-frame CSV, the JSON report that streams the rows and ends with
//! the summary, and the buffered output file under them (and under `simulate`'s contacts file),
//! whose every failure is a message naming its path. A row is written when its frame completes and
//! never kept, so a file of any length takes the same memory. It never decides what a summary
//! holds, only how the files hold it.

use super::summary::Summary;
use crate::CliResult;
use serde::Serialize;
use std::fmt;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use vadop::FrameStats;

/// One frame as written to the per-frame CSV and JSON: its counters, the cost split of
/// c_total in milliseconds and the wall-clock time of the whole step.
#[derive(Debug, Clone, Serialize)]
pub struct FrameRow {
    pub frame: u64,
    pub time: f64,
    pub contacts: u64,
    /// Contacts between two moving bodies.
    pub pair_contacts: u64,
    /// Contacts of a moving body with a static body (contacts with walls are the rest).
    #[serde(default)]
    pub static_contacts: u64,
    /// c_total in milliseconds.
    pub ms: f64,
    pub update_ms: f64,
    pub sort_ms: f64,
    pub test_ms: f64,
    pub response_ms: f64,
    pub endpoint_swaps: u64,
    pub list_entries: u64,
    pub candidate_pairs: u64,
    pub narrow_tests: u64,
    pub invalidations: u64,
    /// Wall-clock milliseconds of the step call, which also covers work outside the four stages.
    pub wall_ms: f64,
    pub broad_phase_bytes: u64,
    pub windows: u64,
    pub retests: u64,
    /// Contacts whose physics a rule changed: made elastic by the TC model, resolved by the jam
    /// rule, brought to rest under gravity by the rest rule.
    pub tc_contacts: u64,
    pub jam_contacts: u64,
    #[serde(default)]
    pub rest_contacts: u64,
    /// Contacts between bodies that ended (with --contact-ends).
    #[serde(default)]
    pub contact_ends: u64,
    /// The collisional virial of the frame's impacts between moving bodies (simulate mode).
    #[serde(default)]
    pub pair_virial: f64,
}

impl FrameRow {
    const CSV_HEADER: &'static str = "frame,time,contacts,pair_contacts,ms,update_ms,sort_ms,test_ms,response_ms,\
        endpoint_swaps,list_entries,candidate_pairs,narrow_tests,invalidations,wall_ms,broad_phase_bytes,\
        windows,retests,tc_contacts,jam_contacts,contact_ends,static_contacts,pair_virial,rest_contacts";

    /// A frame's row; `static_contacts` of its body contacts were with static bodies.
    pub fn new(frame: u64, time: f64, stats: &FrameStats, static_contacts: u64, wall_seconds: f64) -> FrameRow {
        FrameRow {
            frame,
            time,
            contacts: stats.contacts,
            // The core counts every contact between two bodies, static ones included.
            pair_contacts: stats.pair_contacts.saturating_sub(static_contacts),
            static_contacts,
            ms: stats.total_seconds() * 1e3,
            update_ms: stats.update_seconds * 1e3,
            sort_ms: stats.sort_seconds * 1e3,
            test_ms: stats.test_seconds * 1e3,
            response_ms: stats.response_seconds * 1e3,
            endpoint_swaps: stats.endpoint_swaps,
            list_entries: stats.list_entries,
            candidate_pairs: stats.candidate_pairs,
            narrow_tests: stats.narrow_tests,
            invalidations: stats.invalidations,
            wall_ms: wall_seconds * 1e3,
            broad_phase_bytes: stats.broad_phase_bytes,
            windows: stats.windows,
            retests: stats.retests,
            tc_contacts: stats.tc_contacts,
            jam_contacts: stats.jam_contacts,
            rest_contacts: stats.rest_contacts,
            contact_ends: stats.contact_ends,
            pair_virial: stats.pair_virial,
        }
    }

    /// The row in the order of `CSV_HEADER`.
    fn csv_line(&self) -> String {
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            self.frame,
            self.time,
            self.contacts,
            self.pair_contacts,
            self.ms,
            self.update_ms,
            self.sort_ms,
            self.test_ms,
            self.response_ms,
            self.endpoint_swaps,
            self.list_entries,
            self.candidate_pairs,
            self.narrow_tests,
            self.invalidations,
            self.wall_ms,
            self.broad_phase_bytes,
            self.windows,
            self.retests,
            self.tc_contacts,
            self.jam_contacts,
            self.contact_ends,
            self.static_contacts,
            self.pair_virial,
            self.rest_contacts
        )
    }
}

/// The message for an I/O failure on `path`.
pub fn io_error(path: &Path, error: impl fmt::Display) -> String {
    format!("{}: {error}", path.display())
}

/// Creates (truncates) an output file; called before a run so a bad path fails before the work.
pub fn create_file(path: &Path) -> CliResult<File> {
    File::create(path).map_err(|e| io_error(path, e))
}

/// An output file written as the run goes, through a buffer.
pub struct OutputFile {
    out: BufWriter<File>,
    path: PathBuf,
}

impl OutputFile {
    /// Creates (truncates) the file; called before a run so a bad path fails before the work.
    fn create(path: &Path) -> CliResult<OutputFile> {
        create_file(path).map(|file| OutputFile::new(file, path))
    }

    /// Writes to `file`, already open, which `path` names in messages.
    pub fn new(file: File, path: &Path) -> OutputFile {
        OutputFile { out: BufWriter::new(file), path: path.to_path_buf() }
    }

    pub fn line(&mut self, line: fmt::Arguments<'_>) -> CliResult<()> {
        writeln!(self.out, "{line}").map_err(|e| io_error(&self.path, e))
    }

    fn json(&mut self, value: &impl Serialize, pretty: bool) -> CliResult<()> {
        let written = if pretty {
            serde_json::to_writer_pretty(&mut self.out, value)
        } else {
            serde_json::to_writer(&mut self.out, value)
        };
        written.map_err(|e| io_error(&self.path, e))
    }

    /// Hands what is buffered to the system.
    pub fn flush(&mut self) -> CliResult<()> {
        self.out.flush().map_err(|e| io_error(&self.path, e))
    }

    /// Flushes, then waits until the data is on the disk.
    pub fn sync(&mut self) -> CliResult<()> {
        self.flush()?;
        self.out.get_ref().sync_data().map_err(|e| io_error(&self.path, e))
    }
}

/// The per-frame CSV: a header, then one line per frame as it completes.
pub struct FramesCsv(OutputFile);

impl FramesCsv {
    pub fn create(path: &Path) -> CliResult<FramesCsv> {
        let mut file = OutputFile::create(path)?;
        file.line(format_args!("{}", FrameRow::CSV_HEADER))?;
        Ok(FramesCsv(file))
    }

    pub fn row(&mut self, row: &FrameRow) -> CliResult<()> {
        self.0.line(format_args!("{}", row.csv_line()))
    }

    pub fn finish(mut self) -> CliResult<()> {
        self.0.flush()
    }
}

/// The JSON report, `{"frames": [...], "summary": {...}}`: the frames as they complete, the
/// summary last, once it is known.
pub struct JsonReport {
    file: OutputFile,
    rows: u64,
}

impl JsonReport {
    pub fn create(path: &Path) -> CliResult<JsonReport> {
        let mut file = OutputFile::create(path)?;
        file.line(format_args!("{{\"frames\": ["))?;
        Ok(JsonReport { file, rows: 0 })
    }

    pub fn row(&mut self, row: &FrameRow) -> CliResult<()> {
        if self.rows > 0 {
            self.file.line(format_args!(","))?;
        }
        self.rows += 1;
        self.file.json(row, false)
    }

    pub fn finish(mut self, summary: &Summary) -> CliResult<()> {
        self.file.line(format_args!("\n],\n\"summary\":"))?;
        self.file.json(summary, true)?;
        self.file.line(format_args!("\n}}"))?;
        self.file.flush()
    }
}
