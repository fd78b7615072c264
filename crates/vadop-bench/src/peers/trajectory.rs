//! The files the peers share with vadop, and the child jobs that write them. The sphere scene's
//! trajectory file holds the paper scene's detect-mode paths: per frame, every body's start position and
//! velocity, its end position and its wall bounces (time and position), so a path is a polyline
//! (the reader is `bench/peers/cpp/trajectory.h`; keep them in step). A contacts file holds
//! (frame, i, j) u32 triples: pairs that begin touching during the frame. Every pipeline prints
//! one JSON line, `{"frame_ms": [...], "peak_kib": K}` ([`report`]). [`Reader`] reads the sphere
//! file back one frame at a time, for the pipelines of this crate that run on it
//! ([`super::plain_grid`]). The mixed-shape scene and its file are [`super::shapes`]'s.

use super::{shapes, Scene};
use crate::common::io_error;
use crate::markdown::peak_memory_mib;
use crate::CliResult;
use std::io::{BufReader, BufWriter, Read as _, Write as _};
use std::path::{Path, PathBuf};
use std::time::Instant;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Contact, Method, Mode, Touched, World, WorldConfig};

pub const PACKING: f64 = 0.05;
const MAGIC: &[u8; 8] = b"VADOPTR1";

/// The paper scene of `n` bodies at `speed`.
fn paper_scene(n: usize, speed: f64) -> CliResult<vadop::scene::Scene> {
    PaperScene::new(n, PACKING, speed).build().map_err(|e| e.to_string())
}

/// `scene` in detect mode with `method`.
fn detect_world(scene: &vadop::scene::Scene, method: Method) -> CliResult<World> {
    scene.world(WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() }).map_err(|e| e.to_string())
}

/// The child job of one of vadop's own pipelines: steps `scene` with `method`, writes its
/// contacts to `out` and prints the per-frame times and the peak memory.
pub fn time_method(scene: Scene, n: usize, speed: f64, frames: u64, method: Method, out: &Path) -> CliResult<()> {
    let mut world = match scene {
        Scene::Spheres => detect_world(&paper_scene(n, speed)?, method)?,
        Scene::Shapes => shapes::world(n, speed, frames, method)?.0,
    };
    let mut contacts = Vec::new();
    let mut frame_ms = Vec::new();
    for frame in 0..frames {
        let started = Instant::now();
        let step = world.step(1.0 / FRAMES_PER_SECOND).map_err(|e| e.to_string())?;
        frame_ms.push(started.elapsed().as_secs_f64() * 1e3);
        contacts.extend(pair_contacts(frame, step));
    }
    report(out, &contacts, &frame_ms)
}

/// What every pipeline run ends with: writes its contacts to `out` and prints its per-frame
/// times and the process's peak memory as the one JSON line the driver reads.
pub fn report(out: &Path, contacts: &[[u32; 3]], frame_ms: &[f64]) -> CliResult<()> {
    write_contacts(out, contacts)?;
    let peak_kib = peak_memory_mib().map_or(-1, |m| (m * 1024.0) as i64);
    let times: Vec<String> = frame_ms.iter().map(|t| format!("{t:.6}")).collect();
    crate::common::print(&format!("{{\"frame_ms\":[{}],\"peak_kib\":{peak_kib}}}\n", times.join(",")))
}

/// The export child job: steps the paper scene in detect mode and writes `dir`/trajectory.bin and
/// `dir`/reference.bin, the pair contacts found by brute force (`brute`) or by the default method.
pub fn export(n: usize, speed: f64, frames: u64, brute: bool, dir: &Path) -> CliResult<()> {
    export_scene(&paper_scene(n, speed)?, frames, brute, dir)
}

/// [`export`] of any scene of equal spheres (the tests' hand-made ones too).
pub fn export_scene(scene: &vadop::scene::Scene, frames: u64, brute: bool, dir: &Path) -> CliResult<()> {
    let mut world = detect_world(scene, if brute { Method::Brute } else { Method::Auto })?;
    let n = scene.spheres.len();
    let dt = 1.0 / FRAMES_PER_SECOND;
    let mut contacts = Vec::new();
    let mut files = ExportFiles::create(dir)?;
    let header = [n as u64, frames];
    let floats = [dt, scene.spheres[0].radius];
    let corners = [scene.bounds.min.to_array(), scene.bounds.max.to_array()];
    let mut bytes: Vec<u8> = MAGIC.to_vec();
    bytes.extend(header.iter().flat_map(|v| v.to_le_bytes()));
    bytes.extend(floats.iter().chain(corners.iter().flatten()).flat_map(|v| v.to_le_bytes()));
    files.write(&bytes)?;
    for frame in 0..frames {
        let mut bytes = Vec::with_capacity(n * 72);
        let start: Vec<_> = world.spheres().map(|(_, s)| s).collect();
        for s in &start {
            bytes
                .extend(s.position.to_array().iter().chain(s.velocity.to_array().iter()).flat_map(|v| v.to_le_bytes()));
        }
        let t0 = world.time();
        let mut bounces = Vec::new();
        let step = world.step(dt).map_err(|e| e.to_string())?;
        contacts.extend(pair_contacts(frame, step));
        for c in step {
            // The contact point sits one radius out along the normal from the centre.
            if let Touched::Wall(_) = c.touched {
                let i = c.body.index();
                bounces.push((u64::from(i), c.time - t0, c.point - c.normal * start[i as usize].radius))
            }
        }
        for (_, s) in world.spheres() {
            bytes.extend(s.position.to_array().iter().flat_map(|v| v.to_le_bytes()));
        }
        bounces.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        bytes.extend((bounces.len() as u64).to_le_bytes());
        for (body, tau, p) in bounces {
            bytes.extend(body.to_le_bytes());
            bytes.extend([tau, p.x, p.y, p.z].iter().flat_map(|v| v.to_le_bytes()));
        }
        files.write(&bytes)?;
    }
    files.finish(contacts)
}

/// An export child job's files in its folder: `trajectory.bin`, written as the job steps the
/// scene, and `reference.bin`, the pair contacts found, written at the end.
pub(super) struct ExportFiles {
    dir: PathBuf,
    path: PathBuf,
    trajectory: BufWriter<std::fs::File>,
}

impl ExportFiles {
    pub(super) fn create(dir: &Path) -> CliResult<ExportFiles> {
        let path = dir.join("trajectory.bin");
        let file = std::fs::File::create(&path).map_err(|e| io_error(&path, e))?;
        Ok(ExportFiles { dir: dir.to_path_buf(), path, trajectory: BufWriter::new(file) })
    }

    /// Appends `bytes` to the trajectory file.
    pub(super) fn write(&mut self, bytes: &[u8]) -> CliResult<()> {
        self.trajectory.write_all(bytes).map_err(|e| io_error(&self.path, e))
    }

    /// Flushes the trajectory file and writes the reference file: `contacts` sorted, each once.
    pub(super) fn finish(mut self, mut contacts: Vec<[u32; 3]>) -> CliResult<()> {
        self.trajectory.flush().map_err(|e| io_error(&self.path, e))?;
        contacts.sort_unstable();
        contacts.dedup();
        write_contacts(&self.dir.join("reference.bin"), &contacts)
    }
}

/// The sphere scene's trajectory file, read one frame at a time into [`Frame`] buffers that are
/// reused from frame to frame.
pub struct Reader {
    file: BufReader<std::fs::File>,
    pub n: usize,
    pub frames: u64,
    pub dt: f64,
    pub radius: f64,
    /// The box's corners.
    pub low: [f64; 3],
    pub high: [f64; 3],
}

/// One frame of the file. Body i's bounces are `bounce_time[k]`, `bounce_at[k]` for k in
/// `first_bounce[i]..first_bounce[i + 1]`, in time order.
#[derive(Default)]
pub struct Frame {
    pub start: Vec<[f64; 6]>,
    pub end: Vec<[f64; 3]>,
    pub first_bounce: Vec<usize>,
    pub bounce_time: Vec<f64>,
    pub bounce_at: Vec<[f64; 3]>,
}

impl Reader {
    pub fn open(path: &Path) -> CliResult<Reader> {
        let file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
        let mut reader =
            Reader { file: BufReader::new(file), n: 0, frames: 0, dt: 0.0, radius: 0.0, low: [0.0; 3], high: [0.0; 3] };
        let mut magic = [0u8; 8];
        reader.file.read_exact(&mut magic).map_err(|e| io_error(path, e))?;
        if &magic != MAGIC {
            return Err(format!("{}: not a trajectory file of the sphere scene", path.display()));
        }
        (reader.n, reader.frames) = (reader.word()? as usize, reader.word()?);
        (reader.dt, reader.radius) = (reader.float()?, reader.float()?);
        for a in 0..6 {
            let value = reader.float()?;
            if a < 3 {
                reader.low[a] = value
            } else {
                reader.high[a - 3] = value
            }
        }
        Ok(reader)
    }

    fn word(&mut self) -> CliResult<u64> {
        let mut bytes = [0u8; 8];
        self.file.read_exact(&mut bytes).map_err(|_| "trajectory file is truncated".to_string())?;
        Ok(u64::from_le_bytes(bytes))
    }

    fn float(&mut self) -> CliResult<f64> {
        self.word().map(f64::from_bits)
    }

    fn floats<const N: usize>(&mut self) -> CliResult<[f64; N]> {
        let mut values = [0.0; N];
        for v in &mut values {
            *v = self.float()?;
        }
        Ok(values)
    }

    /// Reads the next frame into `frame`.
    pub fn next_frame(&mut self, frame: &mut Frame) -> CliResult<()> {
        let n = self.n;
        frame.start.resize(n, [0.0; 6]);
        frame.end.resize(n, [0.0; 3]);
        for i in 0..n {
            frame.start[i] = self.floats()?;
        }
        for i in 0..n {
            frame.end[i] = self.floats()?;
        }
        let count = self.word()? as usize;
        frame.first_bounce.clear();
        frame.first_bounce.resize(n + 1, 0);
        frame.bounce_time.clear();
        frame.bounce_at.clear();
        for _ in 0..count {
            let body = self.word()? as usize;
            if body >= n {
                return Err(format!("a bounce of body {body} of {n}"));
            }
            let [tau, x, y, z] = self.floats()?;
            frame.first_bounce[body + 1] += 1;
            frame.bounce_time.push(tau);
            frame.bounce_at.push([x, y, z]);
        }
        for i in 0..n {
            frame.first_bounce[i + 1] += frame.first_bounce[i];
        }
        Ok(())
    }
}

/// A frame's contacts between two bodies as (frame, i, j) with i < j.
pub fn pair_contacts(frame: u64, step: &[Contact]) -> impl Iterator<Item = [u32; 3]> + '_ {
    step.iter().filter_map(move |c| match c.touched {
        Touched::Body(j) => Some([frame as u32, c.body.min(j).index(), c.body.max(j).index()]),
        Touched::Wall(_) => None,
    })
}

/// Reads (frame, i, j) u32 triples, sorted and without duplicates.
pub fn read_contacts(path: &Path) -> Result<Vec<[u32; 3]>, String> {
    let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
    let word = |k: usize| u32::from_le_bytes([bytes[4 * k], bytes[4 * k + 1], bytes[4 * k + 2], bytes[4 * k + 3]]);
    let mut triples: Vec<[u32; 3]> =
        (0..bytes.len() / 12).map(|t| [word(3 * t), word(3 * t + 1), word(3 * t + 2)]).collect();
    triples.sort_unstable();
    triples.dedup();
    Ok(triples)
}

pub fn write_contacts(path: &Path, contacts: &[[u32; 3]]) -> CliResult<()> {
    let bytes: Vec<u8> = contacts.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).map_err(|e| io_error(path, e))
}

/// The trajectory file's bytes and the reference contacts that `export` writes into a folder of
/// its own, `name` and the process id in the system's temporary folder, removed after.
#[cfg(test)]
pub(super) fn exported(name: &str, export: impl FnOnce(&Path) -> CliResult<()>) -> (Vec<u8>, Vec<[u32; 3]>) {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    export(&dir).unwrap();
    let bytes = std::fs::read(dir.join("trajectory.bin")).unwrap();
    let contacts = read_contacts(&dir.join("reference.bin")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    (bytes, contacts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_files_round_trip_sorted() {
        let path = std::env::temp_dir().join(format!("vadop-peers-test-{}.bin", std::process::id()));
        write_contacts(&path, &[[1, 2, 3], [0, 5, 9], [1, 2, 3]]).unwrap();
        let read = read_contacts(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(read, vec![[0, 5, 9], [1, 2, 3]]);
    }

    /// Reads the trajectory file the way the peers do and checks that each path is the polyline
    /// vadop stepped: frames chain up, bounces sit on a wall, and the start velocity leads from
    /// the start to the first knot.
    #[test]
    fn trajectory_file_describes_the_stepped_paths() {
        // 60 bodies at 5 diameters per frame in a box about 8.6 wide: bounces in every frame.
        let (bytes, contacts) = exported("vadop-peers-export", |dir| export(60, 5.0, 4, true, dir));
        let at = std::cell::Cell::new(8);
        let word = || {
            at.set(at.get() + 8);
            u64::from_le_bytes(bytes[at.get() - 8..at.get()].try_into().unwrap())
        };
        let float = || f64::from_bits(word());
        assert_eq!(&bytes[..8], MAGIC);
        let (n, frames) = (word() as usize, word());
        let (dt, radius) = (float(), float());
        let (low, high) = ([float(), float(), float()], [float(), float(), float()]);
        assert_eq!((n, frames, dt, radius), (60, 4, 1.0 / 30.0, 0.5));
        let mut previous_end: Option<Vec<[f64; 3]>> = None;
        let mut bounce_total = 0;
        for _ in 0..frames {
            let start: Vec<[f64; 6]> = (0..n).map(|_| std::array::from_fn(|_| float())).collect();
            let end: Vec<[f64; 3]> = (0..n).map(|_| std::array::from_fn(|_| float())).collect();
            if let Some(previous) = &previous_end {
                assert!(start.iter().zip(previous).all(|(s, e)| s[..3] == e[..]));
            }
            let count = word();
            let mut first_knot = vec![None; n];
            let mut bodies_seen = Vec::new();
            for _ in 0..count {
                let body = word() as usize;
                let (tau, p) = (float(), [float(), float(), float()]);
                assert!((0.0..dt).contains(&tau));
                let on_wall =
                    (0..3).any(|a| (p[a] - low[a] - radius).abs() < 1e-9 || (high[a] - p[a] - radius).abs() < 1e-9);
                assert!(on_wall, "bounce of body {body} at {p:?} is on no wall");
                first_knot[body].get_or_insert((tau, p));
                bodies_seen.push(body);
            }
            assert!(bodies_seen.windows(2).all(|w| w[0] <= w[1]), "bounces sorted by body");
            for (i, s) in start.iter().enumerate() {
                let (tau, p) = first_knot[i].unwrap_or((dt, end[i]));
                assert!((0..3).all(|a| (s[a] + tau * s[3 + a] - p[a]).abs() < 1e-9), "body {i} leaves its line");
            }
            bounce_total += count;
            previous_end = Some(end);
        }
        assert_eq!(at.get(), bytes.len());
        assert!(bounce_total > 0 && !contacts.is_empty());
        assert!(contacts.iter().all(|c| (c[0] as u64) < frames && c[1] < c[2] && (c[2] as usize) < n));
    }
}
