//! The warped-tables section of the flat device layout (`spec/GPU_LAYOUT.md`, "Warped tables
//! section", model section kind 2): the compact form the decoder holds
//! (`super::warped::CompactTables`), appended as it is, so that a shader reads the numbers the
//! CPU decoder evaluates.

use super::word;
use super::words::header;
use crate::error::Result;

/// Appends a warped-tables section (its words, offsets relative to its first word) to the
/// layout `out` (whose header is complete) and points header word 19 at it; `total_words` is
/// updated.
pub(crate) fn append_warped_section(out: &mut Vec<u32>, section: &[u32]) -> Result<()> {
    let at = out.len();
    out.extend_from_slice(section);
    out[header::OFF_MODEL] = word(at)?;
    out[header::TOTAL] = word(out.len())?;
    Ok(())
}
