//! ASTM E1392 text: the keyword-and-table layout in which goniometers (the Cornell
//! gonioreflectometer among them) deliver BRDF measurements. Read by `sbrdf encode`, written by
//! `sbrdf decode --astm`, so an archive can give a lab its data back in the format it came in.
//!
//! Layout (`spec/ASTM.md` is the exact contract):
//!
//! ```text
//! LAB_NAME Cornell University, Program of Computer Graphics     keyword lines: KEYWORD value
//! NUM_POINTS 1439                                               the number of data rows
//! VARS theta_i,phi_i,theta_s,phi_s,400nm,410nm,...              the columns
//!
//! 0.872665,0.000000,0.573513,0.000000,0.014369,0.018226,...     one row per direction pair
//! ```
//!
//! Angles are in radians unless a keyword `ANGLE_UNITS DEGREES` says otherwise; θ from the
//! normal, φ counter-clockwise, the mirror direction of (θi, φi) at (θi, φi + π) as in sbrdf. A
//! file whose peaks sit on the side of the source instead (φs measured from the opposite axis)
//! is turned by 180° in φs, and says so. Values are BRDF in 1/sr, one column per wavelength
//! (`400nm`, `400`), or one `BRDF` column with a `WAVELENGTH` keyword. The data table is read
//! with the `csv` crate; every error names the file and line.

use crate::encode::samples::{ReadReport, SampleSet};
use crate::error::{Error, Result};
use crate::io::collect::{Place, Sample};
use crate::io::csv::parse_wavelength_name;
use crate::model::angles::{dir_from_deg, dot, wrap_phi};

/// The metadata key under which an ASTM file's header is kept: its keyword lines in order,
/// blank lines included, without `NUM_POINTS` and `VARS` (the data give those).
pub const HEADER_KEY: &str = "astm.header";
/// The metadata key recording that φs was turned by 180° on reading.
pub const TURNED_KEY: &str = "astm.azimuth_turned_deg";

/// Keywords the reader interprets and the writer regenerates: not carried as provenance.
const STRUCTURAL: [&str; 2] = ["NUM_POINTS", "VARS"];

/// A parsed ASTM file: its keywords in file order and its rows, angles in degrees.
#[derive(Debug, Clone)]
pub struct AstmFile {
    /// Every `KEYWORD value` line before `VARS` except `NUM_POINTS`, in file order.
    pub keywords: Vec<(String, String)>,
    /// The header as written, line by line (blank lines kept), without `NUM_POINTS` and `VARS`.
    pub header: Vec<String>,
    /// The wavelengths of the value columns, nm, in column order.
    pub wavelengths: Vec<f64>,
    /// The data rows, in file order.
    pub rows: Vec<AstmRow>,
    /// True when φs was turned by 180° because the peaks sat on the source's side.
    pub azimuth_turned: bool,
    /// True when the angles were read as degrees (`ANGLE_UNITS DEGREES`).
    pub degrees: bool,
}

/// One data row: θi, φi, θs, φs in degrees (φ in [0, 360)), one value per wavelength.
#[derive(Debug, Clone)]
pub struct AstmRow {
    /// The row's line number in the file, for messages.
    pub line: u64,
    /// θi, φi, θs, φs in degrees (θ clamped to [0, 90], φ wrapped into [0, 360)).
    pub angles: [f64; 4],
    /// The BRDF (1/sr), one value per wavelength of [`AstmFile::wavelengths`].
    pub values: Vec<f64>,
}

/// True when `bytes` look like ASTM text: a `.astm` name, or keyword lines leading to `VARS`.
pub fn looks_like_astm(name: &str, bytes: &[u8]) -> bool {
    if name.to_ascii_lowercase().ends_with(".astm") {
        return true;
    }
    let head = &bytes[..bytes.len().min(1 << 16)];
    let Ok(text) =
        std::str::from_utf8(head).or_else(|e| std::str::from_utf8(&head[..e.valid_up_to()]))
    else {
        return false;
    };
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let key = line.split_whitespace().next().unwrap_or("");
        if !is_keyword(key) {
            return false;
        }
        if key == "VARS" {
            return true;
        }
    }
    false
}

fn is_keyword(s: &str) -> bool {
    let mut c = s.chars();
    c.next().is_some_and(|f| f.is_ascii_uppercase())
        && c.all(|x| x.is_ascii_uppercase() || x.is_ascii_digit() || x == '_')
}

/// Which column holds what.
enum Columns {
    /// Column of θi, φi, θs, φs, and (column, wavelength) per value column.
    Spectral([usize; 4], Vec<(usize, f64)>),
}

fn parse_vars(name: &str, line: u64, vars: &str, keywords: &[(String, String)]) -> Result<Columns> {
    let at = |m: String| Error::Input(format!("{name}:{line}: {m}"));
    let names: Vec<String> = vars.split(',').map(|s| s.trim().to_string()).collect();
    let key = |s: &str| s.to_ascii_lowercase();
    let find = |options: &[&str]| {
        names
            .iter()
            .position(|n| options.contains(&key(n).as_str()))
    };
    let mut angles = [0usize; 4];
    for (slot, options) in angles.iter_mut().zip([
        &["theta_i"][..],
        &["phi_i"],
        &["theta_s", "theta_r", "theta_o"],
        &["phi_s", "phi_r", "phi_o"],
    ]) {
        *slot = find(options).ok_or_else(|| {
            at(format!(
                "VARS lacks {} (it names: {})",
                options[0],
                names.join(", ")
            ))
        })?;
    }
    let mut values = Vec::new();
    for (i, n) in names.iter().enumerate() {
        if angles.contains(&i) {
            continue;
        }
        if let Some(l) = parse_wavelength_name(n) {
            values.push((i, l));
        } else if key(n) == "brdf" {
            let w = keywords
                .iter()
                .find(|(k, _)| k == "WAVELENGTH")
                .ok_or_else(|| at("a BRDF column needs a WAVELENGTH keyword (in nm)".into()))?;
            let l = parse_wavelength_value(&w.1).ok_or_else(|| {
                at(format!(
                    "WAVELENGTH '{}': expected a wavelength like 633, 633 nm or 0.633 um",
                    w.1
                ))
            })?;
            values.push((i, l));
        } else {
            return Err(at(format!(
                "VARS column '{n}' is neither an angle (theta_i, phi_i, theta_s, phi_s) nor a \
                 wavelength (400nm, 400) nor BRDF"
            )));
        }
    }
    if values.is_empty() {
        return Err(at("VARS names no wavelength column".into()));
    }
    let mut seen: Vec<f64> = values.iter().map(|v| v.1).collect();
    seen.sort_by(f64::total_cmp);
    if seen.windows(2).any(|w| w[0] == w[1]) {
        return Err(at("VARS names a wavelength twice".into()));
    }
    Ok(Columns::Spectral(angles, values))
}

/// `633`, `633 nm`, `0.633 um`, `0.633 µm`.
fn parse_wavelength_value(s: &str) -> Option<f64> {
    let t = s.trim().to_ascii_lowercase();
    let (num, scale) = if let Some(n) = t.strip_suffix("um").or(t.strip_suffix("µm")) {
        (n, 1000.0)
    } else {
        (t.strip_suffix("nm").unwrap_or(&t), 1.0)
    };
    let v: f64 = num.trim().parse().ok()?;
    let v = v * scale;
    (v.is_finite() && v > 0.0).then_some(v)
}

/// Degrees from radians printed as `text`: when the text has at least six decimals (so the
/// snap moves the angle by less than 3·10⁻⁵°), the degree value with at most four decimals whose
/// radians print back as `text` at its own number of decimals (0.174533 is 10°, not
/// 10.0000042°); the exact conversion otherwise.
fn radians_to_degrees(text: &str, rad: f64) -> f64 {
    let exact = rad.to_degrees();
    let decimals = text.split_once('.').map_or(0, |(_, f)| f.len());
    if decimals < 6 {
        return exact;
    }
    for places in 0..=4 {
        let p = 10f64.powi(places);
        let nice = (exact * p).round() / p;
        let back = format!("{:.*}", decimals, nice.to_radians());
        if back == text
            || (nice == 0.0 && back.trim_start_matches('-') == text.trim_start_matches('-'))
        {
            return nice;
        }
    }
    exact
}

/// Parses an ASTM E1392 file held in memory; `name` appears in every error.
pub fn read_astm(name: &str, bytes: &[u8]) -> Result<AstmFile> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        Error::Input(format!("{name}:{line}: not UTF-8 text"))
    })?;
    // The header: keyword lines up to and including VARS.
    let mut keywords: Vec<(String, String)> = Vec::new();
    let mut header: Vec<String> = Vec::new();
    let mut num_points: Option<(u64, usize)> = None;
    let mut vars: Option<(u64, String)> = None;
    let mut offset = 0usize;
    let mut line_no = 0u64;
    for raw in text.split_inclusive('\n') {
        line_no += 1;
        offset += raw.len();
        let line = raw.trim();
        if line.is_empty() {
            if !header.is_empty() {
                header.push(String::new());
            }
            continue;
        }
        let (key, value) = match line.find(char::is_whitespace) {
            Some(i) => (&line[..i], line[i..].trim()),
            None => (line, ""),
        };
        if line.starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c)) {
            return Err(Error::Input(format!(
                "{name}:{line_no}: a data row before the VARS line that names the columns"
            )));
        }
        if !is_keyword(key) {
            return Err(Error::Input(format!(
                "{name}:{line_no}: expected a 'KEYWORD value' line (upper-case keyword) before \
                 VARS, found '{}'",
                line.chars().take(40).collect::<String>()
            )));
        }
        match key {
            "VARS" => {
                vars = Some((line_no, value.to_string()));
                break;
            }
            "NUM_POINTS" => {
                let n = value.parse::<usize>().map_err(|_| {
                    Error::Input(format!(
                        "{name}:{line_no}: NUM_POINTS '{value}' is not a whole number"
                    ))
                })?;
                num_points = Some((line_no, n));
            }
            _ => {
                keywords.push((key.to_string(), value.to_string()));
                header.push(line.to_string());
            }
        }
    }
    let (vars_line, vars) = vars.ok_or_else(|| {
        Error::Input(format!(
            "{name}: no VARS line: an ASTM E1392 file names its columns in a line \
             'VARS theta_i,phi_i,theta_s,phi_s,400nm,...' before the data"
        ))
    })?;
    let Columns::Spectral(angle_cols, value_cols) = parse_vars(name, vars_line, &vars, &keywords)?;
    let degrees = match keywords.iter().find(|(k, _)| k == "ANGLE_UNITS") {
        None => false,
        Some((_, v)) => match v.to_ascii_lowercase().as_str() {
            "radians" | "radian" | "rad" => false,
            "degrees" | "degree" | "deg" => true,
            _ => {
                return Err(Error::Input(format!(
                    "{name}: ANGLE_UNITS '{v}': expected RADIANS or DEGREES"
                )))
            }
        },
    };
    // The data table, by the csv crate; its line numbers count from the line after VARS.
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(&bytes[offset..]);
    let ncols = angle_cols
        .iter()
        .chain(value_cols.iter().map(|v| &v.0))
        .max()
        .map_or(0, |m| m + 1);
    let mut rows = Vec::new();
    let mut record = csv::StringRecord::new();
    let data = &bytes[offset..];
    // The file line of a record that starts at byte `at` of the table (the csv crate counts a
    // skipped blank line into the next record's position, so lines are counted here).
    let line_at = |at: u64| {
        let at = (at as usize).min(data.len());
        let start = at
            + data[at..]
                .iter()
                .take_while(|b| **b == b'\n' || **b == b'\r')
                .count();
        vars_line + 1 + data[..start].iter().filter(|&&b| b == b'\n').count() as u64
    };
    loop {
        let more = reader.read_record(&mut record).map_err(|e| {
            let line = line_at(e.position().map_or(0, |p| p.byte()));
            Error::Input(format!("{name}:{line}: {e}"))
        })?;
        if !more {
            break;
        }
        let line = line_at(record.position().map_or(0, |p| p.byte()));
        if record.len() == 1 && record[0].is_empty() {
            continue;
        }
        if record.len() != ncols {
            return Err(Error::Input(format!(
                "{name}:{line}: {} fields, but VARS names {ncols}",
                record.len()
            )));
        }
        let number = |i: usize, what: &str| -> Result<f64> {
            let s = &record[i];
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(Error::Input(format!(
                    "{name}:{line}: {what} '{s}' is not a finite number"
                ))),
            }
        };
        let mut angles = [0.0; 4];
        for (k, (&c, what)) in angle_cols
            .iter()
            .zip(["theta_i", "phi_i", "theta_s", "phi_s"])
            .enumerate()
        {
            let v = if degrees {
                number(c, what)?
            } else {
                radians_to_degrees(&record[c], number(c, what)?)
            };
            angles[k] = if k % 2 == 0 {
                // 1e-4° of slack for radians printed to six decimals (π/2 as 1.570796).
                if !(-1e-4..=90.0 + 1e-4).contains(&v) {
                    return Err(Error::Input(format!(
                        "{name}:{line}: {what} = {v:.4}° is outside [0, 90]{}",
                        if degrees {
                            ""
                        } else {
                            " (angles read as radians; a keyword ANGLE_UNITS DEGREES says otherwise)"
                        }
                    )));
                }
                v.clamp(0.0, 90.0) + 0.0
            } else {
                wrap_phi(v)
            };
        }
        let values = value_cols
            .iter()
            .map(|&(c, l)| number(c, &format!("{l} nm")))
            .collect::<Result<Vec<f64>>>()?;
        rows.push(AstmRow {
            line,
            angles,
            values,
        });
    }
    if let Some((line, n)) = num_points {
        if n != rows.len() {
            return Err(Error::Input(format!(
                "{name}:{line}: NUM_POINTS says {n} data rows, the file holds {}",
                rows.len()
            )));
        }
    }
    if rows.is_empty() {
        return Err(Error::Input(format!("{name}: no data rows after VARS")));
    }
    while header.last().is_some_and(|l| l.is_empty()) {
        header.pop();
    }
    let mut file = AstmFile {
        keywords,
        header,
        wavelengths: value_cols.iter().map(|v| v.1).collect(),
        rows,
        azimuth_turned: false,
        degrees,
    };
    if peaks_on_source_side(&file) {
        for r in &mut file.rows {
            r.angles[3] = wrap_phi(r.angles[3] + 180.0);
        }
        file.azimuth_turned = true;
    }
    Ok(file)
}

/// Checks the azimuth convention against the data: per incidence away from the normal, is the
/// brightest sample nearer the mirror direction (θi, φi + 180°), as sbrdf and Cornell place it,
/// or nearer the source's own side (θi, φi)? True when most incidences with a clear peak say
/// the source's side.
fn peaks_on_source_side(f: &AstmFile) -> bool {
    let mut incidences: Vec<([u64; 2], usize)> = Vec::new();
    for (i, r) in f.rows.iter().enumerate() {
        if r.angles[0] < 5.0 {
            continue; // near the normal both sides are one
        }
        let key = [r.angles[0].to_bits(), r.angles[1].to_bits()];
        let mean = |row: &AstmRow| row.values.iter().sum::<f64>();
        match incidences.iter_mut().find(|e| e.0 == key) {
            Some(e) => {
                if mean(r) > mean(&f.rows[e.1]) {
                    e.1 = i;
                }
            }
            None => incidences.push((key, i)),
        }
    }
    let (mut mirror, mut source) = (0, 0);
    for (_, i) in incidences {
        let a = f.rows[i].angles;
        let peak = dir_from_deg(a[2], a[3]);
        let to_mirror = dot(peak, dir_from_deg(a[0], a[1] + 180.0));
        let to_source = dot(peak, dir_from_deg(a[0], a[1]));
        // A clear peak: within 20° of one candidate.
        let near = 20f64.to_radians().cos();
        if to_mirror > near && to_mirror > to_source {
            mirror += 1;
        } else if to_source > near && to_source > to_mirror {
            source += 1;
        }
    }
    source > mirror
}

/// Appends the samples of one ASTM file (file number `fi`) to `samples` and records its
/// keywords and any convention note in `report`.
pub(crate) fn collect_astm(
    fi: usize,
    name: &str,
    bytes: &[u8],
    samples: &mut Vec<Sample>,
    report: &mut ReadReport,
) -> Result<()> {
    let f = read_astm(name, bytes)?;
    samples.reserve(f.rows.len() * f.wavelengths.len());
    for r in &f.rows {
        let a = r.angles.map(f64::to_bits);
        for (&l, &v) in f.wavelengths.iter().zip(&r.values) {
            samples.push(Sample {
                key: [a[0], a[1], a[2], a[3], l.to_bits()],
                value: v,
                file: fi as u32,
                place: Place::Line(r.line),
            });
        }
    }
    // The first ASTM input's header is the one `decode --astm` writes back; later ones are kept
    // under numbered keys.
    let n = report
        .provenance
        .iter()
        .filter(|(k, _)| k.starts_with(HEADER_KEY))
        .count();
    let suffix = if n == 0 {
        String::new()
    } else {
        format!(".{}", n + 1)
    };
    report
        .provenance
        .push((format!("{HEADER_KEY}{suffix}"), f.header.join("\n")));
    if f.azimuth_turned {
        report
            .provenance
            .push((format!("{TURNED_KEY}{suffix}"), "180".into()));
        report.notes.push(format!(
            "{name}: the specular peaks lie on the source's side of the normal, so φs counts \
             from the opposite axis to sbrdf's; φs was turned by 180° (decode --astm turns it \
             back)"
        ));
    }
    Ok(())
}

/// Writes `set` as ASTM E1392 text: the `header` lines first (keyword lines as given, blank
/// lines kept; any `NUM_POINTS` or `VARS` line or line that is not a keyword line is left out,
/// since the data give those), angles in radians with φ in (−π, π] (turned by 180° first when
/// `turn_azimuth`), values with every digit that reads back the same.
pub fn write_astm(
    set: &SampleSet,
    header: &[String],
    turn_azimuth: bool,
    mut out: impl std::io::Write,
) -> Result<()> {
    let io = |e| Error::Io {
        path: None,
        source: e,
    };
    let rows: usize = set.incidences.iter().map(|s| s.directions.len()).sum();
    for line in header {
        let line = line.trim();
        let key = line.split_whitespace().next().unwrap_or("");
        if line.is_empty() || (is_keyword(key) && !STRUCTURAL.contains(&key)) {
            writeln!(out, "{line}").map_err(io)?;
        }
    }
    writeln!(out, "NUM_POINTS {rows}").map_err(io)?;
    let wl: Vec<String> = set
        .wavelengths
        .iter()
        .map(|l| format!("{}nm", crate::io::csv::wavelength_name(*l)))
        .collect();
    writeln!(out, "VARS theta_i,phi_i,theta_s,phi_s,{}", wl.join(",")).map_err(io)?;
    writeln!(out).map_err(io)?;
    let rad = |deg: f64| {
        let d = if deg > 180.0 { deg - 360.0 } else { deg };
        d.to_radians()
    };
    let w = set.wavelengths.len();
    for s in &set.incidences {
        for (d, dir) in s.directions.iter().enumerate() {
            let phi_s = if turn_azimuth {
                wrap_phi(dir[1] + 180.0)
            } else {
                dir[1]
            };
            let mut line = format!(
                "{},{},{},{}",
                s.theta_i.to_radians(),
                rad(s.phi_i),
                dir[0].to_radians(),
                rad(phi_s)
            );
            for v in &s.values[d * w..(d + 1) * w] {
                line.push(',');
                line.push_str(&v.to_string());
            }
            writeln!(out, "{line}").map_err(io)?;
        }
    }
    Ok(())
}

/// The header a material's metadata kept from its (first) ASTM input, line by line, and
/// whether the reader turned φs; empty and false for files from other inputs.
pub fn header_from_metadata(metadata: Option<&str>) -> (Vec<String>, bool) {
    let Some(v) = metadata.and_then(|m| serde_json::from_str::<serde_json::Value>(m).ok()) else {
        return (Vec::new(), false);
    };
    let p = v.get("provenance");
    let text = |k: &str| p.and_then(|p| p.get(k)).and_then(|v| v.as_str());
    let header = text(HEADER_KEY).map_or(Vec::new(), |h| h.lines().map(String::from).collect());
    (header, text(TURNED_KEY) == Some("180"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = "LAB_NAME Test Lab\nSAMPLE_NAME Blue\nNUM_POINTS 3\n\
VARS theta_i,phi_i,theta_s,phi_s,400nm,500nm\n\n\
0.5,0,0.5,3.141593,9.0,8.0\n0.5,0,0.4,0.5,0.1,0.2\n0.5,0,0.3,-1.0,0.1,0.3\n";

    #[test]
    fn reads_keywords_rows_and_radians() {
        let f = read_astm("t.astm", SMALL.as_bytes()).unwrap();
        assert_eq!(f.keywords[0], ("LAB_NAME".into(), "Test Lab".into()));
        assert_eq!(f.wavelengths, vec![400.0, 500.0]);
        assert_eq!(f.rows.len(), 3);
        assert!((f.rows[0].angles[0] - 28.6479).abs() < 1e-3);
        assert_eq!(radians_to_degrees("0.174533", 0.174533), 10.0);
        assert_eq!(
            radians_to_degrees("3.141593", "3.141593".parse().unwrap()),
            180.0
        );
        assert_eq!(radians_to_degrees("-0.261799", -0.261799), -15.0);
        assert_eq!(radians_to_degrees("0.5", 0.5), 0.5f64.to_degrees());
        assert!((f.rows[2].angles[3] - (360.0 - 57.2958)).abs() < 1e-3);
        assert_eq!(f.rows[1].line, 7);
        assert!(!f.azimuth_turned);
    }

    #[test]
    fn peaks_on_the_source_side_are_turned() {
        let t = SMALL.replace("0.5,0,0.5,3.141593,9.0,8.0", "0.5,0,0.5,0.0,9.0,8.0");
        let f = read_astm("t.astm", t.as_bytes()).unwrap();
        assert!(f.azimuth_turned);
        assert!((f.rows[0].angles[3] - 180.0).abs() < 1e-9);
    }

    #[test]
    fn errors_name_file_and_line() {
        for (bad, want) in [
            (
                SMALL.replace("NUM_POINTS 3", "NUM_POINTS 4"),
                "t.astm:3: NUM_POINTS says 4",
            ),
            (
                SMALL.replace("0.4,0.5,0.1", "0.4,x,0.1"),
                "t.astm:7: phi_s 'x'",
            ),
            (SMALL.replace(",0.2\n", "\n"), "t.astm:7: 5 fields"),
            (
                SMALL.replace("theta_s", "zenith"),
                "t.astm:4: VARS lacks theta_s",
            ),
            (
                SMALL.replace("VARS", "Vars"),
                "t.astm:4: expected a 'KEYWORD value'",
            ),
            (
                SMALL.replace("0.5,0,0.5,3", "2.5,0,0.5,3"),
                "t.astm:6: theta_i = 143",
            ),
            (
                SMALL.replace("VARS theta_i", "NOVARS theta_i"),
                "t.astm:6: a data row before the VARS",
            ),
            ("LAB_NAME x\n".to_string(), "t.astm: no VARS line"),
        ] {
            let e = read_astm("t.astm", bad.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(want), "{want}: {e}");
        }
    }

    #[test]
    fn written_text_reads_back() {
        let f = read_astm("t.astm", SMALL.as_bytes()).unwrap();
        let mut set = SampleSet {
            wavelengths: f.wavelengths.clone(),
            incidences: vec![crate::encode::samples::IncidentSamples {
                theta_i: f.rows[0].angles[0],
                phi_i: 0.0,
                directions: f.rows.iter().map(|r| [r.angles[2], r.angles[3]]).collect(),
                values: f.rows.iter().flat_map(|r| r.values.clone()).collect(),
            }],
        };
        set.incidences[0].values[3] = 0.25;
        let mut out = Vec::new();
        write_astm(&set, &f.header, false, &mut out).unwrap();
        let back = read_astm("back.astm", &out).unwrap();
        assert_eq!(back.keywords, f.keywords);
        assert_eq!(back.header, ["LAB_NAME Test Lab", "SAMPLE_NAME Blue"]);
        assert_eq!(back.rows.len(), 3);
        for (a, b) in back.rows.iter().zip(&f.rows) {
            for k in 0..4 {
                assert!((a.angles[k] - b.angles[k]).abs() < 1e-9);
            }
        }
        assert_eq!(back.rows[1].values, vec![0.1, 0.25]);
        assert!(looks_like_astm("x.txt", &out));
        assert!(!looks_like_astm("x.csv", b"theta_i,phi_i\n1,2\n"));
    }

    #[test]
    fn a_brdf_column_takes_the_wavelength_keyword() {
        let t = "WAVELENGTH 0.633 um\nVARS theta_i,phi_i,theta_s,phi_s,BRDF\n0,0,0.1,0,0.3\n";
        let f = read_astm("m.astm", t.as_bytes()).unwrap();
        assert!((f.wavelengths[0] - 633.0).abs() < 1e-9);
        let d = "ANGLE_UNITS DEGREES\nVARS theta_i,phi_i,theta_s,phi_s,500\n30,0,30,180,2\n";
        let f = read_astm("d.astm", d.as_bytes()).unwrap();
        assert_eq!(f.rows[0].angles, [30.0, 0.0, 30.0, 180.0]);
    }
}
