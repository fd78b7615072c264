//! Reporting: the per-frame rows, the run summary (built once from totals accumulated frame by
//! frame, printed as text, written as JSON and read back by the benchmark from its child runs),
//! the CSV and JSON files, streamed as the frames come, and the small measurement helpers they
//! need. Each part has a file: `summary` (what a run reports, as data), `text` (the summary as
//! printed), `quantiles` (order statistics in bounded memory), `writers` (the files) and
//! `terminal` (stdout and progress bars). This file only names what the rest of the CLI uses and
//! holds no logic. Nothing here grows with the number of frames, so a run of any length takes the
//! same memory; it never steps a world or decides what to run.

mod quantiles;
mod summary;
mod terminal;
mod text;
mod writers;

pub use summary::{Accuracy, Conservation, FrameTotals, Motion, PoolInfo, Resting, RunInfo, SceneInfo, Summary};
pub use terminal::{print, progress_bar, reveal};
pub use text::number;
pub use writers::{create_file, io_error, FrameRow, FramesCsv, JsonReport, OutputFile};
