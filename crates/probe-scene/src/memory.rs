//! Memory limits checked before work starts.
//!
//! A request whose memory is known up front (a scene's declared triangles, a bake's resolution
//! × probe count, an octree's depth, a sweep's view count) is compared with a
//! [`MemoryLimit`] before anything is allocated, and refused with the estimate and the limit
//! in the message ([`MemoryExceeded`]), rather than failing an allocation half-way (which
//! aborts the process) or driving the machine into swap.
//!
//! The default limit is the machine's physical memory ([`MemoryLimit::machine`]: `MemTotal`
//! of `/proc/meminfo`, or [`DEFAULT_MEMORY_LIMIT`] where that cannot be read); callers that
//! know better pass their own ([`MemoryLimit::bytes`], the CLI's `--max-memory`).
//!
//! ```
//! use probe_scene::memory::MemoryLimit;
//! let limit = MemoryLimit::bytes(1 << 30);
//! assert!(limit.check("a small request", 1 << 20).is_ok());
//! let refused = limit.check("a bake of 512 probes at 1024²", 40 << 30).unwrap_err();
//! assert!(refused.to_string().contains("40.0 GiB"));
//! ```

use std::fmt;
use std::sync::OnceLock;

/// The limit used where the machine's memory cannot be read (no `/proc/meminfo`): 8 GiB.
pub const DEFAULT_MEMORY_LIMIT: u64 = 8 << 30;

/// Where a [`MemoryLimit`] came from (named in refusals).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum LimitOrigin {
    /// The machine's physical memory, read from `/proc/meminfo`.
    Machine,
    /// [`DEFAULT_MEMORY_LIMIT`], because the machine's memory could not be read.
    Default,
    /// Given by the caller (e.g. `--max-memory`).
    Given,
}

/// The most memory a request may plan to use, in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit {
    bytes: u64,
    origin: LimitOrigin,
}

/// A request refused because its estimated memory exceeds the limit.
///
/// Fix: make the request smaller (the message says what was asked for), or raise the limit
/// (`--max-memory` on the command line, [`MemoryLimit::bytes`] from Rust) if the machine
/// really has the memory.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{what} needs about {} but the memory limit is {} ({}); make the request smaller or raise the limit (--max-memory)",
    format_bytes(*.estimate),
    format_bytes(*.limit),
    origin_text(*.origin)
)]
#[non_exhaustive]
pub struct MemoryExceeded {
    /// What was asked for, e.g. `a bake of 27 probes at 1024²`.
    pub what: String,
    /// The estimate, in bytes.
    pub estimate: u64,
    /// The limit, in bytes.
    pub limit: u64,
    /// Where the limit came from.
    pub origin: LimitOrigin,
}

fn origin_text(origin: LimitOrigin) -> &'static str {
    match origin {
        LimitOrigin::Machine => "the machine's memory",
        LimitOrigin::Default => "the default, as /proc/meminfo could not be read",
        LimitOrigin::Given => "given",
    }
}

/// Bytes as `12.3 GiB` / `4.0 MiB` / `512 B`.
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["KiB", "MiB", "GiB", "TiB", "PiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

/// `MemTotal` of a `/proc/meminfo` text, in bytes.
fn parse_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut parts = line["MemTotal:".len()..].split_whitespace();
    let value: u64 = parts.next()?.parse().ok()?;
    let scale = match parts.next() {
        Some("kB") | Some("KB") | Some("kiB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    value.checked_mul(scale).filter(|&b| b > 0)
}

/// The machine's physical memory in bytes (`MemTotal` of `/proc/meminfo`), if it can be read.
pub fn machine_memory() -> Option<u64> {
    static MEMORY: OnceLock<Option<u64>> = OnceLock::new();
    *MEMORY.get_or_init(|| {
        std::fs::read_to_string("/proc/meminfo")
            .ok()
            .as_deref()
            .and_then(parse_meminfo)
    })
}

impl MemoryLimit {
    /// The machine's physical memory ([`machine_memory`]), or [`DEFAULT_MEMORY_LIMIT`] where
    /// it cannot be read.
    pub fn machine() -> MemoryLimit {
        match machine_memory() {
            Some(bytes) => MemoryLimit {
                bytes,
                origin: LimitOrigin::Machine,
            },
            None => MemoryLimit {
                bytes: DEFAULT_MEMORY_LIMIT,
                origin: LimitOrigin::Default,
            },
        }
    }

    /// A limit of `bytes` given by the caller.
    pub fn bytes(bytes: u64) -> MemoryLimit {
        MemoryLimit {
            bytes,
            origin: LimitOrigin::Given,
        }
    }

    /// The limit in bytes.
    pub fn limit(&self) -> u64 {
        self.bytes
    }

    /// Where the limit came from.
    pub fn origin(&self) -> LimitOrigin {
        self.origin
    }

    /// `Ok` when `estimate` bytes fit the limit.
    ///
    /// # Errors
    /// [`MemoryExceeded`] naming `what`, the estimate and the limit.
    pub fn check(&self, what: impl fmt::Display, estimate: u64) -> Result<(), MemoryExceeded> {
        if estimate <= self.bytes {
            Ok(())
        } else {
            Err(MemoryExceeded {
                what: what.to_string(),
                estimate,
                limit: self.bytes,
                origin: self.origin,
            })
        }
    }
}

impl Default for MemoryLimit {
    /// [`MemoryLimit::machine`].
    fn default() -> Self {
        MemoryLimit::machine()
    }
}

/// Why a `--max-memory` style size could not be parsed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{text:?} is not a memory size: give a number with an optional unit (B, K, M, G, T; e.g. 16G, 512M)"
)]
#[non_exhaustive]
pub struct ParseSizeError {
    /// The text given.
    pub text: String,
}

/// Parses a size such as `16G`, `512MiB`, `1.5 GB` or `1000000` (bytes). Units are powers of
/// 1024; the `i` and the trailing `B` are optional.
///
/// # Errors
/// [`ParseSizeError`] for anything else (negative, non-finite, unknown unit, overflow).
pub fn parse_size(text: &str) -> Result<u64, ParseSizeError> {
    let bad = || ParseSizeError {
        text: text.to_owned(),
    };
    let trimmed = text.trim();
    let split = trimmed
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(trimmed.len());
    let (number, unit) = trimmed.split_at(split);
    let value: f64 = number.parse().map_err(|_| bad())?;
    let unit = unit.trim().to_ascii_uppercase();
    let unit = unit.strip_suffix('B').unwrap_or(&unit);
    let unit = unit.strip_suffix('I').unwrap_or(unit);
    let scale: f64 = match unit {
        "" => 1.0,
        "K" => 1024.0,
        "M" => 1024.0 * 1024.0,
        "G" => 1024.0 * 1024.0 * 1024.0,
        "T" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        _ => return Err(bad()),
    };
    let bytes = value * scale;
    if !(bytes.is_finite() && bytes >= 0.0 && bytes < u64::MAX as f64) {
        return Err(bad());
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_is_parsed() {
        let text = "MemTotal:       24589412 kB\nMemFree:         1000 kB\n";
        assert_eq!(parse_meminfo(text), Some(24_589_412 * 1024));
        assert_eq!(parse_meminfo("MemFree: 3 kB\n"), None);
        assert_eq!(parse_meminfo("MemTotal: lots kB\n"), None);
        assert_eq!(parse_meminfo("MemTotal: 0 kB\n"), None);
    }

    #[test]
    fn sizes_are_parsed() {
        assert_eq!(parse_size("16G"), Ok(16 << 30));
        assert_eq!(parse_size("512MiB"), Ok(512 << 20));
        assert_eq!(parse_size("1.5 GB"), Ok(3 << 29));
        assert_eq!(parse_size("1000"), Ok(1000));
        for bad in ["", "-1G", "G", "12Q", "1e400", "nanG"] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn refusal_names_estimate_and_limit() {
        let limit = MemoryLimit::bytes(2 << 30);
        assert!(limit.check("x", 2 << 30).is_ok());
        let error = limit.check("a bake of 9 probes", 3 << 30).unwrap_err();
        let text = error.to_string();
        assert!(text.contains("a bake of 9 probes"), "{text}");
        assert!(
            text.contains("3.0 GiB") && text.contains("2.0 GiB"),
            "{text}"
        );
        assert!(MemoryLimit::machine().limit() > 0);
    }
}
