//! One wavelength off the θ line: the general machinery (any lattice, Gaussian and anisotropic
//! lobes, lobes not shared by the blended records) with the terms summed before the records,
//! Σ_r w_r·Σ_k B_k·(…), so that no coefficient vector is formed ("Rounding" in
//! `spec/EVALUATION.md`). `eval` and the batch take it for one wavelength when the file is not on
//! the θ-line path (`super::theta_line`) and has no factor model.

use super::blend::{Incident, LobeShape, Shapes};
use super::evaluator::{Evaluator, SMALL_SH, SMALL_TERMS};
use super::sums::dot_terms;
use crate::model::lobes::lobe_values;
use crate::model::material::LobeKind;
use crate::model::sh::{sh_count, ShBasis};

impl Evaluator {
    /// Whether a query at incidence `inc` takes [`Evaluator::value_at`] for one wavelength: no
    /// factor model, and the small arrays suffice.
    #[inline(always)]
    pub(crate) fn one_wavelength(&self, inc: &Incident) -> bool {
        self.res.factor.is_none() && inc.terms <= SMALL_TERMS && inc.level <= 6
    }

    /// ρ at one wavelength before the clamp, from that wavelength's basis values `b`
    /// (B_0..B_{T*−1}): each record's terms weighted by w_r·B_k before its sums, so no
    /// coefficient vector is formed (terms before records: "Rounding"). `shapes`, when given,
    /// holds [`Evaluator::shapes`] of `inc`. The caller checked
    /// [`Evaluator::one_wavelength`].
    #[inline(always)]
    pub(crate) fn value_at(
        &self,
        inc: &Incident,
        shapes: Option<&Shapes>,
        wo: [f64; 3],
        b: &[f64],
    ) -> f64 {
        // The SH values on the stack, sized for the query: zeroing 49 for a level-0 record
        // would cost more than its evaluation.
        if inc.level <= 2 {
            self.value_at_sized::<{ sh_count(2) }>(inc, shapes, wo, b)
        } else {
            self.value_at_sized::<SMALL_SH>(inc, shapes, wo, b)
        }
    }

    #[inline(always)]
    fn value_at_sized<const NSH: usize>(
        &self,
        inc: &Incident,
        shapes: Option<&Shapes>,
        wo: [f64; 3],
        b: &[f64],
    ) -> f64 {
        let res = &self.res;
        let recs = &inc.blend.rec[..inc.blend.n];
        let ws = &inc.blend.w[..inc.blend.n];
        let mut y = [0.0f64; NSH];
        ShBasis::shared().eval_to_level(inc.level, wo, &mut y);
        let mut acc = 0.0;
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &res.recs[r];
            acc += w * if inc.level == 0 {
                // Level 0 (records whose shape is all lobe): one SH function.
                let t = rec.terms as usize;
                dot_terms(&res.vals[rec.sh as usize..rec.sh as usize + t], &b[..t]) * y[0]
            } else {
                self.sh_sum(rec, &y, b)
            };
        }
        let mut geometry = None;
        for li in 0..inc.nlobes {
            if inc.shared & (1 << li) != 0 {
                let kind = res.lobe(&res.recs[recs[0]], li).kind;
                let shape = &match shapes {
                    Some(s) => s[li],
                    None => self.res.shared_shape(inc, li),
                };
                acc += match kind {
                    LobeKind::AngleGaussian => {
                        let mut c = [0.0f64; SMALL_TERMS];
                        let c = &mut c[..b.len()];
                        self.add_gaussian(c, recs, ws, li, wo, shape.peak);
                        c.iter().zip(b).map(|(c, b)| c * b).sum::<f64>()
                    }
                    _ => {
                        let (v, nv) =
                            lobe_values(kind, &shape.p, shape.peak, inc.wi, wo, &mut geometry);
                        self.amplitudes_at(recs, ws, li, &v[..nv], b)
                    }
                };
            } else {
                for (&r, &w) in recs.iter().zip(ws) {
                    let rec = &res.recs[r];
                    if li >= rec.nlobes as usize {
                        continue;
                    }
                    let l = res.lobe(rec, li);
                    if l.kind == LobeKind::AngleGaussian {
                        let mut c = [0.0f64; SMALL_TERMS];
                        let c = &mut c[..b.len()];
                        self.add_gaussian(c, &[r], &[w], li, wo, rec.peak);
                        acc += c.iter().zip(b).map(|(c, b)| c * b).sum::<f64>();
                        continue;
                    }
                    let mut shape = LobeShape {
                        peak: rec.peak,
                        p: [0.0; 6],
                    };
                    for (p, &v) in shape.p.iter_mut().zip(res.params(rec, l)) {
                        *p = v as f64;
                    }
                    let (v, nv) =
                        lobe_values(l.kind, &shape.p, shape.peak, inc.wi, wo, &mut geometry);
                    acc += self.amplitudes_at(&[r], &[w], li, &v[..nv], b);
                }
            }
        }
        acc
    }

    /// Σ_r w_r·Σ_j v\[j\]·Σ_k B_k·amplitude_r\[j·T_r + k\]: lobe `li`'s values `v` weighted by
    /// every record's amplitudes at one wavelength (basis values `b`).
    #[inline(always)]
    fn amplitudes_at(&self, recs: &[usize], ws: &[f64], li: usize, v: &[f64], b: &[f64]) -> f64 {
        let res = &self.res;
        let mut acc = 0.0;
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &res.recs[r];
            let t = rec.terms as usize;
            let start = res.lobe(rec, li).amp as usize;
            let amp = &res.vals[start..start + v.len() * t];
            let mut sum = 0.0;
            for (row, &vj) in amp.chunks_exact(t).zip(v) {
                sum += vj * dot_terms(row, &b[..t]);
            }
            acc += w * sum;
        }
        acc
    }
}
