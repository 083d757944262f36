//! Encoding with the factor model shared by every incidence ([`crate::model::factor`]): one
//! model of the whole material, for sparse and noisy measurements, plus one empty record per
//! measured incidence (the format's records carry the incidences, their sample positions and
//! their errors).

use crate::encode::factor_fit::{fit_factor, score, FactorOptions};
use crate::encode::metrics::{log_epsilon, rel, stored_error, ErrorSums};
use crate::encode::options::{
    metadata_envelope, sample_positions, EncodeOptions, Encoded, MetaLevel, NearestFigure,
};
use crate::encode::samples::SampleSet;
use crate::error::{Error, Result};
use crate::format::VERSION_MINOR_FACTOR;
use crate::model::angles::mirror_deg;
use crate::model::material::{
    HeldOutErrors, HeldOutProtocol, IncidentRecord, Material, MAX_SET_DIRECTIONS,
};
use crate::model::spectral::{SpectralBasis, SpectralSpace};
use crate::model::Precision;

/// A record that adds nothing: one spectral term, SH level 0, coefficient 0, stored in f16.
fn empty_record(theta_i: f64, phi_i: f64, rel_error: f32) -> IncidentRecord {
    let (tp, pp) = mirror_deg(theta_i, phi_i);
    IncidentRecord {
        terms: 1,
        sh_level: 0,
        precision: Precision::F16,
        theta_i: theta_i as f32,
        phi_i: phi_i as f32,
        theta_p: (tp + 0.0) as f32,
        phi_p: if tp < 1e-9 { 0.0 } else { (pp as f32) % 360.0 },
        rel_error,
        critical_angle: 0.0,
        sh: vec![0.0],
        lobes: Vec::new(),
    }
}

/// Fits the factor model to `set` and writes it with empty records.
pub fn encode_shared(set: &SampleSet, opts: &EncodeOptions) -> Result<Encoded> {
    encode_shared_noting(set, opts, None)
}

/// [`encode_shared`], its metadata recording `nearest` when given (`--model auto`).
pub(crate) fn encode_shared_noting(
    set: &SampleSet,
    opts: &EncodeOptions,
    nearest: Option<NearestFigure>,
) -> Result<Encoded> {
    set.validate()
        .map_err(|e| Error::Parameter(format!("invalid samples: {e}")))?;
    if opts.format_minor < VERSION_MINOR_FACTOR {
        return Err(Error::Parameter(
            "--model shared writes a factor model, a format 1.1 feature: drop --format 1.0, or \
             use --model records"
                .into(),
        ));
    }
    if !set.is_isotropic() {
        return Err(Error::Parameter(
            "--model shared fits an isotropic model: the input must give incidences at φi = 0 \
             only (use --model records for other inputs)"
                .into(),
        ));
    }
    let fopts = FactorOptions {
        precision: opts.precision,
        ..FactorOptions::default()
    };
    let fit = fit_factor(set, &fopts)
        .ok_or_else(|| Error::Parameter("no samples to fit the factor model to".into()))?;
    let eps = log_epsilon(set);
    let (mut sq_e, mut sq_r) = (0.0, 0.0);
    let mut records = Vec::with_capacity(set.incidences.len());
    for (i, s) in set.incidences.iter().enumerate() {
        let mut sums = ErrorSums::default();
        score(&fit.model, set, &|j, _| j == i, eps, &mut sums);
        sq_e += sums.sq_error;
        sq_r += sums.sq_reference;
        records.push(empty_record(s.theta_i, s.phi_i, stored_error(sums.rel())));
    }
    let rel_error = rel(sq_e, sq_r);
    let pooled = fit.held_out().map(|per| {
        let mut p = ErrorSums::default();
        per.iter().for_each(|s| p.merge(s));
        p
    });
    let mut options = serde_json::Map::new();
    options.insert("model".into(), serde_json::json!("shared"));
    options.insert("precision".into(), serde_json::json!(opts.precision.name()));
    options.insert("smoothness".into(), serde_json::json!(fit.smoothness));
    let (lo, hi) = (
        set.wavelengths[0],
        set.wavelengths[set.wavelengths.len() - 1],
    );
    let mut material = Material {
        // A factor model is a 1.1 feature; 1.3 adds compact records when allowed.
        version_minor: opts.format_minor.min(crate::format::VERSION_MINOR),
        // The records add nothing; their basis is the smallest there is.
        spectral: SpectralSpace::analytic(SpectralBasis::Cosine, 1, lo, hi),
        sh_level: 0,
        isotropic: true,
        wavelengths: set.wavelengths.iter().map(|&w| w as f32).collect(),
        records,
        metadata: match opts.meta {
            MetaLevel::None => None,
            level => Some(metadata_envelope(
                options,
                opts,
                rel_error,
                level == MetaLevel::Short,
                nearest,
            )),
        },
        sample_positions: (opts.sample_positions
            && set
                .incidences
                .iter()
                .all(|s| s.directions.len() as u64 <= MAX_SET_DIRECTIONS))
        .then(|| sample_positions(&set.incidences)),
        held_out: fit.held_out().map(|per| HeldOutErrors {
            protocol: HeldOutProtocol::Folds(fopts.inner_folds as u8),
            rel: per.iter().map(|s| stored_error(s.rel())).collect(),
            log: per.iter().map(|s| stored_error(s.log())).collect(),
        }),
        factor: Some(fit.model),
        warped: None,
    };
    // The version the file will declare, so that the material read back from it is this one.
    material.version_minor = crate::format::written_version(&material).0;
    material
        .validate()
        .map_err(|e| Error::Parameter(format!("encoder produced an invalid material: {e}")))?;
    Ok(Encoded {
        material,
        rel_error,
        raw_bytes: set.raw_f32_bytes(),
        unmet: Vec::new(),
        notes: Vec::new(),
        held_out: pooled,
        below_floor: 0,
    })
}
