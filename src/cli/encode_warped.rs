//! `sbrdf encode` of one RGL file into warped tables: the library's
//! [`sbrdf::io::rgl::encode_warped_file`] (which Python's `sbrdf.encode` calls too), written
//! atomically and reported.

use sbrdf::encode::settings::EncodeSettings;
use sbrdf::io::output::write_bytes_atomic;
use sbrdf::Result;

/// Encodes `inputs` as warped tables where the settings and the input call for it, writes
/// `output` and reports; returns whether it did.
pub fn try_encode(
    inputs: &[std::path::PathBuf],
    output: &std::path::Path,
    settings: &EncodeSettings,
) -> Result<bool> {
    let started = std::time::Instant::now();
    let Some(o) = sbrdf::io::rgl::encode_warped_file(inputs, settings)? else {
        return Ok(false);
    };
    for m in &o.messages {
        eprintln!("sbrdf: {m}");
    }
    write_bytes_atomic(output, &o.bytes)?;
    let errs: Vec<String> = o
        .errors
        .iter()
        .zip(&o.thetas_deg)
        .map(|(e, t)| format!("{t:.1}°: {:.3}%", 100.0 * e))
        .collect();
    eprintln!(
        "sbrdf: wrote {}: warped tables, {} incidences, {} spectral terms, {} bytes ({:.0}× smaller \
         than the {}-byte input) in {:.1} s; relative error per stored incidence {}; the \
         measurement's noise estimated at up to {:.3}%",
        output.display(),
        o.thetas_deg.len(),
        o.terms,
        o.bytes.len(),
        o.input_bytes as f64 / o.bytes.len() as f64,
        o.input_bytes,
        started.elapsed().as_secs_f64(),
        errs.join(", "),
        100.0 * o.noise_floor()
    );
    Ok(true)
}
