//! What a fit is asked to do: the peak mode, the critical angle of the paper's split, the lobe
//! families and the budget of the joint fit.

use crate::model::material::LobeKind;
use crate::model::Precision;

/// How the specular peak is represented.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeakMode {
    /// SH only, no peak: the paper's baseline (its Fig. 4).
    None,
    /// The paper's hybrid: SH background fitted outside a critical angle, then a Gaussian.
    Paper,
    /// Background and lobe amplitudes solved together, the lobe width searched on top
    /// (see [`super::joint`]).
    Joint,
}

/// The angle (degrees) around the peak direction inside which samples are left to the peak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CriticalAngle {
    /// Chosen per incident direction by minimising the relative error (the paper's Fig. 6).
    Auto,
    /// This angle (degrees) for every incident direction.
    Fixed(f64),
}

/// Which lobe shapes the encoder may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LobeFamily {
    /// One Gaussian in the angle from the peak direction, one width for all terms (kind 1).
    Gaussian,
    /// The half-vector microfacet lobe in 1 − cos θh (kind 2; holds ABC-model lobes exactly).
    Microfacet,
    /// The half-vector microfacet lobe in sin²θh (kind 3; holds GGX exactly).
    MicrofacetSin2,
    /// Phong's cosine-power lobe about the peak direction (kind 4).
    CosinePower,
    /// The anisotropic microfacet lobe (kind 5; holds anisotropic GGX exactly): tried only on
    /// inputs with several incident azimuths, where a material's surface axes mean something.
    MicrofacetAniso,
}

impl LobeFamily {
    /// The lobe kind a record stores for this family.
    pub fn kind(self) -> LobeKind {
        match self {
            LobeFamily::Gaussian => LobeKind::AngleGaussian,
            LobeFamily::Microfacet => LobeKind::Microfacet,
            LobeFamily::MicrofacetSin2 => LobeKind::MicrofacetSin2,
            LobeFamily::CosinePower => LobeKind::CosinePower,
            LobeFamily::MicrofacetAniso => LobeKind::MicrofacetAniso,
        }
    }

    /// The family's name as the command line spells it (`"gaussian"`, `"microfacet"`, …).
    pub fn name(self) -> &'static str {
        match self {
            LobeFamily::Gaussian => "gaussian",
            LobeFamily::Microfacet => "microfacet",
            LobeFamily::MicrofacetSin2 => "microfacet-sin2",
            LobeFamily::CosinePower => "cosine-power",
            LobeFamily::MicrofacetAniso => "microfacet-aniso",
        }
    }
}

/// What to fit: the largest model, and optionally an error budget to spend as little as possible
/// on.
#[derive(Debug, Clone)]
pub struct JointOptions {
    /// Largest SH level tried.
    pub max_sh_level: usize,
    /// Lobe families tried; the encoder keeps the one with the smaller error.
    pub families: Vec<LobeFamily>,
    /// Storage precision; with a budget, f16 is tried first and f32 only if f16 misses it.
    pub precision: Precision,
    /// Relative error budget per incidence, if any.
    pub max_error: Option<f64>,
    /// With a budget, also hold each candidate to it at samples the fit did not see: a model is
    /// taken only when its leave-one-out error is within `HELD_OUT_SLACK` (1.5) times the budget;
    /// when none is, the model with the lowest leave-one-out error (never bytes spent fitting
    /// noise). Without it, the budget is met at the samples alone.
    pub held_out: bool,
    /// ε of the log error (`EVALUATION.md`, "Held-out error"), for the held-out figures.
    pub log_epsilon: f64,
}

/// How far above the budget a model's leave-one-out error may be for the model to be taken.
pub const HELD_OUT_SLACK: f64 = 1.5;

/// Where no model meets the budget between the samples, models whose held-out score (log² +
/// rel²) is within this factor of the best count as equally good, and the smallest is kept.
pub const HELD_OUT_PLATEAU: f64 = 1.10;

/// Where no model meets the budget even at the samples, the most accurate one is kept (its
/// family cannot do better) unless its held-out score exceeds the best by this factor: then it
/// fits the samples' scatter, and the held-out choice above applies.
pub const HELD_OUT_OVERFIT: f64 = 1.03;
