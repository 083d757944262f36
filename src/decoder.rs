//! The decoder: opens a file once, then answers ρ(ωi, ωo, λ) without allocating.

use crate::angles::{angle_between, deg_from_dir, dir_from_deg, dot, mirror_deg, normalize};
use crate::error::{Error, Result};
use crate::format::{read_material, Limits};
use crate::lobes::MicrofacetGeometry;
use crate::material::{LobeKind, Material, MAX_TERMS};
use crate::sampling::{Sample, SamplingWeights};
use crate::sh::{sh_count, ShBasis, MAX_SH_LEVEL};
use crate::spectral::SpectrumEvaluator;
use std::path::Path;

const MAX_SH: usize = sh_count(MAX_SH_LEVEL);

/// A validated material plus what makes evaluation cheap. `Send + Sync`: one decoder can serve
/// every render thread.
///
/// An incident direction that is not stored is answered by interpolating the *parameters* of the
/// neighbouring records (SH coefficients, lobe amplitudes and shapes, the peak's offset from the
/// mirror direction) and evaluating once, so a specular peak moves with the incident direction
/// instead of cross-fading between two peaks (`spec/EVALUATION.md`, "Between stored incidences").
#[derive(Debug, Clone)]
pub struct Decoder {
    material: Material,
    sh: ShBasis,
    /// Per record: the peak direction's offset from the mirror direction, (Δθ, Δφ) in degrees.
    peak_offset: Vec<(f64, f64)>,
    /// Per record: the unit peak vector (isotropic files blend these directly, which needs no
    /// trigonometry: all their records share the φ = 0 frame).
    pub(crate) peaks: Vec<[f64; 3]>,
    /// Natural logarithms of every lobe parameter, [record][lobe][parameter]: widths, exponents
    /// and microfacet b, c are interpolated geometrically, and taking logs once here keeps
    /// `ln` out of the per-query path.
    pub(crate) ln_params: Vec<Vec<Vec<f64>>>,
    lattice: Lattice,
    /// SH level ≤ 6 and ≤ 16 terms: evaluation can use small scratch arrays.
    small: bool,
    spectrum: SpectrumEvaluator,
    /// The stored θ range's ends with their sine and cosine: a query clamped to an end keeps
    /// its azimuth without trigonometry.
    theta_ends: [(f64, f64, f64); 2],
    /// Per record, the energy of the background and of each lobe: the mixture weights of
    /// importance sampling (`src/sampling.rs`). Computed on first use, once: they cost three
    /// times the rest of opening a file, which a decoder that only evaluates need not pay.
    sampling: std::sync::OnceLock<SamplingWeights>,
}

/// A query's incident direction turned into the frame its records are stored in: for isotropic
/// files rotated about z so that its azimuth is 0 (`spec/EVALUATION.md`, "Reconstruction",
/// step 3).
#[derive(Debug, Clone, Copy)]
pub(crate) struct QueryFrame {
    /// θ and φ of the incident direction in that frame, degrees.
    pub theta: f64,
    pub phi: f64,
    /// The unit incident vector in that frame.
    pub wi: [f64; 3],
    /// (cos ψ, sin ψ) of the rotation by −ψ into the frame; None when there is none.
    pub rotation: Option<(f64, f64)>,
}

impl QueryFrame {
    /// A vector of the local frame in the records' frame.
    #[inline]
    pub fn in_frame(self, v: [f64; 3]) -> [f64; 3] {
        match self.rotation {
            Some((c, s)) => [c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]],
            None => v,
        }
    }

    /// A vector of the records' frame back in the local frame.
    #[inline]
    pub fn out_of_frame(self, v: [f64; 3]) -> [f64; 3] {
        match self.rotation {
            Some((c, s)) => [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]],
            None => v,
        }
    }
}

/// A single-precision vector widened and normalised with one reciprocal (a division per
/// component costs more); None when it is zero or not finite.
#[inline]
pub(crate) fn unit(v: [f32; 3]) -> Option<[f64; 3]> {
    let v = [v[0] as f64, v[1] as f64, v[2] as f64];
    let n = dot(v, v).sqrt();
    (n.is_finite() && n > 0.0).then(|| {
        let s = 1.0 / n;
        [v[0] * s, v[1] * s, v[2] * s]
    })
}

/// How stored incidences are arranged, which decides how a query is interpolated.
#[derive(Debug, Clone)]
enum Lattice {
    /// Isotropic files: records in increasing θi, all at φi = 0; linear in θ.
    Theta(Axis),
    /// Every combination of some θ values and some φ values: bilinear, φ wrapping at 360°.
    Grid {
        thetas: Axis,
        phis: Axis,
        /// Record index of (θ_i, φ_j) at i·phis.len() + j.
        index: Vec<usize>,
    },
    /// Scattered incidences: the nearest stored one.
    Nearest,
}

/// Up to four records and their weights (summing to 1).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Blend {
    pub n: usize,
    pub rec: [usize; 4],
    pub w: [f64; 4],
}

impl Blend {
    fn one(r: usize) -> Self {
        Blend {
            n: 1,
            rec: [r, 0, 0, 0],
            w: [1.0, 0.0, 0.0, 0.0],
        }
    }
    fn push(&mut self, r: usize, w: f64) {
        if w <= 0.0 {
            return;
        }
        if let Some(i) = self.rec[..self.n].iter().position(|&x| x == r) {
            self.w[i] += w;
        } else {
            self.rec[self.n] = r;
            self.w[self.n] = w;
            self.n += 1;
        }
    }
}

/// Strictly increasing stored angles along one axis of the incidence lattice.
#[derive(Debug, Clone)]
struct Axis {
    xs: Vec<f64>,
    /// (n − 1)/(last − first): the cell of an evenly spaced axis (the usual one) is guessed with
    /// one multiplication, then checked; a search settles anything else.
    inv_step: f64,
}

impl Axis {
    fn new(xs: Vec<f64>) -> Self {
        let n = xs.len();
        let inv_step = if n > 1 {
            (n - 1) as f64 / (xs[n - 1] - xs[0])
        } else {
            0.0
        };
        Axis { xs, inv_step }
    }

    fn first(&self) -> f64 {
        self.xs[0]
    }

    fn last(&self) -> f64 {
        self.xs[self.xs.len() - 1]
    }

    /// Index i and fraction t with xs[i] ≤ x ≤ xs[i+1] (x clamped to the range).
    fn bracket(&self, x: f64) -> (usize, f64) {
        let xs = &self.xs;
        if xs.len() == 1 || x.is_nan() || x <= xs[0] {
            return (0, 0.0);
        }
        let last = xs.len() - 1;
        if x >= xs[last] {
            return (last - 1, 1.0);
        }
        let g = (((x - xs[0]) * self.inv_step) as usize).min(last - 1);
        let i = if xs[g] <= x && x < xs[g + 1] {
            g
        } else {
            xs.partition_point(|&v| v <= x) - 1
        };
        (i, (x - xs[i]) / (xs[i + 1] - xs[i]))
    }
}

impl Decoder {
    /// Parses a file held in memory, with the default [`Limits`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        Self::from_bytes_with_limits(bytes, &Limits::default())
    }

    pub fn from_bytes_with_limits(bytes: &[u8], limits: &Limits) -> Result<Self> {
        Self::from_material(read_material(bytes, limits)?)
    }

    /// Reads and parses a file; refuses files above the default size limit before reading them.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let limits = Limits::default();
        let len = std::fs::metadata(path)
            .map_err(|e| Error::io(path, e))?
            .len();
        if len > limits.max_file_bytes as u64 {
            return Err(Error::LimitsExceeded(format!(
                "{}: {len} bytes exceeds the limit of {} bytes",
                path.display(),
                limits.max_file_bytes
            )));
        }
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::from_bytes_with_limits(&bytes, &limits).map_err(|e| match e {
            Error::Format { at, message } => Error::Format {
                at,
                message: format!("{}: {message}", path.display()),
            },
            Error::Unsupported { at, message } => Error::Unsupported {
                at,
                message: format!("{}: {message}", path.display()),
            },
            other => other,
        })
    }

    /// Wraps a material built in memory (by the encoder, say), validating it first.
    pub fn from_material(material: Material) -> Result<Self> {
        material
            .validate()
            .map_err(|e| Error::Parameter(format!("invalid material: {e}")))?;
        let sh = ShBasis::new(material.sh_level);
        let peak_offset = material
            .records
            .iter()
            .map(|r| {
                let (mt, mp) = mirror_deg(r.theta_i as f64, r.phi_i as f64);
                // A peak at the pole has no azimuth: its offset is in θ alone.
                let dphi = if r.theta_p == 0.0 {
                    0.0
                } else {
                    crate::angles::phi_delta(r.phi_p as f64, mp)
                };
                (r.theta_p as f64 - mt, dphi)
            })
            .collect();
        let lattice = Self::lattice_of(&material);
        let small = material.sh_level <= 6 && material.spectral.terms <= 16;
        let peaks = material
            .records
            .iter()
            .map(|r| dir_from_deg(r.theta_p as f64, r.phi_p as f64))
            .collect();
        let ln_params = material
            .records
            .iter()
            .map(|r| {
                r.lobes
                    .iter()
                    .map(|l| l.params.iter().map(|&p| (p as f64).ln()).collect())
                    .collect()
            })
            .collect();
        let spectrum = SpectrumEvaluator::new(&material.spectral);
        let end = |t: f64| {
            let (s, c) = t.to_radians().sin_cos();
            (t, s, c)
        };
        let first = material.records.first().map_or(0.0, |r| r.theta_i as f64);
        let last = material.records.last().map_or(0.0, |r| r.theta_i as f64);
        let decoder = Decoder {
            material,
            sh,
            peak_offset,
            peaks,
            ln_params,
            lattice,
            small,
            spectrum,
            theta_ends: [end(first), end(last)],
            sampling: std::sync::OnceLock::new(),
        };
        Ok(decoder)
    }

    fn lattice_of(m: &Material) -> Lattice {
        let recs = &m.records;
        if m.isotropic {
            return Lattice::Theta(Axis::new(recs.iter().map(|r| r.theta_i as f64).collect()));
        }
        let mut thetas: Vec<f64> = recs.iter().map(|r| r.theta_i as f64).collect();
        thetas.dedup(); // records are sorted by (θ, φ)
        let mut phis: Vec<f64> = recs.iter().map(|r| r.phi_i as f64).collect();
        phis.sort_by(f64::total_cmp);
        phis.dedup();
        if thetas.len() * phis.len() != recs.len() {
            return Lattice::Nearest;
        }
        let mut index = Vec::with_capacity(recs.len());
        for (i, t) in thetas.iter().enumerate() {
            for (j, p) in phis.iter().enumerate() {
                let r = &recs[i * phis.len() + j];
                if r.theta_i as f64 != *t || r.phi_i as f64 != *p {
                    return Lattice::Nearest;
                }
                index.push(i * phis.len() + j);
            }
        }
        Lattice::Grid {
            thetas: Axis::new(thetas),
            phis: Axis::new(phis),
            index,
        }
    }

    /// The records to blend for a query incidence (θ, φ in degrees) and the incidence they are
    /// evaluated at: θ clamped to the stored range, or a scattered file's nearest record's own.
    fn blend(&self, theta: f64, phi: f64) -> (Blend, f64, f64) {
        match &self.lattice {
            Lattice::Theta(thetas) => {
                let (i, t) = thetas.bracket(theta);
                let mut b = Blend::one(i);
                if thetas.xs.len() > 1 {
                    b.w[0] = 1.0 - t;
                    b.push(i + 1, t);
                    if b.w[0] <= 0.0 {
                        b = Blend::one(i + 1);
                    }
                }
                (b, theta.clamp(thetas.first(), thetas.last()), phi)
            }
            Lattice::Grid {
                thetas,
                phis,
                index,
            } => {
                let (i, t) = thetas.bracket(theta);
                let i1 = (i + 1).min(thetas.xs.len() - 1);
                // φ cells wrap: between the last φ and the first + 360°.
                let np = phis.xs.len();
                let p = crate::angles::wrap_phi(phi);
                let (j0, j1, u) = if np == 1 {
                    (0, 0, 0.0)
                } else if p < phis.first() || p >= phis.last() {
                    let span = phis.first() + 360.0 - phis.last();
                    let d = (p - phis.last()).rem_euclid(360.0);
                    (np - 1, 0, d / span)
                } else {
                    let (j, u) = phis.bracket(p);
                    (j, j + 1, u)
                };
                let mut b = Blend {
                    n: 0,
                    rec: [0; 4],
                    w: [0.0; 4],
                };
                b.push(index[i * np + j0], (1.0 - t) * (1.0 - u));
                b.push(index[i * np + j1], (1.0 - t) * u);
                b.push(index[i1 * np + j0], t * (1.0 - u));
                b.push(index[i1 * np + j1], t * u);
                if b.n == 0 {
                    b = Blend::one(index[i * np + j0]);
                }
                // One stored azimuth is clamped to like θ: its records are used whole, at
                // their own φ, as every other query outside the stored range is.
                let phi = if np == 1 { phis.first() } else { phi };
                (b, theta.clamp(thetas.first(), thetas.last()), phi)
            }
            Lattice::Nearest => {
                let q = dir_from_deg(theta, phi);
                let mut best = (f64::NEG_INFINITY, 0);
                for (i, r) in self.material.records.iter().enumerate() {
                    let c = dot(q, dir_from_deg(r.theta_i as f64, r.phi_i as f64));
                    if c > best.0 {
                        best = (c, i);
                    }
                }
                let r = &self.material.records[best.1];
                (Blend::one(best.1), r.theta_i as f64, r.phi_i as f64)
            }
        }
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    pub fn into_material(self) -> Material {
        self.material
    }

    /// ρ at unit vectors `wi` (toward the light) and `wo` (toward the viewer) in the local frame
    /// (z = normal), for each wavelength in nm, into `out` (1/sr); never negative (the series is
    /// clamped at 0, `spec/EVALUATION.md`). Directions below the horizon give 0; so do zero or
    /// non-finite vectors. Wavelengths outside the file's spectral interval are clamped to it;
    /// incident directions outside the stored θ range are clamped to it. Writes
    /// `min(wavelengths.len(), out.len())` values; never allocates.
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3], wavelengths: &[f32], out: &mut [f32]) {
        let n = wavelengths.len().min(out.len());
        let out = &mut out[..n];
        let (Some(wi), Some(wo)) = (unit(wi), unit(wo)) else {
            out.fill(0.0);
            return;
        };
        if wi[2] < 0.0 || wo[2] < 0.0 {
            out.fill(0.0);
            return;
        }
        let q = self.query_frame(wi);
        let wl = wavelengths.iter().map(|&l| l as f64);
        let sink = |i: usize, v: f64| out[i] = v as f32;
        self.eval_frame(q.theta, q.phi, Some(q.wi), q.in_frame(wo), wl, sink);
    }

    /// Computes the importance-sampling weights now rather than on the first call of
    /// [`Decoder::sample`] or [`Decoder::pdf`] (the only call that allocates): for renderers
    /// that want every later call allocation-free. Thread-safe; later calls do nothing.
    pub fn prepare_sampling(&self) {
        self.sampling_weights();
    }

    pub(crate) fn sampling_weights(&self) -> &SamplingWeights {
        self.sampling.get_or_init(|| SamplingWeights::new(self))
    }

    /// Draws an outgoing direction (toward the viewer) for the incident direction `wi` (toward
    /// the light; local frame, z = normal, need not be unit length) from two uniform numbers
    /// in [0, 1). The density is the same for every wavelength: a mixture of the stored lobes'
    /// shapes and a cosine, weighted by the energy of each in the spectrum-averaged BRDF times
    /// cos θo. The returned `pdf` (1/sr, over solid angle) is exactly [`Decoder::pdf`] at the
    /// returned direction. None when `wi` is below the horizon, zero or not finite, or a `u`
    /// is not finite. Never allocates after the first call (see
    /// [`Decoder::prepare_sampling`]). Details: `spec/EVALUATION.md`, "Importance sampling".
    ///
    /// A path tracer that starts at the camera knows the direction toward the viewer, not the
    /// light: it passes that one as `wi` and uses the drawn direction as the light's, which is
    /// right to the extent that the material is reciprocal (ρ(wi, wo) = ρ(wo, wi)); the stored
    /// BRDF is reciprocal exactly as far as its input and its fit are (`tests/sampling.rs`
    /// reports how far).
    pub fn sample(&self, wi: [f32; 3], u: [f32; 2]) -> Option<Sample> {
        crate::sampling::sample(self, wi, u)
    }

    /// The density (1/sr, over solid angle) with which [`Decoder::sample`] draws `wo` for `wi`:
    /// 0 when either is below the horizon, zero or not finite; otherwise > 0 wherever
    /// cos θo > 0. Never allocates.
    pub fn pdf(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        crate::sampling::pdf(self, wi, wo)
    }

    /// The query's incident direction in the records' frame (`wi` a unit vector with z ≥ 0).
    #[inline]
    pub(crate) fn query_frame(&self, wi: [f64; 3]) -> QueryFrame {
        let r = (wi[0] * wi[0] + wi[1] * wi[1]).sqrt();
        // θ only places the query between stored incidences. Single precision matches what
        // the f32 input vector can say about its own angle (≈1e-7 rad); the `libm` crate's
        // atan2f inlines here and costs a fraction of the system library's f64 atan2.
        let theta = (libm::atan2f(r as f32, wi[2] as f32) as f64).to_degrees();
        if self.material.isotropic {
            // Rotate into the stored frame (φi = 0) with the azimuth's cosine and sine, no trig.
            let (c, s) = if r > 0.0 {
                let inv = 1.0 / r;
                (wi[0] * inv, wi[1] * inv)
            } else {
                (1.0, 0.0)
            };
            QueryFrame {
                theta,
                phi: 0.0,
                wi: [r, 0.0, wi[2]],
                rotation: Some((c, s)),
            }
        } else {
            let (_, phi) = deg_from_dir(wi);
            QueryFrame {
                theta,
                phi,
                wi,
                rotation: None,
            }
        }
    }

    /// Convenience form of [`Decoder::eval`] with angles in degrees.
    pub fn eval_deg(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
    ) {
        let n = wavelengths.len().min(out.len());
        let out = &mut out[..n];
        let finite = incident.1.is_finite() && outgoing.1.is_finite();
        if !finite || !(0.0..=90.0).contains(&incident.0) || !(0.0..=90.0).contains(&outgoing.0) {
            out.fill(0.0);
            return;
        }
        let wl = wavelengths[..n].iter().copied();
        let sink = |i: usize, v: f64| out[i] = v;
        if self.material.isotropic {
            let wo = dir_from_deg(outgoing.0, outgoing.1 - incident.1);
            self.eval_frame(incident.0, 0.0, None, wo, wl, sink);
        } else {
            let wo = dir_from_deg(outgoing.0, outgoing.1);
            self.eval_frame(incident.0, incident.1, None, wo, wl, sink);
        }
    }

    /// Evaluates at incidence (θ, φ) in degrees — already rotated to φ = 0 for isotropic files,
    /// as is the unit outgoing vector `wo` — passing (i, ρ(λ_i)) to `sink`. `wi`, when given,
    /// is the unit incident vector of (θ, φ) (it saves the trigonometry).
    fn eval_frame(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
        wo: [f64; 3],
        wavelengths: impl Iterator<Item = f64>,
        sink: impl FnMut(usize, f64),
    ) {
        // Scratch arrays live on the stack; zeroing the format's maxima (441 SH values, 256
        // terms) would cost more than the evaluation, so files within SH level 6 and 16 terms
        // (every file the encoder writes by default) use small ones.
        if self.small {
            self.eval_sized::<{ sh_count(6) }, 16>(theta, phi, wi, wo, wavelengths, sink)
        } else {
            self.eval_sized::<MAX_SH, MAX_TERMS>(theta, phi, wi, wo, wavelengths, sink)
        }
    }

    fn eval_sized<const NSH: usize, const NT: usize>(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
        wo: [f64; 3],
        wavelengths: impl Iterator<Item = f64>,
        mut sink: impl FnMut(usize, f64),
    ) {
        let m = &self.material;
        let (blend, wi, theta, phi) = self.resolve(theta, phi, wi);
        let recs = &blend.rec[..blend.n];
        let ws = &blend.w[..blend.n];
        let k = recs.iter().map(|&r| m.records[r].terms).max().unwrap_or(1);
        let level = recs
            .iter()
            .map(|&r| m.records[r].sh_level)
            .max()
            .unwrap_or(0);
        let mut y = [0.0f64; NSH];
        self.sh.eval_to_level(level, wo, &mut y);
        let mut c = [0.0f64; NT];
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &m.records[r];
            let p = sh_count(rec.sh_level);
            for (kk, ck) in c[..rec.terms].iter_mut().enumerate() {
                let row = &rec.sh[kk * p..(kk + 1) * p];
                let v: f64 = row.iter().zip(&y[..p]).map(|(a, b)| *a as f64 * b).sum();
                *ck += w * v;
            }
        }
        // Lobes: where every blended record has a lobe of the same kind at the same position,
        // its shape parameters are interpolated and it is evaluated once; otherwise each record's
        // lobe is evaluated with its own shape and weighted.
        let max_lobes = recs
            .iter()
            .map(|&r| m.records[r].lobes.len())
            .max()
            .unwrap_or(0);
        // The microfacet geometry depends on the directions alone: computed at most once.
        let mut geometry = None;
        for li in 0..max_lobes {
            let kind = m.records[recs[0]].lobes.get(li).map(|l| l.kind);
            let shared = kind.is_some()
                && recs
                    .iter()
                    .all(|&r| m.records[r].lobes.get(li).map(|l| l.kind) == kind);
            if shared {
                self.add_lobe(
                    &mut c[..k],
                    recs,
                    ws,
                    li,
                    wi,
                    wo,
                    (theta, phi),
                    &mut geometry,
                );
            } else {
                for (&r, &w) in recs.iter().zip(ws) {
                    if li < m.records[r].lobes.len() {
                        let one = ([r], [w]);
                        self.add_lobe(
                            &mut c[..k],
                            &one.0,
                            &one.1,
                            li,
                            wi,
                            wo,
                            (theta, phi),
                            &mut geometry,
                        );
                    }
                }
            }
        }
        for (i, l) in wavelengths.enumerate() {
            if !l.is_finite() {
                sink(i, 0.0); // documented: a non-finite wavelength gives 0
                continue;
            }
            // Clamped at 0 (spec/EVALUATION.md, "Reconstruction", step 5): a fit can undershoot
            // between its samples, and a renderer would turn that into negative light.
            sink(i, self.spectrum.dot(&c[..k], l).max(0.0));
        }
    }

    /// The records to blend for a query incidence (θ, φ in degrees, in the records' frame), the
    /// incident vector they are evaluated with (`wi`, when given, is the unit vector of (θ, φ))
    /// and its angles: outside the stored θ range the nearest stored θ is used, incident vector
    /// included.
    #[inline]
    pub(crate) fn resolve(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
    ) -> (Blend, [f64; 3], f64, f64) {
        let (blend, at_theta, at_phi) = self.blend(theta, phi);
        let wi = match wi {
            Some(v) if at_theta == theta && at_phi == phi => v,
            Some(v) if at_phi == phi => self.clamped(v, at_theta),
            _ => dir_from_deg(at_theta, at_phi),
        };
        (blend, wi, at_theta, at_phi)
    }

    /// The unit vector at polar angle `theta` (degrees; one of the stored range's ends) with the
    /// azimuth of the unit vector `v`; φ = 0 when `v` is the normal.
    fn clamped(&self, v: [f64; 3], theta: f64) -> [f64; 3] {
        let Some(&(_, s, c)) = self.theta_ends.iter().find(|e| e.0 == theta) else {
            return dir_from_deg(theta, crate::angles::deg_from_dir(v).1);
        };
        let r = (v[0] * v[0] + v[1] * v[1]).sqrt();
        if r > 0.0 {
            [s * v[0] / r, s * v[1] / r, c]
        } else {
            [s, 0.0, c]
        }
    }

    /// Adds lobe `li` of the records `recs` (all of the same kind), blended with weights `ws`:
    /// amplitudes linearly, widths and exponents geometrically, the peak's offset from the
    /// mirror direction linearly.
    #[allow(clippy::too_many_arguments)]
    fn add_lobe(
        &self,
        c: &mut [f64],
        recs: &[usize],
        ws: &[f64],
        li: usize,
        wi: [f64; 3],
        wo: [f64; 3],
        incidence: (f64, f64),
        geometry: &mut Option<Option<MicrofacetGeometry>>,
    ) {
        let m = &self.material;
        let lobe0 = &m.records[recs[0]].lobes[li];
        let geo_mean = |param: usize| -> f64 {
            if recs.len() == 1 {
                return m.records[recs[0]].lobes[li].params[param] as f64;
            }
            recs.iter()
                .zip(ws)
                .map(|(&r, &w)| w * self.ln_params[r][li][param])
                .sum::<f64>()
                .exp()
        };
        let peak = || self.blended_peak(recs, ws, incidence);
        // Σ_r w_r·amplitude_r[index] for the records that have that term.
        let amp = |variant: usize, kk: usize| -> f64 {
            recs.iter()
                .zip(ws)
                .map(|(&r, &w)| {
                    let rec = &m.records[r];
                    if kk < rec.terms {
                        w * rec.lobes[li].amplitude[variant * rec.terms + kk] as f64
                    } else {
                        0.0
                    }
                })
                .sum()
        };
        match lobe0.kind {
            LobeKind::AngleGaussian => {
                let a2 = angle_between(wo, peak()).powi(2);
                for (kk, ck) in c.iter_mut().enumerate() {
                    // Per-term widths: a record without term kk contributes nothing to it.
                    let (mut lw, mut wsum) = (0.0, 0.0);
                    for (&r, &w) in recs.iter().zip(ws) {
                        if kk < m.records[r].terms {
                            lw += w * self.ln_params[r][li][kk];
                            wsum += w;
                        }
                    }
                    if recs.len() == 1 && kk < m.records[recs[0]].terms {
                        let b = m.records[recs[0]].lobes[li].params[kk] as f64;
                        *ck += amp(0, kk) * (-a2 / b).exp();
                    } else if wsum > 0.0 {
                        *ck += amp(0, kk) * (-a2 / (lw / wsum).exp()).exp();
                    }
                }
            }
            LobeKind::CosinePower => {
                // The cosine is capped at 1: rounding can exceed it, and a large exponent would
                // turn 1 + ε into infinity.
                // g^n as exp(n·ln g): powf's value to ~1e-15 relative, a little quicker, and the
                // geometric mean of the exponents is already a logarithm.
                let ln_g = dot(wo, peak()).clamp(0.0, 1.0).ln();
                let g = if recs.len() == 1 {
                    (m.records[recs[0]].lobes[li].params[0] as f64 * ln_g).exp()
                } else {
                    let ln_n: f64 = recs
                        .iter()
                        .zip(ws)
                        .map(|(&r, &w)| w * self.ln_params[r][li][0])
                        .sum();
                    (ln_n.exp() * ln_g).exp()
                };
                self.add_amplitudes(c, recs, ws, li, &[g]);
            }
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                // The Smith parameter is interpolated linearly; normalised by the weights, so a
                // record evaluated on its own (lobes not shared) keeps its stored value.
                let (wa, wsum) = recs
                    .iter()
                    .zip(ws)
                    .fold((0.0, 0.0), |(wa, wsum), (&r, &w)| {
                        (wa + w * m.records[r].lobes[li].params[2] as f64, wsum + w)
                    });
                let a = wa / wsum;
                let params = [geo_mean(0) as f32, geo_mean(1) as f32, a as f32];
                let Some(g) = *geometry.get_or_insert_with(|| MicrofacetGeometry::new(wi, wo))
                else {
                    return; // wi = −wo: every variant is 0
                };
                let v = g.variants(&params, lobe0.kind == LobeKind::MicrofacetSin2);
                self.add_amplitudes(c, recs, ws, li, &v);
            }
        }
    }

    /// The peak direction of a lobe blended from the records `recs` with weights `ws`, at the
    /// evaluation incidence (θ, φ) in degrees (`spec/EVALUATION.md`, "Blended peak direction").
    pub(crate) fn blended_peak(
        &self,
        recs: &[usize],
        ws: &[f64],
        incidence: (f64, f64),
    ) -> [f64; 3] {
        if recs.len() == 1 {
            return self.peaks[recs[0]];
        }
        if self.material.isotropic {
            // Records 1D in θ, one frame: the normalised weighted mean of their peaks.
            let mut v = [0.0; 3];
            for (&r, &w) in recs.iter().zip(ws) {
                for (vi, pi) in v.iter_mut().zip(self.peaks[r]) {
                    *vi += w * pi;
                }
            }
            if let Some(u) = normalize(v) {
                return u;
            }
        }
        // Records at different azimuths: blend the offsets from each one's mirror direction.
        let (dt, dp) = recs.iter().zip(ws).fold((0.0, 0.0), |(a, b), (&r, &w)| {
            (a + w * self.peak_offset[r].0, b + w * self.peak_offset[r].1)
        });
        let (mt, mp) = mirror_deg(incidence.0, incidence.1);
        dir_from_deg(mt + dt, mp + dp)
    }

    /// c[k] += Σ_r w_r Σ_j v[j]·amplitude_r[j·K_r + k] over the terms k each record has: the
    /// lobe's variants `v`, evaluated once, weighted by every blended record's amplitudes.
    fn add_amplitudes(&self, c: &mut [f64], recs: &[usize], ws: &[f64], li: usize, v: &[f64]) {
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &self.material.records[r];
            let amplitude = &rec.lobes[li].amplitude;
            let t = rec.terms.min(c.len());
            for (j, &vj) in v.iter().enumerate() {
                let s = w * vj;
                let row = &amplitude[j * rec.terms..j * rec.terms + t];
                for (ck, &a) in c[..t].iter_mut().zip(row) {
                    *ck += s * a as f64;
                }
            }
        }
    }
}
