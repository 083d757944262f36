//! Test material generators: the paper's Phong materials (its Sec. 3, Eq. 14) over ColorChecker
//! spectra shipped with the crate.

use crate::encode::samples::{IncidentSamples, SampleSet};
use crate::error::{Error, Result};
use crate::model::angles::{dir_from_deg, dot, mirror_deg};

/// N. Ohta's ColorChecker reflectances, 380–780 nm every 5 nm (see `samples/README.md`).
pub const COLORCHECKER_CSV: &str = include_str!("../../samples/colorchecker_ohta_380_780_5nm.csv");

/// Named reflectance spectra sampled on a common wavelength grid.
#[derive(Debug, Clone)]
pub struct SpectrumTable {
    /// The common wavelength grid, nm.
    pub wavelengths: Vec<f64>,
    /// The spectra's names (the table's column headers).
    pub names: Vec<String>,
    /// `spectra[i]` is the column of `names[i]`.
    pub spectra: Vec<Vec<f64>>,
}

impl SpectrumTable {
    /// The embedded ColorChecker table.
    pub fn colorchecker() -> Self {
        Self::parse(COLORCHECKER_CSV).expect("the embedded ColorChecker table parses")
    }

    /// Parses a table whose first column is `wavelength_nm` and whose other columns are spectra.
    pub fn parse(text: &str) -> Result<Self> {
        let mut r = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let bad = |m: String| Error::Input(format!("spectrum table: {m}"));
        let names: Vec<String> = r
            .headers()
            .map_err(|e| bad(e.to_string()))?
            .iter()
            .skip(1)
            .map(|s| s.to_string())
            .collect();
        let mut wavelengths = Vec::new();
        let mut spectra = vec![Vec::new(); names.len()];
        for rec in r.records() {
            let rec = rec.map_err(|e| bad(e.to_string()))?;
            let nums: Vec<f64> = rec
                .iter()
                .map(|s| {
                    s.trim()
                        .parse::<f64>()
                        .map_err(|e| bad(format!("{s}: {e}")))
                })
                .collect::<Result<_>>()?;
            wavelengths.push(nums[0]);
            for (i, v) in nums[1..].iter().enumerate() {
                spectra[i].push(*v);
            }
        }
        Ok(SpectrumTable {
            wavelengths,
            names,
            spectra,
        })
    }

    /// Finds a spectrum by name, ignoring case; a unique prefix is enough (`white` finds
    /// `white 9.5 (.05 D)`).
    pub fn find(&self, name: &str) -> Result<usize> {
        let k = name.trim().to_lowercase();
        if let Some(i) = self.names.iter().position(|n| n.to_lowercase() == k) {
            return Ok(i);
        }
        let hits: Vec<usize> = (0..self.names.len())
            .filter(|&i| self.names[i].to_lowercase().starts_with(&k))
            .collect();
        match hits.as_slice() {
            [i] => Ok(*i),
            _ => Err(Error::Parameter(format!(
                "{} patch '{name}'; known patches: {}",
                if hits.is_empty() { "no" } else { "ambiguous" },
                self.names.join(", ")
            ))),
        }
    }

    /// Spectrum `index` linearly interpolated at `wavelengths` (which must lie inside the table).
    pub fn sample(&self, index: usize, wavelengths: &[f64]) -> Result<Vec<f64>> {
        let (lo, hi) = (self.wavelengths[0], *self.wavelengths.last().unwrap());
        wavelengths
            .iter()
            .map(|&l| {
                if !(lo..=hi).contains(&l) {
                    return Err(Error::Parameter(format!(
                        "wavelength {l} nm is outside the spectra's range {lo}–{hi} nm"
                    )));
                }
                let j = self.wavelengths.partition_point(|&w| w <= l).max(1) - 1;
                let j = j.min(self.wavelengths.len() - 2);
                let (w0, w1) = (self.wavelengths[j], self.wavelengths[j + 1]);
                let t = (l - w0) / (w1 - w0);
                let s = &self.spectra[index];
                Ok(s[j] + t * (s[j + 1] - s[j]))
            })
            .collect()
    }
}

/// The paper's Phong material as a BRDF: ρ = kd·Sd(λ) + ks·Ss(λ)·max(0, cos α)ⁿ, α the angle
/// between the outgoing direction and the mirror direction of the incident one. (The paper's
/// Eq. 14 is an intensity with a cos θi factor on the diffuse term; as a BRDF the factor goes.
/// The error figures of its Figs. 4 and 6 are reproduced either way to two digits.)
#[derive(Debug, Clone)]
pub struct Phong {
    /// Sd(λ), the diffuse reflectance at each wavelength.
    pub diffuse: Vec<f64>,
    /// Ss(λ), the specular reflectance at each wavelength.
    pub specular: Vec<f64>,
    /// The diffuse weight kd.
    pub kd: f64,
    /// The specular weight ks.
    pub ks: f64,
    /// The Phong exponent n.
    pub n: f64,
}

impl Phong {
    /// Diffuse and specular spectra from ColorChecker patches (names as [`SpectrumTable::find`]
    /// takes them), sampled at `wavelengths`.
    pub fn colorchecker(
        diffuse: &str,
        specular: &str,
        (kd, ks, n): (f64, f64, f64),
        wavelengths: &[f64],
    ) -> Result<Self> {
        let t = SpectrumTable::colorchecker();
        Ok(Phong {
            diffuse: t.sample(t.find(diffuse)?, wavelengths)?,
            specular: t.sample(t.find(specular)?, wavelengths)?,
            kd,
            ks,
            n,
        })
    }

    /// ρ (1/sr) at incident (θi, φi) and outgoing (θo, φo), degrees, at wavelength index `w`
    /// (into the wavelengths the spectra were sampled at).
    pub fn value(&self, incident: (f64, f64), outgoing: (f64, f64), w: usize) -> f64 {
        let (mt, mp) = mirror_deg(incident.0, incident.1);
        let c = dot(dir_from_deg(mt, mp), dir_from_deg(outgoing.0, outgoing.1)).max(0.0);
        self.kd * self.diffuse[w] + self.ks * self.specular[w] * c.powf(self.n)
    }
}

/// The outgoing grid of the paper: θo = step/2, 3·step/2, … < 90, φo = 0, step, … < 360.
pub fn paper_grid(theta_step: f64, phi_step: f64) -> Vec<[f64; 2]> {
    let mut v = Vec::new();
    let mut i = 0;
    while (i as f64 + 0.5) * theta_step < 90.0 {
        let t = (i as f64 + 0.5) * theta_step;
        let mut j = 0;
        while (j as f64) * phi_step < 360.0 {
            v.push([t, j as f64 * phi_step]);
            j += 1;
        }
        i += 1;
    }
    v
}

/// Samples any material function on a set of directions and wavelengths.
pub fn sample_material(
    wavelengths: &[f64],
    incidences: &[(f64, f64)],
    directions: &[[f64; 2]],
    f: impl Fn((f64, f64), (f64, f64), usize) -> f64,
) -> SampleSet {
    let mut incs: Vec<(f64, f64)> = incidences.to_vec();
    incs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    incs.dedup();
    let mut dirs = directions.to_vec();
    dirs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    SampleSet {
        wavelengths: wavelengths.to_vec(),
        incidences: incs
            .iter()
            .map(|&inc| IncidentSamples {
                theta_i: inc.0,
                phi_i: inc.1,
                directions: dirs.clone(),
                values: dirs
                    .iter()
                    .flat_map(|d| (0..wavelengths.len()).map(move |w| (d, w)))
                    .map(|(d, w)| f(inc, (d[0], d[1]), w))
                    .collect(),
            })
            .collect(),
    }
}

/// Löw et al.'s ABC-model fits to the 100 MERL materials (RGB), as published in the public-domain
/// dj_brdf toolkit (see `samples/README.md`).
pub const MERL_ABC_CSV: &str = include_str!("../../samples/merl_abc_low2012_params.csv");

fn half_vector(wi: [f64; 3], wo: [f64; 3]) -> ([f64; 3], f64, f64) {
    let h = crate::model::angles::normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]])
        .unwrap_or([0.0, 0.0, 1.0]);
    (h, h[2], dot(wi, h))
}

/// Exact unpolarised Fresnel reflectance of a dielectric of relative index `eta` at cos θd.
pub fn fresnel_dielectric(eta: f64, cos_d: f64) -> f64 {
    let c = cos_d.clamp(1e-6, 1.0);
    let g = (eta * eta - 1.0 + c * c).max(0.0).sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    0.5 * a * a * (1.0 + b * b)
}

/// A GGX microfacet material: Lambert base kd·Sd(λ)/π plus D·G2·F/(4 cos θi cos θo) with the
/// GGX distribution, the height-correlated Smith G2 and Schlick's Fresnel with a spectral F0(λ).
///
/// The distribution may be anisotropic (Heitz 2014, "Understanding the masking-shadowing
/// function", eq. 80 and 86): roughness `alpha` along the first surface axis u and `alpha_y`
/// along the second v, with u turned `axis_deg` degrees from the tangent x towards y (v =
/// z × u). In the frame (u, v, z), D(h) = 1/(π αx αy (hu²/αx² + hv²/αy² + hz²)²) and
/// Λ(ω) = (−1 + √(1 + (αx² ωu² + αy² ωv²)/ωz²))/2. `alpha_y == alpha` is the isotropic GGX.
#[derive(Debug, Clone)]
pub struct Ggx {
    /// Roughness along the first axis (the only one when isotropic).
    pub alpha: f64,
    /// Roughness along the second axis.
    pub alpha_y: f64,
    /// Angle of the first axis from the tangent x, degrees, counter-clockwise seen from above.
    pub axis_deg: f64,
    /// The diffuse weight: the diffuse term is kd·diffuse(λ)/π.
    pub kd: f64,
    /// The diffuse reflectance at each wavelength.
    pub diffuse: Vec<f64>,
    /// Schlick's F0(λ) at each wavelength.
    pub f0: Vec<f64>,
}

impl Ggx {
    /// `sbrdf synth ggx`'s material: a ColorChecker diffuse patch and F0(λ) = 0.04 + 0.5·(the
    /// `fresnel` patch), sampled at `wavelengths`.
    pub fn colorchecker(
        alpha: f64,
        kd: f64,
        diffuse: &str,
        fresnel: &str,
        wavelengths: &[f64],
    ) -> Result<Self> {
        let t = SpectrumTable::colorchecker();
        Ok(Ggx {
            alpha,
            alpha_y: alpha,
            axis_deg: 0.0,
            kd,
            diffuse: t.sample(t.find(diffuse)?, wavelengths)?,
            f0: t
                .sample(t.find(fresnel)?, wavelengths)?
                .iter()
                .map(|v| 0.04 + 0.5 * v)
                .collect(),
        })
    }

    /// The same material with an anisotropic distribution: roughness `alpha_y` along the second
    /// axis and the first axis at `axis_deg` degrees from the tangent.
    pub fn with_anisotropy(mut self, alpha_y: f64, axis_deg: f64) -> Self {
        self.alpha_y = alpha_y;
        self.axis_deg = axis_deg;
        self
    }

    /// Components of `w` along the axes u = (cos, sin, 0) and v = (−sin, cos, 0) of the axis angle.
    fn along_axes(&self, w: [f64; 3]) -> (f64, f64) {
        let (s, c) = self.axis_deg.to_radians().sin_cos();
        (w[0] * c + w[1] * s, -w[0] * s + w[1] * c)
    }

    /// The normal distribution D(h) for a unit h in the upper hemisphere (∫ D·hz dω = 1).
    pub fn distribution(&self, h: [f64; 3]) -> f64 {
        let (ax, ay) = (self.alpha, self.alpha_y);
        let (hu, hv) = self.along_axes(h);
        let t = hu * hu / (ax * ax) + hv * hv / (ay * ay) + h[2] * h[2];
        1.0 / (std::f64::consts::PI * ax * ay * t * t)
    }

    /// Smith's Λ for direction `w` (w·z > 0).
    fn lambda(&self, w: [f64; 3]) -> f64 {
        let (ax, ay) = (self.alpha, self.alpha_y);
        let (wu, wv) = self.along_axes(w);
        let z2 = w[2] * w[2];
        0.5 * (-1.0 + (1.0 + (ax * ax * wu * wu + ay * ay * wv * wv) / z2).sqrt())
    }

    /// The specular part alone at one wavelength index.
    pub fn specular(&self, wi: [f64; 3], wo: [f64; 3], f0: f64) -> f64 {
        let (ci, co) = (wi[2], wo[2]);
        if ci <= 0.0 || co <= 0.0 {
            return 0.0;
        }
        let (h, _, cd) = half_vector(wi, wo);
        let d = self.distribution(h);
        let g2 = 1.0 / (1.0 + self.lambda(wi) + self.lambda(wo));
        let f = f0 + (1.0 - f0) * (1.0 - cd).max(0.0).powi(5);
        d * g2 * f / (4.0 * ci * co)
    }

    /// ρ (1/sr) at incident (θi, φi) and outgoing (θo, φo), degrees, at wavelength index `w`
    /// (into the wavelengths the spectra were sampled at).
    pub fn value(&self, incident: (f64, f64), outgoing: (f64, f64), w: usize) -> f64 {
        let wi = dir_from_deg(incident.0, incident.1);
        let wo = dir_from_deg(outgoing.0, outgoing.1);
        self.kd * self.diffuse[w] / std::f64::consts::PI + self.specular(wi, wo, self.f0[w])
    }
}

/// An ABC-model material (Löw et al. 2012) made spectral: f = kD(λ)/π + A(λ)·S·G·F(λ)/(π cos θi
/// cos θo) with S = (1 + B(1 − cos θh))^(−C), the V-cavity G and the exact dielectric Fresnel of
/// a mildly dispersive index. Spectra: kD is a ColorChecker patch scaled to the fit's diffuse
/// luminance, A interpolates the fit's blue, green and red amplitudes at 450, 550 and 610 nm,
/// and η(λ) = ior·(1 + 0.02·(550 − λ)/150).
#[derive(Debug, Clone)]
pub struct Abc {
    /// The fit's name in the embedded table.
    pub name: String,
    /// kD(λ) at each wavelength.
    pub kd: Vec<f64>,
    /// A(λ) at each wavelength.
    pub a: Vec<f64>,
    /// η(λ), the refractive index, at each wavelength.
    pub eta: Vec<f64>,
    /// B of S = (1 + B(1 − cos θh))^(−C).
    pub b: f64,
    /// C of S (see `b`).
    pub c: f64,
}

impl Abc {
    /// The fit called `name` in the embedded table, with diffuse patch `patch`.
    pub fn from_table(name: &str, patch: &str, wavelengths: &[f64]) -> Result<Self> {
        let mut r = csv::ReaderBuilder::new().from_reader(MERL_ABC_CSV.as_bytes());
        let headers = r
            .headers()
            .map_err(|e| Error::Input(e.to_string()))?
            .clone();
        let col = |n: &str| headers.iter().position(|h| h == n).unwrap();
        for rec in r.records() {
            let rec = rec.map_err(|e| Error::Input(e.to_string()))?;
            if &rec[0] != name {
                continue;
            }
            let v = |n: &str| rec[col(n)].parse::<f64>().unwrap();
            let t = SpectrumTable::colorchecker();
            let p = t.sample(t.find(patch)?, wavelengths)?;
            let mean = p.iter().sum::<f64>() / p.len() as f64;
            let lum = 0.2126 * v("kD_r") + 0.7152 * v("kD_g") + 0.0722 * v("kD_b");
            let interp = |l: f64| {
                let (xs, ys) = ([450.0, 550.0, 610.0], [v("A_b"), v("A_g"), v("A_r")]);
                if l <= xs[0] {
                    ys[0]
                } else if l >= xs[2] {
                    ys[2]
                } else {
                    let i = if l < xs[1] { 0 } else { 1 };
                    ys[i] + (l - xs[i]) / (xs[i + 1] - xs[i]) * (ys[i + 1] - ys[i])
                }
            };
            let ior = v("ior").min(50.0);
            return Ok(Abc {
                name: name.to_string(),
                kd: p.iter().map(|x| lum * x / mean).collect(),
                a: wavelengths.iter().map(|&l| interp(l)).collect(),
                eta: wavelengths
                    .iter()
                    .map(|&l| ior * (1.0 + 0.02 * (550.0 - l) / 150.0))
                    .collect(),
                b: v("B"),
                c: v("C"),
            });
        }
        Err(Error::Parameter(format!("no ABC fit named '{name}'")))
    }

    /// ρ (1/sr) at incident (θi, φi) and outgoing (θo, φo), degrees, at wavelength index `w`
    /// (into the wavelengths the spectra were sampled at).
    pub fn value(&self, incident: (f64, f64), outgoing: (f64, f64), w: usize) -> f64 {
        let wi = dir_from_deg(incident.0, incident.1);
        let wo = dir_from_deg(outgoing.0, outgoing.1);
        let (ci, co) = (wi[2], wo[2]);
        let diffuse = self.kd[w] / std::f64::consts::PI;
        if ci <= 0.0 || co <= 0.0 {
            return diffuse;
        }
        let (_, ch, cd) = half_vector(wi, wo);
        let s = (1.0 + self.b * (1.0 - ch)).powf(-self.c);
        let g = 1f64.min(2.0 * ch * co / cd).min(2.0 * ch * ci / cd);
        let f = fresnel_dielectric(self.eta[w], cd);
        diffuse + self.a[w] * s * g * f / (std::f64::consts::PI * ci * co)
    }
}

/// Deterministic pseudo-random query directions (xorshift64), the same on every machine and in
/// every run: what the decoder's timings (`sbrdf tradeoff`, the benches, the throughput example)
/// are measured on.
#[derive(Debug, Clone)]
pub struct QueryRng(u64);

impl QueryRng {
    /// A stream from a non-zero seed.
    pub fn new(seed: u64) -> Self {
        QueryRng(seed.max(1))
    }

    /// The next number, uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        let s = &mut self.0;
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        (*s >> 11) as f32 / (1u64 << 53) as f32
    }

    /// A unit direction over the upper hemisphere with cos θ uniform in [`z_min`, 1) and φ
    /// uniform.
    pub fn direction(&mut self, z_min: f32) -> [f32; 3] {
        let z = z_min + (1.0 - z_min) * self.next_f32();
        let p = std::f32::consts::TAU * self.next_f32();
        let r = (1.0 - z * z).sqrt();
        [r * p.cos(), r * p.sin(), z]
    }

    /// `n` (incident, outgoing) pairs of [`QueryRng::direction`]s.
    pub fn direction_pairs(&mut self, n: usize, z_min: f32) -> Vec<([f32; 3], [f32; 3])> {
        (0..n)
            .map(|_| (self.direction(z_min), self.direction(z_min)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::angles::dir_from_deg;

    fn plain(alpha: f64) -> Ggx {
        Ggx {
            alpha,
            alpha_y: alpha,
            axis_deg: 0.0,
            kd: 0.0,
            diffuse: vec![0.0],
            f0: vec![1.0],
        }
    }

    /// The isotropic GGX written the usual way, in θh only.
    fn isotropic_reference(alpha: f64, wi: [f64; 3], wo: [f64; 3], f0: f64) -> f64 {
        let (ci, co) = (wi[2], wo[2]);
        let (_, ch, cd) = half_vector(wi, wo);
        let a2 = alpha * alpha;
        let d = a2 / (std::f64::consts::PI * (ch * ch * (a2 - 1.0) + 1.0).powi(2));
        let lambda = |c: f64| 0.5 * (-1.0 + (1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt());
        let g2 = 1.0 / (1.0 + lambda(ci) + lambda(co));
        let f = f0 + (1.0 - f0) * (1.0 - cd).max(0.0).powi(5);
        d * g2 * f / (4.0 * ci * co)
    }

    fn pairs() -> Vec<([f64; 3], [f64; 3])> {
        let mut v = Vec::new();
        for (ti, pi) in [(0.0, 0.0), (30.0, 17.0), (60.0, 200.0), (85.0, 310.0)] {
            for (to, po) in [
                (5.0, 0.0),
                (30.0, 197.0),
                (45.0, 90.0),
                (70.0, 20.0),
                (89.0, 250.0),
            ] {
                v.push((dir_from_deg(ti, pi), dir_from_deg(to, po)));
            }
        }
        v
    }

    #[test]
    fn equal_roughnesses_are_the_isotropic_ggx_at_any_axis() {
        for (wi, wo) in pairs() {
            let want = isotropic_reference(0.3, wi, wo, 0.2);
            let got = plain(0.3).with_anisotropy(0.3, 73.0).specular(wi, wo, 0.2);
            assert!(
                (got - want).abs() <= 1e-12 * want.max(1.0),
                "{got} vs {want}"
            );
        }
    }

    #[test]
    fn an_axis_is_the_same_turned_by_180_and_swapping_roughnesses_turns_it_by_90() {
        let a = plain(0.1).with_anisotropy(0.5, 20.0);
        let b = plain(0.1).with_anisotropy(0.5, 200.0);
        let c = plain(0.5).with_anisotropy(0.1, 110.0);
        for (wi, wo) in pairs() {
            let v = a.specular(wi, wo, 0.5);
            assert!((b.specular(wi, wo, 0.5) - v).abs() <= 1e-12 * v.max(1.0));
            assert!((c.specular(wi, wo, 0.5) - v).abs() <= 1e-12 * v.max(1.0));
            // Reciprocity.
            assert!((a.specular(wo, wi, 0.5) - v).abs() <= 1e-12 * v.max(1.0));
        }
    }

    #[test]
    fn the_highlight_is_stretched_along_the_rougher_axis() {
        // Axis u along y (90°) with roughness 0.08, so v, the rougher axis, lies along −x: moving
        // the outgoing direction off the mirror by the same angle loses less along x than along y.
        let m = plain(0.08).with_anisotropy(0.4, 90.0);
        let wi = dir_from_deg(0.0, 0.0);
        let along_x = m.specular(wi, dir_from_deg(10.0, 0.0), 1.0);
        let along_y = m.specular(wi, dir_from_deg(10.0, 90.0), 1.0);
        assert!(along_x > 3.0 * along_y, "{along_x} vs {along_y}");
    }

    #[test]
    fn the_distribution_is_normalised_and_the_albedo_lies_below_one() {
        // ∫ D(h)·hz dω = 1 over the hemisphere, and the directional albedo at normal incidence
        // with F = 1 is below 1 by what masking and the horizon take: for GGX, a fraction
        // α²/(1 + α²) of the normals lies beyond 45° and reflects below the horizon, so with
        // αx = 0.1, αy = 0.3 about 4–5% plus Smith's losses. Midpoint quadrature in (θ, φ).
        let m = plain(0.1).with_anisotropy(0.3, 35.0);
        let wi = dir_from_deg(0.0, 0.0);
        let (nt, np) = (3000, 360);
        let (dt, dp) = (90.0 / nt as f64, 360.0 / np as f64);
        let (mut norm, mut albedo) = (0.0, 0.0);
        for i in 0..nt {
            let t = (i as f64 + 0.5) * dt;
            let (st, ct) = t.to_radians().sin_cos();
            for j in 0..np {
                let w = dir_from_deg(t, (j as f64 + 0.5) * dp);
                norm += m.distribution(w) * ct * st;
                albedo += m.specular(wi, w, 1.0) * ct * st;
            }
        }
        let cell = dt.to_radians() * dp.to_radians();
        let (norm, albedo) = (norm * cell, albedo * cell);
        assert!((norm - 1.0).abs() < 1e-3, "∫D cos = {norm}");
        assert!(albedo > 0.9 && albedo < 0.96, "albedo {albedo}");
    }
}
