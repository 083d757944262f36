//! Writing outputs safely: into a temporary file in the destination folder, renamed into place
//! only once complete, so a failed or interrupted run never leaves a partial file and never
//! damages an existing one. A run stopped by a signal cannot unwind to delete its temporary
//! file, so the files being written are listed here, and the program's signal handler removes
//! them ([`remove_partial_outputs`]) before it exits.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The temporary files [`write_atomic`] is filling now, in this process.
static PARTIAL: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Lists a temporary file in [`PARTIAL`] while it lives.
struct Listed(PathBuf);

impl Listed {
    fn new(path: &Path) -> Self {
        if let Ok(mut list) = PARTIAL.lock() {
            list.push(path.to_path_buf());
        }
        Listed(path.to_path_buf())
    }
}

impl Drop for Listed {
    fn drop(&mut self) {
        if let Ok(mut list) = PARTIAL.lock() {
            list.retain(|p| p != &self.0);
        }
    }
}

/// Deletes every temporary file this process's [`write_atomic`] calls are filling, for a
/// signal handler to call just before the process exits (the program does so on Ctrl-C,
/// SIGTERM and SIGHUP). The destinations are untouched: each is still what it was before,
/// or already the complete new file if its rename came first. Holds the list until the
/// process ends, so that no write starts or finishes renaming behind it.
pub fn remove_partial_outputs() {
    let list = match PARTIAL.lock() {
        Ok(list) => list,
        Err(poisoned) => poisoned.into_inner(),
    };
    for p in list.iter() {
        let _ = std::fs::remove_file(p);
    }
    std::mem::forget(list);
}

/// Creates `path` atomically from what `fill` writes.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::Parameter(format!(
            "output folder '{}' does not exist (for output '{}')",
            dir.display(),
            path.display()
        )));
    }
    if path.is_dir() {
        return Err(Error::Parameter(format!(
            "output '{}' is a folder, not a file",
            path.display()
        )));
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix(".sbrdf-partial-");
    // tempfile creates files readable by the owner alone; an output is an ordinary file, so ask
    // for the usual mode (the umask still applies).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(|e| Error::io(dir, e))?;
    let _listed = Listed::new(tmp.path());
    {
        let mut buf = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut buf)?;
        buf.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Creates `path` atomically with `bytes`.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

/// Makes sure `dir` is a folder to write outputs into: an existing folder, or a new one created
/// when its parent exists (one level, like `mkdir`). `what` names the option in messages.
pub fn ensure_output_folder(dir: &Path, what: &str) -> Result<()> {
    if dir.is_dir() {
        return Ok(());
    }
    if dir.exists() {
        return Err(Error::Parameter(format!(
            "{what} writes a folder of files, but '{}' is a file",
            dir.display()
        )));
    }
    std::fs::create_dir(dir).map_err(|e| Error::io(dir, e))
}
