//! `sbrdf encode`'s options by their command-line names, and the encode around them (input
//! selection, defaults, the error budget's verdict): one place that the command line and the
//! Python binding both call, so that both validate, default and report alike.

use crate::encode::encoder::{EncodeOptions, Encoded, ModelChoice, DEFAULT_MAX_ERROR};
use crate::encode::fit::LobeFamily;
use crate::encode::fit::{CriticalAngle, PeakMode};
use crate::encode::samples::{ReadOptions, ReadReport, RgbToSpectrum, SampleSet};
use crate::error::{Error, Result};
use crate::model::spectral::SpectralBasis;
use crate::model::warped::TableTransform;
use crate::model::Precision;

/// `sbrdf encode`'s options: the encoder's own ([`EncodeOptions`], whose `provenance` holds the
/// `--metadata` pairs and `sample_positions` the inverse of `--no-sample-positions`), plus what
/// the command line decides around the fit.
#[derive(Debug, Clone, Default)]
pub struct EncodeSettings {
    /// The encoder's options. Its `max_error` is resolved by [`EncodeSettings::options`]: the
    /// budget given with `--max-error`, else the default budget with the joint fit and none
    /// for the paper's method or SH alone.
    pub encoder: EncodeOptions,
    /// `--max-error` as given: an explicit budget fails the encode where it cannot be met.
    pub max_error: Option<f64>,
    /// `--best-effort`: write the file even where an explicit budget is unmet (with a warning).
    pub best_effort: bool,
    /// `--wavelengths MIN:MAX`.
    pub wavelengths: Option<(f64, f64)>,
    /// `--incident-max DEG`: encode only the incidences with θi at most this many degrees.
    pub incident_max: Option<f64>,
    /// How the inputs are read (`--rgb-to-spectrum`): for the caller's reader, which runs
    /// before [`encode_samples`].
    pub read: ReadOptions,
    /// Whether one RGL file is kept on its warped grid (`--model warped`: required; `auto`:
    /// where it suits; `records`, `shared`: never), as the RGL reader's `encode_warped_file`
    /// reads it.
    pub warped: WarpedChoice,
    /// `--transform`: the warped tables' transform (`None`, `auto`: the smaller file).
    pub transform: Option<TableTransform>,
}

/// When an input is encoded as warped tables (`--model`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum WarpedChoice {
    /// `--model auto`: one isotropic RGL file without options warped tables do not take.
    #[default]
    Auto,
    /// `--model warped`: warped tables, or an error saying why not.
    Required,
    /// `--model records` or `shared`: never.
    Never,
}

/// The option names `EncodeSettings::set` knows, as the command line spells them.
pub const NAMES: [&str; 18] = [
    "model",
    "transform",
    "basis",
    "terms",
    "sh-level",
    "peak",
    "critical-angle",
    "precision",
    "lobes",
    "max-error",
    "best-effort",
    "metadata",
    "no-sample-positions",
    "wavelengths",
    "incident-max",
    "rgb-to-spectrum",
    "meta",
    "format",
];

fn bad(name: &str, value: &str, expected: &str) -> Error {
    Error::Parameter(format!("--{name} '{value}': expected {expected}"))
}

/// `0.01` or `1%`.
pub fn parse_fraction(name: &str, s: &str) -> Result<f64> {
    let t = s.trim();
    let v = match t.strip_suffix('%') {
        Some(p) => p.trim().parse::<f64>().ok().map(|v| v / 100.0),
        None => t.parse::<f64>().ok(),
    };
    match v {
        Some(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(bad(name, s, "a fraction like 0.01 or 1%")),
    }
}

/// `MIN:MAX` in nm.
pub fn parse_window(name: &str, s: &str) -> Result<(f64, f64)> {
    let err = || bad(name, s, "MIN:MAX in nm, like 450:650");
    let (lo, hi) = s.split_once(':').ok_or_else(err)?;
    let lo: f64 = lo.trim().parse().map_err(|_| err())?;
    let hi: f64 = hi.trim().parse().map_err(|_| err())?;
    if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
        return Err(err());
    }
    Ok((lo, hi))
}

/// `auto` or degrees.
pub fn parse_critical_angle(s: &str) -> Result<CriticalAngle> {
    match s.trim() {
        "auto" => Ok(CriticalAngle::Auto),
        t => t
            .parse::<f64>()
            .map(|g| CriticalAngle::Fixed(g + 0.0))
            .map_err(|_| bad("critical-angle", s, "degrees (like 37) or 'auto'")),
    }
}

/// `--basis`: `data`, `cosine` or `fourier`.
pub fn parse_basis(s: &str) -> Result<SpectralBasis> {
    match s.trim() {
        "data" => Ok(SpectralBasis::Tabulated),
        "cosine" => Ok(SpectralBasis::Cosine),
        "fourier" => Ok(SpectralBasis::PeriodicFourier),
        _ => Err(bad("basis", s, "data, cosine or fourier")),
    }
}

/// `--model`: `auto`, `records`, `shared` or `warped` (which the sample-based encoder meets as
/// `auto`, should the input not be one RGL file: [`WarpedChoice::Required`] refuses it first).
pub fn parse_model(s: &str) -> Result<(ModelChoice, WarpedChoice)> {
    match s.trim() {
        "auto" => Ok((ModelChoice::Auto, WarpedChoice::Auto)),
        "records" => Ok((ModelChoice::Records, WarpedChoice::Never)),
        "shared" => Ok((ModelChoice::Shared, WarpedChoice::Never)),
        "warped" => Ok((ModelChoice::Auto, WarpedChoice::Required)),
        _ => Err(bad("model", s, "auto, records, shared or warped")),
    }
}

/// `--transform`: `dct`, `wavelet` or `auto` (`None`: whichever gives the smaller file).
pub fn parse_transform(s: &str) -> Result<Option<TableTransform>> {
    match s.trim() {
        "auto" => Ok(None),
        "dct" => Ok(Some(TableTransform::Dct)),
        "wavelet" => Ok(Some(TableTransform::Wavelet53)),
        _ => Err(bad("transform", s, "dct, wavelet or auto")),
    }
}

/// `--peak`: `joint`, `paper` or `none`.
pub fn parse_peak(s: &str) -> Result<PeakMode> {
    match s.trim() {
        "joint" => Ok(PeakMode::Joint),
        "paper" => Ok(PeakMode::Paper),
        "none" => Ok(PeakMode::None),
        _ => Err(bad("peak", s, "joint, paper or none")),
    }
}

/// `--precision`: `f16` or `f32`.
pub fn parse_precision(s: &str) -> Result<Precision> {
    match s.trim() {
        "f16" => Ok(Precision::F16),
        "f32" => Ok(Precision::F32),
        _ => Err(bad("precision", s, "f16 or f32")),
    }
}

/// One name of `--lobes`: `cosine-power`, `gaussian`, `microfacet`, `microfacet-sin2` or
/// `microfacet-aniso`.
pub fn parse_lobe(s: &str) -> Result<LobeFamily> {
    match s.trim() {
        "cosine-power" => Ok(LobeFamily::CosinePower),
        "gaussian" => Ok(LobeFamily::Gaussian),
        "microfacet" => Ok(LobeFamily::Microfacet),
        "microfacet-sin2" => Ok(LobeFamily::MicrofacetSin2),
        "microfacet-aniso" => Ok(LobeFamily::MicrofacetAniso),
        _ => Err(bad(
            "lobes",
            s,
            "cosine-power, gaussian, microfacet, microfacet-sin2 or microfacet-aniso",
        )),
    }
}

/// A `--rgb-to-spectrum` method.
pub fn parse_rgb_to_spectrum(s: &str) -> Result<RgbToSpectrum> {
    RgbToSpectrum::parse(s).ok_or_else(|| {
        let names: Vec<&str> = RgbToSpectrum::ALL.iter().map(|m| m.name()).collect();
        bad("rgb-to-spectrum", s, &names.join(" or "))
    })
}

/// `full`, `short` or `none`.
pub fn parse_meta(s: &str) -> Result<crate::encode::encoder::MetaLevel> {
    use crate::encode::encoder::MetaLevel;
    match s.trim() {
        "full" => Ok(MetaLevel::Full),
        "short" => Ok(MetaLevel::Short),
        "none" => Ok(MetaLevel::None),
        _ => Err(bad("meta", s, "full, short or none")),
    }
}

/// `1.0` to `1.3`: the newest minor version a file may use.
pub fn parse_format(s: &str) -> Result<u16> {
    match s.trim() {
        "1.0" => Ok(0),
        "1.1" => Ok(1),
        "1.2" => Ok(2),
        "1.3" => Ok(3),
        "1.4" => Ok(4),
        "1.5" => Ok(5),
        "1.6" => Ok(6),
        "1.7" => Ok(7),
        _ => Err(bad("format", s, "1.0 to 1.7")),
    }
}

/// `KEY=VALUE`.
pub fn parse_metadata(s: &str) -> Result<(String, String)> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| bad("metadata", s, "KEY=VALUE"))?;
    Ok((k.trim().to_string(), v.to_string()))
}

fn parse_bool(name: &str, s: &str) -> Result<bool> {
    match s.trim() {
        "true" | "True" | "1" => Ok(true),
        "false" | "False" | "0" => Ok(false),
        _ => Err(bad(name, s, "true or false")),
    }
}

fn parse_count(name: &str, s: &str) -> Result<usize> {
    s.trim().parse().map_err(|_| bad(name, s, "a whole number"))
}

impl EncodeSettings {
    /// Sets one option from text, by its command-line name (`sh-level` or `sh_level`). Lists
    /// (`lobes`, `metadata`) take comma-separated or repeated values.
    pub fn set(&mut self, name: &str, value: &str) -> Result<()> {
        let key = name.trim().trim_start_matches("--").replace('_', "-");
        let e = &mut self.encoder;
        match key.as_str() {
            "model" => (e.model, self.warped) = parse_model(value)?,
            "transform" => self.transform = parse_transform(value)?,
            "basis" => e.basis = parse_basis(value)?,
            "terms" => e.terms = Some(parse_count(&key, value)?),
            "sh-level" => e.sh_level = Some(parse_count(&key, value)?),
            "peak" => e.peak = parse_peak(value)?,
            "critical-angle" => e.critical_angle = parse_critical_angle(value)?,
            "precision" => e.precision = parse_precision(value)?,
            "lobes" => {
                e.lobes = value
                    .split(',')
                    .map(parse_lobe)
                    .collect::<Result<Vec<_>>>()?
            }
            "max-error" => self.max_error = Some(parse_fraction(&key, value)?),
            "best-effort" => self.best_effort = parse_bool(&key, value)?,
            "metadata" => e.provenance.push(parse_metadata(value)?),
            "no-sample-positions" => e.sample_positions = !parse_bool(&key, value)?,
            "wavelengths" => self.wavelengths = Some(parse_window(&key, value)?),
            "meta" => e.meta = parse_meta(value)?,
            "format" => e.format_minor = parse_format(value)?,
            "incident-max" => {
                self.incident_max = Some(
                    value
                        .trim()
                        .parse()
                        .map_err(|_| bad(&key, value, "degrees"))?,
                )
            }
            "rgb-to-spectrum" => {
                self.read.rgb_to_spectrum = Some(parse_rgb_to_spectrum(value)?);
            }
            _ => {
                return Err(Error::Parameter(format!(
                    "unknown encode option '{name}'; known: {}",
                    NAMES.join(", ")
                )))
            }
        }
        Ok(())
    }

    /// The encoder options, with the command line's defaults (the default budget with the
    /// joint fit; none for the paper's method or SH alone) and the inputs and selections
    /// recorded.
    pub fn options(&self, inputs: &[String]) -> EncodeOptions {
        let mut o = self.encoder.clone();
        if let Some((lo, hi)) = self.wavelengths {
            o.provenance
                .push(("selected_wavelengths_nm".into(), format!("{lo}:{hi}")));
        }
        if let Some(m) = self.incident_max {
            o.provenance
                .push(("selected_incident_max_deg".into(), m.to_string()));
        }
        // An explicit budget is met at the samples, as it always was.
        o.budget_given = self.max_error.is_some();
        o.max_error = match (self.max_error, o.peak) {
            (Some(e), _) => Some(e),
            (None, PeakMode::Joint) => Some(DEFAULT_MAX_ERROR),
            (None, _) => None,
        };
        o.inputs = inputs.to_vec();
        o
    }
}

/// An encode's result: the file's bytes, the material, and what the user should be told.
pub struct Outcome {
    /// The `.sbrdf` file's bytes.
    pub bytes: Vec<u8>,
    /// The material and the encoder's figures.
    pub encoded: Encoded,
    /// The samples actually encoded (after `wavelengths`/`incident_max`).
    pub samples: SampleSet,
    /// Notes and warnings, one line each, without a prefix.
    pub messages: Vec<String>,
}

/// Restricts, encodes and serialises `set` read from `inputs`: what `sbrdf encode` does before
/// writing. Fails, writing nothing, when an explicit `max_error` is unmet without `best_effort`.
pub fn encode_samples(
    set: SampleSet,
    report: &ReadReport,
    inputs: &[String],
    s: &EncodeSettings,
) -> Result<Outcome> {
    encode_samples_with_progress(set, report, inputs, s, None)
}

/// [`encode_samples`], reporting progress as incidences finish.
pub fn encode_samples_with_progress(
    set: SampleSet,
    report: &ReadReport,
    inputs: &[String],
    s: &EncodeSettings,
    progress: Option<crate::encode::encoder::Progress>,
) -> Result<Outcome> {
    let set = if s.wavelengths.is_some() || s.incident_max.is_some() {
        set.restricted(s.wavelengths, s.incident_max)
            .map_err(|e| Error::Parameter(format!("{}: {e}", inputs.join(", "))))?
    } else {
        set
    };
    let mut messages: Vec<String> = report.notes.iter().map(|n| format!("note: {n}")).collect();
    if report.missing_pixels > 0 {
        messages.push(format!(
            "note: {} EXR pixels marked missing (NaN or mask 0) were skipped",
            report.missing_pixels
        ));
    }
    if report.negative_values > 0 {
        messages.push(format!(
            "warning: {} of {} samples are negative (kept as measured)",
            report.negative_values,
            set.sample_count()
        ));
    }
    let mut opts = s.options(inputs);
    opts.provenance.extend(report.provenance.iter().cloned());
    let encoded = crate::encode::encoder::encode_with_progress(&set, &opts, progress)?;
    messages.extend(encoded.notes.iter().map(|n| format!("note: {n}")));
    if !encoded.unmet.is_empty() {
        let m = &encoded.material;
        let list: Vec<String> = encoded
            .unmet
            .iter()
            .map(|&i| {
                let r = &m.records[i];
                format!("({}, {}): {:.4}", r.theta_i, r.phi_i, r.rel_error)
            })
            .collect();
        let msg = format!(
            "the error budget {} cannot be met at {} incident direction(s); best errors reached: {}",
            opts.max_error.unwrap_or(DEFAULT_MAX_ERROR),
            list.len(),
            list.join(", ")
        );
        if !s.best_effort && s.max_error.is_some() {
            return Err(Error::Parameter(format!(
                "{msg}. Nothing written; raise the budget or add --best-effort"
            )));
        }
        let why = if s.best_effort {
            "--best-effort"
        } else {
            "the default budget is best effort"
        };
        messages.push(format!("warning: {msg} (written anyway: {why})"));
    }
    let bytes = crate::write_material(&encoded.material)?;
    Ok(Outcome {
        bytes,
        encoded,
        samples: set,
        messages,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_as_on_the_command_line() {
        let mut s = EncodeSettings::default();
        for (k, v) in [
            ("basis", "cosine"),
            ("terms", "5"),
            ("sh_level", "3"),
            ("--peak", "paper"),
            ("critical-angle", "37"),
            ("precision", "f32"),
            ("lobes", "gaussian,microfacet"),
            ("max_error", "1%"),
            ("best_effort", "true"),
            ("metadata", "source=lab 4"),
            ("no_sample_positions", "1"),
            ("wavelengths", "450:650"),
            ("incident_max", "60"),
            ("rgb_to_spectrum", "jakob-hanika-2019"),
        ] {
            s.set(k, v).unwrap();
        }
        assert_eq!(s.encoder.basis, SpectralBasis::Cosine);
        assert_eq!((s.encoder.terms, s.encoder.sh_level), (Some(5), Some(3)));
        assert_eq!(s.max_error, Some(0.01));
        assert_eq!(
            s.encoder.lobes,
            vec![LobeFamily::Gaussian, LobeFamily::Microfacet]
        );
        assert_eq!(
            s.encoder.provenance,
            vec![("source".into(), "lab 4".into())]
        );
        assert!(!s.encoder.sample_positions);
        assert_eq!(s.wavelengths, Some((450.0, 650.0)));
        assert_eq!(s.read.rgb_to_spectrum, Some(RgbToSpectrum::JakobHanika2019));
        // --model decides warped tables too; --transform their transform.
        assert_eq!(s.warped, WarpedChoice::Auto);
        for (model, choice, warped) in [
            ("warped", ModelChoice::Auto, WarpedChoice::Required),
            ("records", ModelChoice::Records, WarpedChoice::Never),
            ("shared", ModelChoice::Shared, WarpedChoice::Never),
            ("auto", ModelChoice::Auto, WarpedChoice::Auto),
        ] {
            s.set("model", model).unwrap();
            assert_eq!((s.encoder.model, s.warped), (choice, warped), "{model}");
        }
        for (t, want) in [
            ("dct", Some(TableTransform::Dct)),
            ("wavelet", Some(TableTransform::Wavelet53)),
            ("auto", None),
        ] {
            s.set("transform", t).unwrap();
            assert_eq!(s.transform, want);
        }
        for (k, v) in [
            ("basis", "wavelet"),
            ("terms", "-1"),
            ("max-error", "0"),
            ("wavelengths", "650:450"),
            ("rgb-to-spectrum", "smits"),
            ("transform", "haar"),
            ("model", "table"),
            ("colour", "red"),
        ] {
            let e = s.set(k, v).unwrap_err().to_string();
            assert!(e.contains(k) || e.contains("unknown"), "{k}: {e}");
        }
    }
}
