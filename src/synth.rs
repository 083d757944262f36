//! Test material generators: the paper's Phong materials (its Sec. 3, Eq. 14) over ColorChecker
//! spectra shipped with the crate.

use crate::angles::{dir_from_deg, dot, mirror_deg};
use crate::error::{Error, Result};
use crate::samples::{IncidentSamples, SampleSet};

/// N. Ohta's ColorChecker reflectances, 380–780 nm every 5 nm (see `samples/README.md`).
pub const COLORCHECKER_CSV: &str = include_str!("../samples/colorchecker_ohta_380_780_5nm.csv");

/// Named reflectance spectra sampled on a common wavelength grid.
#[derive(Debug, Clone)]
pub struct SpectrumTable {
    pub wavelengths: Vec<f64>,
    pub names: Vec<String>,
    /// spectra[i] is the column of names[i].
    pub spectra: Vec<Vec<f64>>,
}

impl SpectrumTable {
    /// The embedded ColorChecker table.
    pub fn colorchecker() -> Self {
        Self::parse(COLORCHECKER_CSV).expect("the embedded ColorChecker table parses")
    }

    /// Parses a table whose first column is `wavelength_nm` and whose other columns are spectra.
    pub fn parse(text: &str) -> Result<Self> {
        let mut r = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let bad = |m: String| Error::Input(format!("spectrum table: {m}"));
        let names: Vec<String> = r
            .headers()
            .map_err(|e| bad(e.to_string()))?
            .iter()
            .skip(1)
            .map(|s| s.to_string())
            .collect();
        let mut wavelengths = Vec::new();
        let mut spectra = vec![Vec::new(); names.len()];
        for rec in r.records() {
            let rec = rec.map_err(|e| bad(e.to_string()))?;
            let nums: Vec<f64> = rec
                .iter()
                .map(|s| {
                    s.trim()
                        .parse::<f64>()
                        .map_err(|e| bad(format!("{s}: {e}")))
                })
                .collect::<Result<_>>()?;
            wavelengths.push(nums[0]);
            for (i, v) in nums[1..].iter().enumerate() {
                spectra[i].push(*v);
            }
        }
        Ok(SpectrumTable {
            wavelengths,
            names,
            spectra,
        })
    }

    /// Finds a spectrum by name, ignoring case; a unique prefix is enough (`white` finds
    /// `white 9.5 (.05 D)`).
    pub fn find(&self, name: &str) -> Result<usize> {
        let k = name.trim().to_lowercase();
        if let Some(i) = self.names.iter().position(|n| n.to_lowercase() == k) {
            return Ok(i);
        }
        let hits: Vec<usize> = (0..self.names.len())
            .filter(|&i| self.names[i].to_lowercase().starts_with(&k))
            .collect();
        match hits.as_slice() {
            [i] => Ok(*i),
            _ => Err(Error::Parameter(format!(
                "{} patch '{name}'; known patches: {}",
                if hits.is_empty() { "no" } else { "ambiguous" },
                self.names.join(", ")
            ))),
        }
    }

    /// Spectrum `index` linearly interpolated at `wavelengths` (which must lie inside the table).
    pub fn sample(&self, index: usize, wavelengths: &[f64]) -> Result<Vec<f64>> {
        let (lo, hi) = (self.wavelengths[0], *self.wavelengths.last().unwrap());
        wavelengths
            .iter()
            .map(|&l| {
                if !(lo..=hi).contains(&l) {
                    return Err(Error::Parameter(format!(
                        "wavelength {l} nm is outside the spectra's range {lo}–{hi} nm"
                    )));
                }
                let j = self.wavelengths.partition_point(|&w| w <= l).max(1) - 1;
                let j = j.min(self.wavelengths.len() - 2);
                let (w0, w1) = (self.wavelengths[j], self.wavelengths[j + 1]);
                let t = (l - w0) / (w1 - w0);
                let s = &self.spectra[index];
                Ok(s[j] + t * (s[j + 1] - s[j]))
            })
            .collect()
    }
}

/// The paper's Phong material as a BRDF: ρ = kd·Sd(λ) + ks·Ss(λ)·max(0, cos α)ⁿ, α the angle
/// between the outgoing direction and the mirror direction of the incident one. (The paper's
/// Eq. 14 is an intensity with a cos θi factor on the diffuse term; as a BRDF the factor goes.
/// The error figures of its Figs. 4 and 6 are reproduced either way to two digits.)
#[derive(Debug, Clone)]
pub struct Phong {
    pub diffuse: Vec<f64>,
    pub specular: Vec<f64>,
    pub kd: f64,
    pub ks: f64,
    pub n: f64,
}

impl Phong {
    pub fn value(&self, incident: (f64, f64), outgoing: (f64, f64), w: usize) -> f64 {
        let (mt, mp) = mirror_deg(incident.0, incident.1);
        let c = dot(dir_from_deg(mt, mp), dir_from_deg(outgoing.0, outgoing.1)).max(0.0);
        self.kd * self.diffuse[w] + self.ks * self.specular[w] * c.powf(self.n)
    }
}

/// The outgoing grid of the paper: θo = step/2, 3·step/2, … < 90, φo = 0, step, … < 360.
pub fn paper_grid(theta_step: f64, phi_step: f64) -> Vec<[f64; 2]> {
    let mut v = Vec::new();
    let mut i = 0;
    while (i as f64 + 0.5) * theta_step < 90.0 {
        let t = (i as f64 + 0.5) * theta_step;
        let mut j = 0;
        while (j as f64) * phi_step < 360.0 {
            v.push([t, j as f64 * phi_step]);
            j += 1;
        }
        i += 1;
    }
    v
}

/// Samples any material function on a set of directions and wavelengths.
pub fn sample_material(
    wavelengths: &[f64],
    incidences: &[(f64, f64)],
    directions: &[[f64; 2]],
    f: impl Fn((f64, f64), (f64, f64), usize) -> f64,
) -> SampleSet {
    let mut incs: Vec<(f64, f64)> = incidences.to_vec();
    incs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    incs.dedup();
    let mut dirs = directions.to_vec();
    dirs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    SampleSet {
        wavelengths: wavelengths.to_vec(),
        incidences: incs
            .iter()
            .map(|&inc| IncidentSamples {
                theta_i: inc.0,
                phi_i: inc.1,
                directions: dirs.clone(),
                values: dirs
                    .iter()
                    .flat_map(|d| (0..wavelengths.len()).map(move |w| (d, w)))
                    .map(|(d, w)| f(inc, (d[0], d[1]), w))
                    .collect(),
            })
            .collect(),
    }
}
