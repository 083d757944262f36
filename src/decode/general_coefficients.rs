//! The general path: the blended coefficients c_0..c_{T*−1} at an outgoing direction, for any
//! lattice and any lobe kind (`spec/EVALUATION.md`, "Reconstruction"), which `eval` takes for
//! several wavelengths off the θ line and the batch for runs of pairs.

use super::blend::{Incident, LobeShape, Shapes};
use super::evaluator::{Evaluator, SMALL_SH, SMALL_TERMS};
use super::sums::dot_f32;
use crate::model::angles::angle_between;
use crate::model::lobes::lobe_values;
use crate::model::material::{LobeKind, MAX_TERMS};
use crate::model::sh::{sh_count, ShBasis, MAX_SH_LEVEL};

const MAX_SH: usize = sh_count(MAX_SH_LEVEL);

impl Evaluator {
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
                    None => self.res.shared_shape(inc, li),
                };
                match kind {
                    LobeKind::AngleGaussian => self.add_gaussian(c, recs, ws, li, wo, shape.peak),
                    _ => {
                        let (v, nv) =
                            lobe_values(kind, &shape.p, shape.peak, inc.wi, wo, &mut geometry);
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
                    let (v, nv) =
                        lobe_values(l.kind, &shape.p, shape.peak, inc.wi, wo, &mut geometry);
                    self.add_amplitudes(c, &[r], &[w], li, &v[..nv]);
                }
            }
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
