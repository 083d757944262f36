//! The in-memory form of an `.sbrdf` file: what the format stores, with its invariants.
//!
//! Values held here are exactly the values the file represents (f16 values already multiplied by
//! their record's scale), so writing and reading back is lossless.

use crate::model::factor::FactorModel;
use crate::model::precision::Precision;
use crate::model::sh::{sh_count, MAX_SH_LEVEL};
use crate::model::spectral::SpectralSpace;
use crate::model::warped::WarpedModel;

/// Most spectral terms a file may use (bounds the decoder's stack buffers).
pub const MAX_TERMS: usize = 256;
/// Most lobes one incident record may carry.
pub const MAX_LOBES: usize = 8;
/// Most wavelength samples a file may list.
pub const MAX_WAVELENGTHS: usize = 65_536;
/// Most incident directions a file may hold.
pub const MAX_INCIDENCES: usize = 1 << 20;
/// Most outgoing directions one `samp` direction set may describe (a grid is 25 bytes whatever
/// its size, so its expansion is bounded here rather than by the bytes present).
pub const MAX_SET_DIRECTIONS: u64 = 1 << 22;

/// The shape of a specular lobe. New shapes are new codes; old files keep their meaning.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LobeKind {
    /// The paper's Gaussian in the angle α (radians) between the outgoing direction and the
    /// record's peak direction: term k adds p_k·exp(−α²/b_k). Amplitudes: p_k (one per term);
    /// parameters: b_k in rad² (one per term).
    AngleGaussian,
    /// A microfacet-shaped lobe in the half vector h = normalize(ωi + ωo):
    /// D = (1 + b·(1 − cos θh))^(−c) times four shadowing/Fresnel variants, each with its own
    /// amplitude per term: D·Vs, D·Vs·F, D·Vc, D·Vc·F, where Vs is a Smith-like grazing factor
    /// with parameter a, Vc the V-cavity factor and F = (1 − ωi·h)⁵ (Schlick's). Amplitudes:
    /// 4 × terms (variant-major); parameters: b, c, a. Exact formulas: `spec/EVALUATION.md`.
    Microfacet,
    /// As [`LobeKind::Microfacet`] with D = (1 + b·sin²θh)^(−c), which holds GGX exactly
    /// (b = (1 − α²)/α², c = 2).
    MicrofacetSin2,
    /// Phong's lobe about the record's peak direction: term k adds p_k·max(0, cos α)ⁿ, one
    /// exponent n > 0 for all terms. Amplitudes: p_k (one per term); parameters: n.
    CosinePower,
    /// The anisotropic counterpart of [`LobeKind::MicrofacetSin2`] (brushed metals, satin):
    /// D = (1 + bx·hu² + by·hv²)^(−c) with hu, hv the half vector's components along the surface
    /// axes u = (cos ψ, sin ψ, 0) and v = (−sin ψ, cos ψ, 0), which holds anisotropic GGX
    /// exactly (bx = 1/αx² − 1, by = 1/αy² − 1, c = 2); the Smith-like factor takes the
    /// projected roughness √(ax²·ωu² + ay²·ωv²) of each direction. Amplitudes: 4 × terms, as
    /// kind 3; parameters: bx, by, c, ax, ay, ψ (degrees, [0, 180)).
    MicrofacetAniso,
}

impl LobeKind {
    /// The kind's code in the file (`RECD` lobe kind, `spec/FORMAT.md`): 1 to 5.
    pub fn code(self) -> u8 {
        match self {
            LobeKind::AngleGaussian => 1,
            LobeKind::Microfacet => 2,
            LobeKind::MicrofacetSin2 => 3,
            LobeKind::CosinePower => 4,
            LobeKind::MicrofacetAniso => 5,
        }
    }
    /// The kind with this file code; None for a code this version does not know.
    pub fn from_code(c: u8) -> Option<Self> {
        match c {
            1 => Some(LobeKind::AngleGaussian),
            2 => Some(LobeKind::Microfacet),
            3 => Some(LobeKind::MicrofacetSin2),
            4 => Some(LobeKind::CosinePower),
            5 => Some(LobeKind::MicrofacetAniso),
            _ => None,
        }
    }
    /// The kind's name as the command line and reports spell it (`"angle-gaussian"`, …).
    pub fn name(self) -> &'static str {
        match self {
            LobeKind::AngleGaussian => "angle-gaussian",
            LobeKind::Microfacet => "microfacet",
            LobeKind::MicrofacetSin2 => "microfacet-sin2",
            LobeKind::CosinePower => "cosine-power",
            LobeKind::MicrofacetAniso => "microfacet-aniso",
        }
    }
    /// Number of stored amplitudes for a record of `terms` spectral terms.
    pub fn amplitude_count(self, terms: usize) -> usize {
        match self {
            LobeKind::AngleGaussian | LobeKind::CosinePower => terms,
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 | LobeKind::MicrofacetAniso => {
                4 * terms
            }
        }
    }
    /// Number of f32 shape parameters.
    pub fn param_count(self, terms: usize) -> usize {
        match self {
            LobeKind::AngleGaussian => terms,
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => 3,
            LobeKind::CosinePower => 1,
            LobeKind::MicrofacetAniso => 6,
        }
    }

    /// True for the kinds evaluated in the half vector with four shadowing/Fresnel variants.
    pub fn is_microfacet(self) -> bool {
        matches!(
            self,
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 | LobeKind::MicrofacetAniso
        )
    }
    /// Checks the shape parameters; the message says which is wrong.
    pub fn check_params(self, params: &[f32]) -> Result<(), String> {
        match self {
            LobeKind::CosinePower => {
                if !(params[0].is_finite() && params[0] > 0.0) {
                    return Err(format!("cosine-power exponent {} is not > 0", params[0]));
                }
            }
            LobeKind::AngleGaussian => {
                if let Some(v) = params.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                    return Err(format!("lobe width {v} is not a positive number"));
                }
            }
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                let (b, c, a) = (params[0], params[1], params[2]);
                if !(b.is_finite() && b > 0.0 && c.is_finite() && c > 0.0) {
                    return Err(format!(
                        "microfacet lobe b = {b}, c = {c}: both must be > 0"
                    ));
                }
                if !(a.is_finite() && (0.0..=1.0).contains(&a)) {
                    return Err(format!("microfacet lobe a = {a} is outside [0, 1]"));
                }
            }
            LobeKind::MicrofacetAniso => {
                let [bx, by, c, ax, ay, psi] = [0, 1, 2, 3, 4, 5].map(|i| params[i]);
                if ![bx, by, c].iter().all(|v| v.is_finite() && *v > 0.0) {
                    return Err(format!(
                        "anisotropic microfacet lobe bx = {bx}, by = {by}, c = {c}: all must be > 0"
                    ));
                }
                if ![ax, ay]
                    .iter()
                    .all(|v| v.is_finite() && (0.0..=1.0).contains(v))
                {
                    return Err(format!(
                        "anisotropic microfacet lobe ax = {ax}, ay = {ay}: both must be in [0, 1]"
                    ));
                }
                if !(psi.is_finite() && (0.0..180.0).contains(&psi)) || psi.is_sign_negative() {
                    return Err(format!(
                        "anisotropic microfacet lobe axis angle ψ = {psi} is outside [0, 180)"
                    ));
                }
            }
        }
        Ok(())
    }
}

/// One lobe: amplitudes (1/sr, same units as the coefficients) and shape parameters, laid out
/// as its kind defines ([`LobeKind::amplitude_count`], [`LobeKind::param_count`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Lobe {
    /// The lobe's shape.
    pub kind: LobeKind,
    /// Amplitudes (1/sr), [`LobeKind::amplitude_count`] of them for the record's terms.
    pub amplitude: Vec<f32>,
    /// Shape parameters, [`LobeKind::param_count`] of them, as [`LobeKind`] describes.
    pub params: Vec<f32>,
}

/// Everything stored for one incident direction. Each record carries its own model size (terms,
/// SH level, precision) within the file's maxima, so an encoder can spend fewer bytes where an
/// incidence needs less.
#[derive(Debug, Clone, PartialEq)]
pub struct IncidentRecord {
    /// Spectral terms used by this record, 1..=the file's `terms`: the first `terms` basis
    /// functions (missing higher terms are zero).
    pub terms: usize,
    /// SH level of this record, 0..=the file's `sh_level`.
    pub sh_level: usize,
    /// Storage precision of this record's SH coefficients and lobe amplitudes.
    pub precision: Precision,
    /// Incident polar angle θi from the normal, degrees.
    pub theta_i: f32,
    /// Incident azimuth φi, degrees.
    pub phi_i: f32,
    /// Peak (mirror-reflection) direction found by the encoder: polar angle θp, degrees.
    pub theta_p: f32,
    /// Azimuth φp of the peak direction, degrees.
    pub phi_p: f32,
    /// Relative L2 error the encoder measured against its input samples at this incidence.
    pub rel_error: f32,
    /// The critical angle used to separate background and peak, degrees; 0 when none was used.
    pub critical_angle: f32,
    /// SH coefficients A_{k,j}: `terms` rows of (sh_level+1)² values, row k for spectral term k.
    pub sh: Vec<f32>,
    /// Specular lobes, at most [`MAX_LOBES`].
    pub lobes: Vec<Lobe>,
}

impl IncidentRecord {
    /// The empty record of a file with warped tables (`FORMAT.md` §3.10) at incidence (θi, φi):
    /// one term, SH level 0, a +0 coefficient, no lobes, `f32`.
    pub fn empty(theta_i: f32, phi_i: f32) -> Self {
        IncidentRecord {
            terms: 1,
            sh_level: 0,
            precision: Precision::F32,
            theta_i,
            phi_i,
            theta_p: 0.0,
            phi_p: 0.0,
            rel_error: 0.0,
            critical_angle: 0.0,
            sh: vec![0.0],
            lobes: Vec::new(),
        }
    }

    /// Whether this is an empty record in the sense of [`IncidentRecord::empty`] (any incidence,
    /// peak and error fields).
    pub fn is_empty(&self) -> bool {
        self.terms == 1
            && self.sh_level == 0
            && self.sh.len() == 1
            && self.sh[0].to_bits() == 0
            && self.lobes.is_empty()
    }
}

/// Outgoing directions the encoder saw, so `decode` can write the reconstruction there.
#[derive(Debug, Clone, PartialEq)]
pub enum DirectionSet {
    /// θ = θ0 + i·Δθ (i < nθ), φ = φ0 + j·Δφ (j < nφ), in θ-major order; degrees.
    Grid {
        /// First θ, degrees.
        theta0: f32,
        /// θ step, degrees.
        dtheta: f32,
        /// Number of θ values.
        ntheta: u32,
        /// First φ, degrees.
        phi0: f32,
        /// φ step, degrees.
        dphi: f32,
        /// Number of φ values.
        nphi: u32,
    },
    /// Explicit (θ, φ) pairs, degrees.
    List(Vec<[f32; 2]>),
}

impl DirectionSet {
    /// The number of directions in the set.
    pub fn len(&self) -> usize {
        match self {
            DirectionSet::Grid { ntheta, nphi, .. } => *ntheta as usize * *nphi as usize,
            DirectionSet::List(v) => v.len(),
        }
    }
    /// Whether the set holds no direction.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The directions in order, degrees, computed in f64 from the stored f32 parameters.
    pub fn directions(&self) -> Vec<[f64; 2]> {
        match self {
            DirectionSet::Grid {
                theta0,
                dtheta,
                ntheta,
                phi0,
                dphi,
                nphi,
            } => {
                let mut v = Vec::with_capacity(self.len());
                for i in 0..*ntheta {
                    for j in 0..*nphi {
                        v.push([
                            *theta0 as f64 + i as f64 * *dtheta as f64,
                            *phi0 as f64 + j as f64 * *dphi as f64,
                        ]);
                    }
                }
                v
            }
            DirectionSet::List(v) => v.iter().map(|d| [d[0] as f64, d[1] as f64]).collect(),
        }
    }
}

/// The outgoing directions at which the encoder had samples (`samp`, `spec/FORMAT.md` §3.5):
/// distinct direction sets, and which one each incident record used.
#[derive(Debug, Clone, PartialEq)]
pub struct SamplePositions {
    /// The distinct direction sets.
    pub sets: Vec<DirectionSet>,
    /// For each incident record, the index of its set.
    pub set_of_incidence: Vec<u32>,
}

/// A whole `.sbrdf` file.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// The format's minor version (major is 1) as read from a file. For writing, the newest
    /// minor version the file may use: the writer derives the version it writes from this and
    /// the features used ([`crate::format::written_version`]).
    pub version_minor: u16,
    /// The spectral basis, its number of terms and interval.
    pub spectral: SpectralSpace,
    /// The highest SH level any record may use.
    pub sh_level: usize,
    /// True when only φi = 0 was given: other azimuths are answered by rotation.
    pub isotropic: bool,
    /// Wavelength samples of the input, nm, strictly increasing.
    pub wavelengths: Vec<f32>,
    /// One record per stored incident direction, in file order.
    pub records: Vec<IncidentRecord>,
    /// JSON text of the `meta` chunk, if any.
    pub metadata: Option<String>,
    /// The outgoing directions the encoder saw (`samp`), if stored.
    pub sample_positions: Option<SamplePositions>,
    /// The model shared by every incidence (`FACT`), added to the records' values.
    pub factor: Option<FactorModel>,
    /// The encoder's held-out error per record (`xval`), beside each record's fit error.
    pub held_out: Option<HeldOutErrors>,
    /// Warped tables (`WARP`, format 1.4): the measurement on its own parameterisation; the
    /// records of such a file are empty.
    pub warped: Option<Box<WarpedModel>>,
}

/// How a record's held-out error was measured (`FORMAT.md`, `xval`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeldOutProtocol {
    /// k-fold over each incidence's outgoing samples (`EVALUATION.md`, "Held-out error").
    Folds(u8),
    /// Leave one outgoing sample out, predicted from the least-squares hat matrix (PRESS).
    LeaveOneOut,
}

/// Per record, the relative L2 and log errors at samples the encoder did not see.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOutErrors {
    /// How the errors were measured.
    pub protocol: HeldOutProtocol,
    /// Per record, the held-out relative L2 error (`spec/EVALUATION.md`, "Held-out error").
    pub rel: Vec<f32>,
    /// Per record, the held-out log error (`spec/EVALUATION.md`, "Held-out error").
    pub log: Vec<f32>,
}

impl Material {
    /// The rules of `FORMAT.md` §3.10 a file with warped tables keeps beside the chunk's own.
    fn validate_warped(&self, w: &WarpedModel) -> Result<(), String> {
        if !self.isotropic {
            return Err("warped tables need an isotropic file".into());
        }
        if self.factor.is_some() {
            return Err("a file with warped tables cannot also hold a factor model".into());
        }
        if let Some((i, _)) = self.records.iter().enumerate().find(|(_, r)| !r.is_empty()) {
            return Err(format!(
                "record {i} of a file with warped tables is not empty (one term, SH level 0, \
                 a zero coefficient, no lobes)"
            ));
        }
        w.validate(self.records.len(), self.spectral.terms)
    }

    /// The number of SH functions at the file's highest level, (sh_level + 1)².
    pub fn sh_count(&self) -> usize {
        sh_count(self.sh_level)
    }

    /// "f32", "f16", or "mixed" when records differ.
    pub fn precision_name(&self) -> &'static str {
        let first = self.records.first().map(|r| r.precision);
        if self.records.iter().all(|r| Some(r.precision) == first) {
            first.map(|p| p.name()).unwrap_or("none")
        } else {
            "mixed"
        }
    }

    /// Checks every invariant of the format that does not depend on byte layout. Both the writer
    /// and the reader call it, so a `Material` that passed it can be written and evaluated.
    pub fn validate(&self) -> Result<(), String> {
        self.spectral.validate()?;
        let k = self.spectral.terms;
        if k > MAX_TERMS {
            return Err(format!(
                "{k} spectral terms exceed the limit of {MAX_TERMS}"
            ));
        }
        if self.sh_level > MAX_SH_LEVEL {
            return Err(format!(
                "SH level {} exceeds the limit of {MAX_SH_LEVEL}",
                self.sh_level
            ));
        }
        if self.wavelengths.is_empty() || self.wavelengths.len() > MAX_WAVELENGTHS {
            return Err(format!(
                "{} wavelength samples (1 to {MAX_WAVELENGTHS} allowed)",
                self.wavelengths.len()
            ));
        }
        for (i, w) in self.wavelengths.iter().enumerate() {
            if !(w.is_finite() && *w > 0.0) {
                return Err(format!("wavelength #{i} is {w}, not a positive number"));
            }
            if i > 0 && *w <= self.wavelengths[i - 1] {
                return Err(format!("wavelengths are not strictly increasing at #{i}"));
            }
        }
        if let Some(t) = &self.spectral.table {
            if t.nodes.len() != self.wavelengths.len()
                || t.nodes
                    .iter()
                    .zip(&self.wavelengths)
                    .any(|(n, w)| *n != *w as f64)
            {
                return Err("the basis table's nodes are not the file's wavelengths".into());
            }
            let w = t.nodes.len().max(1);
            if let crate::model::basis_storage::BasisStorage::Quantised { exponents } = &t.storage {
                if exponents.len() != self.spectral.terms {
                    return Err(format!(
                        "{} exponents for a quantised basis of {} terms",
                        exponents.len(),
                        self.spectral.terms
                    ));
                }
                if let Some(e) = exponents.iter().find(|&&e| {
                    !crate::model::basis_storage::QUANTISED_EXPONENTS.contains(&(e as i32))
                }) {
                    return Err(format!(
                        "a quantised basis exponent {e} outside [−128, 103]"
                    ));
                }
            }
            if let Some((i, v)) = t
                .values
                .iter()
                .enumerate()
                .find(|(i, v)| !t.storage.holds(i / w, **v))
            {
                return Err(format!(
                    "basis table value {v} (function {}) is not exactly a {} value",
                    i / w,
                    t.storage.name()
                ));
            }
        }
        if self.records.is_empty() || self.records.len() > MAX_INCIDENCES {
            return Err(format!(
                "{} incident directions (1 to {MAX_INCIDENCES} allowed)",
                self.records.len()
            ));
        }
        for (i, r) in self.records.iter().enumerate() {
            let at = |m: String| format!("incident record #{i}: {m}");
            if r.terms == 0 || r.terms > k {
                return Err(at(format!("{} terms, the file allows 1 to {k}", r.terms)));
            }
            if r.sh_level > self.sh_level {
                return Err(at(format!(
                    "SH level {} above the file's {}",
                    r.sh_level, self.sh_level
                )));
            }
            let angles = [r.theta_i, r.phi_i, r.theta_p, r.phi_p, r.critical_angle];
            if angles.iter().any(|a| *a == 0.0 && a.is_sign_negative()) {
                return Err(at("an angle is −0 (write +0)".into()));
            }
            let (k, p) = (r.terms, sh_count(r.sh_level));
            if !(0.0..=90.0).contains(&r.theta_i) || !(0.0..360.0).contains(&r.phi_i) {
                return Err(at(format!(
                    "incident direction ({}, {}) outside θ ∈ [0, 90], φ ∈ [0, 360)",
                    r.theta_i, r.phi_i
                )));
            }
            if self.isotropic && r.phi_i != 0.0 {
                return Err(at("isotropic file with φi ≠ 0".into()));
            }
            if i > 0 {
                let q = &self.records[i - 1];
                if (q.theta_i, q.phi_i) >= (r.theta_i, r.phi_i) {
                    return Err(at(
                        "incident directions not in increasing (θ, φ) order".into()
                    ));
                }
            }
            if !(0.0..=180.0).contains(&r.theta_p) || !(0.0..360.0).contains(&r.phi_p) {
                return Err(at(format!(
                    "peak direction ({}, {}) outside θ ∈ [0, 180], φ ∈ [0, 360)",
                    r.theta_p, r.phi_p
                )));
            }
            if !(r.rel_error.is_finite() && r.rel_error >= 0.0) {
                return Err(at(format!("error figure {} is not ≥ 0", r.rel_error)));
            }
            if !(0.0..=180.0).contains(&r.critical_angle) {
                return Err(at(format!(
                    "critical angle {} outside [0, 180]",
                    r.critical_angle
                )));
            }
            if r.sh.len() != k * p {
                return Err(at(format!("{} SH values, expected {}", r.sh.len(), k * p)));
            }
            if let Some(v) = r.sh.iter().find(|v| !v.is_finite()) {
                return Err(at(format!("SH coefficient {v} is not finite")));
            }
            if r.lobes.len() > MAX_LOBES {
                return Err(at(format!("{} lobes exceed {MAX_LOBES}", r.lobes.len())));
            }
            for lobe in &r.lobes {
                if lobe.amplitude.len() != lobe.kind.amplitude_count(k)
                    || lobe.params.len() != lobe.kind.param_count(k)
                {
                    return Err(at(format!(
                        "a {} lobe needs {} amplitudes and {} parameters for {k} terms",
                        lobe.kind.name(),
                        lobe.kind.amplitude_count(k),
                        lobe.kind.param_count(k)
                    )));
                }
                if let Some(v) = lobe.amplitude.iter().find(|v| !v.is_finite()) {
                    return Err(at(format!("lobe amplitude {v} is not finite")));
                }
                lobe.kind.check_params(&lobe.params).map_err(at)?;
            }
        }
        if let Some(f) = &self.factor {
            if !self.isotropic {
                return Err("a factor model needs an isotropic file".into());
            }
            f.validate(self.wavelengths.len())?;
        }
        if let Some(w) = &self.warped {
            self.validate_warped(w)?;
        }
        if let Some(h) = &self.held_out {
            if h.rel.len() != self.records.len() || h.log.len() != self.records.len() {
                return Err("held-out errors name a different number of incidences".into());
            }
            if let Some(v) = h
                .rel
                .iter()
                .chain(&h.log)
                .find(|v| !(v.is_finite() && **v >= 0.0))
            {
                return Err(format!("held-out error {v} is not ≥ 0"));
            }
            if h.protocol == HeldOutProtocol::Folds(0) || h.protocol == HeldOutProtocol::Folds(1) {
                return Err("held-out errors from fewer than 2 folds".into());
            }
        }
        if let Some(sp) = &self.sample_positions {
            if sp.set_of_incidence.len() != self.records.len() {
                return Err("sample positions name a different number of incidences".into());
            }
            if sp.sets.is_empty() {
                return Err("sample positions hold no direction set".into());
            }
            if let Some(i) = sp
                .set_of_incidence
                .iter()
                .find(|&&i| i as usize >= sp.sets.len())
            {
                return Err(format!("sample positions refer to missing set #{i}"));
            }
            for s in &sp.sets {
                if s.len() as u64 > MAX_SET_DIRECTIONS {
                    return Err(format!(
                        "a direction set of {} directions exceeds {MAX_SET_DIRECTIONS}",
                        s.len()
                    ));
                }
                let ok = match s {
                    DirectionSet::Grid {
                        theta0,
                        dtheta,
                        phi0,
                        dphi,
                        ..
                    } => [theta0, dtheta, phi0, dphi].iter().all(|v| v.is_finite()),
                    DirectionSet::List(v) => v.iter().flatten().all(|x| x.is_finite()),
                };
                if !ok {
                    return Err("a sample position is not finite".into());
                }
            }
        }
        Ok(())
    }
}
