//! Memory a world needs and memory this process may still take, so that a caller can refuse a
//! request that cannot fit with a clear error, before allocating it, instead of being aborted by
//! the allocator (or killed by the kernel) halfway through building or stepping it; and input
//! files read within that room ([`read_json`]), so that none is read until the memory runs out;
//! and [`prefetch`], the cache hint the hot loops give ahead of a memory access.
//!
//! The estimate is measured, not derived from the data structures, because the broad phase's
//! size depends on the method, the speeds and the density. Peak resident memory per body of
//! `vadop simulate --bodies N --frames 3 --reference none` (scene generation, world, stepping):
//! vadop 300–345 bytes (N = 10^6..10^7, speeds up to 0.5 diameters per frame) and 430 at 5;
//! swept-kdop 480–560, grid 235–320, discrete 215–240 (N = 3·10^5, speeds up to 5); brute
//! 430–450 (N = 2·10^4). Denser or faster scenes need more for their candidate pairs and
//! contacts (grid at packing 0.5: 990; brute at 50 diameters per frame: 1040), so the check
//! only refuses what cannot fit; it does not promise that everything it lets through will.
//!
//! Linux only: elsewhere nothing is known about the memory left, and nothing is refused.

use std::fmt;
use std::path::{Path, PathBuf};

/// Bytes per body: the largest peak measured above at the default packing fraction (swept-kdop
/// at 5 diameters per frame, 561), rounded up.
const BYTES_PER_BODY: u64 = 640;

/// Bytes a world of `bodies` bodies needs at its peak: the scene it is built from, the world,
/// its broad phase and a frame's work.
pub fn world_bytes(bodies: usize) -> u64 {
    (bodies as u64).saturating_mul(BYTES_PER_BODY)
}

/// Bytes this process may still allocate: the least of the system's available memory
/// (`MemAvailable`), the room left under every enclosing cgroup's memory limit (v2 and v1), and
/// the room left under the address-space limit (`ulimit -v`). `None` where none can be read.
pub fn available_bytes() -> Option<u64> {
    [system_available(), cgroup_room(), address_space_room()].into_iter().flatten().min()
}

/// Why a request was refused: what it needs and what is available.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shortfall {
    pub needed: u64,
    pub available: u64,
}

impl fmt::Display for Shortfall {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "needs about {} of memory, but only {} is available (free memory, cgroup limit and ulimit -v)",
            format_bytes(self.needed),
            format_bytes(self.available)
        )
    }
}

/// Fails when `needed` bytes exceed what is available; passes when that is unknown.
pub fn check(needed: u64) -> Result<(), Shortfall> {
    match available_bytes() {
        Some(available) if needed > available => Err(Shortfall { needed, available }),
        _ => Ok(()),
    }
}

/// The most bytes of an input file worth reading: its text and what it is parsed into (about as
/// much again) must both fit in the memory left. `None` where that is unknown.
fn input_limit() -> Option<u64> {
    available_bytes().map(|available| available / 2)
}

/// Refuses, before any of it is read, a regular file at `path` too large for the memory left (see
/// [`read_json`]). Anything else passes: a device or FIFO reports no size.
pub fn check_input(path: &Path) -> Result<(), String> {
    let size = std::fs::metadata(path).ok().filter(|meta| meta.is_file()).map_or(0, |meta| meta.len());
    match input_limit() {
        Some(limit) if size > limit => Err(format!(
            "a file of {} {}",
            format_bytes(size),
            Shortfall { needed: size.saturating_mul(2), available: limit.saturating_mul(2) }
        )),
        _ => Ok(()),
    }
}

/// Parses the JSON file at `path`, refusing one too large for the memory left instead of reading
/// until the system runs out: a regular file is checked by its size before it is read
/// ([`check_input`]); anything else (a FIFO, or a device such as `/dev/zero`, whose size reads
/// as 0) is parsed as it streams in, so that what is not JSON fails at its first byte, and
/// refused once it has delivered more than half the memory left. Where the memory left is
/// unknown, nothing is refused.
///
/// ```
/// let error = vadop::memory::read_json::<serde_json::Value>("/dev/zero".as_ref()).unwrap_err();
/// assert!(error.starts_with("expected value at line 1 column 1"), "{error}");
/// ```
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, String> {
    use std::io::Read;
    check_input(path)?;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let regular = file.metadata().is_ok_and(|meta| meta.is_file());
    let limit = input_limit().unwrap_or(u64::MAX);
    let mut input = std::io::BufReader::new(file.take(limit.saturating_add(1)));
    let parsed = if regular {
        // Whole, then parsed: faster than parsing as it is read (serde_json's own advice).
        let mut text = String::new();
        input
            .read_to_string(&mut text)
            .map_err(|e| e.to_string())
            .and_then(|_| serde_json::from_str(&text).map_err(|e| e.to_string()))
    } else {
        serde_json::from_reader(&mut input).map_err(|e| e.to_string())
    };
    // The bound reached: a stream (or a file that grew since it was checked) too long to hold.
    if input.get_ref().limit() == 0 {
        return Err(format!(
            "more than {} of input: its text and what it is parsed into need more than the {} of memory available (free memory, cgroup limit and ulimit -v)",
            format_bytes(limit),
            format_bytes(limit.saturating_mul(2))
        ));
    }
    parsed
}

/// Bytes in the largest binary unit that keeps the number at or above 1: "512 B", "1.5 KiB".
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

/// The value of `key` in a `key: value [kB]` or `key value` listing, in bytes when marked kB.
fn field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|line| line.split([':', ' ']).next() == Some(key))?;
    let mut words = line[key.len()..].trim_start_matches(':').split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    Some(if words.next() == Some("kB") { value.saturating_mul(1024) } else { value })
}

fn read_number(path: &Path) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

fn system_available() -> Option<u64> {
    field(&std::fs::read_to_string("/proc/meminfo").ok()?, "MemAvailable")
}

/// The least room under the memory limits of this process's cgroup and its ancestors. A limit
/// counts what the cgroup uses minus its inactive file cache, which the kernel reclaims before
/// it kills anything (the working set, as container runtimes count it).
fn cgroup_room() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let mut room: Option<u64> = None;
    for line in cgroups.lines() {
        let mut fields = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (fields.next(), fields.next(), fields.next()) else {
            continue;
        };
        let (root, limit, usage, cache) = if controllers.is_empty() {
            ("/sys/fs/cgroup", "memory.max", "memory.current", "inactive_file")
        } else if controllers.split(',').any(|c| c == "memory") {
            ("/sys/fs/cgroup/memory", "memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file")
        } else {
            continue;
        };
        // In a container the cgroup's own path may not be mounted: ancestors up to the mount's
        // root are tried too, and limits there apply as well.
        let root = Path::new(root);
        let mut dir: PathBuf = root.join(path.trim_start_matches('/'));
        loop {
            // "max" (no limit) does not parse: no room limit from this level.
            if let (Some(limit), Some(usage)) = (read_number(&dir.join(limit)), read_number(&dir.join(usage))) {
                let stat = std::fs::read_to_string(dir.join("memory.stat")).unwrap_or_default();
                let used = usage.saturating_sub(field(&stat, cache).unwrap_or(0));
                let here = limit.saturating_sub(used);
                room = Some(room.map_or(here, |r| r.min(here)));
            }
            if dir == root || !dir.pop() {
                break;
            }
        }
    }
    room
}

/// Room under `ulimit -v`: the soft address-space limit minus the address space in use.
fn address_space_room() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|line| line.starts_with("Max address space"))?;
    let limit: u64 = line["Max address space".len()..].split_whitespace().next()?.parse().ok()?;
    let used = field(&std::fs::read_to_string("/proc/self/status").ok()?, "VmSize")?;
    Some(limit.saturating_sub(used))
}

/// Asks for the cache line holding `value` ahead of its use; a hint, without effect on results
/// (and a no-op off x86_64).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    prefetch_address(value as *const T);
}

/// [`prefetch`] of `items[i]` with no bounds check: a prefetch never faults, so an index past the
/// end costs a wasted hint, where the check cost a compare and a branch on every call (the event
/// loop asks for two bodies' records per event).
#[inline(always)]
pub fn prefetch_item<T>(items: &[T], i: usize) {
    prefetch_address(items.as_ptr().wrapping_add(i));
}

#[inline(always)]
fn prefetch_address<T>(address: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing the program sees and never faults, whatever the address.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(address.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = address;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_read_in_bytes() {
        let meminfo = "MemTotal:       24683520 kB\nMemAvailable:   23000000 kB\n";
        assert_eq!(field(meminfo, "MemAvailable"), Some(23_000_000 * 1024));
        assert_eq!(field(meminfo, "MemFree"), None);
        assert_eq!(field("cache 1\ninactive_file 4096\n", "inactive_file"), Some(4096));
        assert_eq!(field("total_inactive_file 7\ninactive_file 4096\n", "inactive_file"), Some(4096));
    }

    #[test]
    fn shortfalls_name_both_figures() {
        let message = Shortfall { needed: 64 << 30, available: 3 << 29 }.to_string();
        assert!(message.starts_with("needs about 64.0 GiB of memory, but only 1.5 GiB is available"), "{message}");
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(1536), "1.5 KiB");
        assert_eq!(world_bytes(usize::MAX), u64::MAX);
    }

    #[test]
    fn a_linux_process_knows_its_room() {
        if Path::new("/proc/meminfo").exists() {
            let room = available_bytes().expect("MemAvailable");
            assert!(room > 0);
            assert!(check(u64::MAX).is_err());
            assert!(check(0).is_ok());
        }
    }
}
