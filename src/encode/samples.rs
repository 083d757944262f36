//! Sampled spectral BRDFs as the encoder takes them, whatever file they came from.

/// All samples of one incident direction: spectra at a list of outgoing directions, every
/// spectrum at the same wavelengths.
#[derive(Debug, Clone, PartialEq)]
pub struct IncidentSamples {
    /// Incident direction, degrees; θ in [0, 90], φ in [0, 360).
    pub theta_i: f64,
    /// Incident azimuth φi, degrees, in [0, 360).
    pub phi_i: f64,
    /// Outgoing directions (θo, φo), degrees, sorted by (θo, φo).
    pub directions: Vec<[f64; 2]>,
    /// `directions.len()` spectra of `wavelengths.len()` values (1/sr), direction-major.
    pub values: Vec<f64>,
}

/// A whole sampled material.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleSet {
    /// Wavelengths in nm, strictly increasing, shared by every spectrum.
    pub wavelengths: Vec<f64>,
    /// Sorted by (θi, φi).
    pub incidences: Vec<IncidentSamples>,
}

impl SampleSet {
    /// True when the only incident azimuth given is 0: the material is taken to be isotropic.
    pub fn is_isotropic(&self) -> bool {
        self.incidences.iter().all(|s| s.phi_i == 0.0)
    }

    /// Number of scalar samples (directions × wavelengths over all incidences).
    pub fn sample_count(&self) -> usize {
        self.incidences.iter().map(|s| s.values.len()).sum()
    }

    /// Size of the samples as a raw float32 table (one value per sample), the baseline that
    /// compression ratios are quoted against.
    pub fn raw_f32_bytes(&self) -> usize {
        4 * self.sample_count()
    }

    /// Fraction of the values at or below 0: a measurement's floor (its noise clipped or read
    /// as exactly 0). Analytic materials give none above the horizon.
    pub fn floor_fraction(&self) -> f64 {
        let n = self.sample_count();
        if n == 0 {
            return 0.0;
        }
        let at_floor = self
            .incidences
            .iter()
            .flat_map(|s| s.values.iter())
            .filter(|v| **v <= 0.0)
            .count();
        at_floor as f64 / n as f64
    }

    /// Number of values below 0 (over all incidences and wavelengths).
    pub fn negative_count(&self) -> usize {
        self.incidences
            .iter()
            .flat_map(|s| s.values.iter())
            .filter(|v| **v < 0.0)
            .count()
    }

    /// Checks the invariants the encoder relies on; the message says what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if self.wavelengths.is_empty() {
            return Err("no wavelengths".into());
        }
        if self.incidences.is_empty() {
            return Err("no samples".into());
        }
        for (i, w) in self.wavelengths.iter().enumerate() {
            if !(w.is_finite() && *w > 0.0) || (i > 0 && *w <= self.wavelengths[i - 1]) {
                return Err("wavelengths must be positive and strictly increasing".into());
            }
        }
        for (i, s) in self.incidences.iter().enumerate() {
            let name = format!("incidence ({}, {})", s.theta_i, s.phi_i);
            if !(0.0..=90.0).contains(&s.theta_i) || !(0.0..360.0).contains(&s.phi_i) {
                return Err(format!("{name} is outside θ ∈ [0, 90], φ ∈ [0, 360)"));
            }
            if i > 0 {
                let q = &self.incidences[i - 1];
                if (q.theta_i, q.phi_i) >= (s.theta_i, s.phi_i) {
                    return Err("incidences are not sorted and distinct".into());
                }
            }
            if s.directions.is_empty() {
                return Err(format!("{name} has no outgoing directions"));
            }
            if s.values.len() != s.directions.len() * self.wavelengths.len() {
                return Err(format!(
                    "{name}: value count does not match directions × wavelengths"
                ));
            }
            if s.values.iter().any(|v| !v.is_finite()) {
                return Err(format!("{name}: a value is not finite"));
            }
            for (j, d) in s.directions.iter().enumerate() {
                if !(0.0..=90.0).contains(&d[0]) || !(0.0..360.0).contains(&d[1]) {
                    return Err(format!("{name}: outgoing direction {d:?} out of range"));
                }
                if j > 0 && s.directions[j - 1] >= *d {
                    return Err(format!(
                        "{name}: outgoing directions not sorted and distinct"
                    ));
                }
            }
        }
        Ok(())
    }

    /// The samples a scene needs: wavelengths within [min, max] nm and incidences with
    /// θi ≤ `incident_max` degrees. Refuses a selection that keeps nothing.
    pub fn restricted(
        &self,
        wavelengths: Option<(f64, f64)>,
        incident_max: Option<f64>,
    ) -> Result<SampleSet, String> {
        let keep_w: Vec<usize> = (0..self.wavelengths.len())
            .filter(|&w| {
                wavelengths.is_none_or(|(lo, hi)| (lo..=hi).contains(&self.wavelengths[w]))
            })
            .collect();
        if keep_w.is_empty() {
            let (lo, hi) = wavelengths.unwrap_or_default();
            return Err(format!(
                "--wavelengths {lo}:{hi} keeps none of the input's wavelengths ({}–{} nm)",
                self.wavelengths[0],
                self.wavelengths[self.wavelengths.len() - 1]
            ));
        }
        let w = self.wavelengths.len();
        let incidences: Vec<IncidentSamples> = self
            .incidences
            .iter()
            .filter(|s| incident_max.is_none_or(|m| s.theta_i <= m))
            .map(|s| IncidentSamples {
                theta_i: s.theta_i,
                phi_i: s.phi_i,
                directions: s.directions.clone(),
                values: s
                    .values
                    .chunks(w)
                    .flat_map(|spectrum| keep_w.iter().map(move |&i| spectrum[i]))
                    .collect(),
            })
            .collect();
        if incidences.is_empty() {
            return Err(format!(
                "--incident-max {}: no incidence of the input has θi ≤ {0}°",
                incident_max.unwrap_or_default()
            ));
        }
        Ok(SampleSet {
            wavelengths: keep_w.iter().map(|&i| self.wavelengths[i]).collect(),
            incidences,
        })
    }
}
/// What reading inputs produced besides the samples.
#[derive(Debug, Clone, Default)]
pub struct ReadReport {
    /// Samples below zero (kept: measured data dips below zero from noise).
    pub negative_values: usize,
    /// EXR pixels skipped as not measured (NaN or mask 0).
    pub missing_pixels: usize,
    /// What the files said about themselves that the encoded file should keep (ASTM header
    /// keywords as `astm.KEY`; what an RGL file held and how it was converted), appended to the
    /// metadata's provenance after `--metadata`.
    pub provenance: Vec<(String, String)>,
    /// Decisions a reader took that the user should hear about, one line each, no prefix.
    pub notes: Vec<String>,
}

/// How inputs are read, beyond their own content.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// Turn RGB-only measurements (RGL `_rgb.bsdf` files) into spectra by this method; `None`
    /// refuses them, naming the spectral file to use instead.
    pub rgb_to_spectrum: Option<RgbToSpectrum>,
}

/// Published methods that make a spectrum from a colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RgbToSpectrum {
    /// Jakob & Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral
    /// Upsampling": a sigmoid of a quadratic in λ whose linear sRGB under D65 is the colour
    /// (what Mitsuba 3's spectral variants do with RGB reflectances).
    JakobHanika2019,
}

impl RgbToSpectrum {
    /// The name `--rgb-to-spectrum` takes.
    pub fn name(self) -> &'static str {
        match self {
            RgbToSpectrum::JakobHanika2019 => "jakob-hanika-2019",
        }
    }

    /// Every method, for messages.
    pub const ALL: [RgbToSpectrum; 1] = [RgbToSpectrum::JakobHanika2019];

    /// Parses a `--rgb-to-spectrum` value.
    pub fn parse(s: &str) -> Option<RgbToSpectrum> {
        Self::ALL.into_iter().find(|m| m.name() == s.trim())
    }
}
