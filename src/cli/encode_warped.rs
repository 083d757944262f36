//! `sbrdf encode` of one RGL file into warped tables (format 1.4/1.5), the default for such a file:
//! chosen here, before the sample-based encoder, because it reads the measurement's own grid
//! rather than samples at directions.

use sbrdf::encode::encoder::MetaLevel;
use sbrdf::encode::settings::EncodeSettings;
use sbrdf::encode::warped::{encode_warped, WarpedOptions, DEFAULT_MAX_ERROR};
use sbrdf::io::output::write_bytes_atomic;
use sbrdf::{Error, Result};

/// What `sbrdf encode` asks of warped tables.
pub struct WarpedRequest<'a> {
    pub inputs: &'a [std::path::PathBuf],
    pub output: &'a std::path::Path,
    /// `--model warped`: warped tables or an error.
    pub asked: bool,
    /// `--model auto`: warped tables where the input suits them.
    pub auto: bool,
    /// `--terms`.
    pub terms: Option<usize>,
}

/// Encodes the request as warped tables when it asks for them (`--model warped`) or leaves the
/// choice (`--model auto`) and names exactly one isotropic RGL file without options warped
/// tables do not take (--wavelengths, --incident-max, records-only options). Returns whether it
/// did.
pub fn try_encode(a: &WarpedRequest, settings: &EncodeSettings) -> Result<bool> {
    let asked = a.asked;
    if !asked && !a.auto {
        return Ok(false);
    }
    let single_rgl = a.inputs.len() == 1 && a.inputs[0].is_file() && {
        let mut magic = [0u8; 12];
        std::fs::File::open(&a.inputs[0])
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
            .is_ok()
            && &magic == sbrdf::io::rgl::MAGIC
    };
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
        return Ok(false);
    }
    let path = &a.inputs[0];
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: Some(path.clone()),
        source,
    })?;
    let read = match sbrdf::io::rgl::read_warped(&name, &bytes, &settings.read)? {
        Ok(r) => r,
        Err(reason) if asked => return Err(Error::Input(reason)),
        Err(_) => return Ok(false),
    };
    let budget = settings.max_error.unwrap_or(DEFAULT_MAX_ERROR);
    let opts = WarpedOptions {
        max_error: budget,
        terms: a.terms,
        transform: None,
    };
    let started = std::time::Instant::now();
    let mut enc = encode_warped(&read.input, &opts)?;
    let worst = enc.errors.iter().cloned().fold(0.0, f64::max);
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
        eprintln!("sbrdf: {msg}; writing the most accurate tables");
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
        let base = a.inputs[0]
            .file_name()
            .map_or_else(|| name.clone(), |f| f.to_string_lossy().into_owned());
        put(&format!("rgl:{base}"), read.description.clone().into());
        if read.upsampled {
            put("rgb_to_spectrum", "jakob-hanika-2019".into());
        }
        if matches!(meta, MetaLevel::Full) {
            put("max_error", budget.into());
            put("rel_error", ((worst * 1e5).round() / 1e5).into());
        }
        for (k, v) in &settings.encoder.provenance {
            put(k, v.clone().into());
        }
        enc.material.metadata = Some(serde_json::Value::Object(m).to_string());
    }
    let out = sbrdf::write_material(&enc.material)?;
    write_bytes_atomic(a.output, &out)?;
    let errs: Vec<String> = enc
        .errors
        .iter()
        .zip(&read.input.thetas_deg)
        .map(|(e, t)| format!("{t:.1}°: {:.3}%", 100.0 * e))
        .collect();
    eprintln!(
        "sbrdf: wrote {}: warped tables, {} incidences, {} spectral terms, {} bytes ({:.0}× smaller \
         than the {}-byte input) in {:.1} s; relative error per stored incidence {}",
        a.output.display(),
        read.input.thetas_deg.len(),
        enc.material.spectral.terms,
        out.len(),
        bytes.len() as f64 / out.len() as f64,
        bytes.len(),
        started.elapsed().as_secs_f64(),
        errs.join(", ")
    );
    Ok(true)
}
