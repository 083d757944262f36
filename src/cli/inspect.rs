//! `sbrdf eval`, `sbrdf info` and `sbrdf verify`: looking into a file.

use super::parse::parse_pair;
use clap::Args;
use sbrdf::{Decoder, Error, Residency, Result};
use std::path::PathBuf;

#[derive(Args)]
pub struct EvalArgs {
    pub input: PathBuf,
    /// Incident direction θ,φ in degrees.
    #[arg(long, value_name = "θ,φ", allow_hyphen_values = true)]
    pub incident: String,
    /// Outgoing direction θ,φ in degrees.
    #[arg(long, value_name = "θ,φ", allow_hyphen_values = true)]
    pub outgoing: String,
    /// Wavelengths in nm [default: the file's samples].
    #[arg(long, value_delimiter = ',', value_name = "λ1,λ2,...")]
    pub wavelengths: Option<Vec<f64>>,
    /// Evaluate the compact form a renderer holds (warped tables packed as the GPU layout
    /// packs them, each value within 1/256 of its quantisation step) instead of the exact
    /// binary64 values the specification defines. Files without warped tables give the same
    /// values either way.
    #[arg(long)]
    pub compact: bool,
}

#[derive(Args)]
pub struct InfoArgs {
    pub input: PathBuf,
    /// Machine-readable output.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct VerifyArgs {
    pub input: PathBuf,
}

pub fn cmd_eval(a: EvalArgs) -> Result<()> {
    let residency = if a.compact {
        Residency::Compact
    } else {
        Residency::Exact
    };
    let dec = Decoder::open_with(&a.input, residency)?;
    let inc = parse_pair("incident", &a.incident)?;
    let outg = parse_pair("outgoing", &a.outgoing)?;
    if !(0.0..=90.0).contains(&inc.0) {
        return Err(Error::Parameter(format!(
            "--incident θ = {} is outside [0, 90] degrees",
            inc.0
        )));
    }
    if outg.0 < 0.0 || outg.0 > 180.0 {
        return Err(Error::Parameter(format!(
            "--outgoing θ = {} is outside [0, 180] degrees",
            outg.0
        )));
    }
    let m = dec.material();
    let wl: Vec<f64> = match a.wavelengths {
        Some(w) => w,
        None => m.wavelengths.iter().map(|&w| w as f64).collect(),
    };
    let (lo, hi) = (m.spectral.lambda_min, m.spectral.lambda_max);
    if let Some(l) = wl
        .iter()
        .find(|l| !(l.is_finite() && **l >= lo && **l <= hi))
    {
        return Err(Error::Parameter(format!(
            "--wavelengths {l} is outside the file's range {lo}–{hi} nm"
        )));
    }
    let mut out = vec![0.0; wl.len()];
    dec.eval_deg(inc, outg, &wl, &mut out);
    println!("wavelength_nm,value");
    for (l, v) in wl.iter().zip(&out) {
        println!("{l},{v}");
    }
    Ok(())
}

pub fn cmd_info(a: InfoArgs) -> Result<()> {
    let len = std::fs::metadata(&a.input)
        .map_err(|e| Error::Io {
            path: Some(a.input.clone()),
            source: e,
        })?
        .len();
    let dec = Decoder::open(&a.input)?;
    let m = dec.material();
    if a.json {
        let v = sbrdf::encode::info::to_json(m, &a.input.display().to_string(), len);
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
        return Ok(());
    }
    println!("file:           {} ({len} bytes)", a.input.display());
    println!(
        "format:         sbrdf {}.{}",
        sbrdf::format::VERSION_MAJOR,
        m.version_minor
    );
    println!(
        "spectral basis: {}, {} terms over [{}, {}] nm{}",
        m.spectral.basis.name(),
        m.spectral.terms,
        m.spectral.lambda_min,
        m.spectral.lambda_max,
        m.spectral
            .table
            .as_ref()
            .map(|t| format!(", stored {}", t.storage.name()))
            .unwrap_or_default()
    );
    println!(
        "wavelengths:    {} samples, {}–{} nm",
        m.wavelengths.len(),
        m.wavelengths[0],
        m.wavelengths.last().unwrap()
    );
    println!(
        "SH level:       {} ({} coefficients per term)",
        m.sh_level,
        m.sh_count()
    );
    println!("precision:      {}", m.precision_name());
    println!(
        "incidences:     {}{}",
        m.records.len(),
        if m.isotropic {
            " (isotropic: φi = 0 only)"
        } else {
            ""
        }
    );
    if let Some(f) = &m.factor {
        let comps: Vec<String> = f
            .components
            .iter()
            .map(|c| {
                let names: Vec<&str> = c.features.iter().map(|k| k.name()).collect();
                format!("rank {} over {}", c.rank(), names.join(", "))
            })
            .collect();
        println!(
            "factor model:   shared by every incidence, {} parameters ({}): {}",
            f.parameter_count(),
            f.precision.name(),
            comps.join("; ")
        );
        let r = &f.ranges;
        println!(
            "measured:       θi {:.1}–{:.1}°, θo {:.1}–{:.1}°, θh {:.1}–{:.1}°, θd {:.1}–{:.1}°, x {:.2}–{:.2}; beyond, each \
             angle is held at its nearest end (the peak follows the mirror direction)",
            r[2][0], r[2][1], r[3][0], r[3][1], r[0][0], r[0][1], r[1][0], r[1][1], r[4][0], r[4][1]
        );
    }
    if let Some(w) = &m.warped {
        let steps = w
            .steps
            .iter()
            .cloned()
            .fold((f32::MAX, 0f32), |(lo, hi), q| (lo.min(q), hi.max(q)));
        let nonzero = w.levels.iter().filter(|&&z| z != 0).count();
        println!(
            "warped tables:  {} incidences × {} terms of {}×{} (Dupuy & Jakob 2018 warp on a \
             {}×{} VNDF grid from {} NDF nodes, {}), {nonzero} of {} {} coefficients \
             non-zero, steps {}–{}",
            m.records.len(),
            m.spectral.terms,
            w.grid,
            w.grid,
            w.warp_grid,
            w.warp_grid,
            w.ndf.len(),
            w.ndf_precision.name(),
            w.levels.len(),
            match w.transform {
                sbrdf::model::warped::TableTransform::Dct => "DCT-II",
                sbrdf::model::warped::TableTransform::Wavelet53 => "CDF 5/3 wavelet",
            },
            steps.0,
            steps.1
        );
        if !w.predicted.is_empty() {
            let predicted: Vec<String> = m
                .records
                .iter()
                .zip(&w.predicted)
                .filter(|(_, &p)| p)
                .map(|(r, _)| r.theta_i.to_string())
                .collect();
            println!(
                "predicted:      {} of {} incidences coded as the difference to the one before{}",
                predicted.len(),
                w.predicted.len().saturating_sub(1),
                if predicted.is_empty() {
                    String::new()
                } else {
                    format!(" (θv {})", predicted.join(", "))
                }
            );
        }
        println!(
            "incidences θv:  {} (viewing directions: the tables follow them, spec/EVALUATION.md)",
            m.records
                .iter()
                .map(|r| r.theta_i.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        // The encoder's noise estimate (issue 39): below it a budget would code noise.
        let noise = m
            .metadata
            .as_deref()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(t).ok())
            .and_then(|v| v.get("noise_floor").and_then(|n| n.as_f64()));
        if let Some(n) = noise {
            println!(
                "noise floor:    {:.3}% (the measurement's own noise as the encoder estimated it, \
                 worst incidence; a default budget codes no incidence below it)",
                100.0 * n
            );
        }
        if let Some(meta) = &m.metadata {
            println!("metadata:       {meta}");
        }
        return Ok(());
    }
    let held = m.held_out.as_ref();
    let protocol = held.map(|h| match h.protocol {
        sbrdf::model::material::HeldOutProtocol::Folds(k) => format!("{k}-fold"),
        sbrdf::model::material::HeldOutProtocol::LeaveOneOut => "leave-one-out".into(),
    });
    println!(
        "records:        θi      φi      θp      φp      critical  lobes  rel_error{}",
        protocol.map_or(String::new(), |p| format!("  held-out rel / log ({p})"))
    );
    for (i, r) in m.records.iter().enumerate() {
        println!(
            "                {:<7} {:<7} {:<7.3} {:<7.3} {:<9.2} {:<6} {:.5}{}",
            r.theta_i,
            r.phi_i,
            r.theta_p,
            r.phi_p,
            r.critical_angle,
            r.lobes.len(),
            r.rel_error,
            held.map_or(String::new(), |h| format!(
                "    {:.5} / {:.4}",
                h.rel[i], h.log[i]
            ))
        );
    }
    if let Some(meta) = &m.metadata {
        println!("metadata:       {meta}");
    }
    Ok(())
}

pub fn cmd_verify(a: VerifyArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    let m = dec.material();
    println!(
        "ok: {}: sbrdf {}.{}, {} records; every CRC and the structure check out",
        a.input.display(),
        sbrdf::format::VERSION_MAJOR,
        m.version_minor,
        m.records.len()
    );
    Ok(())
}
