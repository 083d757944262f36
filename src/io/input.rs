//! Reading sampled BRDFs from files: CSV ([`crate::io::csv`]) and spectral-EXR slices
//! ([`crate::io::exr`]), and folders of them, in any mix, through one collector
//! ([`crate::io::collect`]), so every file gets the same checks whatever its kind.

use crate::encode::samples::{ReadReport, SampleSet};
use crate::error::{Error, Result};
use crate::io::astm::{collect_astm, looks_like_astm};
use crate::io::collect::build_sample_set;
use crate::io::csv::collect_csv;
use crate::io::exr::collect_exr;
use std::path::{Path, PathBuf};

/// The first four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Expands folders into the `.exr` and `.csv` files they hold (sorted by name); files are kept
/// as given.
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
                        && f.extension().and_then(|x| x.to_str()).is_some_and(|x| {
                            ["exr", "csv", "astm"]
                                .iter()
                                .any(|k| x.eq_ignore_ascii_case(k))
                        })
                })
                .collect();
            if found.is_empty() {
                return Err(Error::Input(format!(
                    "{}: the folder holds no .exr, .csv or .astm files",
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

/// Reads CSV files, EXR slices and folders of them into one validated sample set.
pub fn read_inputs(paths: &[impl AsRef<Path>]) -> Result<(SampleSet, ReadReport)> {
    let mut files = Vec::new();
    for p in expand_inputs(paths)? {
        let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
        files.push((p.display().to_string(), bytes));
    }
    read_inputs_from_bytes(&files)
}

/// [`read_inputs`] over (name, bytes) pairs held in memory. A file is read as EXR when it
/// starts with the OpenEXR magic number, as ASTM E1392 text when it is named `.astm` or its
/// keyword lines lead to `VARS`, as CSV otherwise.
pub fn read_inputs_from_bytes(files: &[(String, Vec<u8>)]) -> Result<(SampleSet, ReadReport)> {
    let names: Vec<String> = files.iter().map(|f| f.0.clone()).collect();
    let mut samples = Vec::new();
    let mut found = ReadReport::default();
    for (fi, (name, bytes)) in files.iter().enumerate() {
        if bytes.starts_with(&EXR_MAGIC) {
            found.missing_pixels += collect_exr(fi, name, bytes, &mut samples)?;
        } else if looks_like_astm(name, bytes) {
            collect_astm(fi, name, bytes, &mut samples, &mut found)?;
        } else {
            collect_csv(fi, name, bytes, &mut samples)?;
        }
    }
    let (set, report) = build_sample_set(samples, &names)?;
    Ok((
        set,
        ReadReport {
            negative_values: report.negative_values,
            ..found
        },
    ))
}
