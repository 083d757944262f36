//! Reconstruction: the SH background, the lobes and the spectral basis evaluated at a query,
//! parameters blended between stored incidences (`spec/EVALUATION.md`, "Reconstruction").
//!
//! A query is split in two. Its incident side ([`Incident`]: the records to blend, their
//! weights, the evaluation incidence, and every shared lobe's blended shape) depends on ωi
//! alone; its outgoing side (the SH functions, the lobes' values, the spectrum) on ωo. The
//! batch entry point ([`super::batch`]) computes the incident side once for a run of pairs that
//! share ωi.

use super::blend::{BlendInfo, Incident};
use super::kernel::lanes_batch::Width;
use super::kernel::{self, Kernel, Stored, KERNEL_TERMS};
use super::lattice::{upper, Blend, Lattice, QueryFrame};
use super::resident::{Rec, Resident};
use super::sums::dot_f32;
use super::warped::{Residency, WarpedEval};
use crate::model::angles::{azimuth_rotation, deg_from_dir, dir_from_deg, polar_deg};
use crate::model::factor::{FeatureValues, MAX_COMPONENTS, MAX_RANK};
use crate::model::material::Material;
use crate::model::sh::sh_count;

/// Files within SH level 6 and 16 terms (every file the encoder writes by default) evaluate with
/// small scratch arrays: zeroing the format's maxima (441 SH values, 256 terms) would cost more
/// than the evaluation.
pub(crate) const SMALL_SH: usize = sh_count(6);
pub(crate) const SMALL_TERMS: usize = 16;

/// A validated material in its resident form plus what makes evaluation cheap.
#[derive(Debug, Clone)]
pub(crate) struct Evaluator {
    pub(crate) res: Resident,
    pub(crate) lattice: Lattice,
    pub(crate) small: bool,
    /// The stored θ range's ends with their sine and cosine: a query clamped to an end keeps
    /// its azimuth without trigonometry.
    pub(crate) theta_ends: [(f64, f64, f64); 2],
    /// The factor model shared by every incidence (`FACT`), with the file's wavelengths as its
    /// spectra's nodes, if any: evaluated at the query's own directions and added before the
    /// clamp ("Reconstruction", step 5).
    factor_nodes: Option<WavelengthNodes>,
    /// What [`Evaluator::incident`] derives from the records a query blends, precomputed for
    /// each record alone and, on a θ line, for each pair of neighbours (record i with i + 1).
    pub(crate) alone: Vec<BlendInfo>,
    pub(crate) pairs: Vec<BlendInfo>,
    /// Whether one-wavelength queries take the line path (`super::theta_line`).
    on_line: bool,
    /// The one-wavelength kernel of a file on the line path (`super::kernel`).
    pub(crate) kernel: Option<Kernel>,
    /// Warped tables (`WARP`): when present they answer every query (the records are empty).
    /// Boxed: a file without them pays one pointer.
    pub(crate) warped: Option<Box<WarpedEval>>,
}

/// A factor model's angular terms T_cr at one pair of directions.
type FactorTerms = [f64; MAX_COMPONENTS * MAX_RANK];

impl Evaluator {
    /// Prepares a material for evaluation, its warped tables (if any) held as `residency`
    /// says; the caller has validated it. Fails, saying why, when its warped tables cannot be
    /// prepared (a stored incidence's VNDF or a σ node at zero, tables beyond f32).
    pub(crate) fn new(
        material: &Material,
        residency: Residency,
    ) -> std::result::Result<Self, String> {
        let lattice = Lattice::of(material);
        let small = material.sh_level <= 6 && material.spectral.terms <= SMALL_TERMS;
        let end = |t: f64| {
            let (s, c) = t.to_radians().sin_cos();
            (t, s, c)
        };
        let first = material.records.first().map_or(0.0, |r| r.theta_i as f64);
        let last = material.records.last().map_or(0.0, |r| r.theta_i as f64);
        let res = Resident::new(material);
        let prepared = material.warped.as_ref().map(|w| {
            let thetas: Vec<f32> = material.records.iter().map(|r| r.theta_i).collect();
            let means = res.basis_means();
            WarpedEval::new(w, &thetas, material.spectral.terms, &means, residency).map(Box::new)
        });
        let warped = prepared.transpose()?;
        let n = res.recs.len();
        let alone = (0..n).map(|r| BlendInfo::of(&res, &[r])).collect();
        let pairs = match lattice {
            Lattice::Theta(_) => (1..n).map(|r| BlendInfo::of(&res, &[r - 1, r])).collect(),
            _ => Vec::new(),
        };
        let on_line = matches!(lattice, Lattice::Theta(_))
            && material.factor.is_none()
            && material.warped.is_none()
            && kernel::takes(material);
        let mut ev = Evaluator {
            res,
            alone,
            pairs,
            on_line,
            kernel: None,
            warped,
            lattice,
            small,
            theta_ends: [end(first), end(last)],
            factor_nodes: material
                .factor
                .as_ref()
                .map(|_| WavelengthNodes::new(&material.wavelengths)),
        };
        if ev.on_line {
            ev.kernel = Some(Kernel::new(&ev.res));
        }
        Ok(ev)
    }

    /// Whether the file's pairs are answered one by one through [`Evaluator::eval`] (a factor
    /// model or warped tables: nothing depends on the incident direction alone).
    pub(crate) fn per_pair(&self) -> bool {
        self.res.factor.is_some() || self.warped.is_some()
    }

    /// The factor model's angular terms at unit vectors `wi`, `wo` (any common frame: its
    /// features depend on the pair alone), if the file has one.
    #[inline]
    fn factor_terms(&self, wi: [f64; 3], wo: [f64; 3]) -> Option<FactorTerms> {
        self.res.factor.as_ref().map(|f| {
            let feats = FeatureValues::of(wi, wo).clamped(&f.ranges);
            let mut t = [0.0f64; MAX_COMPONENTS * MAX_RANK];
            f.angular(&feats, &mut t);
            t
        })
    }

    /// ρ at one wavelength from the blended coefficients `c` and the factor terms `t`, before
    /// the clamp; 0 at a non-finite wavelength.
    #[inline]
    fn value_with_factor(&self, c: &[f64], t: &FactorTerms, l: f64) -> f64 {
        if !l.is_finite() {
            return 0.0;
        }
        let mut v = self.res.spectrum.dot(c, l);
        if let (Some(f), Some(nodes)) = (&self.res.factor, &self.factor_nodes) {
            let (j, a) = nodes.bracket(l);
            v += f.value(t, j, a);
        }
        v
    }

    /// Heap bytes held by the evaluator.
    pub(crate) fn heap_bytes(&self) -> usize {
        let nodes = self
            .factor_nodes
            .as_ref()
            .map_or(0, |n| 8 * n.nodes.capacity());
        let info =
            std::mem::size_of::<BlendInfo>() * (self.alone.capacity() + self.pairs.capacity());
        let kernel = self.kernel.as_ref().map_or(0, Kernel::heap_bytes);
        let warped = self
            .warped
            .as_ref()
            .map_or(0, |w| std::mem::size_of::<WarpedEval>() + w.heap_bytes());
        self.res.heap_bytes() + self.lattice.heap_bytes() + nodes + info + kernel + warped
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
            out[0] = self.eval_one(wi, wo, self.basis_at(wavelengths[0], &mut b));
            return;
        }
        let (Some(wi), Some(wo)) = (upper(wi), upper(wo)) else {
            out.fill(0.0);
            return;
        };
        if let Some(w) = &self.warped {
            w.with_coefficients(wi, wo, |c| {
                self.res.spectrum.eval_clamped(c, wavelengths, out)
            });
            return;
        }
        if self.on_line {
            // Several wavelengths: the coefficients once (`b` is their scratch).
            let mut b = [0.0f64; SMALL_TERMS];
            let b = &mut b[..self.res.spectrum.terms()];
            self.line_coefficients(wi, wo, b);
            self.res.spectrum.eval_clamped(b, wavelengths, out);
            return;
        }
        let q = self.query_frame(wi);
        let inc = self.incident(q.theta, q.phi, Some(q.wi));
        let wo = q.in_frame(wo);
        if let Some(t) = self.factor_terms(q.wi, wo) {
            self.outgoing(&inc, wo, |c| {
                for (o, &l) in out.iter_mut().zip(wavelengths) {
                    *o = self.value_with_factor(c, &t, l as f64).max(0.0) as f32;
                }
            });
            return;
        }
        self.outgoing(&inc, wo, |c| {
            self.res.spectrum.eval_clamped(c, wavelengths, out)
        });
    }

    /// Whether one-wavelength queries can be answered from that wavelength's basis values
    /// computed beforehand ([`Evaluator::eval_one`]): the pairs share an incident side (no
    /// factor model, no warped tables) and the file has at most [`SMALL_TERMS`] terms.
    #[inline(always)]
    pub(crate) fn hoists_basis(&self) -> bool {
        !self.per_pair() && self.res.spectrum.terms() <= SMALL_TERMS.min(KERNEL_TERMS)
    }

    /// The basis values B_0..B_{K−1} at wavelength `l` (nm) in the front of `b`; NaN in the
    /// first when `l` is not finite (ρ = 0 there). The caller checked
    /// [`Evaluator::hoists_basis`].
    #[inline(always)]
    pub(crate) fn basis_at<'a>(&self, l: f32, b: &'a mut [f64; SMALL_TERMS]) -> &'a [f64] {
        let b = &mut b[..self.res.spectrum.terms()];
        if (l as f64).is_finite() {
            self.res.spectrum.basis(l as f64, b);
        } else if let Some(b0) = b.first_mut() {
            *b0 = f64::NAN;
        }
        b
    }

    /// ρ at the one wavelength whose basis values are `b` ([`Evaluator::basis_at`]), clamped
    /// at 0: the same operations, in the same order, as [`super::batch`] gives the pair at
    /// that wavelength (the kernel on a θ line, one lane; otherwise the terms summed before the
    /// records, or the coefficients against `b`). The caller checked
    /// [`Evaluator::hoists_basis`].
    #[inline(always)]
    pub(crate) fn eval_one(&self, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> f32 {
        if b.first().is_none_or(|v| v.is_nan()) {
            return 0.0;
        }
        if let Some((kernel, st)) = self.kernel_input() {
            return kernel
                .one(st, wi, wo, b)
                .unwrap_or_else(|| self.line_fallback(wi, wo, b));
        }
        let (Some(wi), Some(wo)) = (upper(wi), upper(wo)) else {
            return 0.0;
        };
        let q = self.query_frame(wi);
        let inc = self.incident(q.theta, q.phi, Some(q.wi));
        let wo = q.in_frame(wo);
        if self.one_wavelength(&inc) {
            return self.value_at(&inc, None, wo, &b[..inc.terms]).max(0.0) as f32;
        }
        self.outgoing(&inc, wo, |c| {
            let mut sum = 0.0;
            for (ck, bk) in c.iter().zip(b) {
                sum += ck * bk;
            }
            sum.max(0.0) as f32
        })
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
        self.kernel = Some(self.kernel?.with_width(width)?);
        Some(self)
    }

    /// The kernel of a file on the θ-line path, with what it reads.
    #[inline(always)]
    pub(crate) fn kernel_input(&self) -> Option<(&Kernel, Stored<'_>)> {
        match (&self.kernel, &self.lattice) {
            (Some(k), Lattice::Theta(axis)) => Some((
                k,
                Stored {
                    res: &self.res,
                    axis,
                    ends: &self.theta_ends,
                },
            )),
            _ => None,
        }
    }

    /// ρ at basis values `b` for a pair the kernel leaves to the θ-line path, clamped at 0.
    #[cold]
    pub(crate) fn line_fallback(&self, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> f32 {
        match (upper(wi), upper(wo)) {
            (Some(a), Some(o)) => self.line_value(a, o, b).max(0.0) as f32,
            _ => 0.0,
        }
    }

    /// The query's incident direction in the records' frame (`wi` a unit vector with z ≥ 0).
    #[inline(always)]
    pub(crate) fn query_frame(&self, wi: [f64; 3]) -> QueryFrame {
        let (r, c, s) = azimuth_rotation(wi);
        // θ only places the query between stored incidences: an error below what the f32
        // input vector can say about its own angle (≈1e-7 rad) is allowed ("Rounding"), and
        // an inlined polynomial costs a fraction of a library atan2.
        let theta = polar_deg(r, wi[2]);
        if self.res.isotropic {
            // Rotate into the stored frame (φi = 0) with the azimuth's cosine and sine, no trig.
            QueryFrame {
                theta,
                phi: 0.0,
                wi: [r, 0.0, wi[2]],
                rotation: Some((c, s)),
            }
        } else {
            let (_, phi) = deg_from_dir(wi);
            QueryFrame {
                theta,
                phi,
                wi,
                rotation: None,
            }
        }
    }

    /// Convenience form of [`crate::Decoder::eval`] with angles in degrees.
    pub(crate) fn eval_deg(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
    ) {
        self.eval_deg_with(incident, outgoing, wavelengths, out, true)
    }

    /// [`Evaluator::eval_deg`], with or without step 5's clamp at 0 (unclamped: to measure how
    /// often a model undershoots).
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
        // A non-finite wavelength gives 0; the value is clamped at 0 unless asked not to.
        let write = |c: &[f64], t: &FactorTerms, out: &mut [f64]| {
            for (o, &l) in out.iter_mut().zip(wavelengths) {
                let v = self.value_with_factor(c, t, l);
                *o = if clamp { v.max(0.0) } else { v };
            }
        };
        let no_factor = [0.0; MAX_COMPONENTS * MAX_RANK];
        if let Some(w) = &self.warped {
            // The vectors as given: the tables turn by the viewing azimuth ("Warped tables").
            let (wi, wo) = (
                dir_from_deg(incident.0, incident.1),
                dir_from_deg(outgoing.0, outgoing.1),
            );
            w.with_coefficients(wi, wo, |c| write(c, &no_factor, out));
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
        let t = self
            .factor_terms(dir_from_deg(incident.0, phi), wo)
            .unwrap_or(no_factor);
        self.outgoing(&inc, wo, |c| write(c, &t, out));
    }

    /// The records to blend for a query incidence (θ, φ in degrees, in the records' frame), the
    /// incident vector they are evaluated with (`wi`, when given, is the unit vector of (θ, φ))
    /// and its angles: outside the stored θ range the nearest stored θ is used, incident vector
    /// included.
    #[inline(always)]
    pub(crate) fn resolve(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
    ) -> (Blend, [f64; 3], f64, f64) {
        let (blend, at_theta, at_phi) = self.lattice.blend(&self.res.recs, theta, phi);
        let wi = match wi {
            Some(v) if at_theta == theta && at_phi == phi => v,
            Some(v) if at_phi == phi => self.clamped(v, at_theta),
            _ => dir_from_deg(at_theta, at_phi),
        };
        (blend, wi, at_theta, at_phi)
    }

    /// The unit vector at polar angle `theta` (degrees; one of the stored range's ends) with the
    /// azimuth of the unit vector `v`; φ = 0 when `v` is the normal.
    #[inline(always)]
    pub(crate) fn clamped(&self, v: [f64; 3], theta: f64) -> [f64; 3] {
        let Some(&(_, s, c)) = self.theta_ends.iter().find(|e| e.0 == theta) else {
            return dir_from_deg(theta, deg_from_dir(v).1);
        };
        let r = (v[0] * v[0] + v[1] * v[1]).sqrt();
        if r > 0.0 {
            [s * v[0] / r, s * v[1] / r, c]
        } else {
            [s, 0.0, c]
        }
    }

    /// The incident side of a query at incidence (θ, φ) in degrees, in the records' frame (`wi`
    /// its unit vector when known).
    #[inline(always)]
    pub(crate) fn incident(&self, theta: f64, phi: f64, wi: Option<[f64; 3]>) -> Incident {
        let (blend, wi, theta, phi) = self.resolve(theta, phi, wi);
        let info = self.blend_info(&blend);
        let (terms, level, nlobes, shared) = (
            info.terms as usize,
            info.level as usize,
            info.nlobes as usize,
            info.shared,
        );
        Incident {
            blend,
            wi,
            theta,
            phi,
            terms,
            level,
            nlobes,
            shared,
        }
    }

    /// [`BlendInfo`] of the records `blend` holds: precomputed for one record and for
    /// neighbours on a θ line.
    #[inline(always)]
    pub(crate) fn blend_info(&self, blend: &Blend) -> BlendInfo {
        let recs = &blend.rec[..blend.n];
        match (recs, &self.lattice) {
            (&[r], _) => self.alone[r],
            (&[r, r1], Lattice::Theta(_)) if r1 == r + 1 => self.pairs[r],
            _ => BlendInfo::of(&self.res, recs),
        }
    }

    /// Whether one-wavelength queries take the line path (`super::theta_line`).
    pub(crate) fn on_line(&self) -> bool {
        self.on_line
    }

    /// Σ_k B_k·Σ_j A_kj·y_j: a record's SH part at one wavelength (basis values `b`, SH values
    /// `y` up to at least its level).
    #[inline(always)]
    pub(crate) fn sh_sum(&self, rec: &Rec, y: &[f64], b: &[f64]) -> f64 {
        let (t, p) = (rec.terms as usize, sh_count(rec.level as usize));
        let a = &self.res.vals[rec.sh as usize..rec.sh as usize + t * p];
        let mut sum = 0.0;
        for (row, &bk) in a.chunks_exact(p).zip(b) {
            sum += bk * dot_f32(row, &y[..p]);
        }
        sum
    }
}

/// The file's wavelengths as interpolation nodes: a wavelength's bracket (j, a), value =
/// (1 − a)·v_j + a·v_{j+1}, λ clamped to the nodes' range.
#[derive(Debug, Clone)]
pub(crate) struct WavelengthNodes {
    nodes: Vec<f64>,
    /// 1/(mean spacing): evenly spaced nodes (the usual case) are located by one
    /// multiplication, the guess checked; 0 with fewer than two nodes.
    inv_step: f64,
}

impl WavelengthNodes {
    fn new(w: &[f32]) -> Self {
        let nodes: Vec<f64> = w.iter().map(|&v| v as f64).collect();
        let inv_step = match nodes.as_slice() {
            [first, .., last] if last > first => (nodes.len() - 1) as f64 / (last - first),
            _ => 0.0,
        };
        WavelengthNodes { nodes, inv_step }
    }

    fn bracket(&self, l: f64) -> (usize, f64) {
        let n = &self.nodes;
        if n.len() == 1 || l.is_nan() || l <= n[0] {
            return (0, 0.0);
        }
        let last = n.len() - 1;
        if l >= n[last] {
            return (last, 0.0);
        }
        // n[0] < l < n[last] here, so the guess is below last.
        let g = (((l - n[0]) * self.inv_step) as usize).min(last - 1);
        let j = if n[g] <= l && l < n[g + 1] {
            g
        } else {
            n.partition_point(|&x| x <= l) - 1
        };
        (j, (l - n[j]) / (n[j + 1] - n[j]))
    }
}
