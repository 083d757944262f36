//! The decoder: opens a file once, then answers ρ(ωi, ωo, λ) without allocating.

use crate::angles::{angle_between, deg_from_dir, dir_from_deg, dot, normalize};
use crate::error::{Error, Result};
use crate::format::{read_material, Limits};
use crate::material::{LobeKind, Material, MAX_TERMS};
use crate::sh::{sh_count, ShBasis, MAX_SH_LEVEL};
use std::path::Path;

const MAX_SH: usize = sh_count(MAX_SH_LEVEL);

/// A validated material plus what makes evaluation cheap. `Send + Sync`: one decoder can serve
/// every render thread.
#[derive(Debug, Clone)]
pub struct Decoder {
    material: Material,
    sh: ShBasis,
    /// Unit vector of each record's peak direction.
    peaks: Vec<[f64; 3]>,
    /// Unit vector of each record's incident direction.
    incidents: Vec<[f64; 3]>,
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
        let peaks = material
            .records
            .iter()
            .map(|r| dir_from_deg(r.theta_p as f64, r.phi_p as f64))
            .collect();
        let incidents = material
            .records
            .iter()
            .map(|r| dir_from_deg(r.theta_i as f64, r.phi_i as f64))
            .collect();
        Ok(Decoder {
            material,
            sh,
            peaks,
            incidents,
        })
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    pub fn into_material(self) -> Material {
        self.material
    }

    /// The stored record used for an incident direction, and the azimuth (degrees) by which the
    /// query is rotated first (non-zero only for isotropic files).
    ///
    /// This version answers with the *nearest* stored incidence (by angle between incident
    /// directions; for isotropic files, by θ after rotating the query to φ = 0).
    pub fn record_for(&self, wi: [f64; 3]) -> (usize, f64) {
        let recs = &self.material.records;
        if self.material.isotropic {
            let (theta, phi) = deg_from_dir(wi);
            let mut best = 0;
            for (i, r) in recs.iter().enumerate() {
                if (r.theta_i as f64 - theta).abs() < (recs[best].theta_i as f64 - theta).abs() {
                    best = i;
                }
            }
            (best, phi)
        } else {
            let mut best = 0;
            let mut best_dot = f64::NEG_INFINITY;
            for (i, d) in self.incidents.iter().enumerate() {
                let c = dot(*d, wi);
                if c > best_dot {
                    best_dot = c;
                    best = i;
                }
            }
            (best, 0.0)
        }
    }

    /// ρ at unit vectors `wi` (toward the light) and `wo` (toward the viewer) in the local frame
    /// (z = normal), for each wavelength in nm, into `out` (1/sr). Directions below the horizon
    /// give 0; so do zero or non-finite vectors. Wavelengths outside the file's spectral interval
    /// are clamped to it. Writes `min(wavelengths.len(), out.len())` values; never allocates.
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3], wavelengths: &[f32], out: &mut [f32]) {
        let n = wavelengths.len().min(out.len());
        let out = &mut out[..n];
        let widen = |v: [f32; 3]| [v[0] as f64, v[1] as f64, v[2] as f64];
        let (Some(wi), Some(wo)) = (normalize(widen(wi)), normalize(widen(wo))) else {
            out.fill(0.0);
            return;
        };
        if wi[2] < 0.0 || wo[2] < 0.0 {
            out.fill(0.0);
            return;
        }
        let (index, rotation) = self.record_for(wi);
        let wo = rotate_z(wo, -rotation);
        self.eval_record_with(index, wo, wavelengths.iter().map(|&l| l as f64), |i, v| {
            out[i] = v as f32
        });
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
        if !(0.0..=90.0).contains(&incident.0) || !(0.0..=90.0).contains(&outgoing.0) {
            out.fill(0.0);
            return;
        }
        let wi = dir_from_deg(incident.0, incident.1);
        let (index, rotation) = self.record_for(wi);
        let wo = dir_from_deg(outgoing.0, outgoing.1 - rotation);
        self.eval_record_with(index, wo, wavelengths[..n].iter().copied(), |i, v| {
            out[i] = v
        });
    }

    /// Evaluates stored record `index` at unit outgoing vector `wo` (already in the record's
    /// frame), passing (i, ρ(λ_i)) to `sink`.
    pub fn eval_record_with(
        &self,
        index: usize,
        wo: [f64; 3],
        wavelengths: impl Iterator<Item = f64>,
        mut sink: impl FnMut(usize, f64),
    ) {
        let m = &self.material;
        let r = &m.records[index];
        // The record's own sizes; its SH functions are the first (L_r+1)² of the file's.
        let k = r.terms;
        let p = sh_count(r.sh_level);
        let mut y = [0.0f64; MAX_SH];
        self.sh.eval(wo, &mut y);
        let mut c = [0.0f64; MAX_TERMS];
        for (kk, ck) in c[..k].iter_mut().enumerate() {
            let row = &r.sh[kk * p..(kk + 1) * p];
            *ck = row.iter().zip(&y[..p]).map(|(a, b)| *a as f64 * b).sum();
        }
        for lobe in &r.lobes {
            match lobe.kind {
                LobeKind::CosinePower => {
                    let cos = crate::angles::dot(wo, self.peaks[index]).max(0.0);
                    let g = cos.powf(lobe.params[0] as f64);
                    for (kk, ck) in c[..k].iter_mut().enumerate() {
                        *ck += lobe.amplitude[kk] as f64 * g;
                    }
                }
                LobeKind::AngleGaussian => {
                    let alpha = angle_between(wo, self.peaks[index]);
                    let a2 = alpha * alpha;
                    for (kk, ck) in c[..k].iter_mut().enumerate() {
                        *ck += lobe.amplitude[kk] as f64 * (-a2 / lobe.params[kk] as f64).exp();
                    }
                }
                LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                    let v = crate::lobes::microfacet_variants_with(
                        &lobe.params,
                        self.incidents[index],
                        wo,
                        lobe.kind == LobeKind::MicrofacetSin2,
                    );
                    for (kk, ck) in c[..k].iter_mut().enumerate() {
                        for (j, vj) in v.iter().enumerate() {
                            *ck += lobe.amplitude[j * k + kk] as f64 * vj;
                        }
                    }
                }
            }
        }
        let mut b = [0.0f64; MAX_TERMS];
        let space = &m.spectral;
        for (i, l) in wavelengths.enumerate() {
            space.eval(l, &mut b);
            sink(i, c[..k].iter().zip(&b[..k]).map(|(x, y)| x * y).sum());
        }
    }
}

fn rotate_z(v: [f64; 3], deg: f64) -> [f64; 3] {
    if deg == 0.0 {
        return v;
    }
    let (s, c) = deg.to_radians().sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}
