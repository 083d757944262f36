//! Angle and direction conventions (normative text: `spec/EVALUATION.md`, section "Directions").
//!
//! The local shading frame has z along the surface normal. A direction (θ, φ) in degrees is the
//! unit vector (sin θ cos φ, sin θ sin φ, cos θ): θ is measured from the normal, φ counter-clockwise
//! from +x about z. The incident direction points from the surface toward the light; the outgoing
//! direction points toward the viewer. The mirror direction of (θ, φ) is (θ, φ + 180°).

use crate::model::lanes::{Lanes, Real};

/// Unit vector of a direction given in degrees.
pub fn dir_from_deg(theta_deg: f64, phi_deg: f64) -> [f64; 3] {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = phi_deg.to_radians().sin_cos();
    [st * cp, st * sp, ct]
}

/// (θ, φ) in degrees of a (not necessarily unit) vector; φ in [0, 360). At the poles φ = 0.
pub fn deg_from_dir(d: [f64; 3]) -> (f64, f64) {
    let r = (d[0] * d[0] + d[1] * d[1]).sqrt();
    let theta = r.atan2(d[2]).to_degrees();
    let phi = if r == 0.0 {
        0.0
    } else {
        wrap_phi(d[1].atan2(d[0]).to_degrees())
    };
    (theta, phi)
}

/// θ in degrees of a direction with horizontal length `r` ≥ 0 and height `z` ≥ 0: atan2(r, z)
/// from one division and a polynomial (Abramowitz & Stegun 4.4.49), inlined where it is used.
/// Within 1.4·10⁻⁸ rad and 1.8·10⁻⁸ relative of atan2 (less than a binary32 atan2 rounds), for
/// the decoder, which needs θ only to place a query between stored incidences; 0 for r = z = 0.
#[inline(always)]
pub fn polar_deg(r: f64, z: f64) -> f64 {
    polar_lanes(Lanes([r]), Lanes([z])).0[0]
}

/// [`polar_deg`] for N directions at once, lane by lane the same operations.
#[inline(always)]
pub fn polar_lanes<const N: usize>(r: Lanes<N>, z: Lanes<N>) -> Lanes<N> {
    const A: [f64; 8] = [
        -0.333_331_452_8,
        0.199_935_508_5,
        -0.142_088_994_4,
        0.106_562_639_3,
        -0.075_289_640_0,
        0.042_909_613_8,
        -0.016_165_736_7,
        0.002_866_225_7,
    ];
    let near_z = r.le(z);
    let lo = Lanes::select(near_z, r, z);
    let hi = Lanes::select(near_z, z, r);
    let zero = hi.le(Lanes::splat(0.0));
    let x = lo / Lanes::select(zero, Lanes::splat(1.0), hi);
    let x2 = x * x;
    let mut p = Lanes::splat(A[7]);
    for &a in A[..7].iter().rev() {
        p = p * x2 + a;
    }
    let atan = x + x * x2 * p;
    let theta = Lanes::select(near_z, atan, std::f64::consts::FRAC_PI_2 - atan);
    Lanes::select(zero, Lanes::splat(0.0), theta.map(f64::to_degrees))
}

/// φ taken modulo 360 into [0, 360).
pub fn wrap_phi(phi_deg: f64) -> f64 {
    let p = phi_deg.rem_euclid(360.0);
    // rem_euclid can round up to exactly 360 for tiny negative inputs.
    if p >= 360.0 {
        0.0
    } else {
        p + 0.0 // turns -0.0 into +0.0
    }
}

/// Signed azimuth difference a − b wrapped into (−180, 180].
pub fn phi_delta(a_deg: f64, b_deg: f64) -> f64 {
    let d = (a_deg - b_deg).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// The mirror-reflection direction of an incident direction: (θ, φ + 180°).
pub fn mirror_deg(theta_i: f64, phi_i: f64) -> (f64, f64) {
    (theta_i, wrap_phi(phi_i + 180.0))
}

/// The dot product of two vectors (of numbers or of lanes).
#[inline(always)]
pub fn dot<R: Real>(a: [R; 3], b: [R; 3]) -> R {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Angle in radians between two unit vectors, robust near 0 and π.
pub fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    // atan2(|a×b|, a·b) keeps full precision for tiny angles, where acos(a·b) loses it.
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let s = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    s.atan2(dot(a, b))
}

/// `v` scaled to unit length with one reciprocal, and where that worked (its length finite
/// and positive; elsewhere the lanes hold `v` unchanged). The decoder's direction check
/// (`spec/EVALUATION.md`, "Directions") for one vector or lanes of them.
#[inline(always)]
pub fn unit_lanes<R: Real>(v: [R; 3]) -> ([R; 3], R::Mask) {
    let (s, ok) = unit_scale_lanes(v);
    (v.map(|c| c * s), ok)
}

/// The factor [`unit_lanes`] scales `v` by, 1/|v| (1 where `v` has no unit multiple), and where
/// it has one: for a caller that scales part of `v`, or finds the factor another way where it
/// can.
#[inline(always)]
pub fn unit_scale_lanes<R: Real>(v: [R; 3]) -> (R, R::Mask) {
    let n = dot(v, v).sqrt();
    let ok = R::and(n.finite(), n.gt(R::splat(0.0)));
    (R::splat(1.0) / R::select(ok, n, R::splat(1.0)), ok)
}

/// The rotation about z that takes unit `wi` to azimuth 0 (the records' frame of an isotropic
/// file), without trigonometry: (r, cos φ, sin φ) with r = √(x² + y²); (0, 1, 0) at the pole.
#[inline(always)]
pub fn azimuth_rotation<R: Real>(wi: [R; 3]) -> (R, R, R) {
    let r = (wi[0] * wi[0] + wi[1] * wi[1]).sqrt();
    let positive = r.gt(R::splat(0.0));
    let inv = R::splat(1.0) / R::select(positive, r, R::splat(1.0));
    let c = R::select(positive, wi[0] * inv, R::splat(1.0));
    let s = R::select(positive, wi[1] * inv, R::splat(0.0));
    (r, c, s)
}

/// `v` turned about z by the rotation (cos, sin) [`azimuth_rotation`] gives.
#[inline(always)]
pub fn rotate_about_z<R: Real>(v: [R; 3], (c, s): (R, R)) -> [R; 3] {
    [c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]]
}

/// `v` scaled to unit length; None when its length is zero or not finite.
pub fn normalize(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(v, v).sqrt();
    if n.is_finite() && n > 0.0 {
        Some([v[0] / n, v[1] / n, v[2] / n])
    } else {
        None
    }
}

/// The weighted mean of axes given as angles in degrees (an axis at ψ is the axis at ψ + 180°):
/// the doubled angles' unit vectors averaged, halved back into [0, 180). `None` when the mean
/// vector is not finite or vanishes: shorter than 10⁻⁹ of the weights' sum (two perpendicular
/// axes with equal weights, whose doubled angles' sines and cosines cancel only to rounding).
/// Normative: `spec/EVALUATION.md`, "Lobes by position".
pub fn mean_axis_deg(axes: impl IntoIterator<Item = (f64, f64)>) -> Option<f64> {
    let (mut x, mut y, mut total) = (0.0f64, 0.0f64, 0.0f64);
    for (w, psi) in axes {
        let (s, c) = (2.0 * psi).to_radians().sin_cos();
        x += w * c;
        y += w * s;
        total += w.abs();
    }
    if !(x.is_finite() && y.is_finite()) || x.hypot(y) <= 1e-9 * total {
        return None;
    }
    let half = 0.5 * y.atan2(x).to_degrees();
    let psi = if half < 0.0 { half + 180.0 } else { half };
    // Rounding may land on 180 itself, which is the axis at 0.
    Some(if psi >= 180.0 { 0.0 } else { psi + 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The decoder's polar angle against atan2: within 1.4·10⁻⁸ rad and 1.8·10⁻⁸ relative over
    /// the quarter circle (the bound `spec/EVALUATION.md` "Rounding" states), exact at its ends.
    #[test]
    fn polar_deg_is_atan2_within_its_stated_error() {
        assert_eq!(polar_deg(0.0, 0.0), 0.0);
        assert_eq!(polar_deg(0.0, 1.0), 0.0);
        assert_eq!(polar_deg(1.0, 0.0), 90.0);
        assert_eq!(polar_deg(0.0, 1e-300), 0.0);
        let (mut worst_abs, mut worst_rel) = (0.0f64, 0.0f64);
        for i in 0..=200_000 {
            let t = std::f64::consts::FRAC_PI_2 * i as f64 / 200_000.0;
            for scale in [1.0, 1e-3, 7.5e5] {
                let (r, z) = (scale * t.sin(), scale * t.cos());
                let want = r.atan2(z);
                let got = polar_deg(r, z).to_radians();
                worst_abs = worst_abs.max((got - want).abs());
                if want > 0.0 {
                    worst_rel = worst_rel.max((got - want).abs() / want);
                }
            }
        }
        assert!(worst_abs < 1.4e-8, "{worst_abs}");
        assert!(worst_rel < 1.8e-8, "{worst_rel}");
        // Tiny angles keep their relative precision.
        let got = polar_deg(1e-9, 1.0).to_radians();
        assert!((got - 1e-9).abs() < 1e-24, "{got}");
    }

    #[test]
    fn round_trip_and_poles() {
        for &(t, p) in &[
            (15.0, 0.0),
            (89.0, 359.0),
            (45.0, 180.0),
            (0.0, 0.0),
            (90.0, 90.0),
        ] {
            let (t2, p2) = deg_from_dir(dir_from_deg(t, p));
            assert!((t - t2).abs() < 1e-9, "{t} {t2}");
            if t > 0.0 {
                assert!(phi_delta(p, p2).abs() < 1e-9, "{p} {p2}");
            }
        }
        assert_eq!(deg_from_dir([0.0, 0.0, 1.0]), (0.0, 0.0));
    }

    #[test]
    fn wrapping() {
        assert_eq!(wrap_phi(-90.0), 270.0);
        assert_eq!(wrap_phi(720.0), 0.0);
        assert_eq!(wrap_phi(-1e-20), 0.0);
        assert_eq!(wrap_phi(-0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(phi_delta(10.0, 350.0), 20.0);
        assert_eq!(phi_delta(350.0, 10.0), -20.0);
        assert_eq!(mirror_deg(15.0, 270.0), (15.0, 90.0));
    }

    #[test]
    fn small_angles_are_precise() {
        let a = dir_from_deg(30.0, 0.0);
        let b = dir_from_deg(30.0 + 1e-6, 0.0);
        let got = angle_between(a, b).to_degrees();
        assert!((got - 1e-6).abs() < 1e-12, "{got}");
    }

    #[test]
    fn axes_average_across_the_wrap() {
        // 179° and 1° are 2° apart: their mean is the axis at 0°, not at 90°.
        let m = mean_axis_deg([(0.5, 179.0), (0.5, 1.0)]).unwrap();
        assert!(m.min(180.0 - m) < 1e-9, "{m}");
        // 170° and 10° with weights 3:1: the doubled angles −20° and 20° average (as vectors)
        // to atan2(−0.5·sin 20°, cos 20°), so ψ = 180° + ½ of that: 174.84°, near the 175° an
        // average along the arc would give.
        let m = mean_axis_deg([(0.75, 170.0), (0.25, 10.0)]).unwrap();
        let t = 20f64.to_radians();
        let want = 180.0 + 0.5 * (-0.5 * t.sin()).atan2(t.cos()).to_degrees();
        assert!(
            (m - want).abs() < 1e-9 && (m - 175.0).abs() < 0.2,
            "{m} vs {want}"
        );
        // An axis turned by 180° is the same axis.
        let m = mean_axis_deg([(0.5, 30.0), (0.5, 210.0)]).unwrap();
        assert!((m - 30.0).abs() < 1e-9, "{m}");
        assert!(mean_axis_deg([(0.5, 0.0), (0.5, 90.0)]).is_none());
        let m = mean_axis_deg([(1.0, 42.0)]).unwrap();
        assert!((m - 42.0).abs() < 1e-12);
    }
}
