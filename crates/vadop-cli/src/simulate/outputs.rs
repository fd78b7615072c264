//! The files `vadop simulate` reads and writes: the check, before any work, that no two outputs
//! name one file and none overwrites an input (links followed, spellings made canonical); the
//! outputs opened once the first frame has stepped (the per-frame CSV and JSON through the
//! report's writers, and the contacts CSV); and, on a resume, the agreement of an existing
//! contacts file with the saved state, so that it holds each contact exactly once. It never steps
//! a world, and it keeps nothing that grows with the frames: contacts are written as they come.

use super::args::SimulateArgs;
use super::slack;
use crate::report::{self, FrameRow, FramesCsv, JsonReport, OutputFile};
use crate::CliResult;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use vadop::Contact;

/// Whether a contact at `time` belongs to frame `frame` (numbered from 1) of `dt`.
fn in_frame(time: f64, frame: u64, dt: f64) -> bool {
    let (start, end) = ((frame.max(1) - 1) as f64 * dt, frame as f64 * dt);
    time >= start - slack(start, dt) && time <= end + slack(end, dt)
}

/// The files a run reads and writes, checked before any work is done.
pub(super) struct Files {
    /// Where `--save-scene` and `--save-state` land, links followed.
    pub(super) save_scene: Option<PathBuf>,
    pub(super) save_state: Option<PathBuf>,
}

impl Files {
    /// No two outputs may name one file, and none may overwrite an input, except the state saved
    /// over the state resumed from. A file the core saves by renaming a new one over it must be a
    /// regular file (or not exist yet): the rename would replace a device, FIFO or socket.
    pub(super) fn check(args: &SimulateArgs) -> CliResult<Files> {
        let inputs = [("--scene", &args.scene), ("--resume", &args.resume)];
        let outputs = [
            ("--csv", &args.csv),
            ("--json", &args.json),
            ("--contacts", &args.contacts),
            ("--save-scene", &args.save_scene),
            ("--save-state", &args.save_state),
        ];
        let mut seen: Vec<(&str, PathBuf)> = Vec::new();
        for (flag, path) in inputs {
            if let Some(path) = path {
                seen.push((flag, destination(path)?));
            }
        }
        for (flag, path) in outputs {
            let Some(path) = path else { continue };
            let target = destination(path)?;
            if let Some((other, _)) = seen.iter().find(|(_, seen)| *seen == target) {
                if (*other, flag) != ("--resume", "--save-state") {
                    let role = if inputs.iter().any(|(input, _)| input == other) { "reads" } else { "writes" };
                    return Err(format!(
                        "{flag} {} is the file {other} {role}: give every output a file of its own",
                        path.display()
                    ));
                }
            }
            seen.push((flag, target));
        }
        let replaced = |flag: &str, path: &Option<PathBuf>| -> CliResult<Option<PathBuf>> {
            let (Some(path), Some((_, target))) = (path, seen.iter().find(|(seen, _)| *seen == flag)) else {
                return Ok(None);
            };
            if std::fs::metadata(target).is_ok_and(|meta| !meta.is_file()) {
                return Err(format!(
                    "{flag} {}: not a regular file; saving replaces the file with a new one, which would destroy a device, FIFO, socket or directory",
                    path.display()
                ));
            }
            Ok(Some(target.clone()))
        };
        Ok(Files {
            save_scene: replaced("--save-scene", &args.save_scene)?,
            save_state: replaced("--save-state", &args.save_state)?,
        })
    }
}

/// Where a write to `path` lands: symbolic links followed (the last may point to a file not yet
/// there) and the directory made canonical, so that two spellings of one file compare equal.
fn destination(path: &Path) -> CliResult<PathBuf> {
    let mut at = path.to_path_buf();
    // The kernel's own limit on links followed in a path.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&at) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let target = std::fs::read_link(&at).map_err(|e| report::io_error(path, e))?;
                // A relative target is relative to the link's directory; join keeps an absolute one.
                at = at.parent().map_or(target.clone(), |dir| dir.join(&target));
            }
            _ => {
                let Some(name) = at.file_name() else { return Ok(at) };
                let dir = at.parent().filter(|dir| !dir.as_os_str().is_empty()).unwrap_or(Path::new("."));
                return std::fs::canonicalize(dir).map(|dir| dir.join(name)).map_err(|e| report::io_error(path, e));
            }
        }
    }
    Err(format!("{}: too many levels of symbolic links", path.display()))
}

/// Output files, created once the first frame has stepped (a bad directory fails before any work
/// is done, in `Files::check`).
#[derive(Default)]
pub(super) struct Outputs {
    pub(super) csv: Option<FramesCsv>,
    pub(super) json: Option<JsonReport>,
    pub(super) contacts: Option<ContactWriter>,
}

impl Outputs {
    pub(super) fn open(args: &SimulateArgs, frames_done: u64) -> CliResult<Outputs> {
        let contacts = match (&args.contacts, &args.resume) {
            (Some(path), Some(_)) => Some(ContactWriter::resume(path, frames_done, args.dt)?),
            (Some(path), None) => Some(ContactWriter::create(path)?),
            (None, _) => None,
        };
        Ok(Outputs {
            csv: args.csv.as_deref().map(FramesCsv::create).transpose()?,
            json: args.json.as_deref().map(JsonReport::create).transpose()?,
            contacts,
        })
    }

    pub(super) fn row(&mut self, row: &FrameRow) -> CliResult<()> {
        if let Some(csv) = &mut self.csv {
            csv.row(row)?;
        }
        match &mut self.json {
            Some(json) => json.row(row),
            None => Ok(()),
        }
    }
}

/// The contacts CSV, streamed frame by frame because it can be far larger than memory allows.
pub(super) struct ContactWriter {
    file: OutputFile,
    /// A regular file, which a sync puts on the disk (a FIFO or a terminal cannot be synced).
    regular: bool,
}

impl ContactWriter {
    const HEADER: &'static str = Contact::CSV_HEADER;

    fn create(path: &Path) -> CliResult<ContactWriter> {
        let file = report::create_file(path)?;
        ContactWriter::start(file, path, 0)
    }

    /// Writes from byte `keep` of `file` on, with a header when the file is to be empty.
    fn start(file: File, path: &Path, keep: u64) -> CliResult<ContactWriter> {
        let regular = file.metadata().is_ok_and(|m| m.is_file());
        let mut writer = ContactWriter { file: OutputFile::new(file, path), regular };
        if keep == 0 {
            writer.file.line(format_args!("{}", ContactWriter::HEADER))?;
        }
        Ok(writer)
    }

    /// The contacts file of a run resumed after `frames_done` frames of `dt`. An existing regular
    /// file is continued: its rows of later frames (written after the state was saved, and the
    /// partial row of a killed run) are dropped, so that it holds each contact exactly once.
    fn resume(path: &Path, frames_done: u64, dt: f64) -> CliResult<ContactWriter> {
        if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
            return ContactWriter::create(path);
        }
        let io = |e: std::io::Error| report::io_error(path, e);
        let mut file = OpenOptions::new().read(true).write(true).open(path).map_err(io)?;
        let keep = ContactWriter::rows_up_to(&file, path, frames_done, dt)?;
        file.set_len(keep).map_err(io)?;
        file.seek(SeekFrom::End(0)).map_err(io)?;
        ContactWriter::start(file, path, keep)
    }

    /// The length of the header and the complete rows of frames up to `last` at the start of
    /// `file`; 0 when it holds no complete header.
    fn rows_up_to(file: &File, path: &Path, last: u64, dt: f64) -> CliResult<u64> {
        let mut reader = BufReader::new(file);
        let (mut line, mut keep, mut number) = (Vec::new(), 0u64, 0u64);
        loop {
            line.clear();
            let read = reader.read_until(b'\n', &mut line).map_err(|e| report::io_error(path, e))?;
            number += 1;
            // The end, or a row cut short by a kill.
            if read == 0 || line.last() != Some(&b'\n') {
                let header_cut_short =
                    number == 1 && format!("{}\n", ContactWriter::HEADER).as_bytes().starts_with(&line);
                return if number > 1 || header_cut_short { Ok(keep) } else { Err(not_contacts(path, number)) };
            }
            let text = std::str::from_utf8(&line[..line.len() - 1]).map_err(|_| not_contacts(path, number))?;
            if number == 1 {
                if text != ContactWriter::HEADER {
                    return Err(not_contacts(path, number));
                }
            } else {
                let mut cells = text.split(',');
                let frame: u64 = cells.next().and_then(|c| c.parse().ok()).ok_or_else(|| not_contacts(path, number))?;
                let time: f64 = cells.next().and_then(|c| c.parse().ok()).ok_or_else(|| not_contacts(path, number))?;
                if frame > last {
                    return Ok(keep);
                }
                if !in_frame(time, frame, dt) {
                    return Err(format!(
                        "--contacts {} line {number}: a contact at time {time} is not in frame {frame} of --dt {dt}, so the file was not written with the state resumed: give --contacts that run's file or a new one",
                        path.display()
                    ));
                }
            }
            keep += read as u64;
        }
    }

    /// Writes a frame's contacts and the ends of contacts, merged in time order (a start before
    /// an end at the same instant, as the engine handles them).
    pub(super) fn frame(&mut self, frame: u64, contacts: &[Contact], ends: &[Contact]) -> CliResult<()> {
        let (mut starts, mut ends) = (contacts.iter().peekable(), ends.iter().peekable());
        loop {
            let (c, ended) = match (starts.peek(), ends.peek()) {
                (Some(s), Some(e)) if e.time < s.time => (ends.next(), true),
                (Some(_), _) => (starts.next(), false),
                (None, Some(_)) => (ends.next(), true),
                (None, None) => return Ok(()),
            };
            let c = c.expect("peeked");
            self.file.line(format_args!("{}", c.csv_row(frame, ended)))?;
        }
    }

    /// Puts every row written so far on the disk (where the file is one), so that a state saved
    /// next never runs ahead of its contacts.
    pub(super) fn sync(&mut self) -> CliResult<()> {
        if self.regular {
            self.file.sync()
        } else {
            self.file.flush()
        }
    }

    pub(super) fn finish(mut self) -> CliResult<()> {
        self.file.flush()
    }
}

fn not_contacts(path: &Path, line: u64) -> String {
    format!(
        "--contacts {} line {line}: not a vadop contacts file; give --contacts a contacts file or a new one",
        path.display()
    )
}
