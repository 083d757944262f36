//! Joint fitting, beyond the paper: the SH background and the lobe amplitudes are solved
//! together by linear least squares for given lobe shape parameters, and the shape parameters
//! are searched on top (variable projection). No critical angle is needed.
//!
//! Per incidence, with the spectral synthesis matrix S (W×K) factored S = Q·R (Q orthonormal),
//! the samples ρ (N×W) split into Cq = ρ·Q (N×K) and a part no model in this basis can
//! represent. For a design matrix M = [Y | G(θ)] (SH functions and lobe shapes at the N
//! outgoing directions) the best coefficients are M⁺·Cq, and the error is
//! ‖Cq − M·M⁺·Cq‖² + ‖ρ‖² − ‖Cq‖²: the relative-error objective of every record, measured on
//! all samples with equal weight. Y is fixed per incidence, so it is projected out once and a
//! shape candidate costs O(N·(L+1)²) instead of a new factorisation. Because R is triangular,
//! the first r columns of Q span the first r basis functions: one fit gives the error of every
//! spectral rank r ≤ K at once, which is what `--max-error` searches over.

use super::context::{lstsq, lstsq_with_leverage, FitContext, Fitted};
use super::options::{
    JointOptions, LobeFamily, HELD_OUT_OVERFIT, HELD_OUT_PLATEAU, HELD_OUT_SLACK,
};
use super::peak::find_peak_direction;
use crate::encode::metrics::{rel, stored_error, ErrorSums};
use crate::encode::samples::IncidentSamples;
use crate::format::quantize_record_f16;
use crate::model::angles::{angle_between, dir_from_deg, mirror_deg, wrap_phi};
use crate::model::lobes::cosine_power_of;
use crate::model::material::{IncidentRecord, Lobe, LobeKind};
use crate::model::sh::sh_count;
use crate::model::Precision;
use nalgebra::DMatrix;

/// Orthonormal basis of the column space of `m` (rank-revealing, via SVD).
fn column_space(m: &DMatrix<f64>) -> DMatrix<f64> {
    let svd = m.clone().svd(true, false);
    let u = svd.u.expect("U requested");
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&i| svd.singular_values[i] > smax * 1e-9)
        .collect();
    u.select_columns(keep.iter())
}

/// Everything about one incidence that does not depend on the model size.
struct Incidence {
    n: usize,
    dirs: Vec<[f64; 3]>,
    wi: [f64; 3],
    peak: (f64, f64),
    alpha2: Vec<f64>,
    /// N×K samples in the orthonormalised spectral basis.
    cq: DMatrix<f64>,
    /// ‖ρ‖² and the part of it outside the spectral basis.
    total: f64,
    floor: f64,
    /// Q (W×K, orthonormal columns) and R⁻ᵀ of the synthesis matrix.
    q: DMatrix<f64>,
    r_inv_t: DMatrix<f64>,
    /// SH values for the largest level, N×P.
    y: DMatrix<f64>,
}

/// One fitted model size: SH level, lobe (if any) and coefficients in the orthonormal basis,
/// with the residual of each orthonormal spectral term.
struct LevelFit {
    level: usize,
    lobe: Option<(LobeFamily, Vec<f64>)>,
    /// (P + lobe columns) × K coefficients in Q space.
    xq: DMatrix<f64>,
    /// Squared residual per orthonormal term k.
    resid: Vec<f64>,
    /// N×K residual in Q space and each sample's leverage (for leave-one-out errors).
    res: DMatrix<f64>,
    leverage: Vec<f64>,
}

fn prepare(ctx: &FitContext, s: &IncidentSamples) -> Result<Incidence, String> {
    let n = s.directions.len();
    let w = ctx.synthesis.ncols();
    let k = ctx.spectral.terms;
    let dirs: Vec<[f64; 3]> = s
        .directions
        .iter()
        .map(|d| dir_from_deg(d[0], d[1]))
        .collect();
    let rho = DMatrix::from_row_slice(n, w, &s.values);
    let qr = ctx.synthesis.transpose().qr();
    let (q, r) = (qr.q(), qr.r());
    if (0..k).any(|i| r[(i, i)].abs() <= 1e-12 * r[(0, 0)].abs().max(1e-300)) {
        return Err(format!(
            "the {k} spectral basis functions are not independent on the {w} wavelength samples"
        ));
    }
    let cq = &rho * &q;
    let total = rho.norm_squared();
    let floor = (total - cq.norm_squared()).max(0.0);
    let r_inv_t = lstsq(&r.transpose(), &DMatrix::identity(k, k));
    let y = ctx.sh_matrix(&dirs);
    let mirror = mirror_deg(s.theta_i, s.phi_i);
    let peak = find_peak_direction(s, mirror);
    let pv = dir_from_deg(peak.0, peak.1);
    let alpha2 = dirs.iter().map(|d| angle_between(*d, pv).powi(2)).collect();
    Ok(Incidence {
        n,
        dirs,
        wi: dir_from_deg(s.theta_i, s.phi_i),
        peak,
        alpha2,
        cq,
        total,
        floor,
        q,
        r_inv_t,
        y,
    })
}

/// Shape parameters are searched unconstrained: Gaussian [ln b]; cosine power [ln n];
/// microfacet [ln b, ln c, logit a]; anisotropic microfacet [ln bx, ln by, ln c, logit ax,
/// logit ay, ψ/30° (any real; ψ wrapped into [0, 180), scaled so that the search's steps turn
/// the axis by tens of degrees)].
fn decode_params(family: LobeFamily, x: &[f64]) -> Vec<f64> {
    match family {
        LobeFamily::Gaussian => vec![x[0].clamp(-30.0, 30.0).exp()],
        LobeFamily::CosinePower => vec![x[0].clamp(-5.0, 7.0 * std::f64::consts::LN_10).exp()],
        // Safeguards: b ≤ 10⁷ (narrower than any sampling resolves), c ≥ 0.05.
        LobeFamily::Microfacet | LobeFamily::MicrofacetSin2 => vec![
            x[0].clamp(-30.0, 7.0 * std::f64::consts::LN_10).exp(),
            x[1].clamp(0.05f64.ln(), 30.0).exp(),
            1.0 / (1.0 + (-x[2]).exp()),
        ],
        LobeFamily::MicrofacetAniso => {
            let b = |v: f64| v.clamp(-30.0, 7.0 * std::f64::consts::LN_10).exp();
            let logistic = |v: f64| 1.0 / (1.0 + (-v).exp());
            let (mut bx, mut by) = (b(x[0]), b(x[1]));
            let (mut ax, mut ay) = (logistic(x[3]), logistic(x[4]));
            let mut psi = 30.0 * x[5];
            // One lobe has two descriptions (the axes swapped and ψ turned by 90°); records keep
            // the one whose first axis is the narrower (bx ≥ by), so that neighbouring records
            // of one material agree and blend parameter by parameter.
            if bx < by {
                std::mem::swap(&mut bx, &mut by);
                std::mem::swap(&mut ax, &mut ay);
                psi += 90.0;
            }
            let psi = psi.rem_euclid(180.0);
            vec![
                bx,
                by,
                x[2].clamp(0.05f64.ln(), 30.0).exp(),
                ax,
                ay,
                // Stored as f32 in [0, 180): a value that rounds up to 180 is the axis at 0.
                if psi as f32 >= 180.0 { 0.0 } else { psi },
            ]
        }
    }
}

/// The columns a lobe adds to the design matrix (parameters as stored, rounded to f32 so the
/// fit sees what the decoder will).
fn lobe_columns(inc: &Incidence, family: LobeFamily, params: &[f64]) -> DMatrix<f64> {
    match family {
        LobeFamily::Gaussian => {
            let b = params[0] as f32 as f64;
            DMatrix::from_iterator(inc.n, 1, inc.alpha2.iter().map(|a| (-a / b).exp()))
        }
        LobeFamily::CosinePower => {
            let n = params[0] as f32 as f64;
            DMatrix::from_iterator(
                inc.n,
                1,
                inc.alpha2
                    .iter()
                    .map(|a| cosine_power_of(n, a.sqrt().cos())),
            )
        }
        LobeFamily::Microfacet | LobeFamily::MicrofacetSin2 | LobeFamily::MicrofacetAniso => {
            let p32: Vec<f32> = params.iter().map(|&v| v as f32).collect();
            let kind = family.kind();
            let mut m = DMatrix::zeros(inc.n, 4);
            let p64 = [0, 1, 2, 3, 4, 5].map(|i| p32.get(i).map_or(0.0, |&v| v as f64));
            let axis = p64[5].to_radians().sin_cos();
            for (i, d) in inc.dirs.iter().enumerate() {
                let v = if kind == LobeKind::MicrofacetAniso {
                    match crate::model::lobes::MicrofacetGeometry::new(inc.wi, *d) {
                        Some(g) => g.variants_aniso_with_axis(p64, axis, inc.wi, *d),
                        None => [0.0; 4],
                    }
                } else {
                    crate::model::lobes::microfacet_kind_variants(kind, &p32, inc.wi, *d)
                };
                for j in 0..4 {
                    m[(i, j)] = v[j];
                }
            }
            m
        }
    }
}

/// Starting points for the shape search.
fn initial_grid(family: LobeFamily) -> Vec<Vec<f64>> {
    match family {
        LobeFamily::Gaussian => (0..=40)
            .map(|i| vec![(1e-7f64).ln() + (4e7f64).ln() * i as f64 / 40.0])
            .collect(),
        LobeFamily::CosinePower => (0..=30)
            .map(|i| vec![-2.0 + (2.0 + 7.0 * std::f64::consts::LN_10) * i as f64 / 30.0])
            .collect(),
        LobeFamily::Microfacet | LobeFamily::MicrofacetSin2 => {
            let mut g = Vec::new();
            for a in [0.1f64, 0.5, 0.9] {
                for i in 0..9 {
                    for c in [0.4f64, 1.2, 3.0] {
                        g.push(vec![15.0 * i as f64 / 8.0, c.ln(), (a / (1.0 - a)).ln()]);
                    }
                }
            }
            g
        }
        LobeFamily::MicrofacetAniso => {
            // Widths from broad to narrow, the second axis as narrow or up to 25× broader in b
            // (5× in roughness), the first axis every 30°; GGX's c and the shadowing
            // roughnesses GGX has for these widths (a = 1/√(1 + b)), which the search then
            // frees. Both axes are searched from every start, so the starts need not cover
            // by > bx.
            let logit_ggx_a = |lb: f64| {
                let a = (1.0 / (1.0 + lb.exp())).sqrt().clamp(1e-3, 1.0 - 1e-3);
                (a / (1.0 - a)).ln()
            };
            let mut g = Vec::new();
            for i in 0..9 {
                let lbx = 15.0 * i as f64 / 8.0;
                for ratio in [1.0f64, 5.0, 25.0] {
                    let lby = lbx - ratio.ln();
                    for psi in 0..6 {
                        g.push(vec![
                            lbx,
                            lby,
                            2f64.ln(),
                            logit_ggx_a(lbx),
                            logit_ggx_a(lby),
                            psi as f64,
                        ]);
                    }
                }
            }
            g
        }
    }
}

/// Error reduction a set of lobe columns brings once the SH part is projected out.
fn gain(qy: &DMatrix<f64>, c_perp: &DMatrix<f64>, cols: &DMatrix<f64>) -> f64 {
    let g = cols - qy * (qy.transpose() * cols);
    if !g.iter().all(|v| v.is_finite()) || g.norm_squared() <= 1e-300 {
        return 0.0;
    }
    let basis = column_space(&g);
    (basis.transpose() * c_perp).norm_squared()
}

/// Nelder–Mead on `f` (to minimise) from `x0`, deterministic, `iters` iterations at most.
fn nelder_mead(f: &dyn Fn(&[f64]) -> f64, x0: &[f64], step: f64, iters: usize) -> (Vec<f64>, f64) {
    let d = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(d + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..d {
        let mut x = x0.to_vec();
        x[i] += step;
        let v = f(&x);
        simplex.push((x, v));
    }
    for _ in 0..iters {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        if (simplex[d].1 - simplex[0].1).abs() <= 1e-12 * simplex[0].1.abs().max(1e-300) {
            break;
        }
        let centroid: Vec<f64> = (0..d)
            .map(|j| simplex[..d].iter().map(|s| s.0[j]).sum::<f64>() / d as f64)
            .collect();
        let at = |t: f64| -> Vec<f64> {
            (0..d)
                .map(|j| centroid[j] + t * (simplex[d].0[j] - centroid[j]))
                .collect()
        };
        let xr = at(-1.0);
        let fr = f(&xr);
        if fr < simplex[0].1 {
            let xe = at(-2.0);
            let fe = f(&xe);
            simplex[d] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[d - 1].1 {
            simplex[d] = (xr, fr);
        } else {
            let xc = if fr < simplex[d].1 { at(-0.5) } else { at(0.5) };
            let fc = f(&xc);
            if fc < simplex[d].1.min(fr) {
                simplex[d] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 = (0..d).map(|j| best[j] + 0.5 * (s.0[j] - best[j])).collect();
                    s.1 = f(&s.0);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// Searches the shape parameters of `family` with the SH background of `level` projected out.
fn search_shape(inc: &Incidence, level: usize, fam: LobeFamily) -> Vec<f64> {
    let p = sh_count(level);
    let y = inc.y.columns(0, p).into_owned();
    let qy = column_space(&y);
    let c_perp = &inc.cq - &qy * (qy.transpose() * &inc.cq);
    {
        let objective = |x: &[f64]| {
            -gain(
                &qy,
                &c_perp,
                &lobe_columns(inc, fam, &decode_params(fam, x)),
            )
        };
        let mut starts: Vec<(Vec<f64>, f64)> = initial_grid(fam)
            .into_iter()
            .map(|x| {
                let v = objective(&x);
                (x, v)
            })
            .collect();
        starts.sort_by(|a, b| a.1.total_cmp(&b.1));
        let mut best = starts[0].clone();
        for s in starts.iter().take(2) {
            let r = nelder_mead(&objective, &s.0, 0.5, 150 * s.0.len());
            if r.1 < best.1 {
                best = r;
            }
        }
        decode_params(fam, &best.0)
    }
}

/// Solves SH level `level` plus the lobe of the given shape (if any) by least squares.
fn fit_level(inc: &Incidence, level: usize, lobe: Option<(LobeFamily, Vec<f64>)>) -> LevelFit {
    let p = sh_count(level);
    let y = inc.y.columns(0, p).into_owned();
    let m = match &lobe {
        Some((fam, params)) => {
            let cols = lobe_columns(inc, *fam, params);
            let mut m = DMatrix::zeros(inc.n, p + cols.ncols());
            m.columns_mut(0, p).copy_from(&y);
            m.columns_mut(p, cols.ncols()).copy_from(&cols);
            m
        }
        None => y,
    };
    let (xq, leverage) = lstsq_with_leverage(&m, &inc.cq, true);
    let res = &inc.cq - &m * &xq;
    let resid = (0..res.ncols())
        .map(|k| res.column(k).norm_squared())
        .collect();
    LevelFit {
        level,
        lobe,
        xq,
        resid,
        res,
        leverage,
    }
}

impl LevelFit {
    /// The leave-one-out error with the first `r` spectral terms: each sample predicted from the
    /// others (residual / (1 − leverage), the PRESS identity of linear least squares for the
    /// fixed lobe shape), clamped at 0 as decoded, against the measured spectrum.
    fn held_out(&self, inc: &Incidence, s: &IncidentSamples, r: usize, eps: f64) -> ErrorSums {
        let w = inc.q.nrows();
        let mut sums = ErrorSums::default();
        let mut pred = vec![0.0; r];
        for i in 0..inc.n {
            let d = (1.0 - self.leverage[i]).max(1e-6);
            for (k, p) in pred.iter_mut().enumerate() {
                *p = inc.cq[(i, k)] - self.res[(i, k)] / d;
            }
            for l in 0..w {
                let v: f64 = pred
                    .iter()
                    .enumerate()
                    .map(|(k, p)| p * inc.q[(l, k)])
                    .sum();
                sums.add(v, s.values[i * w + l], eps);
            }
        }
        sums
    }

    /// True when every value of the full-size record is finite in f32.
    fn storable(&self, inc: &Incidence, s: &IncidentSamples, r: usize) -> bool {
        let rec = self.record(inc, s, r);
        rec.sh
            .iter()
            .chain(rec.lobes.iter().flat_map(|l| l.amplitude.iter()))
            .all(|v| v.is_finite())
    }

    /// Predicted squared error with the first `r` spectral terms.
    fn sq_error(&self, inc: &Incidence, r: usize) -> f64 {
        let kept: f64 = self.resid[..r].iter().sum();
        let dropped: f64 = (r..inc.cq.ncols())
            .map(|k| inc.cq.column(k).norm_squared())
            .sum();
        kept + dropped + inc.floor
    }

    /// The record with the first `r` terms, in f32.
    fn record(&self, inc: &Incidence, s: &IncidentSamples, r: usize) -> IncidentRecord {
        let p = sh_count(self.level);
        // Coefficients on the first r basis functions: ρ̂ = M·Xq·Qᵀ = M·X·Sᵀ = M·X·Rᵀ·Qᵀ, so
        // X = Xq·R⁻ᵀ, restricted to the leading r×r block (R⁻ᵀ is lower triangular, so its
        // leading block is the inverse transpose of R's leading block).
        let xq = self.xq.columns(0, r);
        let rit = inc.r_inv_t.view((0, 0), (r, r));
        let x = xq * rit;
        let mut sh = Vec::with_capacity(r * p);
        for kk in 0..r {
            for j in 0..p {
                sh.push(x[(j, kk)] as f32);
            }
        }
        let lobes = match &self.lobe {
            None => Vec::new(),
            Some((LobeFamily::Gaussian, params)) => vec![Lobe {
                kind: LobeKind::AngleGaussian,
                amplitude: (0..r).map(|kk| x[(p, kk)] as f32).collect(),
                params: vec![params[0] as f32; r],
            }],
            Some((LobeFamily::CosinePower, params)) => vec![Lobe {
                kind: LobeKind::CosinePower,
                amplitude: (0..r).map(|kk| x[(p, kk)] as f32).collect(),
                params: vec![params[0] as f32],
            }],
            Some((
                fam @ (LobeFamily::Microfacet
                | LobeFamily::MicrofacetSin2
                | LobeFamily::MicrofacetAniso),
                params,
            )) => {
                vec![Lobe {
                    kind: fam.kind(),
                    amplitude: (0..4)
                        .flat_map(|j| (0..r).map(move |kk| (j, kk)))
                        .map(|(j, kk)| x[(p + j, kk)] as f32)
                        .collect(),
                    params: params.iter().map(|&v| v as f32).collect(),
                }]
            }
        };
        let (tp, pp) = inc.peak;
        let pp = if tp < 1e-9 { 0.0 } else { pp };
        IncidentRecord {
            terms: r,
            sh_level: self.level,
            precision: Precision::F32,
            theta_i: s.theta_i as f32,
            phi_i: s.phi_i as f32,
            theta_p: (tp + 0.0) as f32,
            phi_p: wrap_phi(pp as f32 as f64) as f32 % 360.0,
            rel_error: 0.0,
            critical_angle: 0.0,
            sh,
            lobes,
        }
    }
}

/// Bytes a record of this size takes in the file (chunk framing included).
fn record_bytes(
    terms: usize,
    level: usize,
    lobe: Option<LobeFamily>,
    precision: Precision,
) -> usize {
    let s = precision.bytes();
    let lobe = match lobe {
        None => 0,
        Some(LobeFamily::Gaussian) => 4 + terms * s + 4 * terms,
        Some(LobeFamily::CosinePower) => 4 + terms * s + 4,
        Some(LobeFamily::Microfacet | LobeFamily::MicrofacetSin2) => 4 + 4 * terms * s + 12,
        Some(LobeFamily::MicrofacetAniso) => 4 + 4 * terms * s + 24,
    };
    12 + 40 + terms * sh_count(level) * s + lobe
}

/// The fits of one incidence, computed when first needed: a shape search per family at the low
/// and the high level, a least-squares fit per (level, lobe). With a budget the candidates are
/// visited smallest first and the visit usually ends long before the largest models, so most
/// shape searches (the high level's above all) are never run. What is computed is what an eager
/// search would compute, so the choice is the same.
struct Lazy<'a> {
    inc: &'a Incidence,
    families: &'a [LobeFamily],
    levels: Vec<usize>,
    lo: usize,
    hi: usize,
    /// Per family: the shape searched at the low and at the high level.
    shapes: Vec<[Option<Vec<f64>>; 2]>,
    /// Per (level, lobe): fit index = level index · (1 + families) + (0: no lobe, 1 + family).
    fits: Vec<Option<LevelFit>>,
}

impl<'a> Lazy<'a> {
    fn new(inc: &'a Incidence, opts: &'a JointOptions) -> Self {
        let levels: Vec<usize> = match opts.max_error {
            Some(_) => (0..=opts.max_sh_level).collect(),
            None => vec![opts.max_sh_level],
        };
        let (lo, hi) = (levels[0], levels[levels.len() - 1]);
        let per_level = 1 + opts.families.len();
        Lazy {
            inc,
            families: &opts.families,
            fits: (0..levels.len() * per_level).map(|_| None).collect(),
            shapes: vec![[None, None]; opts.families.len()],
            levels,
            lo,
            hi,
        }
    }

    fn per_level(&self) -> usize {
        1 + self.families.len()
    }

    /// (level, lobe family) of fit `fi`.
    fn describe(&self, fi: usize) -> (usize, Option<LobeFamily>) {
        let level = self.levels[fi / self.per_level()];
        let j = fi % self.per_level();
        (level, (j > 0).then(|| self.families[j - 1]))
    }

    /// Shapes are searched at two levels only, the lowest and the highest tried, and each level
    /// reuses the shape found at the nearer one: the best shape moves little with the SH level,
    /// and the search is most of the cost.
    fn shape(&mut self, f: usize, level: usize) -> Vec<f64> {
        let (lo, hi) = (self.lo, self.hi);
        let high = level * 2 >= lo + hi;
        let which = if lo == hi { 1 } else { usize::from(high) };
        if self.shapes[f][which].is_none() {
            let at = if which == 1 { hi } else { lo.max(1).min(hi) };
            self.shapes[f][which] = Some(search_shape(self.inc, at, self.families[f]));
        }
        self.shapes[f][which].clone().expect("just searched")
    }

    fn fit(&mut self, fi: usize) -> &LevelFit {
        if self.fits[fi].is_none() {
            let (level, family) = self.describe(fi);
            let lobe = family.map(|fam| {
                let f = fi % self.per_level() - 1;
                (fam, self.shape(f, level))
            });
            self.fits[fi] = Some(fit_level(self.inc, level, lobe));
        }
        self.fits[fi].as_ref().expect("just fitted")
    }

    /// Index of the fit with the smallest predicted error at all `k` terms (every fit computed)
    /// among those that can be stored: a lobe narrower than the sampling can sit between the
    /// samples, where its column is ~0, and least squares then gives it an amplitude beyond f32
    /// (invisible at the samples, infinite between them). If none can, the first (the lowest
    /// level without a lobe).
    fn most_accurate(&mut self, s: &IncidentSamples, k: usize) -> usize {
        let inc = self.inc;
        let mut best = (f64::INFINITY, 0);
        for fi in 0..self.fits.len() {
            let fit = self.fit(fi);
            let e = fit.sq_error(inc, k);
            if e < best.0 && fit.storable(inc, s, k) {
                best = (e, fi);
            }
        }
        best.1
    }
}

/// Fits one incidence: the full model, or with a budget the smallest model (by bytes) that
/// meets it. Returns the fit and whether the budget was met.
pub fn fit_joint(
    ctx: &FitContext,
    s: &IncidentSamples,
    opts: &JointOptions,
) -> Result<(Fitted, bool), String> {
    let inc = prepare(ctx, s)?;
    let k = ctx.spectral.terms;
    let mut lazy = Lazy::new(&inc, opts);
    // Everything a measurement needs but the record, once per incidence: the samples, and the
    // angles to the peak direction as records store it (f32).
    let rho = DMatrix::from_row_slice(inc.n, ctx.synthesis.ncols(), &s.values);
    let probe = stored_peak(&inc);
    let stored_peak = dir_from_deg(probe.0 as f64, probe.1 as f64);
    let alpha: Vec<f64> = inc
        .dirs
        .iter()
        .map(|d| angle_between(*d, stored_peak))
        .collect();
    let finish = |mut record: IncidentRecord, precision: Precision| {
        if precision == Precision::F16 {
            quantize_record_f16(&mut record);
        }
        let (sq_error, sq_reference) = ctx.measure_parts(&record, &inc.y, &inc.dirs, &alpha, &rho);
        record.rel_error = stored_error(rel(sq_error, sq_reference));
        Fitted {
            met: true,
            record,
            sq_error,
            sq_reference,
            held_out: None,
            below_floor: false,
        }
    };
    let eps = opts.log_epsilon;
    match opts.max_error {
        None => {
            // The best of the full-size fits (all terms, the given level and precision); ties
            // to the first, as the eager search had it.
            let best = lazy.most_accurate(s, k);
            let fit = lazy.fit(best);
            let mut fitted = finish(fit.record(&inc, s, k), opts.precision);
            fitted.held_out = Some(fit.held_out(&inc, s, k, eps));
            Ok((fitted, true))
        }
        Some(budget) => {
            let precisions: &[Precision] = match opts.precision {
                Precision::F16 => &[Precision::F16, Precision::F32],
                Precision::F32 => &[Precision::F32],
            };
            let mut candidates = Vec::new();
            for fi in 0..lazy.fits.len() {
                let (level, family) = lazy.describe(fi);
                for r in 1..=k {
                    for &prec in precisions {
                        candidates.push((record_bytes(r, level, family, prec), fi, r, prec));
                    }
                }
            }
            candidates.sort_by_key(|c| (c.0, c.1, c.2, c.3.code()));
            let limit = budget * budget * inc.total;
            // Whether some model met the budget at the samples but not between them.
            let mut fits_scatter = false;
            for &(_, fi, r, prec) in &candidates {
                // The prediction is exact before rounding to f32/f16: skip what cannot meet the
                // budget, measure the rest as stored.
                let fit = lazy.fit(fi);
                if fit.sq_error(&inc, r) > limit * 1.0001 {
                    continue;
                }
                if !fit.storable(&inc, s, k) {
                    continue;
                }
                let mut fitted = finish(fit.record(&inc, s, r), prec);
                if fitted.sq_error <= limit {
                    let ho = lazy.fit(fi).held_out(&inc, s, r, eps);
                    fitted.held_out = Some(ho);
                    if !opts.held_out || ho.rel() <= HELD_OUT_SLACK * budget {
                        fitted.below_floor = ho.rel() > HELD_OUT_SLACK * budget;
                        return Ok((fitted, true));
                    }
                    fits_scatter = true;
                }
            }
            // The most accurate model tried, for when no model meets the budget: it stands
            // unless it predicts held-out samples much worse than the best (it fits the
            // samples' scatter) or a smaller model already met the budget only at the samples.
            let most = lazy.most_accurate(s, k);
            let score = |lazy: &mut Lazy, fi: usize, r: usize| {
                let ho = lazy.fit(fi).held_out(&inc, s, r, eps);
                ho.rel().powi(2) + ho.log().powi(2)
            };
            let overfits = opts.held_out && {
                let mut best = f64::INFINITY;
                for c in candidates.iter().filter(|c| c.3 == opts.precision) {
                    if lazy.fit(c.1).storable(&inc, s, k) {
                        best = best.min(score(&mut lazy, c.1, c.2));
                    }
                }
                score(&mut lazy, most, k) > HELD_OUT_OVERFIT * best
            };
            if opts.held_out && (fits_scatter || overfits) {
                // No model meets the budget between the samples: the noise (or the sampling)
                // sets a floor above it. Keep the smallest model that predicts held-out samples
                // within HELD_OUT_PLATEAU of the best (score log² + rel²): where the held-out
                // error stops improving, bytes stop being spent. Among those, a model whose
                // stored values lose what the fit found (a huge amplitude on a lobe between the
                // samples leaves the rest of an f16 record under its scale) is passed over.
                let mut ranked: Vec<(f64, usize, usize, usize)> = Vec::new();
                for &(bytes, fi, r, prec) in &candidates {
                    if prec == opts.precision && lazy.fit(fi).storable(&inc, s, k) {
                        ranked.push((score(&mut lazy, fi, r), bytes, fi, r));
                    }
                }
                let best = ranked.iter().map(|c| c.0).fold(f64::INFINITY, f64::min);
                // Within the plateau by bytes, then the rest by score.
                ranked.sort_by(|a, b| {
                    let (pa, pb) = (
                        a.0 <= best * HELD_OUT_PLATEAU,
                        b.0 <= best * HELD_OUT_PLATEAU,
                    );
                    pb.cmp(&pa)
                        .then(if pa && pb {
                            a.1.cmp(&b.1)
                        } else {
                            std::cmp::Ordering::Equal
                        })
                        .then(a.0.total_cmp(&b.0))
                        .then(a.1.cmp(&b.1))
                });
                // First pass: models that are also non-negative over the whole hemisphere (an
                // SH series extrapolated past the last sampled θo can dip below 0, which the
                // decoder would have to clamp); second pass: any.
                for need_positive in [true, false] {
                    for &(_, _, fi, r) in &ranked {
                        let fit = lazy.fit(fi);
                        let mut fitted = finish(fit.record(&inc, s, r), opts.precision);
                        let predicted = fit.sq_error(&inc, r);
                        if fitted.sq_error > 1.1 * predicted + 1e-12 * inc.total {
                            continue;
                        }
                        if need_positive && ctx.minimum_on_hemisphere(&fitted.record) < 0.0 {
                            continue;
                        }
                        fitted.held_out = Some(lazy.fit(fi).held_out(&inc, s, r, eps));
                        fitted.below_floor = true;
                        return Ok((fitted, true));
                    }
                }
            }
            // Nothing met the budget: the most accurate model tried, in f32.
            let fit = lazy.fit(most);
            let mut fitted = finish(fit.record(&inc, s, k), Precision::F32);
            fitted.held_out = Some(fit.held_out(&inc, s, k, eps));
            Ok((fitted, false))
        }
    }
}

/// The peak direction as every record of this incidence stores it, (θp, φp) in f32.
fn stored_peak(inc: &Incidence) -> (f32, f32) {
    let (tp, pp) = inc.peak;
    let pp = if tp < 1e-9 { 0.0 } else { pp };
    ((tp + 0.0) as f32, wrap_phi(pp as f32 as f64) as f32 % 360.0)
}
