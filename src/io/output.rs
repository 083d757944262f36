//! Writing outputs safely: into a temporary file in the destination folder, renamed into place
//! only once complete, so a failed or interrupted run never leaves a partial file and never
//! damages an existing one.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

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
