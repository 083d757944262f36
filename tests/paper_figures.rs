//! Reproduces the error figures of the paper's numerical study (Sec. 3), against the figures
//! computed independently for the issue (ColorChecker green diffuse, white specular, kd = 1,
//! 400–700 nm every 10 nm, θo = 2.5…87.5° and φo = 0…355° every 5°, incidence (15°, 0°)).

mod common;
use common::*;
use sbrdf::encode::fit::{CriticalAngle, PeakMode};
use sbrdf::model::spectral::{SpectralBasis, SpectralSpace};

const INCIDENCE: [(f64, f64); 1] = [(15.0, 0.0)];

#[test]
fn direct_sh_level_4_matches_fig_4() {
    // (n, expected error) for ks/kd = 15.
    for (n, want) in [(1.0, 0.077), (15.0, 0.18), (50.0, 0.55), (500.0, 0.89)] {
        let set = paper_samples(15.0, n, &INCIDENCE);
        let e = encode_with(&set, |o| {
            o.peak = PeakMode::None;
            o.sh_level = Some(4);
        });
        // The paper's figure is that of the plain SH series; the decoder clamps its negative
        // values at 0, which can only bring it closer to the (positive) material, and the
        // stored figure is the clamped one.
        let plain = plain_series_error(&e.material, &set);
        let tol = if want < 0.1 { 0.002 } else { 0.01 };
        assert!(
            (plain - want).abs() <= tol,
            "n = {n}: direct SH error {plain:.4}, expected ≈ {want}"
        );
        assert!(e.rel_error <= plain + 1e-6, "{} vs {plain}", e.rel_error);
        eprintln!(
            "n = {n}: direct SH error {plain:.4}, {:.4} as decoded (clamped at 0)",
            e.rel_error
        );
    }
}

/// The relative error of an SH-only record's series Σ_k Σ_j A(k, j)·Y_j(ω)·B_k(λ) as it stands,
/// negative values included: what the paper measured.
fn plain_series_error(m: &sbrdf::Material, set: &sbrdf::encode::samples::SampleSet) -> f64 {
    let r = &m.records[0];
    assert!(r.lobes.is_empty());
    let sh = sbrdf::model::sh::ShBasis::new(r.sh_level);
    let p = sh.count();
    let mut y = vec![0.0; p];
    let mut b = vec![0.0; m.spectral.terms];
    let s = &set.incidences[0];
    let (mut approx, mut truth) = (Vec::new(), Vec::new());
    for (d, row) in s
        .directions
        .iter()
        .zip(s.values.chunks(set.wavelengths.len()))
    {
        sh.eval(sbrdf::model::angles::dir_from_deg(d[0], d[1]), &mut y);
        for (&l, &v) in set.wavelengths.iter().zip(row) {
            m.spectral.eval(l, &mut b);
            let rho: f64 = (0..r.terms)
                .map(|k| b[k] * (0..p).map(|j| r.sh[k * p + j] as f64 * y[j]).sum::<f64>())
                .sum();
            approx.push(rho);
            truth.push(v);
        }
    }
    rel_l2(&approx, &truth)
}

#[test]
fn fourier_truncation_alone_costs_0_076() {
    // Project every outgoing spectrum on 13 Fourier terms and reconstruct: no angular fit.
    let set = paper_samples(15.0, 15.0, &INCIDENCE);
    let wl = paper_wavelengths();
    let space = SpectralSpace::analytic(SpectralBasis::PeriodicFourier, 13, 400.0, 700.0);
    let (proj, syn) = (space.fourier_projection(&wl), space.synthesis(&wl));
    let rho = &set.incidences[0].values;
    let mut approx = Vec::with_capacity(rho.len());
    for spectrum in rho.chunks(wl.len()) {
        let c: Vec<f64> = (0..13)
            .map(|k| {
                (0..wl.len())
                    .map(|w| proj[k * wl.len() + w] * spectrum[w])
                    .sum()
            })
            .collect();
        for w in 0..wl.len() {
            approx.push((0..13).map(|k| syn[w * 13 + k] * c[k]).sum::<f64>());
        }
    }
    let e = rel_l2(&approx, rho);
    assert!((e - 0.076).abs() < 0.002, "truncation error {e:.4}");
}

#[test]
fn paper_mode_minimum_near_37_degrees_fig_6() {
    let set = paper_samples(15.0, 15.0, &INCIDENCE);
    let auto = encode_with(&set, |o| o.sh_level = Some(1));
    let r = &auto.material.records[0];
    assert!(
        (0.07..=0.10).contains(&auto.rel_error),
        "paper-mode error {:.4} outside 0.07–0.10",
        auto.rel_error
    );
    assert!(
        (30.0..=42.0).contains(&r.critical_angle),
        "best critical angle {}° (paper: 37°, independent check: ≈37°)",
        r.critical_angle
    );
    // The peak is found at the mirror direction (15°, 180°).
    assert!((r.theta_p - 15.0).abs() < 0.5 && (r.phi_p - 180.0).abs() < 0.5);
    // The auto choice is the minimum of the error curve: no fixed angle does better.
    for g in (5..=85).step_by(5) {
        let fixed = encode_with(&set, |o| {
            o.sh_level = Some(1);
            o.critical_angle = CriticalAngle::Fixed(g as f64);
        });
        assert!(
            fixed.rel_error >= auto.rel_error - 1e-9,
            "critical angle {g}° gives {:.4} < auto {:.4}",
            fixed.rel_error,
            auto.rel_error
        );
    }
    // The error curve is U-shaped: small and large angles are much worse (Fig. 6).
    let at = |g: f64| {
        encode_with(&set, |o| {
            o.sh_level = Some(1);
            o.critical_angle = CriticalAngle::Fixed(g);
        })
        .rel_error
    };
    assert!(at(5.0) > 3.0 * auto.rel_error && at(80.0) > 3.0 * auto.rel_error);
}

#[test]
fn paper_mode_beats_direct_sh_threefold_at_n_50() {
    let set = paper_samples(15.0, 50.0, &INCIDENCE);
    let paper = encode_with(&set, |o| o.sh_level = Some(1));
    let direct = encode_with(&set, |o| {
        o.peak = PeakMode::None;
        o.sh_level = Some(4);
    });
    assert!(
        (0.07..=0.10).contains(&paper.rel_error),
        "paper mode {:.4}",
        paper.rel_error
    );
    assert!(
        direct.rel_error >= 3.0 * paper.rel_error,
        "direct {:.4} vs paper {:.4}",
        direct.rel_error,
        paper.rel_error
    );
}

#[test]
fn peak_found_at_other_incidences_and_azimuths() {
    // The peak finder must follow the mirror direction, including across φ = 0/360.
    for inc in [(30.0, 0.0), (45.0, 90.0), (60.0, 180.0), (20.0, 270.0)] {
        let set = paper_samples(5.0, 50.0, &[inc]);
        let e = encode_with(&set, |_| {});
        let r = &e.material.records[0];
        let want_phi = (inc.1 + 180.0) % 360.0;
        let dphi = ((r.phi_p as f64 - want_phi + 540.0) % 360.0) - 180.0;
        assert!(
            (r.theta_p as f64 - inc.0).abs() < 1.0 && dphi.abs() < 1.0,
            "incidence {inc:?}: peak at ({}, {})",
            r.theta_p,
            r.phi_p
        );
        assert!(
            e.rel_error < 0.12,
            "incidence {inc:?}: error {}",
            e.rel_error
        );
    }
}

#[test]
fn joint_fit_with_the_papers_basis_reaches_its_spectral_floor() {
    // The joint fit on the 13-term periodic Fourier basis (not orthogonal on the samples): the
    // error must come down to what the basis itself leaves (≈ 0.076), so the mapping back from
    // the orthonormalised basis is right.
    let set = paper_samples(15.0, 15.0, &INCIDENCE);
    let e = encode_with(&set, |o| {
        o.peak = PeakMode::Joint;
        o.sh_level = Some(4);
        o.lobes = vec![sbrdf::encode::fit::LobeFamily::CosinePower];
    });
    assert!(e.rel_error < 0.078, "joint on Fourier: {}", e.rel_error);
}

/// The guide's "Accuracy and size (paper mode)" table (pictures.md), errors and bytes held at
/// SLACK: direct SH at level 4, paper mode at level 1 (the automatic critical angle) and the
/// same in f16, ks/kd = 15. Files without sample positions; the guide's are the command line's,
/// with its metadata, so the material alone is smaller.
/// How a mode changes the paper's options.
type Mode = fn(&mut sbrdf::encode::EncodeOptions);

#[test]
fn accuracy_and_size_table_of_the_guide() {
    use sbrdf::model::Precision;
    // (n, direct (error, bytes), paper mode (error, bytes), paper mode f16 (error, bytes))
    let stated = [
        (1.0, (0.0767, 1769.0), (0.0782, 786.0), (0.0782, 655.0)),
        (15.0, (0.1650, 1770.0), (0.0841, 787.0), (0.0840, 657.0)),
        (50.0, (0.5232, 1769.0), (0.0795, 787.0), (0.0795, 656.0)),
        (500.0, (0.8842, 1770.0), (0.0735, 788.0), (0.0735, 658.0)),
    ];
    for (n, direct, paper, f16) in stated {
        let set = paper_samples(15.0, n, &INCIDENCE);
        let modes: [(&str, (f64, f64), Mode); 3] = [
            ("direct SH, L = 4", direct, |o| {
                o.peak = PeakMode::None;
                o.sh_level = Some(4);
            }),
            ("paper mode", paper, |o| o.sh_level = Some(1)),
            ("paper mode, f16", f16, |o| {
                o.sh_level = Some(1);
                o.precision = Precision::F16;
            }),
        ];
        for (what, (error, bytes), f) in modes {
            let e = encode_with(&set, |o| {
                o.sample_positions = false;
                f(o)
            });
            let size = sbrdf::write_material(&e.material).unwrap().len();
            held(&format!("n = {n}, {what}: error"), e.rel_error, error);
            held(&format!("n = {n}, {what}: bytes"), size as f64, bytes);
        }
    }
}
