//! Writing a material: chunks framed and checksummed, f16 values under a power-of-two scale.

use super::consts::*;
use crate::error::{Error, Result};
use crate::model::basis_storage::BasisStorage;
use crate::model::factor::FactorModel;
use crate::model::material::*;
use crate::model::sh::sh_count;
use crate::model::warped::{PayloadCoding, TableTransform};
use crate::model::Precision;
use half::f16;

/// The power-of-two scale that maps a record's largest magnitude into (2¹⁴, 2¹⁵] for f16
/// storage, keeping values down to ~2⁻²⁹ of the largest in f16's normal range.
pub fn f16_scale(values: impl Iterator<Item = f32>) -> f32 {
    let max = values.fold(0.0f64, |m, v| m.max((v as f64).abs()));
    if max == 0.0 || !max.is_finite() {
        return 1.0;
    }
    let mut scale = 1.0f64;
    while max / scale > 32768.0 && scale < 2f64.powi(127) {
        scale *= 2.0;
    }
    while max / scale <= 16384.0 && scale > 2f64.powi(-126) {
        scale *= 0.5;
    }
    scale as f32
}

/// Rounds a record's stored values to what f16 storage will hold, in place, and returns the
/// scale. The encoder calls this before measuring its error, so the error it records is honest.
pub fn quantize_record_f16(r: &mut IncidentRecord) -> f32 {
    let scale = record_scale(r);
    let q = |v: &mut f32| *v = f16::from_f32(*v / scale).to_f32() * scale;
    r.sh.iter_mut().for_each(q);
    for l in &mut r.lobes {
        l.amplitude.iter_mut().for_each(q);
    }
    r.precision = Precision::F16;
    scale
}

fn record_scale(r: &IncidentRecord) -> f32 {
    f16_scale(
        r.sh.iter()
            .copied()
            .chain(r.lobes.iter().flat_map(|l| l.amplitude.iter().copied())),
    )
}

fn push_chunk(out: &mut Vec<u8>, kind: [u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(&kind);
    out.extend_from_slice(data);
    let mut h = crc32fast::Hasher::new();
    h.update(&kind);
    h.update(data);
    out.extend_from_slice(&h.finalize().to_le_bytes());
}

/// The minor version `m` is written as, and whether its wavelengths are stored as a range.
/// Version 1.1's range is used when the material allows 1.1 features (`version_minor` ≥ 1) and
/// its wavelengths are evenly spaced; a factor model (`FACT`) is a 1.1 feature and an
/// anisotropic lobe (kind 5) a 1.2 feature whatever the material asks. Compact records
/// (`RECS`, 1.3) are used exactly when the material allows 1.3; warped tables (`WARP`) make a
/// file 1.4, 1.5 with the wavelet transform, 1.6 with a range-coded payload, 1.7 with prediction
/// flags. A file without 1.1 features is written as 1.0,
/// byte for byte. Reading the file back gives this minor version.
pub fn written_version(m: &Material) -> (u16, bool) {
    let range = m.version_minor >= 1 && is_wavelength_range(&m.wavelengths);
    if let Some(w) = &m.warped {
        // Warped tables are a 1.4 feature whatever the material asks, as FACT is 1.1's; their
        // wavelet transform a 1.5 one.
        let minor = match (w.coding, w.transform) {
            _ if !w.predicted.is_empty() => VERSION_MINOR_PREDICTED,
            _ if quantised_basis(m) => VERSION_MINOR_RANGE,
            (PayloadCoding::Range, _) => VERSION_MINOR_RANGE,
            (_, TableTransform::Dct) => VERSION_MINOR_WARP,
            (_, TableTransform::Wavelet53) => VERSION_MINOR_WAVELET,
        };
        return (minor, is_wavelength_range(&m.wavelengths));
    }
    if quantised_basis(m) {
        // A quantised basis is a 1.6 feature (compact records, 1.3, come with it).
        return (VERSION_MINOR_RANGE, range);
    }
    if m.version_minor >= VERSION_MINOR_COMPACT {
        return (VERSION_MINOR_COMPACT, range);
    }
    let aniso = m
        .records
        .iter()
        .any(|r| r.lobes.iter().any(|l| l.kind == LobeKind::MicrofacetAniso));
    let minor = if aniso {
        VERSION_MINOR_ANISO
    } else if range || m.factor.is_some() {
        VERSION_MINOR_FACTOR
    } else {
        0
    };
    (minor, range)
}

/// Whether the material's basis is stored quantised (`SBAS` precision 3, a 1.6 feature).
fn quantised_basis(m: &Material) -> bool {
    m.spectral
        .table
        .as_ref()
        .is_some_and(|t| matches!(t.storage, BasisStorage::Quantised { .. }))
}

/// Serialises a material. Fails only if it breaks an invariant of the format.
///
/// ```
/// let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf")).unwrap();
/// let mut material = sbrdf::read_material(&bytes, &sbrdf::Limits::default())?;
/// // An archive tool adds provenance and writes the file back.
/// material.metadata = Some(r#"{"source":"goniometer 3"}"#.to_string());
/// let written = sbrdf::write_material(&material)?;
/// let again = sbrdf::read_material(&written, &sbrdf::Limits::default())?;
/// assert_eq!(again.metadata, material.metadata);
/// assert_eq!(again.records.len(), material.records.len());
/// # Ok::<(), sbrdf::Error>(())
/// ```
pub fn write_material(m: &Material) -> Result<Vec<u8>> {
    m.validate()
        .map_err(|e| Error::Parameter(format!("cannot write this material: {e}")))?;
    let k = m.spectral.terms;
    let mut out = Vec::new();
    out.extend_from_slice(&SIGNATURE);

    let (minor, range) = written_version(m);
    let compact = minor >= VERSION_MINOR_COMPACT;
    let mut flags = if m.isotropic { FLAG_ISOTROPIC } else { 0 };
    if range {
        flags |= FLAG_WAVELENGTH_RANGE;
    }
    // Version 1.7 stores an isotropic file's incidences as θi alone (every φi is +0).
    let theta_only = m.isotropic && minor >= VERSION_MINOR_PREDICTED;
    if theta_only {
        flags |= FLAG_THETA_ONLY;
    }
    let mut d = Vec::with_capacity(HEAD_FIXED + 4 * m.wavelengths.len() + 8 * m.records.len());
    d.extend_from_slice(&VERSION_MAJOR.to_le_bytes());
    d.extend_from_slice(&minor.to_le_bytes());
    d.extend_from_slice(&flags.to_le_bytes());
    d.push(m.spectral.basis.code());
    d.push(0); // reserved (precision is per record)
    d.push(m.sh_level as u8);
    d.push(ANGLE_CONVENTION);
    d.extend_from_slice(&(k as u16).to_le_bytes());
    d.extend_from_slice(&0u16.to_le_bytes());
    d.extend_from_slice(&m.spectral.lambda_min.to_le_bytes());
    d.extend_from_slice(&m.spectral.lambda_max.to_le_bytes());
    d.extend_from_slice(&(m.wavelengths.len() as u32).to_le_bytes());
    d.extend_from_slice(&(m.records.len() as u32).to_le_bytes());
    if range {
        let w = &m.wavelengths;
        d.extend_from_slice(&w[0].to_le_bytes());
        d.extend_from_slice(&w[w.len() - 1].to_le_bytes());
    } else {
        for w in &m.wavelengths {
            d.extend_from_slice(&w.to_le_bytes());
        }
    }
    for r in &m.records {
        d.extend_from_slice(&r.theta_i.to_le_bytes());
        if !theta_only {
            d.extend_from_slice(&r.phi_i.to_le_bytes());
        }
    }
    push_chunk(&mut out, CHUNK_HEAD, &d);

    if let Some(table) = &m.spectral.table {
        let mut d = Vec::with_capacity(4 + 4 * table.values.len());
        match &table.storage {
            BasisStorage::Float(precision) => {
                d.extend_from_slice(&[precision.code(), 0, 0, 0]);
                for v in &table.values {
                    match precision {
                        Precision::F32 => d.extend_from_slice(&(*v as f32).to_le_bytes()),
                        Precision::F16 => d.extend_from_slice(&f16::from_f64(*v).to_le_bytes()),
                    }
                }
            }
            BasisStorage::Quantised { exponents } => {
                d.extend_from_slice(&[SBAS_QUANTISED, 0, 0, 0]);
                d.extend_from_slice(&super::basis_payload::quantised_data(
                    &table.values,
                    exponents,
                    table.nodes.len(),
                ));
            }
        }
        push_chunk(&mut out, CHUNK_SBAS, &d);
    }
    if let Some(f) = &m.factor {
        push_chunk(&mut out, CHUNK_FACT, &factor_chunk(f));
    }
    if let Some(w) = &m.warped {
        push_chunk(&mut out, CHUNK_WARP, &super::warp_chunk::warp_chunk(w, k));
    }
    if let Some(meta) = &m.metadata {
        push_chunk(&mut out, CHUNK_META, meta.as_bytes());
    }
    if let Some(sp) = &m.sample_positions {
        let mut d = Vec::new();
        d.extend_from_slice(&(sp.sets.len() as u32).to_le_bytes());
        for s in &sp.sets {
            match s {
                DirectionSet::Grid {
                    theta0,
                    dtheta,
                    ntheta,
                    phi0,
                    dphi,
                    nphi,
                } => {
                    d.push(0);
                    for v in [theta0, dtheta] {
                        d.extend_from_slice(&v.to_le_bytes());
                    }
                    d.extend_from_slice(&ntheta.to_le_bytes());
                    for v in [phi0, dphi] {
                        d.extend_from_slice(&v.to_le_bytes());
                    }
                    d.extend_from_slice(&nphi.to_le_bytes());
                }
                DirectionSet::List(v) => {
                    d.push(1);
                    d.extend_from_slice(&(v.len() as u32).to_le_bytes());
                    for dir in v {
                        d.extend_from_slice(&dir[0].to_le_bytes());
                        d.extend_from_slice(&dir[1].to_le_bytes());
                    }
                }
            }
        }
        for i in &sp.set_of_incidence {
            d.extend_from_slice(&i.to_le_bytes());
        }
        push_chunk(&mut out, CHUNK_SAMP, &d);
    }
    if let Some(h) = &m.held_out {
        let (protocol, k) = match h.protocol {
            HeldOutProtocol::Folds(k) => (1u8, k),
            HeldOutProtocol::LeaveOneOut => (2, 0),
        };
        let mut d = vec![protocol, k, 0, 0];
        for (r, l) in h.rel.iter().zip(&h.log) {
            d.extend_from_slice(&r.to_le_bytes());
            d.extend_from_slice(&l.to_le_bytes());
        }
        push_chunk(&mut out, CHUNK_XVAL, &d);
    }

    if m.warped.is_some() {
        // Version 1.4: a file with warped tables has no records chunk; its records are the
        // empty ones of §3.10, implied.
    } else if compact {
        // Version 1.3: every record in one chunk, each without index, incidence and reserved
        // bytes, its scale only when it is f16.
        let mut d = Vec::new();
        for r in &m.records {
            let scale = scale_of(r);
            for v in [r.theta_p, r.phi_p, r.rel_error, r.critical_angle] {
                d.extend_from_slice(&v.to_le_bytes());
            }
            d.push(r.lobes.len() as u8);
            d.push(r.precision.code());
            d.push(r.sh_level as u8);
            d.extend_from_slice(&(r.terms as u16).to_le_bytes());
            if r.precision == Precision::F16 {
                d.extend_from_slice(&scale.to_le_bytes());
            }
            record_values(&mut d, r, scale);
        }
        push_chunk(&mut out, CHUNK_RECS, &d);
    } else {
        for (index, r) in m.records.iter().enumerate() {
            let (k, p, s) = (r.terms, sh_count(r.sh_level), r.precision.bytes());
            let mut d =
                Vec::with_capacity(RECD_FIXED + k * p * s + r.lobes.len() * (LOBE_FIXED + 16 * k));
            let scale = scale_of(r);
            d.extend_from_slice(&(index as u32).to_le_bytes());
            for v in [
                r.theta_i,
                r.phi_i,
                r.theta_p,
                r.phi_p,
                r.rel_error,
                r.critical_angle,
                scale,
            ] {
                d.extend_from_slice(&v.to_le_bytes());
            }
            d.push(r.lobes.len() as u8);
            d.push(r.precision.code());
            d.push(r.sh_level as u8);
            d.push(0);
            d.extend_from_slice(&(k as u16).to_le_bytes());
            d.extend_from_slice(&0u16.to_le_bytes());
            record_values(&mut d, r, scale);
            push_chunk(&mut out, CHUNK_RECD, &d);
        }
    }
    push_chunk(&mut out, CHUNK_ENDF, &[]);
    Ok(out)
}

/// The record's scale: 1 for f32, the power of two of §5 for f16.
fn scale_of(r: &IncidentRecord) -> f32 {
    match r.precision {
        Precision::F32 => 1.0,
        Precision::F16 => record_scale(r),
    }
}

/// A record's SH coefficients, then its lobes (header, amplitudes, parameters): the same bytes
/// in `RECD` and `RECS`.
fn record_values(d: &mut Vec<u8>, r: &IncidentRecord, scale: f32) {
    let s = r.precision.bytes();
    let put = |d: &mut Vec<u8>, v: f32| match r.precision {
        Precision::F32 => d.extend_from_slice(&v.to_le_bytes()),
        Precision::F16 => d.extend_from_slice(&f16::from_f32(v / scale).to_le_bytes()),
    };
    for &v in &r.sh {
        put(d, v);
    }
    for lobe in &r.lobes {
        let lobe_bytes = lobe.amplitude.len() * s + 4 * lobe.params.len();
        d.push(lobe.kind.code());
        d.push(0);
        d.extend_from_slice(&(lobe_bytes as u16).to_le_bytes());
        for &v in &lobe.amplitude {
            put(d, v);
        }
        for &v in &lobe.params {
            d.extend_from_slice(&v.to_le_bytes());
        }
    }
}

/// The data of a `FACT` chunk (`FORMAT.md`, §3.7).
fn factor_chunk(f: &FactorModel) -> Vec<u8> {
    let mut d = vec![f.components.len() as u8, f.precision.code(), 0, 0];
    for r in &f.ranges {
        d.extend_from_slice(&r[0].to_le_bytes());
        d.extend_from_slice(&r[1].to_le_bytes());
    }
    for c in &f.components {
        d.push(c.rank() as u8);
        d.push(c.features.len() as u8);
        d.extend(c.features.iter().map(|k| k.code()));
    }
    let mut put = |v: f32| match f.precision {
        Precision::F32 => d.extend_from_slice(&v.to_le_bytes()),
        Precision::F16 => d.extend_from_slice(&f16::from_f32(v).to_le_bytes()),
    };
    for c in &f.components {
        c.spectrum.iter().for_each(|&v| put(v));
        for (r, tables) in c.tables.iter().enumerate() {
            if r >= 1 {
                c.modulation[r - 1].iter().for_each(|&v| put(v));
            }
            tables.iter().flatten().for_each(|&v| put(v));
        }
    }
    d
}
