//! From samples to a [`Material`]: options, the parallel per-incidence fit, f16 rounding,
//! sample positions and metadata.

use crate::encode::basis::{
    derive_basis, rank_meeting, rounded_table, series_limit, singular_vectors, spectral_space,
    AUTO_RANK_MAX,
};
use crate::encode::fit::factor::{FactorOptions, INNER_FOLD_SALT};
use crate::encode::fit::{rel, stored_error, CriticalAngle, FitContext, PeakMode};
use crate::encode::fit::{JointOptions, LobeFamily};
use crate::encode::samples::{IncidentSamples, SampleSet};
use crate::encode::validate::ErrorSums;
use crate::error::{Error, Result};
use crate::format::quantize_record_f16;
use crate::model::material::{
    DirectionSet, HeldOutErrors, HeldOutProtocol, Material, SamplePositions, MAX_TERMS,
};
use crate::model::sh::MAX_SH_LEVEL;
use crate::model::spectral::{BasisTable, SpectralBasis};
use crate::model::Precision;
use rayon::prelude::*;

/// Encoder settings; the CLI's flags map one to one onto these fields.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeOptions {
    pub basis: SpectralBasis,
    /// Number of spectral terms K (the paper: 13 = a0, a1..a6, b1..b6). `None`: 13 for the
    /// analytic bases; for the data-derived basis the smallest rank whose out-of-basis error is
    /// at most half the error budget (0.5% without one) at every incidence, at most 8.
    pub terms: Option<usize>,
    /// SH level L (with an error budget, the largest level tried); `None` picks the paper's
    /// choice for its modes (1 with a peak, its Fig. 6; 4 without, its Fig. 4) and 6 for the
    /// joint fit.
    pub sh_level: Option<usize>,
    pub peak: PeakMode,
    pub critical_angle: CriticalAngle,
    pub precision: Precision,
    /// Lobe families the joint fit may use (`--lobes`).
    pub lobes: Vec<LobeFamily>,
    /// Per-incidence relative error budget (`--max-error`): the joint fit picks the smallest
    /// model meeting it. The default is 0.5%.
    pub max_error: Option<f64>,
    /// Store the outgoing directions seen (`samp` chunk) so `decode` can write them back.
    pub sample_positions: bool,
    /// `--metadata KEY=VALUE` pairs, in the order given.
    pub provenance: Vec<(String, String)>,
    /// Names of the input files, recorded in the metadata.
    pub inputs: Vec<String>,
    /// Which model the file holds (`--model`).
    pub model: ModelChoice,
    /// With a budget, hold each record to it between the samples too (leave-one-out), and
    /// where the samples' scatter makes that impossible keep the model that predicts held-out
    /// samples best (`JointOptions::held_out`). [`ModelChoice::Auto`] tries it for inputs that
    /// look measured.
    pub held_out: bool,
    /// The budget was given explicitly (`--max-error`): it keeps its meaning at the samples,
    /// Auto keeps the records fitted to it, and the encoder says where it lies below the
    /// held-out error.
    pub budget_given: bool,
    /// What the `meta` chunk keeps (`--meta`).
    pub meta: MetaLevel,
    /// The newest minor format version the file may use (`--format 1.0` gives files every 1.0
    /// reader reads; 1.1 stores evenly spaced wavelengths as a range).
    pub format_minor: u16,
}

/// What kind of model an encode writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// Records, unless they cannot meet the budget between the samples of an isotropic input
    /// (measured data: noise, sparse or scattered sampling); then whichever of records and the
    /// shared factor model has the lower held-out error (log² + rel²). The default.
    Auto,
    /// One record per incidence (SH background and lobes), each fitted to its own samples: the
    /// most accurate at the samples of dense, clean data.
    Records,
    /// The factor model shared by every incidence (`FACT`), for sparse, noisy measurements:
    /// predicts between the samples and between the incidences.
    Shared,
}

impl ModelChoice {
    pub fn name(self) -> &'static str {
        match self {
            ModelChoice::Auto => "auto",
            ModelChoice::Records => "records",
            ModelChoice::Shared => "shared",
        }
    }
}

/// What the file's `meta` chunk keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MetaLevel {
    /// The encoder, the inputs, every option that shaped the file, provenance, the overall
    /// error (the default).
    #[default]
    Full,
    /// The encoder, the options that differ from its defaults, provenance, the overall error.
    Short,
    /// No `meta` chunk.
    None,
}

impl MetaLevel {
    pub fn name(self) -> &'static str {
        match self {
            MetaLevel::Full => "full",
            MetaLevel::Short => "short",
            MetaLevel::None => "none",
        }
    }
}

/// The default error budget per incidence (relative L2).
pub const DEFAULT_MAX_ERROR: f64 = 0.005;

impl EncodeOptions {
    /// The paper's method as the paper ran it: 13 periodic Fourier terms, SH level 1, Gaussian
    /// peak outside an automatically chosen critical angle, f32.
    pub fn paper() -> Self {
        EncodeOptions {
            basis: SpectralBasis::PeriodicFourier,
            terms: Some(13),
            peak: PeakMode::Paper,
            precision: Precision::F32,
            max_error: None,
            ..Self::default()
        }
    }
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            basis: SpectralBasis::Tabulated,
            terms: None,
            sh_level: None,
            peak: PeakMode::Joint,
            critical_angle: CriticalAngle::Auto,
            precision: Precision::F16,
            lobes: vec![
                LobeFamily::CosinePower,
                LobeFamily::Gaussian,
                LobeFamily::Microfacet,
                LobeFamily::MicrofacetSin2,
            ],
            max_error: Some(DEFAULT_MAX_ERROR),
            sample_positions: true,
            provenance: Vec::new(),
            inputs: Vec::new(),
            model: ModelChoice::Auto,
            held_out: false,
            budget_given: false,
            meta: MetaLevel::Full,
            format_minor: crate::format::VERSION_MINOR,
        }
    }
}

impl EncodeOptions {
    pub fn effective_sh_level(&self) -> usize {
        self.sh_level.unwrap_or(match self.peak {
            PeakMode::Paper => 1,
            PeakMode::None => 4,
            PeakMode::Joint => 6,
        })
    }

    /// The number of terms to fit, resolving `None`.
    pub fn effective_terms(&self, set: &SampleSet) -> usize {
        self.terms_and_table(set).0
    }

    /// The number of terms, and for the data-derived basis its table, from one SVD.
    fn terms_and_table(&self, set: &SampleSet) -> (usize, Option<BasisTable>) {
        let w = set.wavelengths.len();
        match (self.terms, self.basis) {
            (Some(k), SpectralBasis::Tabulated) if k >= 1 && k <= w => {
                (k, Some(derive_basis(set, k, self.precision)))
            }
            (Some(k), _) => (k, None),
            (None, SpectralBasis::Tabulated) => {
                // The leading rows of a rank-8 derivation are the lower-rank bases themselves;
                // the rank is chosen on the exact (orthonormal) vectors, then they are rounded.
                let limit = 0.5 * self.max_error.unwrap_or(DEFAULT_MAX_ERROR);
                let mut vectors = singular_vectors(set, AUTO_RANK_MAX.min(w));
                let r = rank_meeting(set, &vectors, limit);
                vectors.truncate(r * w);
                (r, Some(rounded_table(set, vectors, self.precision)))
            }
            (None, basis) => (13.min(series_limit(basis, w)), None),
        }
    }

    fn check(&self, set: &SampleSet, terms: usize) -> Result<()> {
        let w = set.wavelengths.len();
        if terms == 0 || terms > MAX_TERMS {
            return Err(Error::Parameter(format!(
                "--terms {terms} is outside 1..={MAX_TERMS}"
            )));
        }
        if terms > w {
            return Err(Error::Parameter(format!(
                "--terms {terms} exceeds the {w} wavelength samples of the input: a spectral \
                 series cannot have more terms than samples (use --terms {w} or fewer)"
            )));
        }
        let limit = series_limit(self.basis, w);
        if terms > limit {
            return Err(Error::Parameter(format!(
                "--terms {terms} is too many for the periodic Fourier basis on {w} wavelength \
                 samples: it takes λmin and λmax as one point, leaving {limit} independent \
                 values (use --terms {limit} or fewer, or --basis cosine)"
            )));
        }
        let l = self.effective_sh_level();
        if l > MAX_SH_LEVEL {
            return Err(Error::Parameter(format!(
                "--sh-level {l} is above the maximum {MAX_SH_LEVEL}"
            )));
        }
        if let Some(e) = self.max_error {
            if !(e.is_finite() && e > 0.0) {
                return Err(Error::Parameter(format!(
                    "--max-error {e} must be a positive fraction (0.01 = 1%)"
                )));
            }
            if self.peak != PeakMode::Joint {
                return Err(Error::Parameter(
                    "--max-error needs --peak joint (the paper's method has no size to choose)"
                        .into(),
                ));
            }
        }
        if let CriticalAngle::Fixed(g) = self.critical_angle {
            if !(g.is_finite() && (0.0..=180.0).contains(&g)) {
                return Err(Error::Parameter(format!(
                    "--critical-angle {g} is outside 0..=180 degrees"
                )));
            }
        }
        Ok(())
    }
}

/// The result of an encode: the material and the figures an encoder reports.
#[derive(Debug, Clone)]
pub struct Encoded {
    pub material: Material,
    /// Relative L2 error over every sample of the input, as stored.
    pub rel_error: f64,
    /// Size of the input as a raw float32 table.
    pub raw_bytes: usize,
    /// Indices of the records whose error budget (`max_error`) could not be met; they hold
    /// the most accurate model tried.
    pub unmet: Vec<usize>,
    /// What the encoder decided on its own that the user should hear about (a lowered SH level
    /// where the samples could not support the one asked for).
    pub notes: Vec<String>,
    /// The held-out error pooled over every incidence, when the encoder measured one (the
    /// records' leave-one-out error; the factor model's inner cross-validation).
    pub held_out: Option<ErrorSums>,
    /// Records whose budget lies below their held-out floor.
    pub below_floor: usize,
}

/// Encodes `set` with the model `opts.model` names.
pub fn encode(set: &SampleSet, opts: &EncodeOptions) -> Result<Encoded> {
    encode_with_progress(set, opts, None)
}

/// [`encode`], reporting progress as the records' incidences finish (the command line draws a
/// bar; the other models of [`ModelChoice::Auto`] are not counted).
pub fn encode_with_progress(
    set: &SampleSet,
    opts: &EncodeOptions,
    progress: Option<Progress>,
) -> Result<Encoded> {
    match opts.model {
        ModelChoice::Records => encode_records_with_progress(set, opts, progress),
        ModelChoice::Shared => crate::encode::shared::encode_shared(set, opts),
        ModelChoice::Auto => encode_auto(set, opts, progress),
    }
}

/// Per-incidence records ([`ModelChoice::Records`]).
pub fn encode_records(set: &SampleSet, opts: &EncodeOptions) -> Result<Encoded> {
    encode_records_with_progress(set, opts, None)
}

/// [`ModelChoice::Auto`]: records fitted to the budget at the samples, unless the input looks
/// measured — the budget is out of reach at most incidences even at the samples (noise above
/// it), or the samples hold a measurement floor (at least [`MEASURED_FLOOR_FRACTION`] of them
/// read 0 or less) and the records' log error at the samples exceeds [`MEASURED_LOG_ERROR`]
/// (they invent light where that floor reads about 0). Then the records held to the budget between
/// the samples and, for isotropic inputs, the shared factor model are fitted too, and the file
/// holds whichever of the three predicts held-out samples best (`EVALUATION.md`, "Which model").
fn encode_auto(
    set: &SampleSet,
    opts: &EncodeOptions,
    progress: Option<Progress>,
) -> Result<Encoded> {
    let classic_opts = EncodeOptions {
        held_out: false,
        ..opts.clone()
    };
    let classic = encode_records_with_progress(set, &classic_opts, progress)?;
    let eps = crate::encode::validate::log_epsilon(set);
    let measured = !opts.budget_given
        && opts.peak == PeakMode::Joint
        && opts.max_error.is_some()
        && (2 * classic.unmet.len() > set.incidences.len()
            || (set.floor_fraction() >= MEASURED_FLOOR_FRACTION
                && classic_log_error(&classic, set, eps) > MEASURED_LOG_ERROR));
    if !measured {
        // The budget is not out of reach: an unmet incidence is the lobe families' limit,
        // reported as before.
        return Ok(classic);
    }
    // Candidates, each judged on the factor model's inner folds (2-fold, its shuffle), by
    // log² + max(rel − 1, 0)²: the log error weighs every value, while on sparse peaky data rel
    // measures the one near-mirror sample of a fold that holds most of Σρ² (Cornell krylon_blue
    // without 70°: the records win on rel, 0.47 against 0.97, and then miss 70° by log 1.35
    // against the factor model's 0.68). Rel counts only above 1, what predicting 0 scores:
    // light a model invents.
    let inner = FactorOptions::default().inner_folds;
    let score = |s: &ErrorSums| s.log().powi(2) + (s.rel() - 1.0).max(0.0).powi(2);
    let cv = |o: &EncodeOptions| -> Result<ErrorSums> {
        let quiet = EncodeOptions {
            sample_positions: false,
            model: ModelChoice::Records,
            ..o.clone()
        };
        let mut t = ErrorSums::default();
        for s in crate::encode::validate::k_fold(set, &quiet, inner, INNER_FOLD_SALT, eps)? {
            t.merge(&s);
        }
        Ok(t)
    };
    let classic_cv = cv(&classic_opts)?;
    // Records that already predict the held-out samples within twice the budget do not fail
    // between the samples, whatever their log error says: a floor of exact zeros under a tiny
    // ε (a pure specular Phong lobe, zero beyond 90° from the mirror) makes that error large
    // for values far below the budget.
    let budget = opts.max_error.unwrap_or(DEFAULT_MAX_ERROR);
    if classic_cv.rel() <= RECORDS_HOLD_FACTOR * budget {
        let mut classic = classic;
        classic.notes.push(format!(
            "the input looks measured, but the records fitted to the budget predict held-out \
             samples within {RECORDS_HOLD_FACTOR}× of it ({inner}-fold rel {:.4}): kept them",
            classic_cv.rel()
        ));
        return Ok(classic);
    }
    let held_opts = EncodeOptions {
        held_out: true,
        ..opts.clone()
    };
    let held = encode_records(set, &held_opts)?;
    let mut candidates: Vec<(&str, Encoded, ErrorSums)> = vec![
        ("records fitted to the budget", classic, classic_cv),
        (
            "records held to the budget between the samples",
            held,
            cv(&held_opts)?,
        ),
    ];
    // The factor model is a format 1.1 feature: not a candidate under --format 1.0.
    if set.is_isotropic() && opts.format_minor >= crate::format::VERSION_MINOR_FACTOR {
        let shared = crate::encode::shared::encode_shared(set, opts)?;
        if let Some(h) = shared.held_out {
            candidates.push(("the factor model shared by every incidence", shared, h));
        }
    }
    let best = (0..candidates.len())
        .min_by(|&a, &b| score(&candidates[a].2).total_cmp(&score(&candidates[b].2)))
        .expect("candidates");
    let figures: Vec<String> = candidates
        .iter()
        .map(|(n, _, s)| format!("{n} {:.4}, {:.3}", s.rel(), s.log()))
        .collect();
    let (name, mut chosen, _) = candidates.swap_remove(best);
    chosen.notes.push(format!(
        "the input looks measured (the budget {} is out of reach at the samples, or the \
         records invent light at a measurement floor); kept {name}. Held-out error ({inner}-fold; \
         rel, log): {}",
        opts.max_error.unwrap_or(DEFAULT_MAX_ERROR),
        figures.join("; ")
    ));
    Ok(chosen)
}

/// Where the records' log error at their own samples lies above this, they invent light where
/// the measurement reads about 0 (fits of smooth synthetic data stay near 0.1; the Cornell
/// measurements, whose floor holds 42% exact zeros, give 1.1).
pub const MEASURED_LOG_ERROR: f64 = 0.5;

/// The fraction of values at or below 0 from which the samples are taken to hold a measurement
/// floor (the Cornell files: acryl_blue 42%, krylon_blue 2.7%; analytic materials above the
/// horizon: none, but for lobes cut off at 0 like Phong's). Without one, a high log error is a
/// dim background fitted with an absolute error, as on MERL chrome, whose peak is sharper than
/// its 5° grid: there the records' lobe family predicts between the samples what neither the
/// samples nor any cross-validation on them can show (dense-grid rel 0.07 against the factor
/// model's 0.91), and the records stand.
pub const MEASURED_FLOOR_FRACTION: f64 = 0.01;

/// Records whose held-out rel error (the inner folds) is at most this times the budget are kept
/// on a measured-looking input: they already hold between the samples.
pub const RECORDS_HOLD_FACTOR: f64 = 2.0;

/// The records' log error at every sample (`EVALUATION.md`, "Held-out error"), decoded.
fn classic_log_error(e: &Encoded, set: &SampleSet, eps: f64) -> f64 {
    let Ok(dec) = crate::decode::Decoder::from_material(e.material.clone()) else {
        return 0.0;
    };
    let w = set.wavelengths.len();
    let mut sums = ErrorSums::default();
    let mut out = vec![0.0; w];
    for s in &set.incidences {
        for (d, dir) in s.directions.iter().enumerate() {
            dec.eval_deg(
                (s.theta_i, s.phi_i),
                (dir[0], dir[1]),
                &set.wavelengths,
                &mut out,
            );
            for (p, m) in out.iter().zip(&s.values[d * w..(d + 1) * w]) {
                sums.add(*p, *m, eps);
            }
        }
    }
    sums.log()
}

/// Called as incidences finish: (incidences fitted, incidences in all), from any thread.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Fits every incident direction (in parallel; the result does not depend on the thread count,
/// since each incidence is fitted alone and results are collected in order).
/// The lobe families the fit tries on `set`: those asked for, and with the default families the
/// anisotropic one (kind 5) too where the input has several incident azimuths and the format
/// allows it (1.2). Never on an isotropic input (one azimuth), whose records are evaluated in the
/// plane of incidence, where a surface axis has no meaning, nor under `--format 1.0` or `1.1`,
/// whose readers do not know kind 5; so isotropic inputs encode as before kind 5 existed.
pub fn lobe_families(opts: &EncodeOptions, set: &SampleSet) -> Vec<LobeFamily> {
    let allowed = !set.is_isotropic() && opts.format_minor >= crate::format::VERSION_MINOR_ANISO;
    let mut families: Vec<LobeFamily> = opts
        .lobes
        .iter()
        .copied()
        .filter(|f| allowed || *f != LobeFamily::MicrofacetAniso)
        .collect();
    if allowed
        && opts.lobes == EncodeOptions::default().lobes
        && !families.contains(&LobeFamily::MicrofacetAniso)
    {
        families.push(LobeFamily::MicrofacetAniso);
    }
    families
}

/// Per-incidence records (`ModelChoice::Records`), reporting progress as incidences finish.
pub fn encode_records_with_progress(
    set: &SampleSet,
    opts: &EncodeOptions,
    progress: Option<Progress>,
) -> Result<Encoded> {
    set.validate()
        .map_err(|e| Error::Parameter(format!("invalid samples: {e}")))?;
    // The families actually tried, which the metadata records.
    let opts = &EncodeOptions {
        lobes: lobe_families(opts, set),
        ..opts.clone()
    };
    let (terms, table) = opts.terms_and_table(set);
    opts.check(set, terms)?;
    let mut spectral = spectral_space(opts.basis, terms, &set.wavelengths);
    spectral.table = table;
    spectral.validate().map_err(Error::Parameter)?;
    let mut ctx = FitContext::new(
        spectral.clone(),
        &set.wavelengths,
        opts.effective_sh_level(),
        opts.peak,
        opts.critical_angle,
    );
    ctx.joint = JointOptions {
        max_sh_level: opts.effective_sh_level(),
        families: opts.lobes.clone(),
        precision: opts.precision,
        max_error: opts.max_error,
        held_out: opts.held_out,
        log_epsilon: crate::encode::validate::log_epsilon(set),
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let total = set.incidences.len();
    let fitted: Vec<_> = set
        .incidences
        .par_iter()
        .map(|s| {
            let mut note = None;
            let fit = ctx.fit(s).or_else(|e| {
                // The paper's split needs (L+1)² background samples; with fewer outgoing
                // samples the level is lowered until the fit is determined, and reported.
                if opts.peak != PeakMode::Paper {
                    return Err(e);
                }
                for level in (0..opts.effective_sh_level()).rev() {
                    let lower = FitContext::new(
                        spectral.clone(),
                        &set.wavelengths,
                        level,
                        opts.peak,
                        opts.critical_angle,
                    );
                    if let Ok(f) = lower.fit(s) {
                        note = Some(format!(
                            "incidence ({}, {}): {} outgoing samples cannot determine SH level \
                             {} beside the peak; stored at level {level}",
                            s.theta_i,
                            s.phi_i,
                            s.directions.len(),
                            opts.effective_sh_level()
                        ));
                        return Ok(f);
                    }
                }
                Err(e)
            });
            let mut f = fit.map_err(|e| {
                Error::Parameter(format!("incidence ({}, {}): {e}", s.theta_i, s.phi_i))
            })?;
            if opts.precision == Precision::F16 && opts.peak != PeakMode::Joint {
                quantize_record_f16(&mut f.record);
                let (e, r) = ctx.measure(&f.record, s);
                f.sq_error = e;
                f.record.rel_error = stored_error(rel(e, r));
            }
            if let Some(p) = progress {
                p(
                    done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                    total,
                );
            }
            Ok((f, note))
        })
        .collect::<Result<Vec<_>>>()?;
    let (mut sq_e, mut sq_r) = (0.0, 0.0);
    let mut records = Vec::with_capacity(fitted.len());
    let mut unmet = Vec::new();
    let mut notes = Vec::new();
    let mut pooled = Some(ErrorSums::default());
    let mut held_out = Some(HeldOutErrors {
        protocol: HeldOutProtocol::LeaveOneOut,
        rel: Vec::new(),
        log: Vec::new(),
    });
    let mut floor = Vec::new();
    for (f, note) in fitted {
        notes.extend(note);
        sq_e += f.sq_error;
        sq_r += f.sq_reference;
        if !f.met {
            unmet.push(records.len());
        }
        match (&mut held_out, &f.held_out) {
            (Some(h), Some(ho)) => {
                if let Some(p) = &mut pooled {
                    p.merge(ho);
                }
                h.rel.push(crate::encode::fit::stored_error(ho.rel()));
                h.log.push(crate::encode::fit::stored_error(ho.log()));
                if f.below_floor {
                    floor.push(ho.rel());
                }
            }
            _ => {
                held_out = None;
                pooled = None;
            }
        }
        records.push(f.record);
    }
    if let (Some(budget), false) = (opts.max_error, floor.is_empty()) {
        let lo = floor.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = floor.iter().cloned().fold(0.0, f64::max);
        if opts.held_out {
            notes.push(format!(
                "at {} incidence(s) no model meets the budget {budget} between the samples \
                 (leave-one-out error {lo:.4}–{hi:.4}): kept the model that predicts held-out \
                 samples best rather than fit the samples' scatter",
                floor.len()
            ));
        } else if opts.budget_given {
            notes.push(format!(
                "--max-error {budget} lies below the leave-one-out error at {} incidence(s) \
                 ({lo:.4}–{hi:.4}): there the file fits the samples' scatter; `sbrdf validate` \
                 measures the error between the samples",
                floor.len()
            ));
        }
    }
    let rel_error = rel(sq_e, sq_r);
    // Records may use fewer terms than were fitted (--max-error): the file keeps only as many
    // basis functions as some record uses.
    let used = records.iter().map(|r| r.terms).max().unwrap_or(1);
    if used < spectral.terms {
        spectral.terms = used;
        if let Some(t) = &mut spectral.table {
            t.values.truncate(used * t.nodes.len());
        }
    }
    let metadata = match opts.meta {
        MetaLevel::None => None,
        level => Some(metadata_json(opts, rel_error, level == MetaLevel::Short)),
    };
    let mut material = Material {
        version_minor: opts.format_minor.min(crate::format::VERSION_MINOR),
        spectral,
        sh_level: opts.effective_sh_level(),
        isotropic: set.is_isotropic(),
        wavelengths: set.wavelengths.iter().map(|&w| w as f32).collect(),
        records,
        metadata,
        // Positions beyond the format's per-set limit are not stored (decode then needs --like).
        sample_positions: (opts.sample_positions
            && set
                .incidences
                .iter()
                .all(|s| s.directions.len() as u64 <= crate::model::material::MAX_SET_DIRECTIONS))
        .then(|| sample_positions(&set.incidences)),
        factor: None,
        held_out,
        warped: None,
    };
    // The version the file will declare (the lowest whose features it uses), so that the
    // material read back from it is this one.
    material.version_minor = crate::format::written_version(&material).0;
    material
        .validate()
        .map_err(|e| Error::Parameter(format!("encoder produced an invalid material: {e}")))?;
    Ok(Encoded {
        material,
        rel_error,
        raw_bytes: set.raw_f32_bytes(),
        unmet,
        notes,
        held_out: pooled,
        below_floor: floor.len(),
    })
}

/// The options that shaped a file, as `meta` records them.
fn metadata_options(opts: &EncodeOptions) -> serde_json::Map<String, serde_json::Value> {
    use serde_json::{json, Map};
    // Only the options that shaped this file, so the metadata stays small next to the model.
    let mut options = Map::new();
    options.insert("basis".into(), json!(opts.basis.name()));
    if let Some(t) = opts.terms {
        options.insert("terms".into(), json!(t));
    }
    options.insert("sh_level".into(), json!(opts.effective_sh_level()));
    let peak = match opts.peak {
        PeakMode::Paper => "paper",
        PeakMode::None => "none",
        PeakMode::Joint => "joint",
    };
    options.insert("peak".into(), json!(peak));
    match (opts.peak, opts.critical_angle) {
        (PeakMode::Paper, CriticalAngle::Auto) => {
            options.insert("critical_angle".into(), json!("auto"));
        }
        (PeakMode::Paper, CriticalAngle::Fixed(g)) => {
            options.insert("critical_angle".into(), json!(g));
        }
        (PeakMode::Joint, _) => {
            let lobes: Vec<&str> = opts.lobes.iter().map(|l| l.name()).collect();
            options.insert("lobes".into(), json!(lobes));
            if let Some(e) = opts.max_error {
                options.insert("max_error".into(), json!(e));
            }
        }
        _ => {}
    }
    options.insert("precision".into(), json!(opts.precision.name()));
    options
}

/// The `meta` text: compact JSON. `short` keeps only the options that differ from the
/// encoder's defaults (and no input names).
pub(crate) fn metadata_json(opts: &EncodeOptions, rel_error: f64, short: bool) -> String {
    let mut options = metadata_options(opts);
    if short {
        // What the defaults of this encoder would write: dropped (the encoder and its version
        // are kept, and spec/FORMAT.md §3.4 lists its defaults).
        let defaults = metadata_options(&EncodeOptions {
            max_error: Some(DEFAULT_MAX_ERROR),
            ..EncodeOptions::default()
        });
        options.retain(|k, v| defaults.get(k) != Some(v));
    }
    metadata_envelope(options, opts, rel_error, short)
}

/// The metadata around a model's own `options`: encoder, inputs (not when `short`),
/// provenance, pooled error.
pub(crate) fn metadata_envelope(
    options: serde_json::Map<String, serde_json::Value>,
    opts: &EncodeOptions,
    rel_error: f64,
    short: bool,
) -> String {
    use serde_json::{json, Map, Value};
    let mut v = Map::new();
    v.insert(
        "encoder".into(),
        json!(format!("sbrdf {}", env!("CARGO_PKG_VERSION"))),
    );
    v.insert("options".into(), Value::Object(options));
    if !opts.inputs.is_empty() && !short {
        v.insert("inputs".into(), json!(opts.inputs));
    }
    if !opts.provenance.is_empty() {
        let p: Map<String, Value> = opts
            .provenance
            .iter()
            .map(|(k, val)| (k.clone(), json!(val)))
            .collect();
        v.insert("provenance".into(), Value::Object(p));
    }
    // Four significant digits are all an error figure needs.
    let rounded: f64 = format!("{rel_error:.3e}").parse().unwrap_or(rel_error);
    v.insert(
        "rel_error".into(),
        if rounded.is_finite() {
            json!(rounded)
        } else {
            Value::Null
        },
    );
    Value::Object(v).to_string()
}

/// Describes each incidence's outgoing directions, as a grid where they form one exactly
/// (to 1e-5°), sharing identical sets between incidences.
pub(crate) fn sample_positions(incidences: &[IncidentSamples]) -> SamplePositions {
    let mut sets: Vec<DirectionSet> = Vec::new();
    let mut set_of_incidence = Vec::with_capacity(incidences.len());
    for s in incidences {
        let set = as_grid(&s.directions).unwrap_or_else(|| {
            DirectionSet::List(
                s.directions
                    .iter()
                    .map(|d| [d[0] as f32, d[1] as f32])
                    .collect(),
            )
        });
        let index = match sets.iter().position(|x| *x == set) {
            Some(i) => i,
            None => {
                sets.push(set);
                sets.len() - 1
            }
        };
        set_of_incidence.push(index as u32);
    }
    SamplePositions {
        sets,
        set_of_incidence,
    }
}

fn as_grid(dirs: &[[f64; 2]]) -> Option<DirectionSet> {
    let mut thetas: Vec<f64> = dirs.iter().map(|d| d[0]).collect();
    thetas.dedup();
    let nphi = dirs.len() / thetas.len();
    if nphi * thetas.len() != dirs.len() {
        return None;
    }
    let phis: Vec<f64> = dirs[..nphi].iter().map(|d| d[1]).collect();
    let step = |v: &[f64]| if v.len() > 1 { v[1] - v[0] } else { 0.0 };
    let grid = DirectionSet::Grid {
        theta0: thetas[0] as f32,
        dtheta: step(&thetas) as f32,
        ntheta: thetas.len() as u32,
        phi0: phis[0] as f32,
        dphi: step(&phis) as f32,
        nphi: nphi as u32,
    };
    let ok = grid
        .directions()
        .iter()
        .zip(dirs)
        .all(|(g, d)| (g[0] - d[0]).abs() <= 1e-5 && (g[1] - d[1]).abs() <= 1e-5);
    ok.then_some(grid)
}
