//! `sbrdf decode`: the reconstruction written as CSV (at a reference's rows or at the positions
//! the encoder saw), as spectral-EXR slices, or as ASTM E1392 text.

use super::parse::parse_resolution;
use clap::{Args, ValueEnum};
use sbrdf::encode::samples::{IncidentSamples, SampleSet};
use sbrdf::io::astm;
use sbrdf::io::csv::{self as csv_io, Layout};
use sbrdf::io::exr;
use sbrdf::io::output::{ensure_output_folder, write_atomic, write_bytes_atomic};
use sbrdf::model::material::DirectionSet;
use sbrdf::{Decoder, Error, Material, Result};
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct DecodeArgs {
    pub input: PathBuf,
    /// Output CSV file; with --exr, the folder for the slices (created if its parent exists).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Reference: write values at exactly its rows, in its layout (CSV); with --astm, any
    /// input (CSV, EXR, ASTM) whose positions and wavelengths to use.
    #[arg(long, value_name = "REF", conflicts_with = "exr")]
    pub like: Option<PathBuf>,
    /// Write ASTM E1392 text (angles in radians, one column per wavelength), headed by the
    /// keyword lines of the ASTM file the material was encoded from (kept in its metadata).
    #[arg(long, conflicts_with = "exr")]
    pub astm: bool,
    /// Write one spectral EXR per stored incident direction (channels T.<λ>nm; pixel (i, j) is
    /// θo = (i + ½)·90°/H, φo = (j + ½)·360°/W), named <stem>_ti<θ>_pi<φ>.exr.
    #[arg(long)]
    pub exr: bool,
    /// With --exr: rows × columns (θo × φo), like 18x72 [default: the stored sample grid when
    /// it is a pixel grid, else 18x72, i.e. 5°].
    #[arg(long, value_name = "HxW", requires = "exr")]
    pub resolution: Option<String>,
    /// With --exr: pixel storage.
    #[arg(long, value_enum, default_value = "float", requires = "exr")]
    pub pixel_type: PixelTypeArg,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum PixelTypeArg {
    Half,
    Float,
}

pub fn cmd_decode(a: DecodeArgs) -> Result<()> {
    let dec = Decoder::open_with(&a.input, sbrdf::Residency::Exact)?;
    if a.exr {
        return decode_exr(&dec, &a);
    }
    if a.astm {
        let m = dec.material();
        let set = match &a.like {
            Some(reference) => {
                let (like, _) = sbrdf::io::read_inputs(std::slice::from_ref(reference))?;
                decode_at(
                    &dec,
                    &like.wavelengths,
                    like.incidences
                        .iter()
                        .map(|s| ((s.theta_i, s.phi_i), s.directions.clone())),
                )
            }
            None => decode_at_stored(&dec, &a.input)?,
        };
        let (mut header, turned) = astm::header_from_metadata(m.metadata.as_deref());
        if header.is_empty() {
            header.push(format!(
                "COMMENTS decoded by sbrdf {} from {}",
                env!("CARGO_PKG_VERSION"),
                a.input.display()
            ));
        }
        return write_atomic(&a.output, |w| astm::write_astm(&set, &header, turned, w));
    }
    match &a.like {
        Some(reference) => decode_like(&dec, reference, &a.output),
        None => {
            let set = decode_at_stored(&dec, &a.input)?;
            let note = format!(
                "decoded by sbrdf {} from {}",
                env!("CARGO_PKG_VERSION"),
                a.input.display()
            );
            write_atomic(&a.output, |w| csv_io::write_wide(&set, w, Some(&note)))
        }
    }
}

/// The decoded values at the file's stored sample positions and wavelengths.
fn decode_at_stored(dec: &Decoder, input: &Path) -> Result<SampleSet> {
    let m = dec.material();
    let sp = m.sample_positions.as_ref().ok_or_else(|| {
        Error::Parameter(format!(
            "{} stores no sample positions (encoded with --no-sample-positions): \
             give --like REF to name the positions",
            input.display()
        ))
    })?;
    let total: u64 = sp
        .set_of_incidence
        .iter()
        .map(|&i| sp.sets[i as usize].len() as u64)
        .sum();
    if total > 1 << 26 {
        return Err(Error::LimitsExceeded(format!(
            "{} lists {total} sample positions, more than this command writes; \
             give --like REF to choose the positions",
            input.display()
        )));
    }
    let wl: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
    Ok(decode_at(
        dec,
        &wl,
        m.records.iter().enumerate().map(|(i, r)| {
            let dirs = sp.sets[sp.set_of_incidence[i] as usize].directions();
            ((r.theta_i as f64, r.phi_i as f64), dirs)
        }),
    ))
}

/// The decoded values at each incidence's outgoing directions, at `wl`.
fn decode_at(
    dec: &Decoder,
    wl: &[f64],
    positions: impl Iterator<Item = ((f64, f64), Vec<[f64; 2]>)>,
) -> SampleSet {
    let mut set = SampleSet {
        wavelengths: wl.to_vec(),
        incidences: Vec::new(),
    };
    for ((ti, pi), dirs) in positions {
        let mut values = vec![0.0; dirs.len() * wl.len()];
        for (dir, out) in dirs.iter().zip(values.chunks_mut(wl.len().max(1))) {
            dec.eval_deg((ti, pi), (dir[0], dir[1]), wl, out);
        }
        set.incidences.push(IncidentSamples {
            theta_i: ti,
            phi_i: pi,
            directions: dirs,
            values,
        });
    }
    set
}

/// The stored sample grid of record `i` as (rows, columns) when it is an EXR pixel grid.
fn stored_pixel_grid(m: &Material, i: usize) -> Option<(usize, usize)> {
    let sp = m.sample_positions.as_ref()?;
    match sp.sets.get(*sp.set_of_incidence.get(i)? as usize)? {
        DirectionSet::Grid {
            theta0,
            dtheta,
            ntheta,
            phi0,
            dphi,
            nphi,
        } => {
            let (h, w) = (*ntheta as usize, *nphi as usize);
            let close = |a: f32, b: f64| (a as f64 - b).abs() <= 1e-5 * b.abs().max(1.0);
            (h > 0
                && w > 0
                && close(*dtheta, 90.0 / h as f64)
                && close(*theta0, 45.0 / h as f64)
                && close(*dphi, 360.0 / w as f64)
                && close(*phi0, 180.0 / w as f64))
            .then_some((h, w))
        }
        DirectionSet::List(_) => None,
    }
}

fn decode_exr(dec: &Decoder, a: &DecodeArgs) -> Result<()> {
    let m = dec.material();
    let fixed = a.resolution.as_deref().map(parse_resolution).transpose()?;
    let dir = &a.output;
    ensure_output_folder(dir, "--exr")?;
    let stem = a
        .input
        .file_stem()
        .map_or("slice".into(), |s| s.to_string_lossy().into_owned());
    let wl: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
    let pixel_type = match a.pixel_type {
        PixelTypeArg::Half => exr::PixelType::Half,
        PixelTypeArg::Float => exr::PixelType::Float,
    };
    for (i, r) in m.records.iter().enumerate() {
        let (h, w) = fixed
            .or_else(|| stored_pixel_grid(m, i))
            .unwrap_or((18, 72));
        let (ti, pi) = (r.theta_i as f64, r.phi_i as f64);
        let mut values = vec![0.0; h * w * wl.len()];
        for row in 0..h {
            for col in 0..w {
                let o = exr::pixel_direction(row, col, h, w);
                let at = (row * w + col) * wl.len();
                dec.eval_deg((ti, pi), (o[0], o[1]), &wl, &mut values[at..at + wl.len()]);
            }
        }
        let bytes = exr::write_slice(ti, pi, h, w, &wl, &values, pixel_type)?;
        let path = dir.join(exr::slice_file_name(&stem, ti, pi));
        write_bytes_atomic(&path, &bytes)?;
    }
    eprintln!(
        "sbrdf: wrote {} spectral EXR slices ({} wavelengths) to {}",
        m.records.len(),
        wl.len(),
        dir.display()
    );
    Ok(())
}

fn decode_like(dec: &Decoder, reference: &Path, output: &Path) -> Result<()> {
    write_atomic(output, |w| {
        let mut out = csv::WriterBuilder::new().flexible(true).from_writer(w);
        let mut wrote_header = false;
        let mut values = Vec::new();
        let fail = |e: csv::Error| Error::Parameter(format!("{}: {e}", output.display()));
        csv_io::scan(reference, |h, row, raw| {
            if !wrote_header {
                out.write_record(&h.names).map_err(fail)?;
                wrote_header = true;
            }
            let inc = (row.angles[0], row.angles[1]);
            let outg = (row.angles[2], row.angles[3]);
            let mut fields: Vec<String> = raw.iter().map(|s| s.to_string()).collect();
            match &h.layout {
                Layout::Long { value, .. } => {
                    let mut v = [0.0];
                    dec.eval_deg(inc, outg, &[row.wavelength.unwrap()], &mut v);
                    fields[*value] = v[0].to_string();
                }
                Layout::Wide { columns } => {
                    let wl: Vec<f64> = columns.iter().map(|c| c.1).collect();
                    values.resize(wl.len(), 0.0);
                    dec.eval_deg(inc, outg, &wl, &mut values);
                    for (j, (c, _)) in columns.iter().enumerate() {
                        fields[*c] = values[j].to_string();
                    }
                }
            }
            out.write_record(&fields).map_err(fail)
        })?;
        out.flush().map_err(|e| Error::Io {
            path: Some(output.to_path_buf()),
            source: e,
        })
    })
}
