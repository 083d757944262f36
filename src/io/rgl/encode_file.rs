//! One RGL file into warped tables (format 1.4/1.5), the default for such a file: the choice,
//! the encode and the metadata that every entry point (`sbrdf encode`, Python's `sbrdf.encode`)
//! calls, so that both write the same bytes. It runs before the sample-based encoder because it
//! reads the measurement's own grid rather than samples at directions.

use super::{read_warped, MAGIC};
use crate::encode::encoder::MetaLevel;
use crate::encode::settings::{EncodeSettings, WarpedChoice};
use crate::encode::warped::{encode_warped, WarpedOptions, DEFAULT_MAX_ERROR};
use crate::error::{Error, Result};
use crate::format::{VERSION_MINOR_PREDICTED, VERSION_MINOR_RANGE};
use crate::format::{VERSION_MINOR_WARP, VERSION_MINOR_WAVELET};
use crate::model::warped::{PayloadCoding, TableTransform};
use std::path::PathBuf;

/// What encoding one RGL file as warped tables gave.
#[derive(Debug, Clone)]
pub struct WarpedFileOutcome {
    /// The `.sbrdf` file's bytes.
    pub bytes: Vec<u8>,
    /// The relative L2 error of each stored incidence, in the order of `thetas_deg`.
    pub errors: Vec<f64>,
    /// The stored viewing incidences, degrees.
    pub thetas_deg: Vec<f64>,
    /// Spectral terms of the tables.
    pub terms: usize,
    /// Bytes of the RGL file read.
    pub input_bytes: usize,
    /// Notes and warnings, one line each, without a prefix.
    pub messages: Vec<String>,
    /// The measurement's estimated noise at each stored incidence, relative like `errors`
    /// ([`crate::encode::noise`]).
    pub noise: Vec<f64>,
    /// The budget each stored incidence was coded to (the asked or default budget, or the
    /// noise where that is higher and the budget was the default).
    pub budgets: Vec<f64>,
}

impl WarpedFileOutcome {
    /// The worst stored incidence's error.
    pub fn worst_error(&self) -> f64 {
        self.errors.iter().cloned().fold(0.0, f64::max)
    }

    /// The largest estimated noise of a stored incidence.
    pub fn noise_floor(&self) -> f64 {
        self.noise.iter().cloned().fold(0.0, f64::max)
    }
}

fn is_rgl_file(path: &std::path::Path) -> bool {
    let mut magic = [0u8; 12];
    path.is_file()
        && std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
            .is_ok()
        && &magic == MAGIC
}

/// Encodes `inputs` as warped tables when `settings.warped` requires it (`--model warped`) or
/// leaves the choice (`auto`) and they are exactly one isotropic RGL file without options warped
/// tables do not take (`--wavelengths`, `--incident-max`). `Ok(None)`: not for warped tables
/// (the caller encodes samples). Fails, writing nothing, where an explicit `max_error` is unmet
/// without `best_effort`, or where `--model warped` cannot be honoured.
pub fn encode_warped_file(
    inputs: &[PathBuf],
    settings: &EncodeSettings,
) -> Result<Option<WarpedFileOutcome>> {
    let asked = settings.warped == WarpedChoice::Required;
    if settings.warped == WarpedChoice::Never {
        return Ok(None);
    }
    let single_rgl = inputs.len() == 1 && is_rgl_file(&inputs[0]);
    let restricted = settings.wavelengths.is_some() || settings.incident_max.is_some();
    if !single_rgl || restricted {
        if asked {
            return Err(Error::Parameter(format!(
                "--model warped takes exactly one RGL .bsdf file{}",
                if restricted {
                    ", without --wavelengths or --incident-max"
                } else {
                    ""
                }
            )));
        }
        return Ok(None);
    }
    let path = &inputs[0];
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: Some(path.clone()),
        source,
    })?;
    let read = match read_warped(&name, &bytes, &settings.read)? {
        Ok(r) => r,
        Err(reason) if asked => return Err(Error::Input(reason)),
        Err(_) => return Ok(None),
    };
    let budget = settings.max_error.unwrap_or(DEFAULT_MAX_ERROR);
    // `--format 1.4` / `1.5`: what decoders of that version read (DEFLATE; 1.4: the DCT only).
    let minor = settings.encoder.format_minor;
    if minor < VERSION_MINOR_WARP {
        return Err(Error::Parameter(format!(
            "{name}: warped tables need format 1.{VERSION_MINOR_WARP} or later (--format 1.{minor} \
             was asked)"
        )));
    }
    let transform = match settings.transform {
        Some(TableTransform::Wavelet53) if minor < VERSION_MINOR_WAVELET => {
            return Err(Error::Parameter(format!(
                "--transform wavelet needs format 1.{VERSION_MINOR_WAVELET} or later (--format \
                 1.{minor} was asked)"
            )))
        }
        None if minor < VERSION_MINOR_WAVELET => Some(TableTransform::Dct),
        t => t,
    };
    let coding = if minor >= VERSION_MINOR_RANGE {
        PayloadCoding::Range
    } else {
        PayloadCoding::Deflate
    };
    let opts = WarpedOptions {
        max_error: budget,
        terms: settings.encoder.terms,
        transform,
        coding,
        predict: minor >= VERSION_MINOR_PREDICTED,
        // A default budget never codes below the measurement's own noise; an explicit one
        // means what it says.
        noise_floor: settings.max_error.is_none(),
    };
    let mut enc = encode_warped(&read.input, &opts)?;
    let worst = enc.errors.iter().cloned().fold(0.0, f64::max);
    let mut messages = Vec::new();
    let noise = enc.noise.iter().cloned().fold(0.0, f64::max);
    let raised = enc.budgets.iter().filter(|&&b| b > budget).count();
    if raised > 0 {
        messages.push(format!(
            "{name}: the measurement's noise, estimated at up to {:.2}%, is above the default \
             budget of {:.2}% at {raised} of {} stored incidences: those are coded to their noise \
             instead (below it the bytes would code noise; --max-error sets the budget exactly)",
            100.0 * noise,
            100.0 * budget,
            enc.budgets.len()
        ));
    } else if settings.max_error.is_some() && noise > budget {
        messages.push(format!(
            "{name}: the budget of {:.2}% is below the measurement's noise, estimated at up to \
             {:.2}%: part of the file's bytes code that noise",
            100.0 * budget,
            100.0 * noise
        ));
    }
    if !enc.met {
        let msg = format!(
            "{name}: warped tables reach at best {:.3}% at the worst stored incidence, above the \
             budget of {:.3}%",
            100.0 * worst,
            100.0 * budget
        );
        if settings.max_error.is_some() && !settings.best_effort {
            return Err(Error::Input(format!(
                "{msg}; nothing written (pass --best-effort to write the most accurate tables)"
            )));
        }
        messages.push(format!("{msg}; writing the most accurate tables"));
    }
    let meta: MetaLevel = settings.encoder.meta;
    if !matches!(meta, MetaLevel::None) {
        // What a reader of the file needs to know of its making; what the file itself says
        // (terms, steps, incidences) is not repeated. `short` leaves out the budget and error.
        let mut m = serde_json::Map::new();
        let mut put = |k: &str, v: serde_json::Value| {
            m.insert(k.to_string(), v);
        };
        put(
            "encoder",
            format!("sbrdf {} warped tables", env!("CARGO_PKG_VERSION")).into(),
        );
        let base = path
            .file_name()
            .map_or_else(|| name.clone(), |f| f.to_string_lossy().into_owned());
        put(&format!("rgl:{base}"), read.description.clone().into());
        if read.upsampled {
            put("rgb_to_spectrum", "jakob-hanika-2019".into());
        }
        if matches!(meta, MetaLevel::Full) {
            put("max_error", budget.into());
            put("rel_error", ((worst * 1e5).round() / 1e5).into());
            put("noise_floor", ((noise * 1e5).round() / 1e5).into());
        }
        for (k, v) in &settings.encoder.provenance {
            put(k, v.clone().into());
        }
        enc.material.metadata = Some(serde_json::Value::Object(m).to_string());
    }
    Ok(Some(WarpedFileOutcome {
        bytes: crate::write_material(&enc.material)?,
        errors: enc.errors,
        thetas_deg: read.input.thetas_deg.iter().map(|&t| t as f64).collect(),
        terms: enc.material.spectral.terms,
        input_bytes: bytes.len(),
        messages,
        noise: enc.noise,
        budgets: enc.budgets,
    }))
}
