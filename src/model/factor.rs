//! The factor model: one model of the whole material, shared by every incidence, for measured
//! data that is sparse, noisy and sampled at few incidences (normative text: `spec/EVALUATION.md`,
//! "Factor model"; bytes: `spec/FORMAT.md`, `FACT`).
//!
//! ```text
//! ρ(ωi, ωo, λ) = Σ_c exp(η_c),   η_c = s_c(λ) + Σ_r w_cr(λ)·T_cr(ωi, ωo),   w_c0 ≡ 1,
//! T_cr = Σ_k t_crk(u_k(ωi, ωo))   (piecewise-linear tables over fixed nodes)
//! ```
//!
//! Each component c is a spectrum times an angular function in log space (rank 1), or a sum of
//! such log terms (rank R: the spectrum's shape changes with geometry, as Beer–Lambert
//! absorption does). Everything is an exponential, so the model is positive everywhere by
//! construction. The angular features are the half-vector angles of Rusinkiewicz (θh, θd), the
//! polar angles θi and θo (interpolated linearly in 1/cos θ, the path length through a layer),
//! and x = sin θo·cos(φo − φi), which tells the side of the source from the mirror side. The
//! model is isotropic.

use crate::model::warped::POLE_HALF_XY;
use crate::model::Precision;

/// The angle features a table can be over. Codes are the format's (`FORMAT.md`, §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feature {
    /// θh, degrees: the half vector's angle from the normal.
    HalfAngle,
    /// θd, degrees: the angle between the incident direction and the half vector.
    DifferenceAngle,
    /// θi, degrees, interpolated linearly in 1/cos θi.
    Incidence,
    /// θo, degrees, interpolated linearly in 1/cos θo.
    Exitance,
    /// x = sin θo·cos(φo − φi): +1 toward the source, −1 the mirror side.
    Toward,
    /// A 2-D table over (θi on a coarse axis, in 1/cos θi) × x, bilinear.
    IncidenceToward,
}

/// Node lists, constants of the format.
const NODES_H: [f64; 23] = [
    0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.5, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0,
    30.0, 40.0, 50.0, 60.0, 75.0, 90.0,
];
const NODES_D: [f64; 10] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0];
const NODES_POLAR: [f64; 12] = [
    0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 75.0, 80.0, 85.0, 88.0,
];
const NODES_POLAR_COARSE: [f64; 7] = [0.0, 20.0, 40.0, 60.0, 70.0, 80.0, 88.0];
const NODES_X: [f64; 9] = [-1.0, -0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0];

/// The largest polar angle the 1/cos coordinate takes, degrees.
pub const POLAR_MAX: f64 = 88.0;

impl Feature {
    /// The feature's code in `FACT` (`spec/FORMAT.md` §4): 1 to 6.
    pub fn code(self) -> u8 {
        match self {
            Feature::HalfAngle => 1,
            Feature::DifferenceAngle => 2,
            Feature::Incidence => 3,
            Feature::Exitance => 4,
            Feature::Toward => 5,
            Feature::IncidenceToward => 6,
        }
    }

    /// The feature with this code; None for an unknown code.
    pub fn from_code(c: u8) -> Option<Self> {
        Some(match c {
            1 => Feature::HalfAngle,
            2 => Feature::DifferenceAngle,
            3 => Feature::Incidence,
            4 => Feature::Exitance,
            5 => Feature::Toward,
            6 => Feature::IncidenceToward,
            _ => return None,
        })
    }

    /// The feature's name in reports: `"theta_h"`, `"theta_d"`, `"theta_i"`, `"theta_o"`, `"x"`,
    /// `"theta_i*x"`.
    pub fn name(self) -> &'static str {
        match self {
            Feature::HalfAngle => "theta_h",
            Feature::DifferenceAngle => "theta_d",
            Feature::Incidence => "theta_i",
            Feature::Exitance => "theta_o",
            Feature::Toward => "x",
            Feature::IncidenceToward => "theta_i*x",
        }
    }

    /// The number of table values: the node count (a product for the 2-D table).
    pub fn table_len(self) -> usize {
        match self {
            Feature::HalfAngle => NODES_H.len(),
            Feature::DifferenceAngle => NODES_D.len(),
            Feature::Incidence | Feature::Exitance => NODES_POLAR.len(),
            Feature::Toward => NODES_X.len(),
            Feature::IncidenceToward => NODES_POLAR_COARSE.len() * NODES_X.len(),
        }
    }
}

/// One 1-D axis: its nodes in degrees (or x), and whether it interpolates in 1/cos θ.
#[derive(Debug, Clone, Copy)]
pub struct Axis {
    /// The nodes, increasing: degrees for angles, plain values for x.
    pub nodes: &'static [f64],
    /// Whether the axis interpolates linearly in 1/cos θ rather than in the value.
    pub secant: bool,
}

impl Axis {
    /// The θh axis: 23 nodes from 0° to 90°, dense near 0.
    pub const H: Axis = Axis {
        nodes: &NODES_H,
        secant: false,
    };
    /// The θd axis: every 10° from 0° to 90°.
    pub const D: Axis = Axis {
        nodes: &NODES_D,
        secant: false,
    };
    /// The θi and θo axis: 12 nodes from 0° to 88°, linear in 1/cos θ.
    pub const POLAR: Axis = Axis {
        nodes: &NODES_POLAR,
        secant: true,
    };
    /// The coarse θi axis of the 2-D (θi, x) table: 7 nodes from 0° to 88°, linear in 1/cos θ.
    pub const POLAR_COARSE: Axis = Axis {
        nodes: &NODES_POLAR_COARSE,
        secant: true,
    };
    /// The x axis: every 0.25 from −1 to 1.
    pub const X: Axis = Axis {
        nodes: &NODES_X,
        secant: false,
    };

    /// The coordinate the axis is linear in: 1/cos θ (θ clamped to [0, 88°]) or the value.
    pub fn coordinate(self, v: f64) -> f64 {
        if self.secant {
            1.0 / v.clamp(0.0, POLAR_MAX).to_radians().cos()
        } else {
            v
        }
    }

    /// The node index j and weight a of `v` (clamped to the nodes): value = (1−a)·t_j + a·t_{j+1}.
    pub fn locate(self, v: f64) -> (usize, f64) {
        let n = self.nodes;
        let v = if v.is_nan() {
            n[0]
        } else {
            v.clamp(n[0], n[n.len() - 1])
        };
        let j = n.partition_point(|&x| x <= v).clamp(1, n.len() - 1) - 1;
        let (a, b) = (self.coordinate(n[j]), self.coordinate(n[j + 1]));
        let t = ((self.coordinate(v) - a) / (b - a)).clamp(0.0, 1.0);
        (j, t)
    }
}

/// Up to four (table index, weight) pairs of one feature's table, and how many are used.
pub type Taps = ([(usize, f64); 4], usize);

/// The features' clamp ranges as stored: [min, max] of θh, θd, θi, θo (degrees) and x, the
/// ranges the training data covered. A query outside is evaluated at the nearest end.
pub type FeatureRanges = [[f32; 2]; 5];

/// The angle features of one query, clamped to the stored ranges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureValues {
    /// θh, degrees.
    pub h: f64,
    /// θd, degrees.
    pub d: f64,
    /// θi, degrees.
    pub i: f64,
    /// θo, degrees.
    pub o: f64,
    /// x = sin θo·cos(φo − φi).
    pub x: f64,
}

impl FeatureValues {
    /// The features of unit vectors `wi`, `wo` (z = normal, both with z ≥ 0), before clamping.
    pub fn of(wi: [f64; 3], wo: [f64; 3]) -> Self {
        let ri = (wi[0] * wi[0] + wi[1] * wi[1]).sqrt();
        // The query rotated about z so that φi = 0: wi' = (ri, 0, zi), wo' = R·wo.
        let (c, s) = if ri > 0.0 {
            (wi[0] / ri, wi[1] / ri)
        } else {
            (1.0, 0.0)
        };
        let wox = c * wo[0] + s * wo[1];
        let woy = -s * wo[0] + c * wo[1];
        let (wi, wo) = ([ri, 0.0, wi[2]], [wox, woy, wo[2]]);
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
        let polar = |z: f64, r: f64| r.atan2(z).to_degrees();
        // The mirror direction (and both directions opposite on the horizon, m = 0): the half
        // vector is the pole, θh = 0 and θd = θi, whatever the rounding residue of m's
        // horizontal part (the warped tables' rule, `POLE_HALF_XY`; issue 43).
        let (h_deg, d_deg) = if (sum[0] * sum[0] + sum[1] * sum[1]).sqrt() <= POLE_HALF_XY {
            (0.0, polar(wi[2], ri))
        } else if n > 0.0 {
            let hv = [sum[0] / n, sum[1] / n, sum[2] / n];
            let h = (hv[0] * hv[0] + hv[1] * hv[1])
                .sqrt()
                .atan2(hv[2])
                .to_degrees();
            let cross = [
                wi[1] * hv[2] - wi[2] * hv[1],
                wi[2] * hv[0] - wi[0] * hv[2],
                wi[0] * hv[1] - wi[1] * hv[0],
            ];
            let cn = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let dotp = wi[0] * hv[0] + wi[1] * hv[1] + wi[2] * hv[2];
            (h, cn.atan2(dotp).to_degrees())
        } else {
            (90.0, 90.0)
        };
        FeatureValues {
            h: h_deg,
            d: d_deg,
            i: polar(wi[2], ri),
            o: polar(wo[2], (wo[0] * wo[0] + wo[1] * wo[1]).sqrt()),
            x: wox,
        }
    }

    /// Each feature clamped to its stored range.
    pub fn clamped(self, r: &FeatureRanges) -> Self {
        let c = |v: f64, k: usize| {
            if v.is_nan() {
                r[k][0] as f64
            } else {
                v.clamp(r[k][0] as f64, r[k][1] as f64)
            }
        };
        FeatureValues {
            h: c(self.h, 0),
            d: c(self.d, 1),
            i: c(self.i, 2),
            o: c(self.o, 3),
            x: c(self.x, 4),
        }
    }

    /// Up to four (table index, weight) pairs of `feature`'s table at these values.
    pub fn taps(&self, feature: Feature) -> Taps {
        let one = |axis: Axis, v: f64| {
            let (j, t) = axis.locate(v);
            ([(j, 1.0 - t), (j + 1, t), (0, 0.0), (0, 0.0)], 2)
        };
        match feature {
            Feature::HalfAngle => one(Axis::H, self.h),
            Feature::DifferenceAngle => one(Axis::D, self.d),
            Feature::Incidence => one(Axis::POLAR, self.i),
            Feature::Exitance => one(Axis::POLAR, self.o),
            Feature::Toward => one(Axis::X, self.x),
            Feature::IncidenceToward => {
                let (a, ta) = Axis::POLAR_COARSE.locate(self.i);
                let (b, tb) = Axis::X.locate(self.x);
                let nx = NODES_X.len();
                (
                    [
                        (a * nx + b, (1.0 - ta) * (1.0 - tb)),
                        (a * nx + b + 1, (1.0 - ta) * tb),
                        ((a + 1) * nx + b, ta * (1.0 - tb)),
                        ((a + 1) * nx + b + 1, ta * tb),
                    ],
                    4,
                )
            }
        }
    }
}

/// One component: its features and, per rank r, a spectral vector (none for r = 0) and one table
/// per feature.
#[derive(Debug, Clone, PartialEq)]
pub struct FactorComponent {
    /// The features its tables are over, each at most once.
    pub features: Vec<Feature>,
    /// s_c at the file's wavelengths (natural log of 1/sr).
    pub spectrum: Vec<f32>,
    /// Per rank r ≥ 1, w_cr at the file's wavelengths: `modulation[r − 1]`.
    pub modulation: Vec<Vec<f32>>,
    /// `tables[r][k]`: t_crk, `features[k].table_len()` values.
    pub tables: Vec<Vec<Vec<f32>>>,
}

impl FactorComponent {
    /// R, the number of log terms (ranks r = 0..R), one set of tables each.
    pub fn rank(&self) -> usize {
        self.tables.len()
    }
}

/// The factor model of a file (`FACT` chunk).
#[derive(Debug, Clone, PartialEq)]
pub struct FactorModel {
    /// The precision the parameters are stored in; the values held here are exactly the stored
    /// ones.
    pub precision: Precision,
    /// The features' clamp ranges: what the training data covered.
    pub ranges: FeatureRanges,
    /// The components, summed after exponentiation; 1 to [`MAX_COMPONENTS`].
    pub components: Vec<FactorComponent>,
}

/// The most components, ranks and features per component the format allows.
pub const MAX_COMPONENTS: usize = 8;
/// The most ranks (log terms) per component.
pub const MAX_RANK: usize = 8;
/// The most features per component.
pub const MAX_FEATURES: usize = 6;
/// exp arguments are capped here (e⁶⁰ ≈ 10²⁶ 1/sr), so a value is always finite.
pub const ETA_MAX: f64 = 60.0;

impl FactorModel {
    /// Checks the model against `w` wavelengths; the message says what is wrong.
    pub fn validate(&self, w: usize) -> Result<(), String> {
        if self.components.is_empty() || self.components.len() > MAX_COMPONENTS {
            return Err(format!(
                "{} factor components (1 to {MAX_COMPONENTS})",
                self.components.len()
            ));
        }
        for (k, (r, hi)) in self
            .ranges
            .iter()
            .zip([90.0, 90.0, 90.0, 90.0, 1.0])
            .enumerate()
        {
            let lo = if k == 4 { -1.0 } else { 0.0 };
            if !(r[0].is_finite() && r[1].is_finite() && lo <= r[0] && r[0] <= r[1] && r[1] <= hi) {
                return Err(format!(
                    "feature range {k} [{}, {}] is not an interval within [{lo}, {hi}]",
                    r[0], r[1]
                ));
            }
        }
        for (ci, c) in self.components.iter().enumerate() {
            let here = |m: String| format!("factor component {ci}: {m}");
            if c.features.is_empty() || c.features.len() > MAX_FEATURES {
                return Err(here(format!(
                    "{} features (1 to {MAX_FEATURES})",
                    c.features.len()
                )));
            }
            for (a, f) in c.features.iter().enumerate() {
                if c.features[..a].contains(f) {
                    return Err(here(format!("feature {} twice", f.name())));
                }
            }
            let r = c.rank();
            if r == 0 || r > MAX_RANK || c.modulation.len() != r - 1 {
                return Err(here(format!(
                    "rank {r} with {} modulations",
                    c.modulation.len()
                )));
            }
            if c.spectrum.len() != w || c.modulation.iter().any(|m| m.len() != w) {
                return Err(here(format!(
                    "spectra must have the {w} wavelengths of the file"
                )));
            }
            for t in &c.tables {
                if t.len() != c.features.len()
                    || t.iter()
                        .zip(&c.features)
                        .any(|(v, f)| v.len() != f.table_len())
                {
                    return Err(here("a table of the wrong size".into()));
                }
            }
            let all = c
                .spectrum
                .iter()
                .chain(c.modulation.iter().flatten())
                .chain(c.tables.iter().flatten().flatten());
            for v in all {
                if !v.is_finite() {
                    return Err(here(format!("value {v} is not finite")));
                }
                if self.precision == Precision::F16 && half::f16::from_f32(*v).to_f32() != *v {
                    return Err(here(format!("value {v} is not exactly an f16 number")));
                }
            }
        }
        Ok(())
    }

    /// The number of stored parameters (spectra, modulations, tables).
    pub fn parameter_count(&self) -> usize {
        self.components
            .iter()
            .map(|c| {
                c.spectrum.len()
                    + c.modulation.iter().map(Vec::len).sum::<usize>()
                    + c.tables.iter().flatten().map(Vec::len).sum::<usize>()
            })
            .sum()
    }

    /// T_cr for every component and rank at `f` (already clamped), into `out` in component
    /// order, rank-major ([`FactorModel::total_rank`] values; `out` must hold them).
    pub fn angular(&self, f: &FeatureValues, out: &mut [f64]) {
        // Each feature's taps once: components share features.
        let mut taps: [Option<Taps>; 6] = [None; 6];
        let mut n = 0;
        for c in &self.components {
            for tables in &c.tables {
                let mut t = 0.0;
                for (feature, table) in c.features.iter().zip(tables) {
                    let slot = &mut taps[feature.code() as usize - 1];
                    let (tp, m) = *slot.get_or_insert_with(|| f.taps(*feature));
                    for &(j, wgt) in &tp[..m] {
                        t += wgt * table[j] as f64;
                    }
                }
                out[n] = t;
                n += 1;
            }
        }
    }

    /// ρ at wavelength index bracket (j, a) (value = (1−a)·v_j + a·v_{j+1}) from the angular
    /// values `t` of [`FactorModel::angular`].
    pub fn value(&self, t: &[f64], j: usize, a: f64) -> f64 {
        let at = |v: &[f32]| {
            let lo = v[j] as f64;
            if a == 0.0 || j + 1 >= v.len() {
                lo
            } else {
                lo + a * (v[j + 1] as f64 - lo)
            }
        };
        let mut rho = 0.0;
        let mut k = 0;
        for c in &self.components {
            let mut eta = at(&c.spectrum) + t[k];
            for (r, m) in c.modulation.iter().enumerate() {
                eta += at(m) * t[k + 1 + r];
            }
            k += c.rank();
            rho += eta.min(ETA_MAX).exp();
        }
        rho
    }

    /// Total rank: the number of angular values [`FactorModel::angular`] writes.
    pub fn total_rank(&self) -> usize {
        self.components.iter().map(FactorComponent::rank).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::angles::dir_from_deg;

    #[test]
    fn features_of_known_directions() {
        // Mirror configuration: the half vector is the normal, θd = θi, x = −sin θo.
        let f = FeatureValues::of(dir_from_deg(30.0, 40.0), dir_from_deg(30.0, 220.0));
        assert!(f.h.abs() < 1e-9 && (f.d - 30.0).abs() < 1e-9);
        assert!((f.i - 30.0).abs() < 1e-9 && (f.o - 30.0).abs() < 1e-9);
        assert!((f.x + 0.5).abs() < 1e-12);
        // Retro-reflection: θh = θi, θd = 0, x = +sin θo.
        let f = FeatureValues::of(dir_from_deg(50.0, 10.0), dir_from_deg(50.0, 10.0));
        assert!((f.h - 50.0).abs() < 1e-9 && f.d.abs() < 1e-6);
        assert!((f.x - 50f64.to_radians().sin()).abs() < 1e-12);
    }

    /// The mirror direction is the pole exactly (issue 43): θh = 0 and θd = θi whatever the
    /// residue, and two directions opposite on the horizon (m = 0) are its limit (θh = 0,
    /// θd = 90°), not θh = θd = 90° (which the GPU and the CPU reached by different roundings).
    #[test]
    fn the_mirror_direction_is_the_pole() {
        for (t, p) in [(30.0, 40.0), (89.9999, 123.0), (90.0, 77.0), (0.0, 0.0)] {
            let f = FeatureValues::of(dir_from_deg(t, p), dir_from_deg(t, p + 180.0));
            assert_eq!(f.h, 0.0, "{t}° {p}°");
            assert_eq!(f.d, f.i, "{t}° {p}°");
        }
        let (a, b) = ([0.8, -0.6, 0.0], [-0.8, 0.6, 0.0]);
        let f = FeatureValues::of(a, b);
        assert_eq!((f.h, f.d, f.i, f.o), (0.0, 90.0, 90.0, 90.0));
        // Just off the mirror, the ordinary formula.
        let f = FeatureValues::of(dir_from_deg(30.0, 40.0), dir_from_deg(30.0, 221.0));
        assert!(f.h > 0.1 && f.h < 1.0, "{}", f.h);
    }

    #[test]
    fn axes_interpolate_in_their_coordinate() {
        let (j, t) = Axis::POLAR.locate(75.0);
        assert_eq!((j, t), (8, 0.0));
        // 1/cos is steeper near grazing: 65° lies nearer 60° than half-way in that coordinate.
        let (j, t) = Axis::POLAR.locate(65.0);
        assert_eq!(j, 6);
        assert!(t < 0.5 && t > 0.3, "{t}");
        assert_eq!(Axis::H.locate(200.0), (21, 1.0));
        assert_eq!(Axis::X.locate(-3.0), (0, 0.0));
        assert_eq!(Axis::H.locate(f64::NAN), (0, 0.0));
    }
}
