//! The kernel's computation of one pair for a baked view (`crate::decode::baked`): the same
//! groups, blend weights, θ clamp, peak blend and lobe formulas (`model::lobes`) as
//! [`Kernel::one_collapsed`], with each record's SH part given (the view's grids), the shared
//! shapes blended ahead ([`BakedLobes`]: `blend_shape` at evenly spaced weights, read back
//! linearly) and θi read from a table ([`polar_table`]): what takes the blend's exponentials
//! and the polar polynomial off the query's longest chain of dependent operations; the lobes'
//! powers are [`super::power`]'s, which make no library call. Approximate
//! by design: the baked view holds its values to the tolerance it was asked for.

use super::formulas::{Frame, LINE_LOBES};
use super::groups::{Collapsed, Kernel, Op, Stored};
use super::power::Power;
use crate::decode::records::resident::Resident;
use crate::model::angles::{azimuth_rotation, dot, rotate_about_z, unit_scale_lanes};
use crate::model::lanes::{min_or_first, Lanes, Mask};
use crate::model::lobes::{blend_peak, blend_shape, shape_rule, MicrofacetGeometry, ParamBlend};
use crate::model::material::LobeKind;

/// Nodes of [`polar_table`]'s table of asin over [0, 1/√2].
const POLAR_NODES: usize = 1024;

/// θ in degrees of a unit incident direction with horizontal length r and height z ≥ 0 (r² +
/// z² = 1), with no division: asin of the smaller of r and z read from a table of 1025 nodes
/// over [0, 1/√2], linearly (θ = asin r where r ≤ z, else 90° − asin z). There asin'' ≤ 2.0,
/// so the table is within (0.7072/1024)²/8·2.0 rad (7·10⁻⁶ degrees) of the exact angle: where
/// a query falls between stored incidences moves by less than 10⁻⁵ of their spacing.
/// (`model::angles::polar_deg` is the exact route's, to 1.4·10⁻⁸ rad.)
#[inline(always)]
fn polar_table(r: f64, z: f64) -> f64 {
    static TABLE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..=POLAR_NODES)
            .map(|i| {
                (i as f64 / POLAR_NODES as f64 * SQRT_HALF)
                    .asin()
                    .to_degrees()
            })
            .collect()
    });
    let small = min_or_first(z, r); // r where it is the smaller (both are numbers here)
    let x = small * (POLAR_NODES as f64 / SQRT_HALF);
    let i = (x as u32 as usize).min(POLAR_NODES - 1); // u32: fewer instructions than usize
    let f = x - i as f64;
    let a = match table.get(i..i + 2) {
        Some(v) => v[0] + f * (v[1] - v[0]),
        None => 0.0,
    };
    if r <= z {
        a
    } else {
        90.0 - a
    }
}

const SQRT_HALF: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The factor that scales `v` to unit length, None where there is none (length 0 or not
/// finite). Within 2⁻²⁰ of unit length (what a renderer passes) by one Newton step from 1,
/// 1/|v| ≈ (3 − |v|²)/2: within 3/8·2⁻⁴⁰ (4·10⁻¹³) of it with no square root or division, the
/// divider's work that a query waits on; elsewhere 1/|v| as the exact route forms it
/// ([`unit_scale_lanes`]).
#[inline(always)]
fn unit_scale(v: [f64; 3]) -> Option<f64> {
    let n2 = dot(v, v);
    if (n2 - 1.0).abs() <= 1.0 / 1_048_576.0 {
        return Some(1.5 - 0.5 * n2);
    }
    let (s, ok) = unit_scale_lanes(v);
    ok.then_some(s)
}

/// The frame step of [`super::formulas::frame`] (`unit_lanes`, `azimuth_rotation`,
/// `rotate_about_z`) with unit lengths from [`unit_scale`] and θ from [`polar_table`]; None
/// where either vector is not normalisable or below the surface. The rotation about z is the
/// same for a vector and its unit multiple, so it is taken from `wi` as given and its
/// horizontal length scaled after: the square root that θ waits on starts with the query
/// rather than after the scale.
#[inline(always)]
fn frame32(wi: [f32; 3], wo: [f32; 3]) -> Option<Frame<1>> {
    let (wi, wo) = (wi.map(f64::from), wo.map(f64::from));
    let (si, so) = (unit_scale(wi)?, unit_scale(wo)?);
    if !(wi[2] >= 0.0 && wo[2] >= 0.0) {
        return None;
    }
    let (r, c, s) = azimuth_rotation(wi);
    let (r, z) = (r * si, wi[2] * si);
    let wo = rotate_about_z(wo.map(|v| v * so), (c, s));
    let lane = |v: f64| Lanes([v]);
    Some(Frame {
        valid: Mask([true]),
        r: lane(r),
        z: lane(z),
        theta: Lanes([polar_table(r, z)]),
        wo: wo.map(lane),
    })
}

/// Every group's lobe operations resolved at bake time, in the order [`Kernel::value`] walks
/// them: each one's kind, its shapes blended at weights t = k/K, k = 0..=K (`blend_shape`, in
/// binary64, rounded to binary32 as it rounds them; a query between two steps reads the two and
/// interpolates linearly), and its amplitudes at the view's wavelength per record slot, so that
/// a query reads one short list with no operation to decode. Against blending at the query's own
/// t, a geometric parameter's relative error is at most (Δ ln p)²/8 for Δ ln p its change over
/// one step.
#[derive(Debug, Clone)]
pub(crate) struct BakedLobes {
    steps: usize,
    /// [i·(K + 1) + k][j]: parameter j of operation i at step k (binary32 values, held widened:
    /// a query reads them with no conversion).
    values: Vec<[f64; 3]>,
    /// The operations, group by group.
    ops: Vec<BakedOp>,
    /// Group g's operations: ops[starts[g]..starts[g + 1]].
    starts: Vec<usize>,
    /// The lobes' powers (D's, a cosine power's) without library calls.
    power: &'static Power,
}

/// One lobe operation of a group: ρ += w₀·(v·amps[0]) + w₁·(v·amps[1]) for the group's blend
/// weights (w₀, w₁) ((1, 0) for a record alone) and v its variants (a cosine power's one value
/// in slot 0).
#[derive(Debug, Clone, Copy)]
struct BakedOp {
    kind: LobeKind,
    slots: usize,
    amps: [[f64; 4]; 2],
    /// A cosine power's peak directions: of the first record it reads and, where it blends two,
    /// the second (copied here so that a query reads no record).
    peaks: [[f64; 3]; 2],
}

impl BakedLobes {
    /// The lobes of `kernel`'s groups with shapes at `steps` + 1 weights (`steps` ≥ 1) and
    /// amplitudes from `c` (the records collapsed at the view's wavelength).
    pub(crate) fn new(kernel: &Kernel, res: &Resident, c: &Collapsed, steps: usize) -> Self {
        let steps = steps.max(1);
        let (mut values, mut ops, mut starts) = (Vec::new(), Vec::new(), vec![0]);
        for (g, group) in kernel.groups.iter().enumerate() {
            let (r0, count) = kernel.records(g);
            for op in group.ops {
                let Some((first, slots, li, kind)) = unpack(op, count) else {
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
                    // The isotropic kinds' three parameters (b, c, a; a cosine power's n).
                    values.push([p[0], p[1], p[2]].map(|p| p as f32 as f64));
                }
                let mut amps = [[0.0; 4]; 2];
                let n = if kind == LobeKind::CosinePower { 1 } else { 4 };
                for (slot, to) in amps.iter_mut().enumerate().skip(first).take(slots) {
                    to[..n].copy_from_slice(&c.amps(r0 + slot)[4 * li..4 * li + n]);
                }
                let peak = |slot: usize| res.recs.get(r0 + slot).map_or([0.0; 3], |r| r.peak);
                ops.push(BakedOp {
                    kind,
                    slots,
                    amps,
                    peaks: [peak(first), peak(first + slots - 1)],
                });
            }
            starts.push(ops.len());
        }
        BakedLobes {
            steps,
            values,
            ops,
            starts,
            power: Power::tables(),
        }
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
        self.values.capacity() * std::mem::size_of::<[f64; 3]>()
            + self.ops.capacity() * std::mem::size_of::<BakedOp>()
            + self.starts.capacity() * std::mem::size_of::<usize>()
    }

    /// Operation i's shape at weight t in [0, 1].
    #[inline(always)]
    fn shape(&self, i: usize, t: f64) -> [f64; 3] {
        let x = t * self.steps as f64;
        // t ∈ [0, 1]: through u32, which converts in fewer instructions than usize.
        let k = (x as u32 as usize).min(self.steps - 1);
        let f = x - k as f64;
        let at = i * (self.steps + 1) + k;
        match (self.values.get(at), self.values.get(at + 1)) {
            (Some(a), Some(b)) => [
                a[0] + f * (b[0] - a[0]),
                a[1] + f * (b[1] - a[1]),
                a[2] + f * (b[2] - a[2]),
            ],
            _ => [0.0; 3],
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

/// ρ for one pair at the wavelength `baked` was made at, clamped at 0, with `sh(r0, count,
/// ωo)` the SH parts of records r0..r0 + count at ωo (in the records' frame); None for a pair
/// the kernel leaves to the general path.
#[inline(always)]
pub(crate) fn one_baked(
    kernel: &Kernel,
    st: Stored,
    wi: [f32; 3],
    wo: [f32; 3],
    baked: &BakedLobes,
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
    let lobes = lobes(g, (w, t), (qi, qo), baked);
    Some((sh_part + lobes).max(0.0) as f32)
}

/// Group g's lobes at incidence `wi` and outgoing `wo` (records' frame), each record's
/// weighted by its blend weight `w` (the second's t).
///
/// This walk mirrors [`Kernel::value`]'s on purpose, in plain binary64 rather than its
/// `Lanes<1>`, over the operations resolved at bake time ([`BakedLobes`]): `Lanes::exp`/`ln`
/// are branch-free for the batch's vectors and bit-identical across widths, which the exact
/// route needs and this view does not. Calling `Kernel::value` with the shapes supplied (tried)
/// gave the same values within 10⁻⁷ and made the GGX view 84 → 163 ns a query (table 74 ns).
/// The powers come from [`Power`] (tables, short polynomials, no library call): against the C
/// library's `ln` and `exp`, 81 → 73 ns on GGX beside a 136 ns table (AMD EPYC).
#[inline(always)]
fn lobes(
    g: usize,
    (w, t): ([f64; 2], f64),
    (wi, wo): ([f64; 3], [f64; 3]),
    baked: &BakedLobes,
) -> f64 {
    let (Some(&start), Some(&end)) = (baked.starts.get(g), baked.starts.get(g + 1)) else {
        return 0.0;
    };
    let Some(ops) = baked.ops.get(start..end) else {
        return 0.0;
    };
    let mut sum = 0.0;
    let mut geometry: Option<MicrofacetGeometry> = None;
    for (i, op) in (start..).zip(ops) {
        let p = baked.shape(i, t);
        if op.kind == LobeKind::CosinePower {
            let peak = if op.slots == 2 {
                blend_peak([(w[0], op.peaks[0]), (w[1], op.peaks[1])]).0
            } else {
                op.peaks[0]
            };
            // `cosine_power`'s g^n (g capped at 1, 0 where g ≤ 0); one value, its amplitudes'
            // blend alone.
            let g = dot(wo, peak);
            let g = min_or_first(1.0, g); // g where it is below 1
            let v = if g > 0.0 {
                baked.power.pow(g, p[0])
            } else {
                0.0
            };
            sum += v * (w[0] * op.amps[0][0] + w[1] * op.amps[1][0]);
        } else {
            let gm = match geometry {
                Some(gm) => gm,
                None => match MicrofacetGeometry::at_one_division(wi, wo) {
                    Some(gm) => *geometry.insert(gm),
                    None => continue, // wi + wo vanishes: every microfacet variant is 0
                },
            };
            let x = gm.argument(op.kind == LobeKind::MicrofacetSin2);
            // The variants are D times [Vs, Vs·F, Vc, Vc·F]: those factors weighted, then D.
            let v = gm.variants_with_d(1.0, p[2]);
            let dot = |a: &[f64; 4]| v[0] * a[0] + v[1] * a[1] + v[2] * a[2] + v[3] * a[3];
            let weighted = w[0] * dot(&op.amps[0]) + w[1] * dot(&op.amps[1]);
            sum += weighted * baked.power.pow(1.0 + p[0] * x, -p[1]);
        }
    }
    sum
}
