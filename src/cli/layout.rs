//! `sbrdf layout`: a file's flat device layout (`spec/GPU_LAYOUT.md`) written as raw words.

use clap::Args;
use sbrdf::io::output::write_bytes_atomic;
use sbrdf::{Decoder, Error, Result};
use std::path::PathBuf;

#[derive(Args)]
pub struct LayoutArgs {
    pub input: PathBuf,
    /// Where to write the layout: its 32-bit words, little-endian, nothing else.
    #[arg(short, long, value_name = "OUT.bin")]
    pub output: PathBuf,
}

pub fn cmd_layout(a: LayoutArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    // The library's message says which chunk is not covered; the file is named here.
    let words = dec.gpu_layout().map_err(|e| match e {
        Error::Parameter(m) => Error::Parameter(format!("{}: {m}", a.input.display())),
        other => other,
    })?;
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    write_bytes_atomic(&a.output, &bytes)
}
