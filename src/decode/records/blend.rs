//! How the records a query blends combine: what they share ([`BlendInfo`]), the incident side
//! of a query ([`Incident`]), and each shared lobe's blended shape ([`shared_shape`], by the
//! kind's rule in `model::lobes::blend_shape`; `spec/EVALUATION.md`, "Between stored
//! incidences", "Blended peak direction", "Lobes by position"), read from the resident arrays.

use super::lattice::Blend;
use super::resident::Resident;
use crate::model::angles::{dir_from_deg, mirror_deg, phi_delta};
use crate::model::lobes::{blend_peak, blend_shape, shape_rule};
use crate::model::material::MAX_LOBES;

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
    pub(crate) fn of(res: &Resident, recs: &[usize]) -> Self {
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

/// Every shared lobe's blended shape into `shapes`, for reuse over a run of pairs.
pub(crate) fn shapes(res: &Resident, inc: &Incident, shapes: &mut Shapes) {
    for (li, s) in shapes.iter_mut().enumerate().take(inc.nlobes) {
        if inc.shared & (1 << li) != 0 {
            *s = shared_shape(res, inc, li);
        }
    }
}

/// The blended shape of the shared lobe at position `li`: its parameters by the kind's rule
/// ([`blend_shape`]), the axis by [`blended_axis`], the peak direction by "Blended peak
/// direction".
#[inline(always)]
pub(crate) fn shared_shape(res: &Resident, inc: &Incident, li: usize) -> LobeShape {
    let recs = &inc.blend.rec[..inc.blend.n];
    let ws = &inc.blend.w[..inc.blend.n];
    let kind = res.lobe(&res.recs[recs[0]], li).kind;
    let p = blended_params(res, recs, ws, li);
    LobeShape {
        peak: if shape_rule(kind).peak {
            blended_peak(res, recs, ws, (inc.theta, inc.phi))
        } else {
            [0.0; 3]
        },
        p,
    }
}

/// The parameters of the lobe at position `li` blended from the records `recs` with weights
/// `ws` (the lobe shared by all of them, or one record's own with weight 1), by its kind's rule
/// ([`blend_shape`]; the axis by [`blended_axis`]): what evaluation and the sampler's proposal
/// both blend.
#[inline(always)]
pub(crate) fn blended_params(res: &Resident, recs: &[usize], ws: &[f64], li: usize) -> [f64; 6] {
    let kind = res.lobe(&res.recs[recs[0]], li).kind;
    let par = |i: usize| res.lobe(&res.recs[recs[i]], li).par as usize;
    blend_shape(
        kind,
        ws,
        |i, j| res.params[par(i) + j] as f64,
        |i, j| res.ln_params[par(i) + j],
        || blended_axis(res, recs, ws, li),
    )
}

/// The axis angle ψ (degrees) of the kind-5 lobe at position `li` blended from the records
/// `recs` with weights `ws`: an axis, not a direction (ψ and ψ + 180° are one axis), so the
/// doubled angles are averaged; perpendicular axes with equal weights keep the first
/// record's (`spec/EVALUATION.md`, "Lobes by position").
pub(crate) fn blended_axis(res: &Resident, recs: &[usize], ws: &[f64], li: usize) -> f64 {
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
    res: &Resident,
    recs: &[usize],
    ws: &[f64],
    incidence: (f64, f64),
) -> [f64; 3] {
    if recs.len() == 1 {
        return res.recs[recs[0]].peak;
    }
    if res.isotropic {
        // Records 1D in θ, one frame: the normalised weighted mean of their peaks.
        let (peak, ok) = blend_peak(recs.iter().zip(ws).map(|(&r, &w)| (w, res.recs[r].peak)));
        if ok {
            return peak;
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
