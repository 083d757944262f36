//! `sbrdf subset`: a smaller file derived from an existing one, without the samples.

use clap::{Args, ValueEnum};
use sbrdf::encode::{settings, subset};
use sbrdf::io::output::write_bytes_atomic;
use sbrdf::{Decoder, Precision, Result};
use std::path::PathBuf;

#[derive(Args)]
pub struct SubsetArgs {
    pub input: PathBuf,
    /// Output .sbrdf file (written atomically).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Keep wavelengths within MIN:MAX nm.
    #[arg(long, value_name = "MIN:MAX")]
    pub wavelengths: Option<String>,
    /// Keep incident directions with θi ≤ DEG.
    #[arg(long, value_name = "DEG")]
    pub incident_max: Option<f64>,
    /// Keep at most K spectral terms.
    #[arg(long, value_name = "K")]
    pub terms: Option<usize>,
    /// Keep SH functions up to level L.
    #[arg(long, value_name = "L")]
    pub sh_level: Option<usize>,
    /// Store coefficients in f16 (f32 records are rounded).
    #[arg(long, value_enum)]
    pub precision: Option<SubsetPrecisionArg>,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum SubsetPrecisionArg {
    F16,
}

pub fn cmd_subset(a: SubsetArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    let original = dec.into_material();
    let opts = subset::SubsetOptions {
        wavelengths: a
            .wavelengths
            .as_deref()
            .map(|w| settings::parse_window("wavelengths", w))
            .transpose()?,
        incident_max: a.incident_max,
        terms: a.terms,
        sh_level: a.sh_level,
        precision: a.precision.map(|_| Precision::F16),
    };
    let (m, report) = subset::subset(&original, &opts)?;
    let before = sbrdf::write_material(&original)?.len();
    let bytes = sbrdf::write_material(&m)?;
    write_bytes_atomic(&a.output, &bytes)?;
    for action in &report.actions {
        eprintln!("sbrdf: {action}");
    }
    if report.actions.is_empty() {
        eprintln!("sbrdf: nothing to cut: the file is copied unchanged");
    }
    let place = if report.at_stored_positions {
        "at the stored sample positions"
    } else {
        "on a 5° grid (the file stores no sample positions)"
    };
    if m.warped.is_some() {
        // Warped tables record no error per incidence (their implied records hold +0): the
        // bound is the change against the original file's own values, reported, not stored.
        eprintln!(
            "sbrdf: change per (viewing) incidence made by the cuts against the original \
             file ({place}); warped tables store no error, so the bound is not stored:"
        );
    } else {
        eprintln!(
            "sbrdf: error per incidence: recorded, change made by the cuts ({place}), and the \
             upper bound now stored:"
        );
    }
    for r in &report.records {
        eprintln!(
            "  ({}, {}): recorded {:.5}, change {:.5}, bound {:.5}",
            r.theta_i, r.phi_i, r.recorded, r.change, r.bound
        );
    }
    eprintln!(
        "sbrdf: wrote {}: {} bytes (was {before}, {:.0}%)",
        a.output.display(),
        bytes.len(),
        100.0 * bytes.len() as f64 / before as f64
    );
    Ok(())
}
