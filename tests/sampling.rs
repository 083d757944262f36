//! What a renderer needs beyond `eval`: importance sampling whose density is exactly `pdf` and
//! integrates to 1, that estimates the directional albedo with less variance than cosine
//! sampling; decoded values that are never negative; and how reciprocal the stored BRDF is,
//! which decides whether a path tracer may swap wi and wo. Monte Carlo runs use fixed seeds.

mod common;
use common::*;
use sbrdf::encode::fit::PeakMode;
use sbrdf::Decoder;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Marsaglia's xorshift64: deterministic uniform numbers without a dependency.
struct XorShift(u64);

impl XorShift {
    fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// In [0, 1) after rounding to f32 (a plain cast can round up to 1).
    fn next_f32(&mut self) -> f32 {
        (self.next_f64() as f32).min(1.0 - f32::EPSILON / 2.0)
    }
}

fn dir(theta_deg: f64, phi_deg: f64) -> [f32; 3] {
    let d = sbrdf::model::angles::dir_from_deg(theta_deg, phi_deg);
    [d[0] as f32, d[1] as f32, d[2] as f32]
}

/// Phong n = 200 (ks/kd = 15, the interpolation tests' material) stored every 10° from 0 to 80°.
fn phong() -> &'static Decoder {
    static D: OnceLock<Decoder> = OnceLock::new();
    D.get_or_init(|| {
        let stored: Vec<(f64, f64)> = (0..9).map(|i| (10.0 * i as f64, 0.0)).collect();
        let set = paper_samples(15.0, 200.0, &stored);
        Decoder::from_material(encode_default(&set, |_| {}).material).unwrap()
    })
}

/// GGX α = 0.2 over a blue Lambert base, stored every 10° from 0 to 80° and at 85°.
fn ggx_material() -> &'static Decoder {
    static D: OnceLock<Decoder> = OnceLock::new();
    D.get_or_init(|| {
        let mut stored: Vec<(f64, f64)> = (0..9).map(|i| (10.0 * i as f64, 0.0)).collect();
        stored.push((85.0, 0.0));
        let g = ggx(0.2);
        let set = sample_on_paper_grid(&stored, |i, o, w| g.value(i, o, w));
        Decoder::from_material(encode_default(&set, |_| {}).material).unwrap()
    })
}

/// Anisotropic GGX (αx = 0.08, αy = 0.35, axis at 30°) over the blue base, stored on a lattice
/// of θi = 10°, 30°, 50°, 70° × φi every 45° (kind-5 lobes, issue 15).
fn aniso_material() -> &'static Decoder {
    static D: OnceLock<Decoder> = OnceLock::new();
    D.get_or_init(|| {
        let mut stored = Vec::new();
        for t in [10.0, 30.0, 50.0, 70.0] {
            for p in 0..8 {
                stored.push((t, 45.0 * p as f64));
            }
        }
        let g = ggx(0.08).with_anisotropy(0.35, 30.0);
        let set = sample_on_paper_grid(&stored, |i, o, w| g.value(i, o, w));
        Decoder::from_material(encode_default(&set, |_| {}).material).unwrap()
    })
}

fn golden_decoders() -> Vec<(String, Decoder)> {
    let mut v: Vec<(String, Decoder)> = std::fs::read_dir(samples_dir().join("golden"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "sbrdf"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, Decoder::open(&p).unwrap())
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v.push((
        "ggx_slices.sbrdf".into(),
        Decoder::open(samples_dir().join("ggx_slices.sbrdf")).unwrap(),
    ));
    v
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9: ~1e-15 relative).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised upper incomplete gamma function Q(a, x): the χ² test's p-value is
/// Q(dof/2, χ²/2). Series below a + 1, Lentz's continued fraction above (Numerical Recipes).
fn gamma_q(a: f64, x: f64) -> f64 {
    let lead = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * lead
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        lead * h
    }
}

/// Midpoint quadrature over the upper hemisphere on an nt × np grid in (θ, φ): calls `f` with
/// each cell's indices, centre direction and exact solid angle.
fn hemisphere(nt: usize, np: usize, mut f: impl FnMut(usize, usize, [f32; 3], f64)) {
    let dt = 0.5 * PI / nt as f64;
    let dp = 2.0 * PI / np as f64;
    for i in 0..nt {
        let area = ((i as f64 * dt).cos() - ((i + 1) as f64 * dt).cos()) * dp;
        let t = ((i as f64 + 0.5) * dt).to_degrees();
        for j in 0..np {
            let p = ((j as f64 + 0.5) * dp).to_degrees();
            f(i, j, dir(t, p), area);
        }
    }
}

/// The (θ, φ) bin of a direction on an nt × np grid over the upper hemisphere.
fn bin_of(w: [f32; 3], nt: usize, np: usize) -> usize {
    let w = [w[0] as f64, w[1] as f64, w[2] as f64];
    let (t, p) = sbrdf::model::angles::deg_from_dir(w);
    let i = ((t / 90.0 * nt as f64) as usize).min(nt - 1);
    let j = ((p / 360.0 * np as f64) as usize).min(np - 1);
    i * np + j
}

/// Pearson's χ² of observed against expected counts, bins expecting fewer than 5 pooled
/// (the usual condition for the χ² approximation): (statistic, degrees of freedom, p-value).
fn chi2(observed: &[u64], expected: &[f64]) -> (f64, usize, f64) {
    let (mut stat, mut bins) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pool_o += o as f64;
            pool_e += e;
        } else {
            stat += (o as f64 - e).powi(2) / e;
            bins += 1;
        }
    }
    if pool_e >= 5.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e;
        bins += 1;
    } else {
        // Too little expected in the pool for a term of its own: counts there must be rare.
        assert!(
            pool_o <= 5.0 + 5.0 * pool_e,
            "{pool_o} samples where {pool_e} expected"
        );
    }
    let dof = bins - 1;
    (stat, dof, gamma_q(dof as f64 / 2.0, stat / 2.0))
}

/// Figures of one incidence of one material (`sample`, `pdf` and `eval` against a dense
/// quadrature, and the albedo estimator against cosine sampling's).
struct Report {
    pdf_integral: f64,
    chi2: (f64, usize, f64),
    /// Per wavelength: albedo by quadrature and by sampling.
    albedo: Vec<(f64, f64)>,
    /// Variance per sample of the albedo estimator at 550 nm: cosine sampling's over ours.
    variance_ratio: f64,
}

const WAVELENGTHS: [f32; 3] = [450.0, 550.0, 650.0];

fn study(dec: &Decoder, incidence: (f64, f64), n: usize, seed: u64) -> Report {
    let wi = dir(incidence.0, incidence.1);
    let (bt, bp) = (18, 36);
    // Quadrature cells: 100 × 40 per bin, 0.05° × 0.25°, fine against Phong n = 200's ~4° lobe.
    let (qt, qp) = (bt * 100, bp * 40);
    let mut expected = vec![0.0; bt * bp];
    let mut pdf_integral = 0.0;
    let mut albedo_quad = [0.0f64; 3];
    let mut out = [0.0f32; 3];
    hemisphere(qt, qp, |i, j, wo, area| {
        let p = dec.pdf(wi, wo) as f64 * area;
        pdf_integral += p;
        expected[(i / 100) * bp + j / 40] += p * n as f64;
        dec.eval(wi, wo, &WAVELENGTHS, &mut out);
        for (a, v) in albedo_quad.iter_mut().zip(&out) {
            *a += *v as f64 * wo[2] as f64 * area;
        }
        // Cell centres lie above the horizon: wherever ρ > 0 the density must be too, or an
        // estimator could never see that part of the BRDF.
        if out.iter().any(|&v| v > 0.0) {
            assert!(p > 0.0, "pdf 0 where ρ = {out:?} at {wo:?}");
        }
    });
    let mut rng = XorShift(seed);
    let mut observed = vec![0u64; bt * bp];
    let (mut sum, mut sum2) = ([0.0f64; 3], 0.0f64);
    for _ in 0..n {
        let u = [rng.next_f32(), rng.next_f32()];
        // None would be a zero-valued sample; the fold above the horizon leaves none here.
        let s = dec
            .sample(wi, u)
            .expect("a direction for an incidence above the horizon");
        assert!(s.wo[2] >= 0.0 && s.pdf > 0.0, "{s:?}");
        observed[bin_of(s.wo, bt, bp)] += 1;
        dec.eval(wi, s.wo, &WAVELENGTHS, &mut out);
        for (acc, v) in sum.iter_mut().zip(&out) {
            *acc += *v as f64 * s.wo[2] as f64 / s.pdf as f64;
        }
        let e = out[1] as f64 * s.wo[2] as f64 / s.pdf as f64;
        sum2 += e * e;
    }
    let mean = sum.map(|s| s / n as f64);
    let var_ours = sum2 / n as f64 - mean[1] * mean[1];
    // Cosine-weighted sampling: the estimator is π·ρ.
    let (mut c1, mut c2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let (u1, u2) = (rng.next_f64(), rng.next_f64());
        let r = u1.sqrt();
        let p = 2.0 * PI * u2;
        let wo = [
            (r * p.cos()) as f32,
            (r * p.sin()) as f32,
            (1.0 - u1).sqrt() as f32,
        ];
        dec.eval(wi, wo, &WAVELENGTHS[1..2], &mut out[..1]);
        let e = PI * out[0] as f64;
        c1 += e;
        c2 += e * e;
    }
    let c1 = c1 / n as f64;
    let var_cos = c2 / n as f64 - c1 * c1;
    Report {
        pdf_integral,
        chi2: chi2(&observed, &expected),
        albedo: albedo_quad.iter().copied().zip(mean).collect(),
        variance_ratio: var_cos / var_ours,
    }
}

/// A row of the guide's sampling table (library.md, "Importance sampling"), held at SLACK:
/// ∫pdf's largest distance from 1, the albedo's largest relative difference between sampling
/// and quadrature, and the lowest variance ratio against cosine sampling. The χ² p-values of the
/// table are not held beyond p > 0.01: a correct sampler's p is uniform on [0, 1].
struct Stated {
    pdf_from_1: f64,
    albedo: f64,
    variance_ratio: f64,
}

fn check(
    name: &str,
    dec: &Decoder,
    incidences: &[(f64, f64)],
    min_variance_ratio: f64,
    stated: Option<Stated>,
) {
    const N: usize = 1_000_000;
    let (mut pdf_from_1, mut albedo, mut variance_ratio) = (0.0f64, 0.0f64, f64::INFINITY);
    for (k, &inc) in incidences.iter().enumerate() {
        let r = study(dec, inc, N, 0x9E37_79B9_7F4A_7C15 ^ (k as u64 + 1));
        let (stat, dof, p) = r.chi2;
        eprintln!(
            "{name} θi = {}°, φi = {}°: ∫pdf dω = {:.5}; χ² = {stat:.1} on {dof} dof, p = {p:.3}; \
             variance ratio vs cosine sampling {:.1}",
            inc.0, inc.1, r.pdf_integral, r.variance_ratio
        );
        assert!(
            (r.pdf_integral - 1.0).abs() < 0.01,
            "{name} {inc:?}: ∫pdf dω = {}",
            r.pdf_integral
        );
        // Four or five tests per material: at 1% each, a correct sampler passes all of them with
        // probability ≥ 95% (the seeds are fixed, so the outcome is too).
        assert!(
            p > 0.01,
            "{name} {inc:?}: χ² = {stat} on {dof} dof, p = {p}"
        );
        for (&l, &(quad, mc)) in WAVELENGTHS.iter().zip(&r.albedo) {
            eprintln!("  albedo at {l} nm: quadrature {quad:.5}, sampling {mc:.5}");
            assert!(
                (mc - quad).abs() < 0.01 * quad,
                "{name} {inc:?} {l} nm: albedo {mc} by sampling, {quad} by quadrature"
            );
            albedo = albedo.max((mc - quad).abs() / quad);
        }
        pdf_from_1 = pdf_from_1.max((r.pdf_integral - 1.0).abs());
        variance_ratio = variance_ratio.min(r.variance_ratio);
        assert!(
            r.variance_ratio >= min_variance_ratio,
            "{name} {inc:?}: variance only {}× lower than cosine sampling's",
            r.variance_ratio
        );
    }
    if let Some(s) = stated {
        held(&format!("{name}: |∫pdf dω − 1|"), pdf_from_1, s.pdf_from_1);
        held(
            &format!("{name}: albedo, sampling vs quadrature"),
            albedo,
            s.albedo,
        );
        held(
            &format!("{name}: 1 / variance ratio"),
            1.0 / variance_ratio,
            1.0 / s.variance_ratio,
        );
    }
}

/// Stored (30°), between stored incidences (25°, 67°, with azimuths the isotropic file rotates
/// away), and near grazing: 78° lies between 70° and 80°, 85° beyond the last stored (clamped).
#[test]
fn phong_n200_sampling_matches_pdf_and_beats_cosine_sampling() {
    check(
        "Phong n = 200",
        phong(),
        &[
            (30.0, 0.0),
            (25.0, 40.0),
            (67.0, 200.0),
            (78.0, 300.0),
            (85.0, 120.0),
        ],
        5.0,
        // 1.00000, within 0.11%, 29.8–34× lower.
        Some(Stated {
            pdf_from_1: 0.5e-5,
            albedo: 0.0011,
            variance_ratio: 29.8,
        }),
    );
}

/// GGX α = 0.2: the half-vector proposal; 83° lies between the stored 80° and 85°.
#[test]
fn ggx_sampling_matches_pdf_and_beats_cosine_sampling() {
    check(
        "GGX α = 0.2",
        ggx_material(),
        &[(0.0, 0.0), (35.0, 0.0), (52.0, 77.0), (83.0, 250.0)],
        5.0,
        // 0.99993–1.00000, within 0.09%, 23–354× lower.
        Some(Stated {
            pdf_from_1: 7e-5,
            albedo: 0.0009,
            variance_ratio: 23.0,
        }),
    );
}

/// Anisotropic GGX: the stretched visible-normal proposal, at a stored incidence, between
/// lattice nodes in φi and in θi, and near the last stored θi.
#[test]
fn anisotropic_ggx_sampling_matches_pdf_and_beats_cosine_sampling() {
    check(
        "anisotropic GGX 0.08/0.35",
        aniso_material(),
        &[(30.0, 0.0), (40.0, 67.0), (20.0, 200.0), (65.0, 300.0)],
        5.0,
        None,
    );
}

/// Every lobe kind and every way of blending records (Gaussian lobes of the paper's method,
/// the 1 − cos θh microfacet lobe, lobes of different kinds that are not shared, a lattice of
/// incidences that is not isotropic): ∫pdf = 1, and `sample` draws by `pdf` (χ², fewer samples).
#[test]
fn every_golden_file_samples_by_its_pdf() {
    const N: usize = 200_000;
    for (name, dec) in golden_decoders() {
        let thetas: Vec<f64> = dec
            .material()
            .records
            .iter()
            .map(|r| r.theta_i as f64)
            .collect();
        let (lo, hi) = (thetas[0], thetas[thetas.len() - 1]);
        for (k, inc) in [(lo, 0.0), (0.5 * (lo + hi) + 1.0, 33.0)]
            .iter()
            .enumerate()
        {
            let wi = dir(inc.0, inc.1);
            let (bt, bp) = (9, 18);
            let (qt, qp) = (bt * 60, bp * 24);
            let mut expected = vec![0.0; bt * bp];
            let mut total = 0.0;
            hemisphere(qt, qp, |i, j, wo, area| {
                let p = dec.pdf(wi, wo) as f64 * area;
                total += p;
                expected[(i / 60) * bp + j / 24] += p * N as f64;
            });
            let mut rng = XorShift(0x2545_F491_4F6C_DD1D ^ k as u64);
            let mut observed = vec![0u64; bt * bp];
            for _ in 0..N {
                let s = dec.sample(wi, [rng.next_f32(), rng.next_f32()]).unwrap();
                assert_eq!(
                    s.pdf,
                    dec.pdf(wi, s.wo),
                    "{name}: the sample's pdf is pdf()'s"
                );
                observed[bin_of(s.wo, bt, bp)] += 1;
            }
            let (stat, dof, p) = chi2(&observed, &expected);
            eprintln!(
                "{name} {inc:?}: ∫pdf dω = {total:.5}, χ² = {stat:.1} on {dof} dof, p = {p:.3}"
            );
            assert!(
                (total - 1.0).abs() < 0.01,
                "{name} {inc:?}: ∫pdf dω = {total}"
            );
            assert!(
                p > 0.001,
                "{name} {inc:?}: χ² = {stat} on {dof} dof, p = {p}"
            );
        }
    }
}

#[test]
fn sampling_refuses_what_it_cannot_answer() {
    let dec = &golden_decoders()[0].1;
    let up = [0.0f32, 0.0, 1.0];
    assert!(
        dec.sample([0.0, 0.6, -0.8], [0.5, 0.5]).is_none(),
        "light below"
    );
    assert!(dec.sample([0.0; 3], [0.5, 0.5]).is_none(), "zero vector");
    assert!(dec.sample(up, [f32::NAN, 0.5]).is_none(), "NaN number");
    assert_eq!(dec.pdf(up, [0.0, 0.6, -0.8]), 0.0, "viewer below");
    assert_eq!(dec.pdf([f32::INFINITY, 0.0, 1.0], up), 0.0);
    // u = 1 (a float rounding up) is taken as just below 1, not refused.
    let s = dec.sample(up, [1.0, 1.0]).unwrap();
    assert_eq!(s.pdf, dec.pdf(up, s.wo));
}

/// A decoded value is never negative: the SH-only baseline undershoots (14% of its values
/// would be negative), a default fit of a MERL ABC material between its samples (0.4% on a
/// dense grid), and the decoder clamps them; every material must come out non-negative, at any
/// direction and wavelength (outside the file's range included).
#[test]
fn no_decoded_value_is_negative() {
    let direct = {
        let set = paper_samples(15.0, 15.0, &[(15.0, 0.0)]);
        let e = encode_with(&set, |o| {
            o.peak = PeakMode::None;
            o.sh_level = Some(4);
        });
        Decoder::from_material(e.material).unwrap()
    };
    let abc = {
        let a = sbrdf::io::synth::Abc::from_table("gray-plastic", "magenta", &paper_wavelengths())
            .unwrap();
        let incidences = [(0.0, 0.0), (30.0, 0.0), (60.0, 0.0), (85.0, 0.0)];
        let set = sample_on_paper_grid(&incidences, |i, o, w| a.value(i, o, w));
        Decoder::from_material(encode_default(&set, |_| {}).material).unwrap()
    };
    let mut all: Vec<(String, &Decoder)> = vec![
        ("direct SH, Phong n = 15".into(), &direct),
        ("ABC gray-plastic".into(), &abc),
        ("Phong n = 200".into(), phong()),
        ("GGX α = 0.2".into(), ggx_material()),
    ];
    let golden = golden_decoders();
    all.extend(golden.iter().map(|(n, d)| (n.clone(), d)));
    let wl: Vec<f32> = (0..=70).map(|i| 370.0 + 5.0 * i as f32).collect();
    let mut out = vec![0.0f32; wl.len()];
    let mut out64 = vec![0.0f64; wl.len()];
    let wl64: Vec<f64> = wl.iter().map(|&l| l as f64).collect();
    for (name, dec) in &all {
        let (mut values, mut zeros) = (0usize, 0usize);
        for ti in (0..=90).step_by(6) {
            for pi in [0.0, 130.0] {
                let wi = dir(ti as f64, pi);
                for to in (0..=90).step_by(3) {
                    for po in (0..360).step_by(6) {
                        let wo = dir(to as f64, po as f64);
                        dec.eval(wi, wo, &wl, &mut out);
                        dec.eval_deg((ti as f64, pi), (to as f64, po as f64), &wl64, &mut out64);
                        for (&v, &v64) in out.iter().zip(&out64) {
                            assert!(v >= 0.0 && v64 >= 0.0, "{name}: {v}, {v64}");
                            values += 1;
                            zeros += (v == 0.0) as usize;
                        }
                    }
                }
            }
        }
        eprintln!("{name}: {values} values, none negative, {zeros} clamped or exactly 0");
        // Both materials are positive everywhere (a diffuse base), so their zeros are the clamp
        // at work: without it they would have been negative.
        if name.starts_with("direct SH") {
            assert!(zeros > values / 20, "{name}: only {zeros} zeros");
        }
        if name.starts_with("ABC") {
            assert!(zeros > 0, "{name}: no zeros");
        }
    }
}

/// |ρ(wi, wo) − ρ(wo, wi)| for reciprocal inputs: Phong about the mirror direction and GGX with
/// a symmetric Fresnel and shadowing term are reciprocal, so whatever differs is the encoding
/// (the fit at each incidence and the interpolation between incidences). Pairs are drawn over
/// the hemisphere and, as often, near the mirror configuration where the lobes are.
#[test]
fn reciprocity_of_reciprocal_inputs() {
    // θ range of the pairs: the stored range (a query outside it is answered at its end).
    // The guide's figures (library.md, "Importance sampling"): relative L2 0.06% and 0.11%,
    // worst 0.1% of the peak value, held at SLACK; the anisotropic material is not stated.
    for (name, dec, tmin, tmax, stated) in [
        ("Phong n = 200", phong(), 0.0, 80.0, Some((0.0006, 0.001))),
        (
            "GGX α = 0.2",
            ggx_material(),
            0.0,
            80.0,
            Some((0.0011, 0.001)),
        ),
        (
            "anisotropic GGX 0.08/0.35",
            aniso_material(),
            10.0,
            70.0,
            None,
        ),
    ] {
        let mut rng = XorShift(0xD1B5_4A32_D192_ED03);
        let (mut d2, mut r2, mut worst, mut peak) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let wl = [550.0f32];
        let (mut a, mut b) = ([0.0f32], [0.0f32]);
        for k in 0..200_000 {
            let ti = tmin + (tmax - tmin) * rng.next_f64();
            let pi = 360.0 * rng.next_f64();
            let (to, po) = if k % 2 == 0 {
                (
                    tmin + (tmax - tmin) * rng.next_f64(),
                    360.0 * rng.next_f64(),
                )
            } else {
                // Within ~8° of the mirror direction.
                let t = (ti + 8.0 * (2.0 * rng.next_f64() - 1.0)).clamp(tmin, tmax);
                (t, pi + 180.0 + 16.0 * (2.0 * rng.next_f64() - 1.0))
            };
            let (wi, wo) = (dir(ti, pi), dir(to, po));
            dec.eval(wi, wo, &wl, &mut a);
            dec.eval(wo, wi, &wl, &mut b);
            let (x, y) = (a[0] as f64, b[0] as f64);
            d2 += (x - y).powi(2);
            r2 += 0.5 * (x * x + y * y);
            worst = worst.max((x - y).abs());
            peak = peak.max(x.max(y));
        }
        let rel = (d2 / r2).sqrt();
        eprintln!(
            "{name}: reciprocity |ρ(wi,wo) − ρ(wo,wi)| relative L2 {:.2}%, worst {worst:.4} 1/sr \
             ({:.1}% of the largest value {peak:.3})",
            100.0 * rel,
            100.0 * worst / peak
        );
        // Measured: 0.06% and 0.11% (worst 0.1% of the peak); the encoder's 0.5% budget per
        // incidence and the interpolation between incidences bound what a sound encoding gives.
        assert!(rel < 0.01, "{name}: relative L2 {rel}");
        assert!(worst < 0.05 * peak, "{name}: worst {worst} of {peak}");
        if let Some((rel_stated, worst_stated)) = stated {
            held(
                &format!("{name}: reciprocity, relative L2"),
                rel,
                rel_stated,
            );
            held(
                &format!("{name}: reciprocity, worst / peak"),
                worst / peak,
                worst_stated,
            );
        }
    }
}
