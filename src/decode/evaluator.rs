//! Reconstruction (`spec/EVALUATION.md`, "Reconstruction"): the route a file's queries take,
//! chosen once when it is opened ([`Route`]) and once per [`crate::Decoder::at`] view
//! ([`AtRoute`]), and matched here alone, for every entry point (`eval`, one wavelength,
//! `eval_deg`, the batch).
//!
//! A query is split in two. Its incident side ([`Incident`]: the records to blend, their
//! weights, the evaluation incidence, and every shared lobe's blended shape) depends on ωi
//! alone; its outgoing side (the SH functions, the lobes' values, the spectrum) on ωo. The
//! batch ([`super::batch`]) computes the incident side once for a run of pairs that share ωi.

use super::batch;
use super::factor::{factor_terms, value_with_factor, FactorTerms, WavelengthNodes, NO_FACTOR};
use super::kernel::baked::{self as kernel_baked, BakedLobes};
use super::kernel::groups::{self, Collapsed, Kernel, Stored};
use super::kernel::lanes_batch::{self, Pairs};
use super::kernel::width::Width;
use super::records::blend::Incident;
use super::records::general::{self, SMALL_TERMS};
use super::records::incidence::{Incidences, Records};
use super::records::lattice::{unit_above, Lattice, QueryFrame};
use super::records::resident::Resident;
use super::warped::{Residency, WarpedEval};
use crate::model::angles::dir_from_deg;
use crate::model::material::Material;

/// How a file's queries are answered: chosen once, when it is opened ([`Route::of`]).
#[derive(Debug, Clone)]
pub(crate) enum Route {
    /// Records on a θ line that the one-wavelength kernel takes (`super::kernel`: isotropic, at
    /// most two lobes of kinds 2–4 per record, SH level ≤ 6, ≤ 16 terms): one wavelength
    /// through the kernel, several (and the pairs the kernel hands back) through the general
    /// path.
    Kernel(Kernel),
    /// Records through the general path (`super::records::general`).
    Records,
    /// Records plus the factor model shared by every incidence (`FACT`), with the file's
    /// wavelengths as its spectra's nodes: evaluated at the query's own directions and added
    /// before the clamp ("Reconstruction", step 5).
    Factor(WavelengthNodes),
    /// Warped tables (`WARP`): they answer every query (the records are empty). Boxed: a file
    /// without them pays one pointer.
    Warped(Box<WarpedEval>),
}

impl Route {
    /// The route of `material` (validated; `res` its resident form, `lattice` its incidences),
    /// its warped tables (if any) held as `residency` says. Fails, saying why, when its warped
    /// tables cannot be prepared (a stored incidence's VNDF or a σ node at zero, tables beyond
    /// f32).
    fn of(
        material: &Material,
        res: &Resident,
        lattice: &Lattice,
        residency: Residency,
    ) -> std::result::Result<Self, String> {
        if let Some(w) = &material.warped {
            let thetas: Vec<f32> = material.records.iter().map(|r| r.theta_i).collect();
            let means = res.basis_means();
            let w = WarpedEval::new(w, &thetas, material.spectral.terms, &means, residency)?;
            return Ok(Route::Warped(Box::new(w)));
        }
        if material.factor.is_some() {
            return Ok(Route::Factor(WavelengthNodes::new(&material.wavelengths)));
        }
        if matches!(lattice, Lattice::Theta(_)) && groups::takes(material) {
            return Ok(Route::Kernel(Kernel::new(res)));
        }
        Ok(Route::Records)
    }
}

/// How a [`crate::Decoder::at`] view answers: chosen once per wavelength
/// ([`Evaluator::at_route`]).
#[derive(Debug, Clone, Copy)]
// The collapsed records (8 KiB) live in the view, on its caller's stack, as before: boxing them
// would allocate, and `Decoder::at` never does.
#[allow(clippy::large_enum_variant)]
pub(crate) enum AtRoute {
    /// The kernel from every record collapsed at the wavelength (basis values B_0..B_{K−1}
    /// first), computed at about the cost of two queries per record (when the file's records
    /// fit: 17 at SH level 6, more at lower levels).
    Collapsed([f64; SMALL_TERMS], Collapsed),
    /// The wavelength's basis values computed once (NaN first when it is not finite).
    Basis([f64; SMALL_TERMS]),
    /// Each query through `eval` (a factor model, warped tables, more than 16 terms).
    Eval,
}

/// What a baked view keeps from the exact route at its wavelength
/// ([`Evaluator::baked_input`]).
#[derive(Debug, Clone)]
pub(crate) struct BakedInput {
    /// The wavelength's basis values.
    pub(crate) basis: [f64; SMALL_TERMS],
    /// Every record collapsed at them (its amplitudes; the SH coefficients grids are baked
    /// from).
    pub(crate) collapsed: Box<Collapsed>,
    /// Each record's SH function count.
    pub(crate) sh_counts: Vec<usize>,
    /// The groups' lobes resolved at the wavelength, their shapes blended ahead.
    pub(crate) lobes: BakedLobes,
}

/// A validated material in its resident form plus what makes evaluation cheap.
#[derive(Debug, Clone)]
pub(crate) struct Evaluator {
    pub(crate) res: Resident,
    pub(crate) places: Incidences,
    route: Route,
}

impl Evaluator {
    /// Prepares a material for evaluation, its warped tables (if any) held as `residency`
    /// says; the caller has validated it. Fails, saying why, when its warped tables cannot be
    /// prepared.
    pub(crate) fn new(
        material: &Material,
        residency: Residency,
    ) -> std::result::Result<Self, String> {
        let res = Resident::new(material);
        let places = Incidences::new(material, &res);
        let route = Route::of(material, &res, &places.lattice, residency)?;
        Ok(Evaluator { res, places, route })
    }

    /// The records with what places a query among them (what the sampler reads).
    pub(crate) fn records(&self) -> Records<'_> {
        Records {
            res: &self.res,
            places: &self.places,
        }
    }

    /// The warped tables, if the file has them.
    pub(crate) fn warped(&self) -> Option<&WarpedEval> {
        match &self.route {
            Route::Warped(w) => Some(w),
            _ => None,
        }
    }

    /// Heap bytes held by the evaluator.
    pub(crate) fn heap_bytes(&self) -> usize {
        let route = match &self.route {
            Route::Kernel(k) => k.heap_bytes(),
            Route::Records => 0,
            Route::Factor(nodes) => nodes.heap_bytes(),
            Route::Warped(w) => std::mem::size_of::<WarpedEval>() + w.heap_bytes(),
        };
        self.res.heap_bytes() + self.places.heap_bytes() + route
    }

    /// The kernel with what it reads, on the kernel's route.
    #[inline(always)]
    pub(crate) fn kernel_input(&self) -> Option<(&Kernel, Stored<'_>)> {
        match (&self.route, &self.places.lattice) {
            (Route::Kernel(k), Lattice::Theta(axis)) => Some((
                k,
                Stored {
                    res: &self.res,
                    axis,
                    ends: &self.places.theta_ends,
                },
            )),
            _ => None,
        }
    }

    /// The evaluator with its kernel's batch `lanes` wide (1, 4, 8); None when this CPU
    /// cannot or the file has no kernel.
    pub(crate) fn with_kernel_lanes(mut self, lanes: u32) -> Option<Self> {
        let width = match lanes {
            1 => Width::Base,
            4 => Width::Avx2,
            8 => Width::Avx512,
            _ => return None,
        };
        match self.route {
            Route::Kernel(k) => self.route = Route::Kernel(k.with_width(width)?),
            _ => return None,
        }
        Some(self)
    }

    /// The query's incident direction in the records' frame (`wi` a unit vector, z ≥ 0).
    #[inline(always)]
    pub(crate) fn query_frame(&self, wi: [f64; 3]) -> QueryFrame {
        self.places.query_frame(wi)
    }

    /// The incident side of a query at incidence (θ, φ) in degrees, in the records' frame (`wi`
    /// its unit vector when known).
    #[inline(always)]
    fn incident(&self, theta: f64, phi: f64, wi: Option<[f64; 3]>) -> Incident {
        self.places.incident(&self.res, theta, phi, wi)
    }

    /// Whether one-wavelength queries can be answered from that wavelength's basis values
    /// computed beforehand ([`Evaluator::eval_one`]): the records' routes (the pairs share an
    /// incident side) with at most [`SMALL_TERMS`] terms.
    #[inline(always)]
    fn hoists_basis(&self) -> bool {
        matches!(self.route, Route::Kernel(_) | Route::Records)
            && self.res.spectrum.terms() <= SMALL_TERMS
    }

    /// The basis values B_0..B_{K−1} at wavelength `l` (nm) in the front of `b`; NaN in the
    /// first when `l` is not finite (ρ = 0 there).
    #[inline(always)]
    fn basis_at(&self, l: f32, b: &mut [f64; SMALL_TERMS]) {
        let b = &mut b[..self.res.spectrum.terms()];
        if (l as f64).is_finite() {
            self.res.spectrum.basis(l as f64, b);
        } else if let Some(b0) = b.first_mut() {
            *b0 = f64::NAN;
        }
    }

    /// ρ at vectors `wi` (toward the light) and `wo` (toward the viewer) in the local frame
    /// (z = normal), for each wavelength in nm, into `out` (1/sr); never negative. Writes
    /// `min(wavelengths.len(), out.len())` values; never allocates.
    #[inline(always)]
    pub(crate) fn eval(&self, wi: [f32; 3], wo: [f32; 3], wavelengths: &[f32], out: &mut [f32]) {
        let n = wavelengths.len().min(out.len());
        let (out, wavelengths) = (&mut out[..n], &wavelengths[..n]);
        if n == 1 && self.hoists_basis() {
            // One wavelength: the route `eval_batch` takes, so both give the same bits.
            let mut b = [0.0f64; SMALL_TERMS];
            self.basis_at(wavelengths[0], &mut b);
            out[0] = self.eval_one(wi, wo, &b[..self.res.spectrum.terms()]);
            return;
        }
        let (Some(wi), Some(wo)) = (unit_above(wi), unit_above(wo)) else {
            out.fill(0.0);
            return;
        };
        if let Route::Warped(w) = &self.route {
            w.with_coefficients(wi, wo, |c| {
                self.res.spectrum.eval_clamped(c, wavelengths, out)
            });
            return;
        }
        let q = self.query_frame(wi);
        let inc = self.incident(q.theta, q.phi, Some(q.wi));
        let wo = q.in_frame(wo);
        match &self.route {
            Route::Factor(nodes) => {
                let t = factor_terms(&self.res, q.wi, wo).unwrap_or(NO_FACTOR);
                general::with_coefficients(&self.res, &inc, None, wo, |c| {
                    for (o, &l) in out.iter_mut().zip(wavelengths) {
                        let v = value_with_factor(&self.res, Some(nodes), c, &t, l as f64);
                        *o = v.max(0.0) as f32;
                    }
                })
            }
            _ => general::with_coefficients(&self.res, &inc, None, wo, |c| {
                self.res.spectrum.eval_clamped(c, wavelengths, out)
            }),
        }
    }

    /// ρ at the one wavelength whose basis values are `b` ([`Evaluator::basis_at`]), clamped
    /// at 0: the same operations, in the same order, as the batch gives the pair at that
    /// wavelength (the kernel, one lane; otherwise the terms summed before the records, or the
    /// coefficients against `b`). The caller checked [`Evaluator::hoists_basis`].
    #[inline(always)]
    fn eval_one(&self, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> f32 {
        if b.first().is_none_or(|v| v.is_nan()) {
            return 0.0;
        }
        if let Some((kernel, st)) = self.kernel_input() {
            return kernel
                .one(st, wi, wo, b)
                .unwrap_or_else(|| self.kernel_fallback(wi, wo, b));
        }
        let (Some(wi), Some(wo)) = (unit_above(wi), unit_above(wo)) else {
            return 0.0;
        };
        let q = self.query_frame(wi);
        let inc = self.incident(q.theta, q.phi, Some(q.wi));
        let wo = q.in_frame(wo);
        if general::takes_one_wavelength(&self.res, &inc) {
            return general::value_at(&self.res, &inc, None, wo, &b[..inc.terms]).max(0.0) as f32;
        }
        general::with_coefficients(&self.res, &inc, None, wo, |c| {
            let mut sum = 0.0;
            for (ck, bk) in c.iter().zip(b) {
                sum += ck * bk;
            }
            sum.max(0.0) as f32
        })
    }

    /// ρ at basis values `b` for a pair the kernel hands back, clamped at 0: the general path.
    #[cold]
    pub(crate) fn kernel_fallback(&self, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> f32 {
        let (Some(wi), Some(wo)) = (unit_above(wi), unit_above(wo)) else {
            return 0.0;
        };
        let q = self.query_frame(wi);
        let inc = self.incident(q.theta, q.phi, Some(q.wi));
        general::value_at(&self.res, &inc, None, q.in_frame(wo), &b[..inc.terms]).max(0.0) as f32
    }

    /// The route of a [`crate::Decoder::at`] view at `wavelength` (nm).
    pub(crate) fn at_route(&self, wavelength: f32) -> AtRoute {
        if !self.hoists_basis() {
            return AtRoute::Eval;
        }
        let mut b = [0.0f64; SMALL_TERMS];
        self.basis_at(wavelength, &mut b);
        match self.kernel_input() {
            Some((kernel, st)) if !b[0].is_nan() => {
                match kernel.collapse_all(st.res, &b[..st.res.spectrum.terms()]) {
                    Some(c) => AtRoute::Collapsed(b, c),
                    None => AtRoute::Basis(b),
                }
            }
            _ => AtRoute::Basis(b),
        }
    }

    /// What a baked view at `wavelength` (nm) needs from the exact route, its shapes blended
    /// at `steps(Δ)` + 1 weights for Δ the widest change of a shape's logarithm between two
    /// records. Only the kernel's route is baked (a θ line, at most two lobes of kinds 2–4 per
    /// record, SH level ≤ 6, ≤ 16 terms, records that fit the collapsed table); elsewhere Err
    /// says why.
    pub(crate) fn baked_input(
        &self,
        wavelength: f32,
        steps: impl Fn(f64) -> usize,
    ) -> std::result::Result<BakedInput, String> {
        let route = match &self.route {
            Route::Kernel(_) => None,
            Route::Records => Some("records the one-wavelength kernel does not take"),
            Route::Factor(_) => Some("a factor model"),
            Route::Warped(_) => Some("warped tables"),
        };
        if let Some(what) = route {
            return Err(format!(
                "a baked view takes records on a θ line with at most two cosine-power or \
                 microfacet lobes each, SH level ≤ 6 and ≤ 16 spectral terms; this file has {what}: \
                 use Decoder::at for its one-wavelength queries"
            ));
        }
        let Some((kernel, st)) = self.kernel_input() else {
            return Err("no kernel".into());
        };
        let mut basis = [0.0f64; SMALL_TERMS];
        self.basis_at(wavelength, &mut basis);
        if basis[0].is_nan() {
            return Err(format!("the wavelength {wavelength} nm is not finite"));
        }
        let collapsed = kernel
            .collapse_all(st.res, &basis[..st.res.spectrum.terms()])
            .ok_or_else(|| {
                format!(
                    "its {} records do not fit the one-wavelength table a baked view keeps",
                    st.res.recs.len()
                )
            })?;
        let widest = BakedLobes::widest_log_step(kernel, st.res);
        let lobes = BakedLobes::new(kernel, st.res, &collapsed, steps(widest));
        Ok(BakedInput {
            basis,
            collapsed: Box::new(collapsed),
            sh_counts: kernel.sh_counts().collect(),
            lobes,
        })
    }

    /// ρ with each record's SH part from `sh` (a baked view's grids: `sh(r0, count, ωo)` for
    /// records r0..r0 + count at ωo in the records' frame) and the lobes from `input`
    /// (shapes blended ahead) ([`Evaluator::baked_input`]); the pairs the kernel hands back take the general
    /// path, exactly.
    #[inline(always)]
    pub(crate) fn eval_baked(
        &self,
        input: &BakedInput,
        sh: impl Fn(usize, usize, [f64; 3]) -> [f64; 2],
        wi: [f32; 3],
        wo: [f32; 3],
    ) -> f32 {
        match self.kernel_input() {
            Some((kernel, st)) => kernel_baked::one_baked(kernel, st, wi, wo, &input.lobes, sh)
                .unwrap_or_else(|| {
                    self.kernel_fallback(wi, wo, &input.basis[..self.res.spectrum.terms()])
                }),
            None => 0.0,
        }
    }

    /// ρ at `wavelength` (nm) by a view's route ([`Evaluator::at_route`] at that wavelength):
    /// [`Evaluator::eval`]'s bits.
    #[inline(always)]
    pub(crate) fn eval_at(
        &self,
        route: &AtRoute,
        wavelength: f32,
        wi: [f32; 3],
        wo: [f32; 3],
    ) -> f32 {
        let k = self.res.spectrum.terms();
        match route {
            AtRoute::Collapsed(b, c) => match self.kernel_input() {
                Some((kernel, st)) => kernel
                    .one_collapsed(st, wi, wo, c)
                    .unwrap_or_else(|| self.kernel_fallback(wi, wo, &b[..k])),
                None => self.eval_one(wi, wo, &b[..k]),
            },
            AtRoute::Basis(b) => self.eval_one(wi, wo, &b[..k]),
            AtRoute::Eval => {
                let mut out = [0.0f32];
                self.eval(wi, wo, &[wavelength], &mut out);
                out[0]
            }
        }
    }

    /// `out[i·M..(i+1)·M]` = ρ(wi(i), wo(i), λ) for i < n, M = `wavelengths.len()`, exactly
    /// [`Evaluator::eval`]'s values. The caller checked that `out` holds n·M values.
    pub(crate) fn eval_batch(
        &self,
        wi: impl Fn(usize) -> [f32; 3],
        wo: impl Fn(usize) -> [f32; 3],
        n: usize,
        wavelengths: &[f32],
        out: &mut [f32],
    ) {
        let m = wavelengths.len();
        if m == 0 || n == 0 {
            return;
        }
        if matches!(self.route, Route::Factor(_) | Route::Warped(_)) {
            // A factor model or warped tables depend on each pair's own directions: nothing to
            // share per run.
            for (i, row) in out[..n * m].chunks_exact_mut(m).enumerate() {
                self.eval(wi(i), wo(i), wavelengths, row);
            }
            return;
        }
        let spectra = batch::Spectra::new(&self.res, wavelengths);
        if let (Some((kernel, st)), 1, Some(b)) = (self.kernel_input(), m, spectra.basis()) {
            // One wavelength through the kernel: its pairs sorted by group, W lanes at once.
            let fallback = |i: usize| self.kernel_fallback(wi(i), wo(i), b);
            let pairs = Pairs {
                wi: &wi,
                wo: &wo,
                n,
                fallback,
            };
            lanes_batch::batch(kernel, st, &pairs, b, out);
            return;
        }
        batch::records(&self.res, &self.places, &spectra, wi, wo, n, out);
    }

    /// Convenience form of [`crate::Decoder::eval`] with angles in degrees, with or without
    /// step 5's clamp at 0 (unclamped: to measure how often a model undershoots).
    pub(crate) fn eval_deg_with(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
        clamp: bool,
    ) {
        let n = wavelengths.len().min(out.len());
        let out = &mut out[..n];
        let finite = incident.1.is_finite() && outgoing.1.is_finite();
        if !finite || !(0.0..=90.0).contains(&incident.0) || !(0.0..=90.0).contains(&outgoing.0) {
            out.fill(0.0);
            return;
        }
        let nodes = match &self.route {
            Route::Factor(nodes) => Some(nodes),
            _ => None,
        };
        // A non-finite wavelength gives 0; the value is clamped at 0 unless asked not to.
        let write = |c: &[f64], t: &FactorTerms, out: &mut [f64]| {
            for (o, &l) in out.iter_mut().zip(wavelengths) {
                let v = value_with_factor(&self.res, nodes, c, t, l);
                *o = if clamp { v.max(0.0) } else { v };
            }
        };
        if let Route::Warped(w) = &self.route {
            // The vectors as given: the tables turn by the viewing azimuth ("Warped tables").
            let (wi, wo) = (
                dir_from_deg(incident.0, incident.1),
                dir_from_deg(outgoing.0, outgoing.1),
            );
            w.with_coefficients(wi, wo, |c| write(c, &NO_FACTOR, out));
            return;
        }
        let (phi, wo) = if self.res.isotropic {
            (0.0, dir_from_deg(outgoing.0, outgoing.1 - incident.1))
        } else {
            (incident.1, dir_from_deg(outgoing.0, outgoing.1))
        };
        let inc = self.incident(incident.0, phi, None);
        // The factor model sees the query as it is (its features are clamped to the ranges it
        // was fitted on); the records, the nearest stored incidences.
        let t = factor_terms(&self.res, dir_from_deg(incident.0, phi), wo).unwrap_or(NO_FACTOR);
        general::with_coefficients(&self.res, &inc, None, wo, |c| write(c, &t, out));
    }
}
