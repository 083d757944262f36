//! The kernel's computation of one pair for a baked view (`crate::decode::baked`): the same
//! groups, blend weights, θ clamp, peak blend and lobe formulas (`model::lobes`) as
//! [`Kernel::one_collapsed`], with each record's SH part given (the view's grids), the shared
//! shapes blended ahead ([`ShapeSteps`]: `blend_shape` at evenly spaced weights, read back
//! linearly) and θi read from a table ([`polar_table`]): what takes the blend's exponentials
//! and the polar polynomial off the query's longest chain of dependent operations. Approximate
//! by design: the baked view holds its values to the tolerance it was asked for.

use super::formulas::{Frame, LINE_LOBES};
use super::groups::{Collapsed, Kernel, Op, Stored};
use crate::decode::records::resident::Resident;
use crate::model::angles::{azimuth_rotation, rotate_about_z, unit_lanes};
use crate::model::lanes::{Lanes, Mask};
use crate::model::lobes::{
    blend_peak, blend_shape, cosine_power, shape_rule, MicrofacetGeometry, ParamBlend,
};
use crate::model::material::LobeKind;

/// Nodes of [`polar_table`]'s table over u in [0, 1].
const POLAR_NODES: usize = 1024;

/// θ in degrees of an incident direction with horizontal length r and height z ≥ 0 (r + z >
/// 0), from u = r/(r + z): θ = atan(u/(1 − u)) read from a table of 1025 nodes, linearly.
/// Its second derivative is below 2.6 in u, so the table is within (1/1024)²/8·2.6 rad
/// (2·10⁻⁵ degrees) of the exact angle: where a query falls between stored incidences moves by
/// less than 10⁻⁵ of their spacing, with one division and no polynomial on the query's longest
/// chain. (`model::angles::polar_deg` is the exact route's, to 1.4·10⁻⁸ rad.)
#[inline(always)]
fn polar_table(r: f64, z: f64) -> f64 {
    static TABLE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..=POLAR_NODES)
            .map(|i| {
                let u = i as f64 / POLAR_NODES as f64;
                u.atan2(1.0 - u).to_degrees()
            })
            .collect()
    });
    let x = r / (r + z) * POLAR_NODES as f64;
    let i = (x as usize).min(POLAR_NODES - 1);
    let f = x - i as f64;
    match table.get(i..i + 2) {
        Some(v) => v[0] + f * (v[1] - v[0]),
        None => 0.0,
    }
}

/// The frame step of [`super::formulas::frame`] (`unit_lanes`, `azimuth_rotation`,
/// `rotate_about_z`) with θ from [`polar_table`]; None where
/// either vector is not normalisable or below the surface.
#[inline(always)]
fn frame32(wi: [f32; 3], wo: [f32; 3]) -> Option<Frame<1>> {
    let (wi, ok_i) = unit_lanes(wi.map(f64::from));
    let (wo, ok_o) = unit_lanes(wo.map(f64::from));
    if !(ok_i && ok_o && wi[2] >= 0.0 && wo[2] >= 0.0) {
        return None;
    }
    let (r, c, s) = azimuth_rotation(wi);
    let wo = rotate_about_z(wo, (c, s));
    let lane = |v: f64| Lanes([v]);
    Some(Frame {
        valid: Mask([true]),
        r: lane(r),
        z: lane(wi[2]),
        theta: Lanes([polar_table(r, wi[2])]),
        wo: wo.map(lane),
    })
}

/// Every group's lobe shapes blended at weights t = k/K, k = 0..=K (`blend_shape`, in
/// binary64, rounded to binary32 as it rounds them): a query between two steps reads the two
/// and interpolates linearly. Against blending at the query's own t, a geometric parameter's
/// relative error is at most (Δ ln p)²/8 for Δ ln p its change over one step.
#[derive(Debug, Clone)]
pub(crate) struct ShapeSteps {
    steps: usize,
    /// [((g·OPS + op)·(K + 1) + k)·3 + j]: parameter j of group g's operation op at step k.
    values: Vec<f32>,
}

/// Lobe operations a group holds.
const OPS: usize = 2 * LINE_LOBES;

impl ShapeSteps {
    /// The shapes of `kernel`'s groups at `steps` + 1 weights (`steps` ≥ 1).
    pub(crate) fn new(kernel: &Kernel, res: &Resident, steps: usize) -> Self {
        let steps = steps.max(1);
        let mut values = vec![0.0f32; kernel.groups.len() * OPS * (steps + 1) * 3];
        for (g, group) in kernel.groups.iter().enumerate() {
            let (r0, count) = kernel.records(g);
            for (o, op) in group.ops.iter().enumerate() {
                let Some((first, slots, li, kind)) = unpack(*op, count) else {
                    break;
                };
                let pars = params_of(kernel, r0, count, first, li);
                for k in 0..=steps {
                    let t = k as f64 / steps as f64;
                    let w = if count == 2 { [1.0 - t, t] } else { [1.0, 0.0] };
                    let p = blend_shape(
                        kind,
                        &w[..slots],
                        |i, j| res.params[pars[i] + j] as f64,
                        |i, j| res.ln_params[pars[i] + j],
                        || 0.0,
                    );
                    let at = ((g * OPS + o) * (steps + 1) + k) * 3;
                    for (v, p) in values[at..at + 3].iter_mut().zip(p) {
                        *v = p as f32;
                    }
                }
            }
        }
        ShapeSteps { steps, values }
    }

    /// The largest change of a geometric parameter's logarithm over one step, of any group:
    /// what bounds the steps' error.
    pub(crate) fn widest_log_step(kernel: &Kernel, res: &Resident) -> f64 {
        let mut widest = 0.0f64;
        for (g, group) in kernel.groups.iter().enumerate() {
            let (r0, count) = kernel.records(g);
            for op in group.ops {
                let Some((first, slots, li, kind)) = unpack(op, count) else {
                    break;
                };
                if slots == 2 {
                    let pars = params_of(kernel, r0, count, first, li);
                    for (j, how) in shape_rule(kind).params.iter().enumerate() {
                        if *how != ParamBlend::Geometric {
                            continue;
                        }
                        let ln = |i: usize| res.ln_params.get(pars[i] + j).copied();
                        let d = match (ln(0), ln(1)) {
                            (Some(a), Some(b)) => (b - a).abs(),
                            _ => f64::INFINITY,
                        };
                        widest = widest.max(if d.is_finite() { d } else { f64::INFINITY });
                    }
                }
            }
        }
        widest
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.values.capacity() * std::mem::size_of::<f32>()
    }

    /// Group g's operation o's shape at weight t in [0, 1].
    #[inline(always)]
    fn at(&self, g: usize, o: usize, t: f64) -> [f64; 3] {
        let x = t * self.steps as f64;
        let k = (x as usize).min(self.steps - 1);
        let f = x - k as f64;
        let at = ((g * OPS + o) * (self.steps + 1) + k) * 3;
        match self.values.get(at..at + 6) {
            Some(v) => std::array::from_fn(|j| v[j] as f64 + f * (v[j + 3] as f64 - v[j] as f64)),
            None => [0.0; 3],
        }
    }
}

/// An operation's first record slot, records, lobe position and kind (None: no more).
#[inline(always)]
fn unpack(op: Op, count: usize) -> Option<(usize, usize, usize, LobeKind)> {
    match op {
        Op::None => None,
        Op::Shared { li, kind } => Some((0, count, (li as usize).min(LINE_LOBES - 1), kind)),
        Op::Own { slot, li, kind } => {
            Some((slot as usize, 1, (li as usize).min(LINE_LOBES - 1), kind))
        }
    }
}

/// Where the parameters of the one or two records an operation reads start.
#[inline(always)]
fn params_of(kernel: &Kernel, r0: usize, count: usize, first: usize, li: usize) -> [usize; 2] {
    [
        kernel.recs[r0 + first].par[li] as usize,
        kernel.recs[r0 + count - 1].par[li] as usize,
    ]
}

/// ρ for one pair at the wavelength `c` was collapsed at, clamped at 0, with `sh(r0, count,
/// ωo)` the SH parts of records r0..r0 + count at ωo (in the records' frame); None for a pair
/// the kernel leaves to the general path.
#[inline(always)]
pub(crate) fn one_baked(
    kernel: &Kernel,
    st: Stored,
    wi: [f32; 3],
    wo: [f32; 3],
    c: &Collapsed,
    shapes: &ShapeSteps,
    sh: impl Fn(usize, usize, [f64; 3]) -> [f64; 2],
) -> Option<f32> {
    let Some(f) = frame32(wi, wo) else {
        return Some(0.0); // below the horizon or not normalisable
    };
    let (g, t) = kernel.group_of(st.axis, f.theta.0[0]);
    if !kernel.groups[g].fast {
        return None;
    }
    let (r0, count) = kernel.records(g);
    let q = kernel.query(st.ends, g, &f, [t]);
    let one = |v: [Lanes<1>; 3]| v.map(|c| c.0[0]);
    let (qi, qo) = (one(q.wi), one(q.wo));
    let w = [q.w[0].0[0], q.w[1].0[0]];
    let s = sh(r0, count, qo);
    let sh_part = if count == 2 {
        w[0] * s[0] + w[1] * s[1]
    } else {
        s[0]
    };
    let lobes = lobes(kernel, st.res, g, (w, t), qi, qo, c, shapes);
    Some((sh_part + lobes).max(0.0) as f32)
}

/// Group g's lobes at incidence `wi` and outgoing `wo` (records' frame), each record's
/// weighted by its blend weight `w` (the second's t).
///
/// This walk mirrors [`Kernel::value`]'s on purpose, in plain binary64 rather than its
/// `Lanes<1>`: `Lanes::exp`/`ln` are branch-free for the batch's vectors and bit-identical
/// across widths, which the exact route needs and this view does not; the C library's scalar
/// `exp`/`ln` are faster here. Calling `Kernel::value` with the shapes supplied (tried) gave the
/// same values within 10⁻⁷ and made the GGX view 84 → 163 ns a query (table 74 ns).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn lobes(
    kernel: &Kernel,
    res: &Resident,
    g: usize,
    (w, t): ([f64; 2], f64),
    wi: [f64; 3],
    wo: [f64; 3],
    c: &Collapsed,
    shapes: &ShapeSteps,
) -> f64 {
    let (r0, count) = kernel.records(g);
    // A record's share of ρ: its blend weight (1 for a record alone).
    let share = |slot: usize| if count == 2 { w[slot] } else { 1.0 };
    let mut sum = 0.0;
    let mut geometry: Option<MicrofacetGeometry> = None;
    for (o, op) in kernel.groups[g].ops.into_iter().enumerate() {
        let Some((first, slots, li, kind)) = unpack(op, count) else {
            break;
        };
        let p = shapes.at(g, o, t);
        if kind == LobeKind::CosinePower {
            let peak = if slots == 2 {
                let peaks = [res.recs[r0].peak, res.recs[r0 + 1].peak];
                blend_peak([(w[0], peaks[0]), (w[1], peaks[1])]).0
            } else {
                res.recs[r0 + first].peak
            };
            let v = cosine_power(p[0], wo, peak);
            for slot in first..first + slots {
                sum += share(slot) * (v * c.amps(r0 + slot)[4 * li]);
            }
            continue;
        }
        let gm = *geometry.get_or_insert_with(|| MicrofacetGeometry::at(wi, wo));
        let v = gm.variants_of(p[0], p[1], p[2], kind == LobeKind::MicrofacetSin2);
        for slot in first..first + slots {
            let a = &c.amps(r0 + slot)[4 * li..4 * li + 4];
            let d = v[0] * a[0] + v[1] * a[1] + v[2] * a[2] + v[3] * a[3];
            sum += share(slot) * d;
        }
    }
    sum
}
