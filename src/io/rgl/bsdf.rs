//! An RGL measurement read and validated, its grid nodes turned into real directions.

use super::tensor::{DType, FieldInfo, Result, RglError, TensorFile};
use super::warp::{bilerp, Warp2};

fn unit(theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [st * cp, st * sp, ct]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// (θ, φ) in degrees of a unit vector, φ ∈ [0, 360) and 0 at the pole.
pub fn angles_deg(v: [f64; 3]) -> (f64, f64) {
    let rho = (v[0] * v[0] + v[1] * v[1]).sqrt();
    let theta = rho.atan2(v[2]).to_degrees();
    if theta < 1e-9 {
        return (theta.max(0.0), 0.0);
    }
    let mut phi = v[1].atan2(v[0]).to_degrees().rem_euclid(360.0);
    if phi >= 360.0 {
        phi -= 360.0;
    }
    (theta, phi)
}

fn theta2u(theta: f64) -> f64 {
    (theta.max(0.0) * (2.0 / std::f64::consts::PI)).sqrt()
}

fn phi2u(phi: f64) -> f64 {
    (phi + std::f64::consts::PI) / (2.0 * std::f64::consts::PI)
}

/// What each grid node carries.
#[derive(Debug, Clone, PartialEq)]
pub enum Channels {
    /// `rgb`: linear sRGB triplets (channel 0 = R).
    Rgb,
    /// `spectra` at these wavelengths (nm).
    Spectral {
        /// The wavelength of each channel, nm.
        wavelengths: Vec<f32>,
    },
}

/// A validated RGL measurement.
#[derive(Debug, Clone)]
pub struct RglBsdf {
    /// The file's `description` field (UTF-8, invalid bytes replaced).
    pub description: String,
    /// Stored incidences, radians, as in the file.
    pub theta_i: Vec<f32>,
    /// Stored incident azimuths φi, radians, as in the file (strictly increasing).
    pub phi_i: Vec<f32>,
    /// What each grid node carries: RGB or spectra.
    pub channels: Channels,
    /// The `jacobian` flag: multiply by NDF(u)/(4 σ(ωi)).
    pub jacobian: bool,
    /// Mitsuba's rule: ≤ 2 stored φi means isotropic (half-vector azimuth relative to φi).
    pub isotropic: bool,
    /// Grid resolution R of the measurement (R × R nodes per incidence and channel).
    pub res: usize,
    /// The `valid` bytes, if present (not used by Mitsuba; see [`RglBsdf::valid_bits`]).
    pub valid: Option<Vec<u8>>,
    ndf: Vec<f32>,
    ndf_wh: (usize, usize),
    sigma: Vec<f32>,
    sigma_wh: (usize, usize),
    vndf: Vec<f32>,
    vndf_wh: (usize, usize),
    vndf_at: u64,
    values: Vec<f32>,
    values_name: &'static str,
}

/// One grid node mapped to a real outgoing direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// The node's row in the grid (second-to-last tensor axis).
    pub row: u32,
    /// The node's column in the grid (last tensor axis).
    pub col: u32,
    /// Outgoing direction, degrees (sbrdf convention).
    pub theta_o: f64,
    /// Outgoing azimuth φo, degrees, in [0, 360).
    pub phi_o: f64,
    /// The same as a unit vector (z = cos θo).
    pub wo: [f64; 3],
    /// cos θo > 0. Below-horizon cells carry 0 (Mitsuba's eval is 0 there).
    pub above: bool,
}

/// Every grid node of one stored incidence.
#[derive(Debug, Clone)]
pub struct Incidence {
    /// Index of the stored θi in [`RglBsdf::theta_i`].
    pub theta_index: usize,
    /// Index of the stored φi in [`RglBsdf::phi_i`].
    pub phi_index: usize,
    /// Degrees; φi in [0, 360).
    pub theta_i: f64,
    /// Incident azimuth, degrees (see `theta_i`).
    pub phi_i: f64,
    /// The incident direction as a unit vector (toward the light, z = normal).
    pub wi: [f64; 3],
    /// Row-major (row = second-to-last tensor axis, col = last).
    pub cells: Vec<Cell>,
    /// `cells.len() × channels` BRDF values (1/sr), cell-major.
    pub values: Vec<f64>,
    /// Values per cell: 3 for RGB, else the number of wavelengths.
    pub channels: usize,
}

/// The samples of one incidence in sbrdf's shape: distinct outgoing directions above the
/// horizon, sorted by (θo, φo), values cell-major.
#[derive(Debug, Clone)]
pub struct IncidenceSamples {
    /// The stored incidence's (θi, φi) indices in the file.
    pub index: [usize; 2],
    /// Incident polar angle θi, degrees.
    pub theta_i: f64,
    /// Incident azimuth φi, degrees, in [0, 360).
    pub phi_i: f64,
    /// Distinct outgoing directions (θo, φo) in degrees, sorted.
    pub directions: Vec<[f64; 2]>,
    /// `directions.len()` × channels BRDF values (1/sr), direction-major.
    pub values: Vec<f64>,
    /// Per direction, the grid node (row, column) it came from (the first of a merged group).
    pub nodes: Vec<[u32; 2]>,
    /// Grid nodes that landed on an already-present direction (the θm = 0 column and the
    /// φm = ±180° rows are each one direction) and were averaged into it.
    pub merged: usize,
    /// Largest relative spread (max − min)/max|mean| among merged groups.
    pub merge_spread: f64,
    /// Grid nodes dropped because cos θo ≤ 0 or θo > the cut.
    pub dropped: usize,
}

fn bad(field: &str, at: u64, reason: impl Into<String>) -> RglError {
    RglError::BadData {
        field: field.to_string(),
        at,
        reason: reason.into(),
    }
}

impl RglBsdf {
    /// Reads and validates an RGL `.bsdf` file (RGB or spectral).
    pub fn from_bytes(bytes: &[u8]) -> Result<RglBsdf> {
        let tf = TensorFile::parse(bytes)?;
        let get = |name: &str, dtype: DType, ndim: usize| -> Result<&FieldInfo> {
            let f = tf.field(name).ok_or_else(|| RglError::MissingField {
                field: name.to_string(),
            })?;
            if f.dtype != dtype {
                return Err(RglError::WrongDType {
                    field: name.into(),
                    at: f.offset,
                    expected: dtype,
                    found: f.dtype,
                });
            }
            if f.shape.len() != ndim {
                return Err(RglError::WrongShape {
                    field: name.into(),
                    at: f.offset,
                    expected: format!("{ndim} dimensions"),
                    found: f.shape.clone(),
                });
            }
            Ok(f)
        };
        let shape_err = |f: &FieldInfo, expected: String| RglError::WrongShape {
            field: f.name.clone(),
            at: f.offset,
            expected,
            found: f.shape.clone(),
        };
        let finite = |f: &FieldInfo, v: &[f32], nonneg: bool| -> Result<()> {
            for (i, x) in v.iter().enumerate() {
                let at = f.offset + 4 * i as u64;
                if !x.is_finite() {
                    return Err(bad(&f.name, at, format!("value {x} is not finite")));
                }
                if nonneg && *x < 0.0 {
                    return Err(bad(&f.name, at, format!("density {x} is negative")));
                }
            }
            Ok(())
        };

        let description = get("description", DType::U8, 1)?;
        let description = String::from_utf8_lossy(tf.data(description)).into_owned();

        let th = get("theta_i", DType::F32, 1)?;
        let ph = get("phi_i", DType::F32, 1)?;
        let theta_i = tf.f32s(th);
        let phi_i = tf.f32s(ph);
        if theta_i.is_empty() {
            return Err(shape_err(th, "at least one incidence".into()));
        }
        if phi_i.is_empty() {
            return Err(shape_err(ph, "at least one azimuth".into()));
        }
        finite(th, &theta_i, true)?;
        finite(ph, &phi_i, false)?;
        for (i, &t) in theta_i.iter().enumerate() {
            let at = th.offset + 4 * i as u64;
            if t as f64 > std::f64::consts::FRAC_PI_2 + 1e-6 {
                return Err(bad("theta_i", at, format!("{t} rad is beyond 90°")));
            }
            if i > 0 && t <= theta_i[i - 1] {
                return Err(bad("theta_i", at, "not strictly increasing"));
            }
        }
        for (i, &p) in phi_i.iter().enumerate() {
            let at = ph.offset + 4 * i as u64;
            if (p as f64).abs() > 2.0 * std::f64::consts::PI + 1e-6 {
                return Err(bad("phi_i", at, format!("{p} rad is outside [−2π, 2π]")));
            }
            if i > 0 && p <= phi_i[i - 1] {
                return Err(bad("phi_i", at, "not strictly increasing"));
            }
        }
        let (n_phi, n_theta) = (phi_i.len() as u64, theta_i.len() as u64);

        let grid2 = |name: &str| -> Result<(Vec<f32>, (usize, usize))> {
            let f = get(name, DType::F32, 2)?;
            if f.shape[0] < 2 || f.shape[1] < 2 {
                return Err(shape_err(f, "[≥2, ≥2]".into()));
            }
            let v = tf.f32s(f);
            finite(f, &v, name == "ndf")?;
            Ok((v, (f.shape[1] as usize, f.shape[0] as usize)))
        };
        let (ndf, ndf_wh) = grid2("ndf")?;
        let (sigma, sigma_wh) = grid2("sigma")?;

        let vf = get("vndf", DType::F32, 4)?;
        if vf.shape[0] != n_phi || vf.shape[1] != n_theta || vf.shape[2] < 2 || vf.shape[3] < 2 {
            return Err(shape_err(vf, format!("[{n_phi}, {n_theta}, ≥2, ≥2]")));
        }
        let vndf = tf.f32s(vf);
        finite(vf, &vndf, true)?;
        let vndf_wh = (vf.shape[3] as usize, vf.shape[2] as usize);

        let spectral = tf.field("wavelengths").is_some();
        let (values_name, channels) = if spectral {
            let wf = get("wavelengths", DType::F32, 1)?;
            let wl = tf.f32s(wf);
            if wl.is_empty() {
                return Err(shape_err(wf, "at least one wavelength".into()));
            }
            for (i, &l) in wl.iter().enumerate() {
                let at = wf.offset + 4 * i as u64;
                if !(l.is_finite() && l > 0.0) || (i > 0 && l <= wl[i - 1]) {
                    return Err(bad(
                        "wavelengths",
                        at,
                        "not positive and strictly increasing",
                    ));
                }
            }
            ("spectra", Channels::Spectral { wavelengths: wl })
        } else {
            ("rgb", Channels::Rgb)
        };
        let n_ch = match &channels {
            Channels::Rgb => 3u64,
            Channels::Spectral { wavelengths } => wavelengths.len() as u64,
        };
        let sf = get(values_name, DType::F32, 5)?;
        let s = &sf.shape;
        if s[0] != n_phi || s[1] != n_theta || s[2] != n_ch || s[3] != s[4] || s[3] < 2 {
            return Err(shape_err(
                sf,
                format!("[{n_phi}, {n_theta}, {n_ch}, R, R] with R ≥ 2"),
            ));
        }
        let res = s[3] as usize;
        let values = tf.f32s(sf);
        finite(sf, &values, false)?;

        let lf = get("luminance", DType::F32, 4)?;
        let r = res as u64;
        if lf.shape != [n_phi, n_theta, r, r] {
            return Err(shape_err(lf, format!("[{n_phi}, {n_theta}, {r}, {r}]")));
        }

        let jf = get("jacobian", DType::U8, 1)?;
        if jf.shape != [1] {
            return Err(shape_err(jf, "[1]".into()));
        }
        let jacobian = tf.data(jf)[0] != 0;
        if jacobian {
            for (i, &v) in sigma.iter().enumerate() {
                if v <= 0.0 {
                    let at = tf.field("sigma").map_or(0, |f| f.offset) + 4 * i as u64;
                    return Err(bad(
                        "sigma",
                        at,
                        format!("projected area {v} is not positive"),
                    ));
                }
            }
        }
        let valid = match tf.field("valid") {
            Some(f) if f.dtype == DType::U8 => Some(tf.data(f).to_vec()),
            _ => None,
        };

        Ok(RglBsdf {
            description,
            theta_i,
            phi_i,
            channels,
            jacobian,
            isotropic: n_phi <= 2,
            res,
            valid,
            ndf,
            ndf_wh,
            sigma,
            sigma_wh,
            vndf,
            vndf_wh,
            vndf_at: vf.offset,
            values,
            values_name,
        })
    }

    /// What warped tables keep of an isotropic file (`spec/FORMAT.md` §3.10): the NDF and σ
    /// along u_x (their first row; `None` when the rows differ, as in an anisotropic NDF, or
    /// the file has no `jacobian` flag) and the VNDF grid side (`None` unless square).
    pub fn isotropic_warp_parts(&self) -> Option<(Vec<f32>, Vec<f32>, usize)> {
        let (nw, nh) = self.ndf_wh;
        let (sw, sh) = self.sigma_wh;
        let (vw, vh) = self.vndf_wh;
        if !self.isotropic || !self.jacobian || vw != vh || self.phi_i.len() != 1 {
            return None;
        }
        let same_rows =
            |v: &[f32], w: usize, h: usize| (1..h).all(|y| v[y * w..(y + 1) * w] == v[..w]);
        if !same_rows(&self.ndf, nw, nh) || !same_rows(&self.sigma, sw, sh) {
            return None;
        }
        Some((self.ndf[..nw].to_vec(), self.sigma[..sw].to_vec(), vw))
    }

    /// The stored values of incidence (theta_index, phi_index): channel-major, then row, column.
    pub fn values_at(&self, t: usize, p: usize) -> &[f32] {
        let (r, nc) = (self.res, self.channel_count());
        let base = (p * self.theta_i.len() + t) * nc * r * r;
        &self.values[base..base + nc * r * r]
    }

    /// Values per grid node: 3 for RGB, else the number of wavelengths.
    pub fn channel_count(&self) -> usize {
        match &self.channels {
            Channels::Rgb => 3,
            Channels::Spectral { wavelengths } => wavelengths.len(),
        }
    }

    /// The name of the field holding the measurement: `rgb` or `spectra`.
    pub fn values_field(&self) -> &'static str {
        self.values_name
    }

    /// Whether the measurement is RGB (`rgb`) rather than spectral.
    pub fn is_rgb(&self) -> bool {
        self.channels == Channels::Rgb
    }

    /// True when Mitsuba's eval is active at this stored incidence: cos θi > 0 for the stored
    /// float32 angle. (RGL files end with θi = 1.5707962 rad, just under 90°, cos = 7.5e−8:
    /// that one is usable in this sense; see [`RglBsdf::samples`] for cutting it.)
    pub fn incidence_usable(&self, theta_index: usize) -> bool {
        self.theta_i
            .get(theta_index)
            .is_some_and(|&t| (t as f64).cos() > 0.0)
    }

    /// The `valid` field read as a bit per grid node (numpy `packbits` order: most significant
    /// bit first), for [phi_i, theta_i, R, R]. Mitsuba and powitacq ignore this field; in the
    /// three RGL RGB files examined it equals the above-horizon mask in one file and its
    /// complement in the other two, so it is reported, never used.
    pub fn valid_bits(&self, theta_index: usize, phi_index: usize) -> Option<Vec<bool>> {
        let v = self.valid.as_ref()?;
        let n = self.res.checked_mul(self.res)?;
        let k = phi_index
            .checked_mul(self.theta_i.len())?
            .checked_add(theta_index)?;
        let start = k.checked_mul(n)?;
        let end = start.checked_add(n)?;
        if end > v.len().checked_mul(8)? {
            return None;
        }
        Some(
            (start..end)
                .map(|b| v[b / 8] & (0x80 >> (b % 8)) != 0)
                .collect(),
        )
    }

    fn check_indices(&self, t: usize, p: usize) -> Result<()> {
        if t >= self.theta_i.len() || p >= self.phi_i.len() {
            return Err(RglError::BadIncidence {
                reason: format!(
                    "index ({t}, {p}) outside {} × {} stored incidences",
                    self.theta_i.len(),
                    self.phi_i.len()
                ),
            });
        }
        if !self.incidence_usable(t) {
            return Err(RglError::BadIncidence {
                reason: format!(
                    "θi = {:.4}° is grazing: Mitsuba's eval is 0 there",
                    (self.theta_i[t] as f64).to_degrees()
                ),
            });
        }
        Ok(())
    }

    pub(super) fn warp(&self, t: usize, p: usize) -> Result<Warp2> {
        let (w, h) = self.vndf_wh;
        let start = (p * self.theta_i.len() + t) * w * h;
        Warp2::new(&self.vndf[start..start + w * h], w, h).ok_or_else(|| {
            bad(
                "vndf",
                self.vndf_at + 4 * start as u64,
                "VNDF slice integrates to zero",
            )
        })
    }

    /// NDF/(4σ) at half-vector parameter u for the incidence (θi, φi) in radians.
    fn jacobian_factor(&self, ux: f64, uy: f64, ti: f64, pi: f64) -> f64 {
        if !self.jacobian {
            return 1.0;
        }
        let (nw, nh) = self.ndf_wh;
        let (sw, sh) = self.sigma_wh;
        bilerp(&self.ndf, nw, nh, ux, uy)
            / (4.0 * bilerp(&self.sigma, sw, sh, theta2u(ti), phi2u(pi)))
    }

    /// Every grid node of stored incidence (theta_index, phi_index) as a real direction with
    /// its BRDF value(s).
    pub fn incidence(&self, theta_index: usize, phi_index: usize) -> Result<Incidence> {
        self.check_indices(theta_index, phi_index)?;
        let (t, p) = (theta_index, phi_index);
        let warp = self.warp(t, p)?;
        let ti = self.theta_i[t] as f64;
        let pi = self.phi_i[p] as f64;
        let wi = unit(ti, pi);
        let r = self.res;
        let nc = self.channel_count();
        let base = (p * self.theta_i.len() + t) * nc * r * r;
        let mut cells = Vec::with_capacity(r * r);
        let mut values = Vec::with_capacity(r * r * nc);
        let step = 1.0 / (r - 1) as f64;
        for row in 0..r {
            for col in 0..r {
                let (ux, uy) = warp.sample(col as f64 * step, row as f64 * step);
                let theta_m = ux * ux * std::f64::consts::FRAC_PI_2;
                let mut phi_m = (2.0 * uy - 1.0) * std::f64::consts::PI;
                if self.isotropic {
                    phi_m += pi;
                }
                let m = unit(theta_m, phi_m);
                let k = 2.0 * dot(m, wi);
                let mut wo = [k * m[0] - wi[0], k * m[1] - wi[1], k * m[2] - wi[2]];
                let len = dot(wo, wo).sqrt();
                wo.iter_mut().for_each(|c| *c /= len);
                let above = wo[2] > 0.0;
                let (theta_o, phi_o) = angles_deg(wo);
                let f = if above {
                    self.jacobian_factor(ux, uy, ti, pi) / wo[2]
                } else {
                    0.0
                };
                for c in 0..nc {
                    let v = self.values[base + (c * r + row) * r + col] as f64;
                    values.push(v * f);
                }
                cells.push(Cell {
                    row: row as u32,
                    col: col as u32,
                    theta_o,
                    phi_o,
                    wo,
                    above,
                });
            }
        }
        let (theta_i, phi_i) = (ti.to_degrees(), (pi.to_degrees()).rem_euclid(360.0));
        Ok(Incidence {
            theta_index: t,
            phi_index: p,
            theta_i,
            phi_i: if phi_i >= 360.0 { 0.0 } else { phi_i },
            wi,
            cells,
            values,
            channels: nc,
        })
    }

    /// Every usable stored incidence (cos θi > 0), in file order (φi outer, θi inner).
    pub fn incidences(&self) -> Result<Vec<Incidence>> {
        let mut out = Vec::new();
        for p in 0..self.phi_i.len() {
            for t in 0..self.theta_i.len() {
                if self.incidence_usable(t) {
                    out.push(self.incidence(t, p)?);
                }
            }
        }
        Ok(out)
    }

    /// Mitsuba's `measured` eval / cos θo at stored incidence (theta_index, phi_index) for an
    /// arbitrary outgoing direction in degrees; `None` below the horizon. Builds the warp on
    /// each call: use [`RglBsdf::evaluator`] for many directions.
    pub fn eval_at(
        &self,
        t: usize,
        p: usize,
        theta_o: f64,
        phi_o: f64,
    ) -> Result<Option<Vec<f64>>> {
        let e = self.evaluator(t, p)?;
        let mut out = vec![0.0; self.channel_count()];
        Ok(e.eval(theta_o, phi_o, &mut out).then_some(out))
    }

    /// An evaluator of stored incidence (t, p) (indices into `theta_i`, `phi_i`) at arbitrary
    /// outgoing directions. Errors: indices out of range, a grazing incidence (cos θi ≤ 0), or a
    /// VNDF slice that integrates to zero.
    pub fn evaluator(&self, t: usize, p: usize) -> Result<Evaluator<'_>> {
        self.check_indices(t, p)?;
        Ok(Evaluator {
            bsdf: self,
            warp: self.warp(t, p)?,
            t,
            p,
        })
    }

    /// The incidences as sbrdf samples: incidences with θi > `max_theta_i` (degrees) left out,
    /// below-horizon nodes (and nodes with θo > `max_theta_o`) dropped, nodes sharing a
    /// direction averaged, sorted by (θi, φi) then (θo, φo).
    ///
    /// RGL files end with θi = 1.5707962 rad (89.999995°): Mitsuba evaluates it, but cos θo
    /// of many of its nodes is ~1e−8 and Mitsuba itself returns NaN for some;
    /// [`super::MAX_THETA_I`] (85°) leaves it out.
    pub fn samples(&self, max_theta_i: f64, max_theta_o: f64) -> Result<Vec<IncidenceSamples>> {
        let mut out = Vec::new();
        for inc in self.incidences()? {
            if inc.theta_i <= max_theta_i {
                out.push(merge_cells(&inc, max_theta_o));
            }
        }
        out.sort_by(|a, b| {
            a.theta_i
                .total_cmp(&b.theta_i)
                .then(a.phi_i.total_cmp(&b.phi_i))
        });
        Ok(out)
    }
}

/// Evaluates one stored incidence at arbitrary outgoing directions (Mitsuba's inverse warp).
pub struct Evaluator<'a> {
    bsdf: &'a RglBsdf,
    warp: Warp2,
    t: usize,
    p: usize,
}

impl Evaluator<'_> {
    /// Writes the BRDF (1/sr) at (θo, φo) degrees into `out` (channel_count values); returns
    /// false (and zeros) below the horizon.
    pub fn eval(&self, theta_o: f64, phi_o: f64, out: &mut [f64]) -> bool {
        let b = self.bsdf;
        out.iter_mut().for_each(|v| *v = 0.0);
        if !(theta_o.is_finite() && phi_o.is_finite()) {
            return false;
        }
        let ti = b.theta_i[self.t] as f64;
        let pi = b.phi_i[self.p] as f64;
        let wi = unit(ti, pi);
        let wo = unit(theta_o.to_radians(), phi_o.to_radians());
        if wo[2] <= 0.0 {
            return false;
        }
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = dot(h, h).sqrt();
        let m = [h[0] / n, h[1] / n, h[2] / n];
        let theta_m = (m[0] * m[0] + m[1] * m[1]).sqrt().atan2(m[2]);
        let mut phi_m = m[1].atan2(m[0]);
        if b.isotropic {
            phi_m -= pi;
        }
        let ux = theta2u(theta_m);
        let mut uy = phi2u(phi_m);
        uy -= uy.floor();
        let (sx, sy) = self.warp.invert(ux, uy);
        let f = b.jacobian_factor(ux, uy, ti, pi) / wo[2];
        let r = b.res;
        let nc = b.channel_count();
        let base = (self.p * b.theta_i.len() + self.t) * nc * r * r;
        for (c, o) in out.iter_mut().enumerate().take(nc) {
            let g = &b.values[base + c * r * r..base + (c + 1) * r * r];
            *o = bilerp(g, r, r, sx, sy) * f;
        }
        true
    }
}

/// Drops below-horizon nodes, averages nodes that share a direction (to 1e−6°), sorts.
pub fn merge_cells(inc: &Incidence, max_theta_o: f64) -> IncidenceSamples {
    let nc = inc.channels;
    let q = |x: f64| (x * 1e6).round() as i64;
    let mut keep: Vec<(i64, i64, usize)> = Vec::new();
    let mut dropped = 0;
    for (k, c) in inc.cells.iter().enumerate() {
        if !c.above || c.theta_o > max_theta_o {
            dropped += 1;
            continue;
        }
        let mut pk = q(c.phi_o);
        if pk >= q(360.0) {
            pk -= q(360.0);
        }
        keep.push((q(c.theta_o), pk, k));
    }
    keep.sort();
    let (mut directions, mut values, mut nodes) = (Vec::new(), Vec::new(), Vec::new());
    let (mut merged, mut spread) = (0usize, 0f64);
    let mut i = 0;
    while i < keep.len() {
        let mut j = i + 1;
        while j < keep.len() && (keep[j].0, keep[j].1) == (keep[i].0, keep[i].1) {
            j += 1;
        }
        let group = &keep[i..j];
        merged += group.len() - 1;
        let first = &inc.cells[group[0].2];
        directions.push([first.theta_o, first.phi_o]);
        nodes.push([first.row, first.col]);
        for c in 0..nc {
            let vals = group.iter().map(|g| inc.values[g.2 * nc + c]);
            let mean = vals.clone().sum::<f64>() / group.len() as f64;
            if group.len() > 1 && mean.abs() > 0.0 {
                let (lo, hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
                spread = spread.max((hi - lo) / mean.abs());
            }
            values.push(mean);
        }
        i = j;
    }
    // Keys are quantised; order by the directions themselves (equal keys are merged already,
    // so the directions are distinct).
    let mut order: Vec<usize> = (0..directions.len()).collect();
    order.sort_by(|&a, &b| {
        let (da, db) = (directions[a], directions[b]);
        da[0].total_cmp(&db[0]).then(da[1].total_cmp(&db[1]))
    });
    let directions: Vec<[f64; 2]> = order.iter().map(|&k| directions[k]).collect();
    let nodes: Vec<[u32; 2]> = order.iter().map(|&k| nodes[k]).collect();
    let values: Vec<f64> = order
        .iter()
        .flat_map(|&k| values[k * nc..(k + 1) * nc].to_vec())
        .collect();
    IncidenceSamples {
        index: [inc.theta_index, inc.phi_index],
        theta_i: inc.theta_i,
        phi_i: inc.phi_i,
        directions,
        values,
        nodes,
        merged,
        merge_spread: spread,
        dropped,
    }
}
