//! The sample collector: rows from any reader (CSV lines, EXR pixels, columns handed over in
//! memory), each with the place it was read, checked and merged into one validated
//! [`SampleSet`]: duplicates, one wavelength set for every direction, ranges.

use crate::encode::samples::{IncidentSamples, ReadReport, SampleSet};
use crate::error::{Error, Result};

/// The column names of the long layout, in order: the columns [`samples_from_columns`] takes.
pub const COLUMNS: [&str; 6] = [
    "theta_i",
    "phi_i",
    "theta_o",
    "phi_o",
    "wavelength_nm",
    "value",
];

/// Samples given as six equally long columns (the long CSV layout's, in [`COLUMNS`] order),
/// held in memory under the name `name`: the same checks as a CSV file, errors naming
/// `name[index]`.
pub fn samples_from_columns(name: &str, columns: [&[f64]; 6]) -> Result<(SampleSet, ReadReport)> {
    let n = columns[0].len();
    if let Some(c) = (1..6).find(|&c| columns[c].len() != n) {
        return Err(Error::Input(format!(
            "{name}: column {} has {} values but {} has {n}",
            COLUMNS[c],
            columns[c].len(),
            COLUMNS[0]
        )));
    }
    if n == 0 {
        return Err(Error::Input(format!("{name}: no samples")));
    }
    let mut samples = Vec::with_capacity(n);
    // Row i of six parallel columns: an index reads clearer than six zipped iterators.
    #[allow(clippy::needless_range_loop)]
    for i in 0..n {
        let here = |m: String| Error::Input(format!("{name}[{i}]: {m}"));
        let mut a = [0.0; 4];
        for (j, v) in a.iter_mut().enumerate() {
            let x = columns[j][i];
            if !x.is_finite() {
                return Err(here(format!("{} = {x} is not a finite number", COLUMNS[j])));
            }
            *v = if j % 2 == 0 {
                if !(0.0..=90.0).contains(&x) {
                    return Err(here(format!(
                        "{} = {x} is outside [0, 90] degrees",
                        COLUMNS[j]
                    )));
                }
                x + 0.0
            } else {
                crate::model::angles::wrap_phi(x)
            };
        }
        let (l, v) = (columns[4][i], columns[5][i]);
        if !(l.is_finite() && l > 0.0) {
            return Err(here(format!(
                "wavelength_nm = {l} is not a positive number"
            )));
        }
        if !v.is_finite() {
            return Err(here(format!("value = {v} is not a finite number")));
        }
        samples.push(Sample {
            key: [
                a[0].to_bits(),
                a[1].to_bits(),
                a[2].to_bits(),
                a[3].to_bits(),
                l.to_bits(),
            ],
            value: v,
            file: 0,
            place: Place::Index(i as u64),
        });
    }
    build_sample_set(samples, &[name.to_string()])
}

/// One sample with where it came from, for duplicate and consistency messages.
pub(crate) struct Sample {
    /// Bit patterns of θi, φi, θo, φo, λ (all non-negative, so they sort like the values).
    pub key: [u64; 5],
    pub value: f64,
    /// Index into the list of input names.
    pub file: u32,
    pub place: Place,
}

/// Where in its file a sample was read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Place {
    /// A CSV line (1-based).
    Line(u64),
    /// An EXR pixel.
    Pixel { row: u32, column: u32 },
    /// An index into arrays handed over in memory (the Python binding's columns), 0-based.
    Index(u64),
    /// A grid node of an RGL file: stored incidence (θi index, φi index), node row and column.
    Node {
        incidence: [u32; 2],
        row: u32,
        column: u32,
    },
    /// A sample an RGL file's own interpolation gave where its grid leaves a gap: stored
    /// incidence (θi index, φi index) and the sample's number among that incidence's fills.
    Fill { incidence: [u32; 2], index: u32 },
}

/// Whether two runs of keys are equal, compared element by element: `==` on integer slices
/// compiles to a `bcmp` call, which fuzz builds intercept at a cost per call (a hash of both
/// operands for libFuzzer's comparison table); over one comparison per sample that was 15% of
/// the `rgl_full` target's time. `cmp` on `u64` slices compares in place.
fn same(a: &[u64], b: &[u64]) -> bool {
    a.cmp(b).is_eq()
}

pub(crate) fn build_sample_set(
    mut samples: Vec<Sample>,
    names: &[String],
) -> Result<(SampleSet, ReadReport)> {
    // All keys are non-negative floats, whose bit patterns sort like their values.
    samples.sort_by(|a, b| {
        a.key
            .cmp(&b.key)
            .then((a.file, a.place).cmp(&(b.file, b.place)))
    });
    let here = |s: &Sample| match s.place {
        Place::Line(line) => format!("{}:{line}", names[s.file as usize]),
        Place::Pixel { row, column } => {
            format!(
                "{}: pixel (row {row}, column {column})",
                names[s.file as usize]
            )
        }
        Place::Index(i) => format!("{}[{i}]", names[s.file as usize]),
        Place::Node {
            incidence: [t, p],
            row,
            column,
        } => format!(
            "{}: incidence (theta_i[{t}], phi_i[{p}]), grid node (row {row}, column {column})",
            names[s.file as usize]
        ),
        Place::Fill {
            incidence: [t, p],
            index,
        } => format!(
            "{}: incidence (theta_i[{t}], phi_i[{p}]), interpolated sample {index}",
            names[s.file as usize]
        ),
    };
    let f = f64::from_bits;
    for w in samples.windows(2) {
        if same(&w[0].key, &w[1].key) {
            let k = w[1].key;
            return Err(Error::Input(format!(
                "{}: sample (theta_i {}, phi_i {}, theta_o {}, phi_o {}, {} nm) is given twice; \
                 first at {}",
                here(&w[1]),
                f(k[0]),
                f(k[1]),
                f(k[2]),
                f(k[3]),
                f(k[4]),
                here(&w[0])
            )));
        }
    }
    let report = ReadReport {
        negative_values: samples.iter().filter(|s| s.value < 0.0).count(),
        ..ReadReport::default()
    };
    // Split into directions (runs of equal 4-angle keys).
    let mut reference: Option<(Vec<u64>, usize)> = None;
    let mut incidences: Vec<IncidentSamples> = Vec::new();
    let mut start = 0;
    while start < samples.len() {
        let dir = &samples[start].key[..4];
        let end = start
            + samples[start..]
                .iter()
                .take_while(|s| same(&s.key[..4], dir))
                .count();
        let wls: Vec<u64> = samples[start..end].iter().map(|s| s.key[4]).collect();
        match &reference {
            None => reference = Some((wls, start)),
            Some((r, at)) if !same(r, &wls) => {
                let extra: Vec<String> = wls
                    .iter()
                    .filter(|w| !r.contains(w))
                    .take(4)
                    .map(|w| f(*w).to_string())
                    .collect();
                let lacking: Vec<String> = r
                    .iter()
                    .filter(|w| !wls.contains(w))
                    .take(4)
                    .map(|w| f(*w).to_string())
                    .collect();
                return Err(Error::Input(format!(
                    "{}: direction (theta_i {}, phi_i {}, theta_o {}, phi_o {}) has {} wavelengths \
                     but the direction at {} has {}{}{}; every direction needs the same wavelengths",
                    here(&samples[start]),
                    f(dir[0]),
                    f(dir[1]),
                    f(dir[2]),
                    f(dir[3]),
                    wls.len(),
                    here(&samples[*at]),
                    r.len(),
                    if extra.is_empty() { String::new() } else { format!("; only here: {} nm", extra.join(", ")) },
                    if lacking.is_empty() { String::new() } else { format!("; missing here: {} nm", lacking.join(", ")) },
                )));
            }
            _ => {}
        }
        let (ti, pi) = (f(dir[0]), f(dir[1]));
        if incidences
            .last()
            .is_none_or(|s| (s.theta_i, s.phi_i) != (ti, pi))
        {
            incidences.push(IncidentSamples {
                theta_i: ti,
                phi_i: pi,
                directions: Vec::new(),
                values: Vec::new(),
            });
        }
        let inc = incidences.last_mut().unwrap();
        inc.directions.push([f(dir[2]), f(dir[3])]);
        inc.values
            .extend(samples[start..end].iter().map(|s| s.value));
        start = end;
    }
    let wavelengths = reference
        .map(|(r, _)| r.into_iter().map(f).collect())
        .unwrap_or_default();
    let set = SampleSet {
        wavelengths,
        incidences,
    };
    set.validate()
        .map_err(|e| Error::Input(format!("{}: {e}", names.join(", "))))?;
    Ok((set, report))
}
