//! Atomic writes: files and directories are written under a temporary name beside the
//! destination and renamed into place, so a reader never sees a half-written result and a
//! failed write leaves the previous one untouched.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A fresh hidden name beside `path`: `.NAME.TAG-PID-N`.
pub(crate) fn sibling(path: &Path, tag: &str) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.{tag}-{}-{n}", std::process::id()))
}

/// The parent folder of `path` (`.` for a bare name), created if missing.
fn parent_of(path: &Path) -> io::Result<PathBuf> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent)?;
    Ok(parent)
}

/// Writes a file through `write(temporary path)`, then renames it to `path`. On error the
/// temporary file is removed and `path` is left as it was.
pub(crate) fn write_file<E>(
    path: &Path,
    io_error: impl Fn(&Path, io::Error) -> E,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    parent_of(path).map_err(|e| io_error(path, e))?;
    let temporary = sibling(path, "tmp");
    let result = write(&temporary)
        .and_then(|()| std::fs::rename(&temporary, path).map_err(|e| io_error(path, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    result
}

/// Writes a directory: `write(temporary directory)` fills a fresh directory beside `dir`,
/// which then replaces `dir` (an existing `dir` is moved aside first and removed after the
/// swap; if the swap fails it is moved back). `may_replace` decides whether an existing `dir`
/// may be replaced.
pub(crate) fn write_dir<E>(
    dir: &Path,
    io_error: impl Fn(&Path, io::Error) -> E,
    may_replace: impl FnOnce(&Path) -> Result<(), E>,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    parent_of(dir).map_err(|e| io_error(dir, e))?;
    let exists = dir.symlink_metadata().is_ok();
    if exists {
        may_replace(dir)?;
    }
    let temporary = sibling(dir, "tmp");
    std::fs::create_dir(&temporary).map_err(|e| io_error(&temporary, e))?;
    if let Err(e) = write(&temporary) {
        let _ = std::fs::remove_dir_all(&temporary);
        return Err(e);
    }
    if exists {
        let old = sibling(dir, "old");
        if let Err(e) = std::fs::rename(dir, &old) {
            let _ = std::fs::remove_dir_all(&temporary);
            return Err(io_error(dir, e));
        }
        if let Err(e) = std::fs::rename(&temporary, dir) {
            let _ = std::fs::rename(&old, dir);
            let _ = std::fs::remove_dir_all(&temporary);
            return Err(io_error(dir, e));
        }
        let _ = std::fs::remove_dir_all(&old);
        Ok(())
    } else {
        std::fs::rename(&temporary, dir).map_err(|e| {
            let _ = std::fs::remove_dir_all(&temporary);
            io_error(dir, e)
        })
    }
}
