//! What an encode is asked ([`EncodeOptions`], [`ModelChoice`], [`MetaLevel`]) and gives back
//! ([`Encoded`]), and what every model's encoder writes beside its model: the sample positions
//! and the `meta` text. Shared by the records' encoder ([`super::encoder`]) and the factor
//! model's ([`super::factor_model`]), which the records' encoder also calls.

use crate::encode::fit::{CriticalAngle, LobeFamily, PeakMode};
use crate::encode::metrics::ErrorSums;
use crate::encode::samples::IncidentSamples;
use crate::model::material::{DirectionSet, Material, SamplePositions};
use crate::model::spectral::SpectralBasis;
use crate::model::Precision;

/// Encoder settings; the CLI's flags map one to one onto these fields.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeOptions {
    /// The spectral basis (`--basis`); the default is the data-derived one.
    pub basis: SpectralBasis,
    /// Number of spectral terms K (the paper: 13 = a0, a1..a6, b1..b6). `None`: 13 for the
    /// analytic bases; for the data-derived basis the smallest rank whose out-of-basis error is
    /// at most half the error budget (0.5% without one) at every incidence, at most 8.
    pub terms: Option<usize>,
    /// SH level L (with an error budget, the largest level tried); `None` picks the paper's
    /// choice for its modes (1 with a peak, its Fig. 6; 4 without, its Fig. 4) and 6 for the
    /// joint fit.
    pub sh_level: Option<usize>,
    /// How the specular peak is represented (`--peak`); the default is the joint fit.
    pub peak: PeakMode,
    /// The critical angle of the paper's split (used with [`PeakMode::Paper`]).
    pub critical_angle: CriticalAngle,
    /// Storage precision of coefficients and amplitudes (`--precision`); with a budget, the
    /// joint fit falls back to f32 where f16 misses it.
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
    /// The choice's name as `--model` spells it: `"auto"`, `"records"` or `"shared"`.
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
    /// The level's name as `--meta` spells it: `"full"`, `"short"` or `"none"`.
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

    /// The SH level to fit, resolving `None`: 1 for the paper's split, 4 without a peak, 6 for
    /// the joint fit.
    pub fn effective_sh_level(&self) -> usize {
        self.sh_level.unwrap_or(match self.peak {
            PeakMode::Paper => 1,
            PeakMode::None => 4,
            PeakMode::Joint => 6,
        })
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

/// The result of an encode: the material and the figures an encoder reports.
#[derive(Debug, Clone)]
pub struct Encoded {
    /// The encoded material, ready for [`crate::write_material`].
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
pub(crate) fn metadata_json(
    opts: &EncodeOptions,
    rel_error: f64,
    short: bool,
    nearest: Option<NearestFigure>,
) -> String {
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
    metadata_envelope(options, opts, rel_error, short, nearest)
}

/// The nearest sample's pooled held-out error on `--model auto`'s inner folds, the floor its
/// candidates were held to: `meta` records it beside the kept model (`info` shows it by the
/// model's own held-out figures).
#[derive(Debug, Clone, Copy)]
pub(crate) struct NearestFigure {
    /// The folds (k of k-fold).
    pub folds: usize,
    pub rel: f64,
    pub log: f64,
}

/// The metadata around a model's own `options`: encoder, inputs (not when `short`),
/// provenance, pooled error, and the nearest sample's figure when `--model auto` measured one.
pub(crate) fn metadata_envelope(
    options: serde_json::Map<String, serde_json::Value>,
    opts: &EncodeOptions,
    rel_error: f64,
    short: bool,
    nearest: Option<NearestFigure>,
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
    // Three significant digits, as a figure for people.
    if let Some(n) = nearest {
        v.insert(
            format!("nearest_sample_{}fold", n.folds),
            json!([round3(n.rel), round3(n.log)]),
        );
    }
    Value::Object(v).to_string()
}

/// `v` to three significant digits (a figure for people; NaN and infinities as 0).
fn round3(v: f64) -> f64 {
    let r: f64 = format!("{v:.2e}").parse().unwrap_or(0.0);
    if r.is_finite() {
        r
    } else {
        0.0
    }
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
