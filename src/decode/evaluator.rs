//! Reconstruction: the SH background, the lobes and the spectral basis evaluated at a query,
//! parameters blended between stored incidences (`spec/EVALUATION.md`, "Reconstruction").
//!
//! A query is split in two. Its incident side ([`Incident`]: the records to blend, their
//! weights, the evaluation incidence, and every shared lobe's blended shape) depends on ωi
//! alone; its outgoing side (the SH functions, the lobes' values, the spectrum) on ωo. The
//! batch entry point ([`super::batch`]) computes the incident side once for a run of pairs that
//! share ωi.

use super::kernel::Kernel;
use super::lattice::{upper, Blend, Lattice, QueryFrame};
use super::line::{line_lobes, line_sizes};
use super::resident::{Rec, Resident};
use super::warped::WarpedEval;
use crate::model::angles::phi_delta;
use crate::model::angles::{angle_between, deg_from_dir, dir_from_deg, dot, mirror_deg, polar_deg};
use crate::model::factor::{FeatureValues, MAX_COMPONENTS, MAX_RANK};
use crate::model::lobes::MicrofacetGeometry;
use crate::model::material::{LobeKind, Material, MAX_LOBES, MAX_TERMS};
use crate::model::sh::{sh_count, ShBasis, MAX_SH_LEVEL};

const MAX_SH: usize = sh_count(MAX_SH_LEVEL);
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
    small: bool,
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
    /// Whether one-wavelength queries take the line path (`super::line`).
    on_line: bool,
    /// The one-wavelength kernel of a file on the line path (`super::kernel`).
    pub(crate) kernel: Option<Kernel>,
    /// Warped tables (`WARP`): when present they answer every query (the records are empty).
    /// Boxed: a file without them pays one pointer.
    pub(crate) warped: Option<Box<WarpedEval>>,
}

/// T*, the highest SH level and the most lobes among the records a query blends, and bit li
/// set when lobe position li is shared by all of them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BlendInfo {
    pub terms: u16,
    pub level: u8,
    pub nlobes: u8,
    pub shared: u8,
}

impl BlendInfo {
    fn of(res: &Resident, recs: &[usize]) -> Self {
        let r0 = &res.recs[recs[0]];
        let (mut terms, mut level, mut nlobes) = (r0.terms, r0.level, r0.nlobes);
        for &r in &recs[1..] {
            let rec = &res.recs[r];
            terms = terms.max(rec.terms);
            level = level.max(rec.level);
            nlobes = nlobes.max(rec.nlobes);
        }
        // Position li is shared when every blended record has a lobe there, of one kind.
        let mut shared = 0u8;
        for li in 0..nlobes as usize {
            let kind = (r0.kinds >> (4 * li)) & 15;
            if kind != 0
                && recs
                    .iter()
                    .all(|&r| (res.recs[r].kinds >> (4 * li)) & 15 == kind)
            {
                shared |= 1 << li;
            }
        }
        BlendInfo {
            terms,
            level,
            nlobes,
            shared,
        }
    }
}

/// A factor model's angular terms T_cr at one pair of directions.
type FactorTerms = [f64; MAX_COMPONENTS * MAX_RANK];

/// The shape of a lobe shared by the blended records, blended once per incidence.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct LobeShape {
    /// The peak direction (kinds 1 and 4).
    pub peak: [f64; 3],
    /// Kind 4: [n, –, …]; kinds 2 and 3: [b, c, a, –, …]; kind 5: [bx, by, c, ax, ay, ψ];
    /// rounded to f32 (`spec/EVALUATION.md`, "Lobes by position"); kind 1 blends its widths per
    /// term at evaluation.
    pub p: [f64; 6],
}

/// The incident side of a query: everything that does not depend on ωo.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Incident {
    pub blend: Blend,
    /// The evaluation incidence ωi* and its angles (degrees, in the records' frame).
    pub wi: [f64; 3],
    pub theta: f64,
    pub phi: f64,
    /// T* and the highest SH level among the blended records.
    pub terms: usize,
    pub level: usize,
    /// The most lobes a blended record has, and bit li set when position li is shared.
    pub nlobes: usize,
    pub shared: u8,
}

/// The blended shapes of an incidence's shared lobes, by position (for a run of pairs that
/// share the incidence).
pub(crate) type Shapes = [LobeShape; MAX_LOBES];

impl Evaluator {
    /// Prepares a material for evaluation; the caller has validated it.
    pub(crate) fn new(material: &Material) -> Self {
        let lattice = Lattice::of(material);
        let small = material.sh_level <= 6 && material.spectral.terms <= SMALL_TERMS;
        let end = |t: f64| {
            let (s, c) = t.to_radians().sin_cos();
            (t, s, c)
        };
        let first = material.records.first().map_or(0.0, |r| r.theta_i as f64);
        let last = material.records.last().map_or(0.0, |r| r.theta_i as f64);
        let res = Resident::new(material);
        let warped = material.warped.as_ref().and_then(|w| {
            let thetas: Vec<f32> = material.records.iter().map(|r| r.theta_i).collect();
            let means = res.basis_means();
            WarpedEval::new(w, &thetas, material.spectral.terms, &means).map(Box::new)
        });
        let n = res.recs.len();
        let alone = (0..n).map(|r| BlendInfo::of(&res, &[r])).collect();
        let pairs = match lattice {
            Lattice::Theta(_) => (1..n).map(|r| BlendInfo::of(&res, &[r - 1, r])).collect(),
            _ => Vec::new(),
        };
        let on_line = matches!(lattice, Lattice::Theta(_))
            && material.factor.is_none()
            && material.warped.is_none()
            && line_sizes(material.sh_level, material.spectral.terms)
            && material
                .records
                .iter()
                .all(|r| line_lobes(&r.lobes.iter().map(|l| l.kind).collect::<Vec<_>>()));
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
            ev.kernel = Some(Kernel::new(&ev));
        }
        ev
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
            let mut b = [0.0f64; SMALL_TERMS];
            let b = &mut b[..self.res.spectrum.terms()];
            if n == 1 {
                let l = wavelengths[0] as f64;
                out[0] = if l.is_finite() {
                    self.res.spectrum.basis(l, b);
                    self.line_value(wi, wo, b).max(0.0) as f32
                } else {
                    0.0
                };
            } else {
                // Several wavelengths: the coefficients once (`b` is their scratch).
                self.line_coefficients(wi, wo, b);
                self.res.spectrum.eval_clamped(b, wavelengths, out);
            }
            return;
        }
        let q = self.query_frame(wi);
        let inc = self.incident(q.theta, q.phi, Some(q.wi));
        let wo = q.in_frame(wo);
        if n == 1 && self.one_wavelength(&inc) {
            let l = wavelengths[0] as f64;
            out[0] = if l.is_finite() {
                let mut b = [0.0f64; SMALL_TERMS];
                self.res.spectrum.basis(l, &mut b[..inc.terms]);
                self.value_at(&inc, None, wo, &b[..inc.terms]).max(0.0) as f32
            } else {
                0.0
            };
            return;
        }
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

    /// The query's incident direction in the records' frame (`wi` a unit vector with z ≥ 0).
    #[inline(always)]
    pub(crate) fn query_frame(&self, wi: [f64; 3]) -> QueryFrame {
        let r = (wi[0] * wi[0] + wi[1] * wi[1]).sqrt();
        // θ only places the query between stored incidences: an error below what the f32
        // input vector can say about its own angle (≈1e-7 rad) is allowed ("Rounding"), and
        // an inlined polynomial costs a fraction of a library atan2.
        let theta = polar_deg(r, wi[2]);
        if self.res.isotropic {
            // Rotate into the stored frame (φi = 0) with the azimuth's cosine and sine, no trig.
            let (c, s) = if r > 0.0 {
                let inv = 1.0 / r;
                (wi[0] * inv, wi[1] * inv)
            } else {
                (1.0, 0.0)
            };
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

    /// Whether one-wavelength queries take the line path (`super::line`).
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

    /// Every shared lobe's blended shape into `shapes`, for reuse over a run of pairs.
    pub(crate) fn shapes(&self, inc: &Incident, shapes: &mut Shapes) {
        for (li, s) in shapes.iter_mut().enumerate().take(inc.nlobes) {
            if inc.shared & (1 << li) != 0 {
                *s = self.shared_shape(inc, li);
            }
        }
    }

    /// The blended shape of the shared lobe at position `li`: exponents and microfacet b, c (bx,
    /// by) geometrically, microfacet a (ax, ay) linearly, the axis by [`Evaluator::blended_axis`],
    /// the peak direction by "Blended peak direction".
    #[inline(always)]
    pub(crate) fn shared_shape(&self, inc: &Incident, li: usize) -> LobeShape {
        let res = &self.res;
        let recs = &inc.blend.rec[..inc.blend.n];
        let ws = &inc.blend.w[..inc.blend.n];
        let r0 = &res.recs[recs[0]];
        let l0 = res.lobe(r0, li);
        let single = recs.len() == 1;
        let geo = |i: usize| -> f64 {
            if single {
                return res.params[l0.par as usize + i] as f64;
            }
            let mut s = 0.0;
            for (&r, &w) in recs.iter().zip(ws) {
                s += w * res.ln_params[res.lobe(&res.recs[r], li).par as usize + i];
            }
            s.exp()
        };
        let lin = |i: usize| -> f64 {
            if single {
                return res.params[l0.par as usize + i] as f64;
            }
            let (mut wa, mut wsum) = (0.0, 0.0);
            for (&r, &w) in recs.iter().zip(ws) {
                wa += w * res.params[res.lobe(&res.recs[r], li).par as usize + i] as f64;
                wsum += w;
            }
            wa / wsum
        };
        let r32 = |v: f64| v as f32 as f64;
        match l0.kind {
            LobeKind::AngleGaussian => LobeShape {
                peak: self.blended_peak(recs, ws, (inc.theta, inc.phi)),
                p: [0.0; 6],
            },
            LobeKind::CosinePower => LobeShape {
                peak: self.blended_peak(recs, ws, (inc.theta, inc.phi)),
                p: [geo(0), 0.0, 0.0, 0.0, 0.0, 0.0],
            },
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => LobeShape {
                peak: [0.0; 3],
                p: [r32(geo(0)), r32(geo(1)), r32(lin(2)), 0.0, 0.0, 0.0],
            },
            LobeKind::MicrofacetAniso => LobeShape {
                peak: [0.0; 3],
                p: [
                    r32(geo(0)),
                    r32(geo(1)),
                    r32(geo(2)),
                    r32(lin(3)),
                    r32(lin(4)),
                    r32(self.blended_axis(recs, ws, li)),
                ],
            },
        }
    }

    /// The axis angle ψ (degrees) of the kind-5 lobe at position `li` blended from the records
    /// `recs` with weights `ws`: an axis, not a direction (ψ and ψ + 180° are one axis), so the
    /// doubled angles are averaged; perpendicular axes with equal weights keep the first
    /// record's (`spec/EVALUATION.md`, "Lobes by position").
    pub(crate) fn blended_axis(&self, recs: &[usize], ws: &[f64], li: usize) -> f64 {
        let res = &self.res;
        let psi = |r: usize| res.params[res.lobe(&res.recs[r], li).par as usize + 5] as f64;
        if recs.len() == 1 {
            return psi(recs[0]);
        }
        crate::model::angles::mean_axis_deg(recs.iter().zip(ws).map(|(&r, &w)| (w, psi(r))))
            .unwrap_or_else(|| psi(recs[0]))
    }

    /// The peak direction of a lobe blended from the records `recs` with weights `ws`, at the
    /// evaluation incidence (θ, φ) in degrees (`spec/EVALUATION.md`, "Blended peak direction").
    #[inline(always)]
    pub(crate) fn blended_peak(
        &self,
        recs: &[usize],
        ws: &[f64],
        incidence: (f64, f64),
    ) -> [f64; 3] {
        let res = &self.res;
        if recs.len() == 1 {
            return res.recs[recs[0]].peak;
        }
        if res.isotropic {
            // Records 1D in θ, one frame: the normalised weighted mean of their peaks.
            let mut v = [0.0; 3];
            for (&r, &w) in recs.iter().zip(ws) {
                for (vi, pi) in v.iter_mut().zip(res.recs[r].peak) {
                    *vi += w * pi;
                }
            }
            let n2 = dot(v, v);
            if n2 > 0.0 && n2.is_finite() {
                let s = 1.0 / n2.sqrt();
                return [v[0] * s, v[1] * s, v[2] * s];
            }
        }
        // Records at different azimuths: blend the offsets from each one's mirror direction.
        let (mut dt, mut dp) = (0.0, 0.0);
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &res.recs[r];
            let (mt, mp) = mirror_deg(rec.theta_i as f64, rec.phi_i as f64);
            // A peak at the pole has no azimuth: its offset is in θ alone.
            if rec.theta_p != 0.0 {
                dp += w * phi_delta(rec.phi_p as f64, mp);
            }
            dt += w * (rec.theta_p as f64 - mt);
        }
        let (mt, mp) = mirror_deg(incidence.0, incidence.1);
        dir_from_deg(mt + dt, mp + dp)
    }

    /// Computes the blended coefficients c_0..c_{T*−1} at the unit outgoing vector `wo` (records'
    /// frame) and passes them to `f`.
    #[inline]
    pub(crate) fn outgoing<R>(
        &self,
        inc: &Incident,
        wo: [f64; 3],
        f: impl FnOnce(&[f64]) -> R,
    ) -> R {
        self.with_coefficients(inc, None, wo, f)
    }

    /// [`Evaluator::coefficients`] into scratch arrays on the stack sized for the query (zeroing
    /// the format's maxima, 441 SH values and 256 terms, would cost more than the evaluation):
    /// SH level ≤ 2 and ≤ 8 terms, level ≤ 6 and ≤ 16 terms, or the maxima.
    #[inline(always)]
    pub(crate) fn with_coefficients<R>(
        &self,
        inc: &Incident,
        shapes: Option<&Shapes>,
        wo: [f64; 3],
        f: impl FnOnce(&[f64]) -> R,
    ) -> R {
        let t = inc.terms;
        if inc.level <= 2 && t <= 8 {
            let mut c = [0.0f64; 8];
            self.coefficients::<{ sh_count(2) }>(inc, shapes, wo, &mut c[..t]);
            f(&c[..t])
        } else if self.small {
            let mut c = [0.0f64; SMALL_TERMS];
            self.coefficients::<SMALL_SH>(inc, shapes, wo, &mut c[..t]);
            f(&c[..t])
        } else {
            let mut c = [0.0f64; MAX_TERMS];
            self.coefficients::<MAX_SH>(inc, shapes, wo, &mut c[..t]);
            f(&c[..t])
        }
    }

    /// c\[k\] += the blended coefficients at `wo`; `c` holds T* zeros. `shapes`, when given,
    /// holds [`Evaluator::shapes`] of `inc`.
    #[inline(always)]
    pub(crate) fn coefficients<const NSH: usize>(
        &self,
        inc: &Incident,
        shapes: Option<&Shapes>,
        wo: [f64; 3],
        c: &mut [f64],
    ) {
        let res = &self.res;
        let recs = &inc.blend.rec[..inc.blend.n];
        let ws = &inc.blend.w[..inc.blend.n];
        let mut y = [0.0f64; NSH];
        ShBasis::shared().eval_to_level(inc.level, wo, &mut y);
        // Term by term, every record's share summed in a register and written once.
        for (k, ck) in c.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (&r, &w) in recs.iter().zip(ws) {
                let rec = &res.recs[r];
                if k < rec.terms as usize {
                    let p = sh_count(rec.level as usize);
                    let at = rec.sh as usize + k * p;
                    acc += w * dot_f32(&res.vals[at..at + p], &y[..p]);
                }
            }
            *ck = acc;
        }
        // The microfacet geometry depends on the directions alone: computed at most once.
        let mut geometry = None;
        for li in 0..inc.nlobes {
            if inc.shared & (1 << li) != 0 {
                let kind = res.lobe(&res.recs[recs[0]], li).kind;
                let shape = &match shapes {
                    Some(s) => s[li],
                    None => self.shared_shape(inc, li),
                };
                match kind {
                    LobeKind::AngleGaussian => self.add_gaussian(c, recs, ws, li, wo, shape.peak),
                    _ => {
                        let (v, nv) = self.values(kind, shape, inc.wi, wo, &mut geometry);
                        self.add_amplitudes(c, recs, ws, li, &v[..nv]);
                    }
                }
            } else {
                for (&r, &w) in recs.iter().zip(ws) {
                    let rec = &res.recs[r];
                    if li >= rec.nlobes as usize {
                        continue;
                    }
                    let l = res.lobe(rec, li);
                    if l.kind == LobeKind::AngleGaussian {
                        self.add_gaussian(c, &[r], &[w], li, wo, rec.peak);
                        continue;
                    }
                    let stored = res.params(rec, l);
                    let mut shape = LobeShape {
                        peak: rec.peak,
                        p: [0.0; 6],
                    };
                    for (p, &v) in shape.p.iter_mut().zip(stored) {
                        *p = v as f64;
                    }
                    let (v, nv) = self.values(l.kind, &shape, inc.wi, wo, &mut geometry);
                    self.add_amplitudes(c, &[r], &[w], li, &v[..nv]);
                }
            }
        }
    }

    /// The values a lobe of kind 2, 3 or 4 multiplies its amplitudes by at `wo`: four variants,
    /// or the cosine power (one).
    #[inline(always)]
    pub(crate) fn values(
        &self,
        kind: LobeKind,
        shape: &LobeShape,
        wi: [f64; 3],
        wo: [f64; 3],
        geometry: &mut Option<Option<MicrofacetGeometry>>,
    ) -> ([f64; 4], usize) {
        match kind {
            LobeKind::CosinePower => {
                // The cosine is capped at 1: rounding can exceed it, and a large exponent would
                // turn 1 + ε into infinity. g^n as exp(n·ln g): powf's value to ~1e-15 relative,
                // and a little quicker.
                let g = dot(wo, shape.peak).min(1.0);
                let v = if g > 0.0 {
                    (shape.p[0] * g.ln()).exp()
                } else {
                    0.0 // 0ⁿ, without ln 0's division-by-zero trap
                };
                ([v, 0.0, 0.0, 0.0], 1)
            }
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                match *geometry.get_or_insert_with(|| MicrofacetGeometry::new(wi, wo)) {
                    Some(g) => (
                        g.variants_f64(
                            [shape.p[0], shape.p[1], shape.p[2]],
                            kind == LobeKind::MicrofacetSin2,
                        ),
                        4,
                    ),
                    None => ([0.0; 4], 4), // wi = −wo: every variant is 0
                }
            }
            LobeKind::MicrofacetAniso => {
                match *geometry.get_or_insert_with(|| MicrofacetGeometry::new(wi, wo)) {
                    Some(g) => (g.variants_aniso(shape.p, wi, wo), 4),
                    None => ([0.0; 4], 4),
                }
            }
            LobeKind::AngleGaussian => unreachable!("Gaussian lobes have per-term values"),
        }
    }

    /// Adds angle-Gaussian lobe `li` of the records `recs` (weights `ws`), with peak `peak`:
    /// per term, the amplitudes blended linearly and the widths geometrically over the records
    /// that have the term.
    pub(crate) fn add_gaussian(
        &self,
        c: &mut [f64],
        recs: &[usize],
        ws: &[f64],
        li: usize,
        wo: [f64; 3],
        peak: [f64; 3],
    ) {
        let res = &self.res;
        let a2 = angle_between(wo, peak).powi(2);
        if recs.len() == 1 {
            let rec = &res.recs[recs[0]];
            let l = res.lobe(rec, li);
            let (amp, width) = (res.amplitudes(rec, l, 0), res.params(rec, l));
            for ((ck, &p), &b) in c.iter_mut().zip(amp).zip(width) {
                *ck += ws[0] * (p as f64 * (-a2 / b as f64).exp());
            }
            return;
        }
        for (kk, ck) in c.iter_mut().enumerate() {
            let (mut lw, mut wsum, mut amp) = (0.0, 0.0, 0.0);
            for (&r, &w) in recs.iter().zip(ws) {
                let rec = &res.recs[r];
                if kk < rec.terms as usize {
                    let l = res.lobe(rec, li);
                    lw += w * res.ln_params[l.par as usize + kk];
                    wsum += w;
                    amp += w * res.vals[l.amp as usize + kk] as f64;
                }
            }
            if wsum > 0.0 {
                *ck += amp * (-a2 / (lw / wsum).exp()).exp();
            }
        }
    }

    /// c\[k\] += Σ_r w_r·Σ_j v\[j\]·amplitude_r\[j·T_r + k\] over the records (weights `ws`)
    /// that have term k: lobe `li`'s values `v`, evaluated once, weighted by every record's
    /// amplitudes; each c\[k\] is summed in a register and written once.
    #[inline(always)]
    fn add_amplitudes(&self, c: &mut [f64], recs: &[usize], ws: &[f64], li: usize, v: &[f64]) {
        let res = &self.res;
        let nv = v.len();
        // Per record: w·v_j, where its amplitudes start, and its terms.
        let mut scaled = [[0.0f64; 4]; 4];
        let mut start = [0usize; 4];
        let mut terms = [0usize; 4];
        for (i, (&r, &w)) in recs.iter().zip(ws).enumerate() {
            let rec = &res.recs[r];
            start[i] = res.lobe(rec, li).amp as usize;
            terms[i] = rec.terms as usize;
            for (s, &vj) in scaled[i].iter_mut().zip(v) {
                *s = w * vj;
            }
        }
        let n = recs.len();
        for (k, ck) in c.iter_mut().enumerate() {
            let mut acc = 0.0;
            for i in 0..n {
                let t = terms[i];
                if k < t {
                    let amp = &res.vals[start[i] + k..start[i] + k + (nv - 1) * t + 1];
                    for (j, &s) in scaled[i][..nv].iter().enumerate() {
                        acc += s * amp[j * t] as f64;
                    }
                }
            }
            *ck += acc;
        }
    }
}

/// Σ a\[k\]·b\[k\] in order: a record's few spectral terms at one wavelength.
#[inline(always)]
pub(crate) fn dot_terms(a: &[f32], b: &[f64]) -> f64 {
    let mut s = 0.0;
    for (x, y) in a.iter().zip(b) {
        s += *x as f64 * y;
    }
    s
}

/// Σ a\[j\]·b\[j\] in four interleaved partial sums: one running sum would make every
/// addition wait for the last (a level-6 record has 49 terms per coefficient).
#[inline(always)]
pub(crate) fn dot_f32(a: &[f32], b: &[f64]) -> f64 {
    let (mut s0, mut s1, mut s2, mut s3) = (0.0, 0.0, 0.0, 0.0);
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ar, br) = (a4.remainder(), b4.remainder());
    for (x, y) in a4.zip(b4) {
        s0 += x[0] as f64 * y[0];
        s1 += x[1] as f64 * y[1];
        s2 += x[2] as f64 * y[2];
        s3 += x[3] as f64 * y[3];
    }
    for (x, y) in ar.iter().zip(br) {
        s0 += *x as f64 * y;
    }
    (s0 + s1) + (s2 + s3)
}

/// The file's wavelengths as interpolation nodes: a wavelength's bracket (j, a), value =
/// (1 − a)·v_j + a·v_{j+1}, λ clamped to the nodes' range.
#[derive(Debug, Clone)]
pub(crate) struct WavelengthNodes {
    nodes: Vec<f64>,
}

impl WavelengthNodes {
    fn new(w: &[f32]) -> Self {
        WavelengthNodes {
            nodes: w.iter().map(|&v| v as f64).collect(),
        }
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
        let j = n.partition_point(|&x| x <= l) - 1;
        (j, (l - n[j]) / (n[j + 1] - n[j]))
    }
}
