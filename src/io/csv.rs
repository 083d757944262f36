//! CSV input and output (the `csv` crate does the parsing).
//!
//! Two layouts, found by header name (case-insensitive, surrounding spaces ignored):
//! * long: `theta_i,phi_i,theta_o,phi_o,wavelength_nm,value`, one sample a row;
//! * wide: `theta_i,phi_i,theta_o,phi_o,` then one column per wavelength in nm, named `400`,
//!   `400nm` or `412.5`.
//!
//! Lines starting with `#` are comments. Angles are degrees (θ ∈ [0, 90], φ taken modulo 360),
//! values are BRDF values in 1/sr. Every error names the file and line.

use crate::encode::samples::ReadReport;
use crate::encode::samples::SampleSet;
use crate::error::{Error, Result};
use crate::io::collect::{build_sample_set, Place, Sample};
use crate::model::angles::wrap_phi;
use std::path::Path;

const ANGLE_COLUMNS: [&str; 4] = ["theta_i", "phi_i", "theta_o", "phi_o"];

/// Which layout a file uses and where its columns are.
#[derive(Debug, Clone, PartialEq)]
pub enum Layout {
    /// One sample a row: `wavelength_nm` and `value` columns.
    Long {
        /// Column index of `wavelength_nm`.
        wavelength: usize,
        /// Column index of `value`.
        value: usize,
    },
    /// (column index, wavelength in nm) for each wavelength column, in file order.
    Wide {
        /// (column index, wavelength in nm) pairs.
        columns: Vec<(usize, f64)>,
    },
}

/// A parsed header.
#[derive(Debug, Clone)]
pub struct Header {
    /// The header fields as written.
    pub names: Vec<String>,
    /// Column of θi, φi, θo, φo.
    pub angles: [usize; 4],
    /// The layout and its value columns.
    pub layout: Layout,
}

/// One data row, validated: angles in degrees (φ wrapped into [0, 360)), and either one
/// (wavelength, value) pair (long) or one value per wavelength column (wide).
#[derive(Debug, Clone)]
pub struct Row {
    /// The row's line number in the file, for messages.
    pub line: u64,
    /// θi, φi, θo, φo in degrees (φ wrapped into [0, 360)).
    pub angles: [f64; 4],
    /// Long layout: `Some(wavelength)` in nm; wide: `None` (the header holds them).
    pub wavelength: Option<f64>,
    /// BRDF values (1/sr): one (long) or one per wavelength column (wide).
    pub values: Vec<f64>,
}

fn name_key(s: &str) -> String {
    s.trim().to_ascii_lowercase()
}

/// Parses a wavelength column name: `400`, `400nm`, `412.5`, `412.5 nm`.
pub fn parse_wavelength_name(s: &str) -> Option<f64> {
    let k = name_key(s);
    let num = k.strip_suffix("nm").unwrap_or(&k).trim();
    let v: f64 = num.parse().ok()?;
    (v.is_finite() && v > 0.0).then_some(v)
}

fn parse_header(path: &str, line: u64, fields: &csv::StringRecord) -> Result<Header> {
    let names: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
    let find = |want: &str| names.iter().position(|n| name_key(n) == want);
    let at = |m: String| Error::Input(format!("{path}:{line}: {m}"));
    let missing: Vec<&str> = ANGLE_COLUMNS
        .iter()
        .copied()
        .filter(|c| find(c).is_none())
        .collect();
    let wl = find("wavelength_nm");
    let value = find("value");
    let mut wide = Vec::new();
    for (i, n) in names.iter().enumerate() {
        let k = name_key(n);
        if ANGLE_COLUMNS.contains(&k.as_str()) || Some(i) == wl || Some(i) == value {
            continue;
        }
        match parse_wavelength_name(n) {
            Some(l) => wide.push((i, l)),
            None => {
                return Err(at(format!(
                    "column '{n}' is neither an angle column, 'wavelength_nm', 'value', nor a \
                     wavelength in nm (like '550' or '550nm')"
                )))
            }
        }
    }
    if !missing.is_empty() {
        return Err(at(format!(
            "missing column(s) {} (the header must name theta_i, phi_i, theta_o, phi_o, then \
             either wavelength_nm,value or one column per wavelength)",
            missing.join(", ")
        )));
    }
    let angles = ANGLE_COLUMNS.map(|c| find(c).unwrap());
    let layout = match (wl, value, wide.is_empty()) {
        (Some(wavelength), Some(value), true) => Layout::Long { wavelength, value },
        (None, None, false) => {
            for (i, (_, l)) in wide.iter().enumerate() {
                if let Some((_, other)) = wide[..i].iter().find(|(_, o)| o == l) {
                    return Err(at(format!("wavelength {other} nm has two columns")));
                }
            }
            Layout::Wide { columns: wide }
        }
        (Some(_), None, _) => return Err(at("missing column 'value' (long layout)".into())),
        (None, Some(_), _) => {
            return Err(at("missing column 'wavelength_nm' (long layout)".into()))
        }
        (None, None, true) => {
            return Err(at(
                "no wavelength columns: give wavelength_nm,value (long layout) or one column \
                 per wavelength (wide layout)"
                    .into(),
            ))
        }
        (Some(_), Some(_), false) => {
            return Err(at(
                "both wavelength_nm/value and wavelength columns: use one layout per file".into(),
            ))
        }
    };
    Ok(Header {
        names,
        angles,
        layout,
    })
}

fn number(path: &str, line: u64, column: &str, text: &str) -> Result<f64> {
    let v: f64 = text.trim().parse().map_err(|_| {
        Error::Input(format!(
            "{path}:{line}: column '{column}': '{text}' is not a number"
        ))
    })?;
    if !v.is_finite() {
        return Err(Error::Input(format!(
            "{path}:{line}: column '{column}': '{text}' is not a finite number"
        )));
    }
    Ok(v + 0.0) // −0 → +0, so equal angles compare equal bit for bit
}

fn parse_row(path: &str, h: &Header, line: u64, rec: &csv::StringRecord) -> Result<Row> {
    let get = |i: usize| rec.get(i).unwrap_or("");
    let mut angles = [0.0; 4];
    for (j, &c) in h.angles.iter().enumerate() {
        let v = number(path, line, ANGLE_COLUMNS[j], get(c))?;
        angles[j] = if j % 2 == 0 {
            if !(0.0..=90.0).contains(&v) {
                return Err(Error::Input(format!(
                    "{path}:{line}: {} = {v} is outside [0, 90] degrees",
                    ANGLE_COLUMNS[j]
                )));
            }
            v
        } else {
            wrap_phi(v)
        };
    }
    match &h.layout {
        Layout::Long { wavelength, value } => {
            let l = number(path, line, "wavelength_nm", get(*wavelength))?;
            if l <= 0.0 {
                return Err(Error::Input(format!(
                    "{path}:{line}: wavelength_nm = {l} is not positive"
                )));
            }
            let v = number(path, line, "value", get(*value))?;
            Ok(Row {
                line,
                angles,
                wavelength: Some(l),
                values: vec![v],
            })
        }
        Layout::Wide { columns } => {
            let mut values = Vec::with_capacity(columns.len());
            for &(c, _) in columns {
                values.push(number(path, line, &h.names[c], get(c))?);
            }
            Ok(Row {
                line,
                angles,
                wavelength: None,
                values,
            })
        }
    }
}

fn csv_error(path: &str, e: csv::Error) -> Error {
    let line = e.position().map(|p| p.line());
    let what = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("expected {expected_len} fields like the header, found {len}"),
        csv::ErrorKind::Utf8 { .. } => "the text is not valid UTF-8".into(),
        csv::ErrorKind::Io(io) => io.to_string(),
        _ => e.to_string(),
    };
    match line {
        Some(l) => Error::Input(format!("{path}:{l}: {what}")),
        None => Error::Input(format!("{path}: {what}")),
    }
}

/// The line number of the header: the csv crate reports line 1 for the first record even when
/// comment lines precede it, so count them here.
fn header_line(bytes: &[u8]) -> u64 {
    let mut line = 1;
    for l in bytes.split(|&b| b == b'\n') {
        if l.first() == Some(&b'#') || l.iter().all(|b| b.is_ascii_whitespace()) {
            line += 1;
        } else {
            break;
        }
    }
    line
}

/// Reads a CSV file row by row, validating each, and calls `f` with the header, the parsed row
/// and the raw record (so `decode --like` can copy the other fields verbatim).
pub fn scan(
    path: &Path,
    f: impl FnMut(&Header, Row, &csv::StringRecord) -> Result<()>,
) -> Result<Header> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    scan_bytes(&path.display().to_string(), &bytes, f)
}

/// [`scan`] over CSV text in memory; `name` stands for the file in messages.
pub fn scan_bytes(
    name: &str,
    bytes: &[u8],
    mut f: impl FnMut(&Header, Row, &csv::StringRecord) -> Result<()>,
) -> Result<Header> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .comment(Some(b'#'))
        .flexible(false)
        .from_reader(bytes);
    let mut header: Option<Header> = None;
    let mut rec = csv::StringRecord::new();
    let mut rows = 0usize;
    while reader
        .read_record(&mut rec)
        .map_err(|e| csv_error(name, e))?
    {
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        match &header {
            None => header = Some(parse_header(name, header_line(bytes), &rec)?),
            Some(h) => {
                // A blank line inside the data is harmless; csv yields it as one empty field.
                if rec.len() == 1 && rec[0].trim().is_empty() {
                    continue;
                }
                let row = parse_row(name, h, line, &rec)?;
                f(h, row, &rec)?;
                rows += 1;
            }
        }
    }
    let header =
        header.ok_or_else(|| Error::Input(format!("{name}: empty file (no header line)")))?;
    if rows == 0 {
        return Err(Error::Input(format!(
            "{name}: no data rows after the header"
        )));
    }
    Ok(header)
}

/// Reads one or more CSV files (any mix of layouts) into one validated sample set.
pub fn read_samples(paths: &[impl AsRef<Path>]) -> Result<(SampleSet, ReadReport)> {
    let mut files = Vec::with_capacity(paths.len());
    for p in paths {
        let p = p.as_ref();
        files.push((
            p.display().to_string(),
            std::fs::read(p).map_err(|e| Error::io(p, e))?,
        ));
    }
    read_samples_from_bytes(&files)
}

/// [`read_samples`] over (name, CSV text) pairs held in memory.
pub fn read_samples_from_bytes(files: &[(String, Vec<u8>)]) -> Result<(SampleSet, ReadReport)> {
    let names: Vec<String> = files.iter().map(|f| f.0.clone()).collect();
    let mut samples: Vec<Sample> = Vec::new();
    for (fi, (name, bytes)) in files.iter().enumerate() {
        collect_csv(fi, name, bytes, &mut samples)?;
    }
    build_sample_set(samples, &names)
}

/// Appends the samples of one CSV file (file number `fi`) to `samples`.
pub(crate) fn collect_csv(
    fi: usize,
    name: &str,
    bytes: &[u8],
    samples: &mut Vec<Sample>,
) -> Result<()> {
    {
        scan_bytes(name, bytes, |h, row, _| {
            let a = row.angles.map(f64::to_bits);
            let mut push = |l: f64, v: f64| {
                samples.push(Sample {
                    key: [a[0], a[1], a[2], a[3], l.to_bits()],
                    value: v,
                    file: fi as u32,
                    place: Place::Line(row.line),
                })
            };
            match (&h.layout, row.wavelength) {
                (Layout::Long { .. }, Some(l)) => push(l, row.values[0]),
                (Layout::Wide { columns }, _) => {
                    for (&(_, l), &v) in columns.iter().zip(&row.values) {
                        push(l, v);
                    }
                }
                _ => unreachable!("long rows carry their wavelength"),
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// Formats a wavelength as a column name: the shortest text that reads back the same.
pub fn wavelength_name(l: f64) -> String {
    format!("{l}")
}

/// Writes samples in the wide layout (one row per direction, one column per wavelength).
pub fn write_wide(set: &SampleSet, out: impl std::io::Write, comment: Option<&str>) -> Result<()> {
    let mut out = out;
    if let Some(c) = comment {
        for line in c.lines() {
            writeln!(out, "# {line}").map_err(|e| Error::Io {
                path: None,
                source: e,
            })?;
        }
    }
    let mut w = csv::Writer::from_writer(out);
    let mut header: Vec<String> = ANGLE_COLUMNS.iter().map(|s| s.to_string()).collect();
    header.extend(set.wavelengths.iter().map(|&l| wavelength_name(l)));
    w.write_record(&header)
        .map_err(|e| csv_error("output", e))?;
    let nw = set.wavelengths.len();
    for s in &set.incidences {
        for (d, dir) in s.directions.iter().enumerate() {
            let mut row = vec![
                s.theta_i.to_string(),
                s.phi_i.to_string(),
                dir[0].to_string(),
                dir[1].to_string(),
            ];
            row.extend(s.values[d * nw..(d + 1) * nw].iter().map(|v| v.to_string()));
            w.write_record(&row).map_err(|e| csv_error("output", e))?;
        }
    }
    w.flush().map_err(|e| Error::Io {
        path: None,
        source: e,
    })?;
    Ok(())
}

/// Writes samples in the long layout (one row per sample).
pub fn write_long(set: &SampleSet, out: impl std::io::Write) -> Result<()> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(
        ANGLE_COLUMNS
            .iter()
            .copied()
            .chain(["wavelength_nm", "value"]),
    )
    .map_err(|e| csv_error("output", e))?;
    let nw = set.wavelengths.len();
    for s in &set.incidences {
        for (d, dir) in s.directions.iter().enumerate() {
            for (j, l) in set.wavelengths.iter().enumerate() {
                w.write_record([
                    s.theta_i.to_string(),
                    s.phi_i.to_string(),
                    dir[0].to_string(),
                    dir[1].to_string(),
                    l.to_string(),
                    s.values[d * nw + j].to_string(),
                ])
                .map_err(|e| csv_error("output", e))?;
            }
        }
    }
    w.flush().map_err(|e| Error::Io {
        path: None,
        source: e,
    })?;
    Ok(())
}
