//! Reading sampled BRDFs from files: CSV ([`crate::io::csv`]), spectral-EXR slices
//! ([`crate::io::exr`]) and RGL measurements ([`crate::io::rgl`]), and folders of them, in any
//! mix, through one collector ([`crate::io::collect`]), so every file gets the same checks
//! whatever its kind.

use crate::encode::samples::{ReadOptions, ReadReport, SampleSet};
use crate::error::{Error, Result};
use crate::io::astm::{collect_astm, looks_like_astm};
use crate::io::collect::build_sample_set;
use crate::io::csv::collect_csv;
use crate::io::exr::collect_exr;
use crate::io::rgl::{collect_rgl, MAGIC as RGL_MAGIC};
use std::path::{Path, PathBuf};

/// The first four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// The file-name extensions a folder is searched for.
const EXTENSIONS: [&str; 4] = ["exr", "csv", "astm", "bsdf"];

/// Expands folders into the `.exr`, `.csv`, `.astm` and `.bsdf` files they hold (sorted by name); files
/// are kept as given.
pub fn expand_inputs(paths: &[impl AsRef<Path>]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        let p = p.as_ref();
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| Error::io(p, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.is_file()
                        && f.extension()
                            .and_then(|x| x.to_str())
                            .is_some_and(|x| EXTENSIONS.iter().any(|e| x.eq_ignore_ascii_case(e)))
                })
                .collect();
            if found.is_empty() {
                return Err(Error::Input(format!(
                    "{}: the folder holds no .exr, .csv, .astm or .bsdf files",
                    p.display()
                )));
            }
            found.sort();
            out.extend(found);
        } else {
            out.push(p.to_path_buf());
        }
    }
    Ok(out)
}

/// Reads CSV files, EXR slices, RGL files and folders of them into one validated sample set,
/// with the default [`ReadOptions`] (RGB-only RGL files refused).
pub fn read_inputs(paths: &[impl AsRef<Path>]) -> Result<(SampleSet, ReadReport)> {
    read_inputs_with(paths, &ReadOptions::default())
}

/// [`read_inputs`] with options (`--rgb-to-spectrum`).
pub fn read_inputs_with(
    paths: &[impl AsRef<Path>],
    options: &ReadOptions,
) -> Result<(SampleSet, ReadReport)> {
    let mut files = Vec::new();
    for p in expand_inputs(paths)? {
        let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
        files.push((p.display().to_string(), bytes));
    }
    read_inputs_from_bytes_with(&files, options)
}

/// Named like an RGL file: read as one whatever its first bytes, so a damaged one is told so.
fn is_bsdf_name(name: &str) -> bool {
    Path::new(name)
        .extension()
        .and_then(|x| x.to_str())
        .is_some_and(|x| x.eq_ignore_ascii_case("bsdf"))
}

/// [`read_inputs`] over (name, bytes) pairs held in memory. A file is read as EXR when it
/// starts with the OpenEXR magic number, as an RGL tensor file when it starts with its magic or
/// is named `.bsdf`, as ASTM E1392 text when it is named `.astm` or its keyword lines lead to
/// `VARS`, as CSV otherwise.
pub fn read_inputs_from_bytes(files: &[(String, Vec<u8>)]) -> Result<(SampleSet, ReadReport)> {
    read_inputs_from_bytes_with(files, &ReadOptions::default())
}

/// [`read_inputs_with`] over (name, bytes) pairs held in memory. A file is read by its first
/// bytes: as EXR after the OpenEXR magic number, as an RGL file after `tensor_file\0` (or when
/// named `*.bsdf`), as CSV otherwise.
pub fn read_inputs_from_bytes_with(
    files: &[(String, Vec<u8>)],
    options: &ReadOptions,
) -> Result<(SampleSet, ReadReport)> {
    let names: Vec<String> = files.iter().map(|f| f.0.clone()).collect();
    let mut samples = Vec::new();
    let mut missing = 0;
    let mut from_readers = ReadReport::default();
    for (fi, (name, bytes)) in files.iter().enumerate() {
        if bytes.starts_with(&EXR_MAGIC) {
            missing += collect_exr(fi, name, bytes, &mut samples)?;
        } else if bytes.starts_with(RGL_MAGIC) || is_bsdf_name(name) {
            collect_rgl(fi, name, bytes, options, &mut samples, &mut from_readers)?;
        } else if looks_like_astm(name, bytes) {
            collect_astm(fi, name, bytes, &mut samples, &mut from_readers)?;
        } else {
            collect_csv(fi, name, bytes, &mut samples)?;
        }
    }
    let (set, mut report) = build_sample_set(samples, &names)?;
    report.missing_pixels = missing;
    report.notes = from_readers.notes;
    report.provenance = from_readers.provenance;
    Ok((set, report))
}
