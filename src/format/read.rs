//! Reading a file: every chunk framed, CRC-checked and bounded by the bytes present, then
//! validated into a [`Material`] (`spec/FORMAT.md`, "Decoder behaviour").

use super::consts::*;
use super::fields::{Fields, Head};
use super::read_records::{read_compact_records, read_record};
use crate::error::{Error, Location, Result};
use crate::model::factor::{
    FactorComponent, FactorModel, Feature, MAX_COMPONENTS, MAX_FEATURES, MAX_RANK,
};
use crate::model::material::*;
use crate::model::sh::MAX_SH_LEVEL;
use crate::model::spectral::{SpectralBasis, SpectralSpace};
use crate::model::Precision;

fn read_head(f: &mut Fields) -> Result<Head> {
    let major = f.u16("version_major")?;
    let minor = f.u16("version_minor")?;
    if major != VERSION_MAJOR {
        return Err(f.unsupported(format!(
            "the file is format version {major}.{minor}; this sbrdf reads version {VERSION_MAJOR}.x \
             (a newer major version changes meaning: upgrade sbrdf to read it)"
        )));
    }
    // Flags before anything else: a flag of a newer minor version may change HEAD's layout
    // (spec/FORMAT.md §7), so an unknown one is reported as unsupported, not as a bad length.
    let flags = f.u32("flags")?;
    if flags & !(FLAG_ISOTROPIC | FLAG_WAVELENGTH_RANGE | FLAG_THETA_ONLY) != 0 {
        return Err(f.unsupported(format!("unknown flag bits {flags:#x} set")));
    }
    let range = flags & FLAG_WAVELENGTH_RANGE != 0;
    let theta_only = flags & FLAG_THETA_ONLY != 0;
    if theta_only && flags & FLAG_ISOTROPIC == 0 {
        return Err(f.malformed(
            "flag bit 2 (incidences as θi alone) without the isotropic flag".to_string(),
        ));
    }
    if theta_only && minor < VERSION_MINOR_PREDICTED {
        return Err(f.malformed(format!(
            "flag bit 2 (incidences as θi alone) is a 1.{VERSION_MINOR_PREDICTED} feature, in a \
             1.{minor} file"
        )));
    }
    let basis_code = f.u8("spectral_basis")?;
    let basis = SpectralBasis::from_code(basis_code)
        .ok_or_else(|| f.unsupported(format!("unknown spectral basis code {basis_code}")))?;
    f.zero(1, "reserved")?;
    let sh_level = f.u8("sh_level")? as usize;
    if sh_level > MAX_SH_LEVEL {
        return Err(f.malformed(format!("SH level {sh_level} exceeds {MAX_SH_LEVEL}")));
    }
    let conv = f.u8("angle_convention")?;
    if conv != ANGLE_CONVENTION {
        return Err(f.unsupported(format!("unknown angle convention {conv}")));
    }
    let terms = f.u16("terms")? as usize;
    if terms == 0 || terms > MAX_TERMS {
        return Err(f.malformed(format!("{terms} spectral terms (1 to {MAX_TERMS} allowed)")));
    }
    f.zero(2, "reserved")?;
    let lambda_min = f.f64("lambda_min")?;
    let lambda_max = f.f64("lambda_max")?;
    let w = f.u32("wavelength_count")? as usize;
    let n = f.u32("incident_count")? as usize;
    if range && w < 2 {
        return Err(f.malformed(format!(
            "a wavelength range of {w} wavelength: the range flag needs at least 2"
        )));
    }
    // Check the counts against the bytes present before allocating anything for them. A range
    // stores 2 wavelengths of W (at most 65 536, so W values are bounded by the format).
    let stored = if range { 2 } else { w as u64 };
    let need = stored * 4 + (n as u64) * if theta_only { 4 } else { 8 };
    if need != f.remaining() as u64 {
        return Err(f.malformed(format!(
            "{stored} stored wavelengths and {n} incident directions need {need} bytes, the \
             chunk has {}",
            f.remaining()
        )));
    }
    let wavelengths = if range {
        let first = f.f32("first_wavelength")?;
        let last = f.f32("last_wavelength")?;
        if w > MAX_WAVELENGTHS {
            return Err(f.malformed(format!("{w} wavelengths (1 to {MAX_WAVELENGTHS} allowed)")));
        }
        range_wavelengths(first, last, w).collect()
    } else {
        let mut wavelengths = Vec::with_capacity(w);
        for _ in 0..w {
            wavelengths.push(f.f32("wavelength")?);
        }
        wavelengths
    };
    let mut incidences = Vec::with_capacity(n);
    for _ in 0..n {
        let theta = f.f32("theta_i")?;
        let phi = if theta_only { 0.0 } else { f.f32("phi_i")? };
        incidences.push([theta, phi]);
    }
    f.finish()?;
    Ok(Head {
        spectral: SpectralSpace::analytic(basis, terms, lambda_min, lambda_max),
        sh_level,
        isotropic: flags & FLAG_ISOTROPIC != 0,
        minor,
        wavelengths,
        incidences,
    })
}

/// Reads a `samp` chunk; `Ok(None)` when it uses a direction-set kind this reader does not know
/// (the chunk is ancillary, so it is skipped as a whole).
fn read_samp(f: &mut Fields, n: usize) -> Result<Option<SamplePositions>> {
    let set_count = f.u32("set_count")? as usize;
    // Each set takes at least 5 bytes, each incidence 4: bound the counts by the bytes present.
    if set_count == 0 || set_count as u64 * 5 + n as u64 * 4 > f.remaining() as u64 {
        return Err(f.malformed(format!(
            "{set_count} direction sets for {n} incidences cannot fit in {} bytes",
            f.remaining()
        )));
    }
    let mut sets = Vec::with_capacity(set_count);
    for _ in 0..set_count {
        match f.u8("set_kind")? {
            0 => {
                let theta0 = f.f32("theta0")?;
                let dtheta = f.f32("dtheta")?;
                let ntheta = f.u32("ntheta")?;
                let phi0 = f.f32("phi0")?;
                let dphi = f.f32("dphi")?;
                let nphi = f.u32("nphi")?;
                // A grid costs 24 bytes but expands: bound its size like any other allocation.
                if ntheta as u64 * nphi as u64 > MAX_SET_DIRECTIONS {
                    return Err(f.malformed(format!(
                        "grid of {ntheta}×{nphi} directions exceeds {MAX_SET_DIRECTIONS}"
                    )));
                }
                sets.push(DirectionSet::Grid {
                    theta0,
                    dtheta,
                    ntheta,
                    phi0,
                    dphi,
                    nphi,
                });
            }
            1 => {
                let count = f.u32("direction_count")? as usize;
                if count as u64 * 8 > f.remaining() as u64 || count as u64 > MAX_SET_DIRECTIONS {
                    return Err(f.malformed(format!(
                        "{count} directions cannot fit in {} bytes",
                        f.remaining()
                    )));
                }
                let mut v = Vec::with_capacity(count);
                for _ in 0..count {
                    v.push([f.f32("theta_o")?, f.f32("phi_o")?]);
                }
                sets.push(DirectionSet::List(v));
            }
            _ => return Ok(None),
        }
    }
    let mut set_of_incidence = Vec::with_capacity(n);
    for _ in 0..n {
        set_of_incidence.push(f.u32("set_index")?);
    }
    f.finish()?;
    Ok(Some(SamplePositions {
        sets,
        set_of_incidence,
    }))
}

/// A `FACT` chunk (`FORMAT.md`, §3.7): sizes and codes first, every length checked against the
/// bytes present before anything is allocated.
fn read_factor(f: &mut Fields, w: usize) -> Result<FactorModel> {
    let count = f.u8("component_count")? as usize;
    if count == 0 || count > MAX_COMPONENTS {
        return Err(f.malformed(format!("{count} factor components (1 to {MAX_COMPONENTS})")));
    }
    let code = f.u8("precision")?;
    let precision = Precision::from_code(code)
        .ok_or_else(|| f.unsupported(format!("unknown factor precision code {code}")))?;
    f.zero(2, "reserved")?;
    let mut ranges = [[0f32; 2]; 5];
    for r in &mut ranges {
        r[0] = f.f32("range_min")?;
        r[1] = f.f32("range_max")?;
    }
    let mut shapes = Vec::with_capacity(count);
    let mut values = 0usize;
    for _ in 0..count {
        let rank = f.u8("rank")? as usize;
        let nf = f.u8("feature_count")? as usize;
        if rank == 0 || rank > MAX_RANK || nf == 0 || nf > MAX_FEATURES {
            return Err(f.malformed(format!(
                "a factor component of rank {rank} with {nf} features (1 to {MAX_RANK}, 1 to \
                 {MAX_FEATURES})"
            )));
        }
        let mut features = Vec::with_capacity(nf);
        for _ in 0..nf {
            let c = f.u8("feature")?;
            let k = Feature::from_code(c)
                .ok_or_else(|| f.unsupported(format!("unknown factor feature code {c}")))?;
            features.push(k);
        }
        let per_rank: usize = features.iter().map(|k| k.table_len()).sum();
        values += w * rank + rank * per_rank;
        shapes.push((rank, features));
    }
    let need = values * precision.bytes();
    if f.remaining() != need {
        return Err(f.malformed(format!(
            "the factor components need {need} bytes of values, the chunk has {} left",
            f.remaining()
        )));
    }
    let read_n = |f: &mut Fields, n: usize, what: &str| -> Result<Vec<f32>> {
        (0..n).map(|_| f.stored(precision, 1.0, what)).collect()
    };
    let mut components = Vec::with_capacity(count);
    for (rank, features) in shapes {
        let spectrum = read_n(f, w, "spectrum")?;
        let mut modulation = Vec::with_capacity(rank - 1);
        let mut tables = Vec::with_capacity(rank);
        for r in 0..rank {
            if r >= 1 {
                modulation.push(read_n(f, w, "modulation")?);
            }
            let mut t = Vec::with_capacity(features.len());
            for k in &features {
                t.push(read_n(f, k.table_len(), "table")?);
            }
            tables.push(t);
        }
        components.push(FactorComponent {
            features,
            spectrum,
            modulation,
            tables,
        });
    }
    f.finish()?;
    Ok(FactorModel {
        precision,
        ranges,
        components,
    })
}

/// An `xval` chunk: per record the held-out rel and log errors. An unknown protocol code makes
/// the reader skip the chunk, as it skips an unknown ancillary chunk.
fn read_xval(f: &mut Fields, n: usize) -> Result<Option<HeldOutErrors>> {
    let code = f.u8("protocol")?;
    if !(1..=2).contains(&code) {
        return Ok(None); // unknown protocol: the chunk is skipped whatever it holds
    }
    let k = f.u8("folds")?;
    f.zero(2, "reserved")?;
    let protocol = match (code, k) {
        (1, k) if k >= 2 => HeldOutProtocol::Folds(k),
        (2, 0) => HeldOutProtocol::LeaveOneOut,
        _ => {
            return Err(f.malformed(format!(
                "held-out protocol {code} with {k} folds (protocol 1 needs 2 or more, 2 needs 0)"
            )))
        }
    };
    if f.remaining() != 8 * n {
        return Err(f.malformed(format!(
            "{n} records need {} bytes of held-out errors, the chunk has {}",
            8 * n,
            f.remaining()
        )));
    }
    let (mut rel, mut log) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        rel.push(f.f32("rel")?);
        log.push(f.f32("log")?);
    }
    Ok(Some(HeldOutErrors { protocol, rel, log }))
}

fn location(offset: usize, chunk: Option<[u8; 4]>) -> Location {
    Location {
        offset: offset as u64,
        chunk,
    }
}

/// Parses and validates a whole file. Every CRC is checked (except in fuzzing builds, so the
/// fuzzer can reach the parser behind them).
///
/// ```
/// let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf")).unwrap();
/// let material = sbrdf::read_material(&bytes, &sbrdf::Limits::default())?;
/// println!("{} records over {:?} nm", material.records.len(), material.wavelengths);
/// // One flipped bit anywhere is refused (every chunk carries a CRC-32).
/// let mut damaged = bytes.clone();
/// damaged[bytes.len() / 2] ^= 1;
/// assert!(sbrdf::read_material(&damaged, &sbrdf::Limits::default()).is_err());
/// # Ok::<(), sbrdf::Error>(())
/// ```
pub fn read_material(bytes: &[u8], limits: &Limits) -> Result<Material> {
    if bytes.len() > limits.max_file_bytes {
        return Err(Error::LimitsExceeded(format!(
            "file of {} bytes exceeds the limit of {} bytes",
            bytes.len(),
            limits.max_file_bytes
        )));
    }
    let malformed = |offset: usize, chunk: Option<[u8; 4]>, message: String| Error::Format {
        at: location(offset, chunk),
        message,
    };
    if bytes.len() < SIGNATURE.len() || bytes[..SIGNATURE.len()] != SIGNATURE {
        let message = if bytes.starts_with(b"\x89SBRDF") {
            "the signature is damaged: the file went through a text-mode transfer that changed \
             line endings, or was truncated"
        } else if bytes.len() < SIGNATURE.len() && SIGNATURE.starts_with(bytes) {
            "the file is truncated inside its signature"
        } else {
            "not an sbrdf file (the signature is missing)"
        };
        return Err(malformed(0, None, message.into()));
    }
    let mut pos = SIGNATURE.len();
    let mut head: Option<Head> = None;
    let mut records = Vec::new();
    let mut metadata = None;
    let mut samples = None;
    let mut seen_samp = false;
    let mut table = None;
    let mut factor = None;
    let mut warped = None;
    let (mut held_out, mut seen_xval) = (None, false);
    let mut seen_recs = false;
    loop {
        if pos == bytes.len() {
            return Err(malformed(
                pos,
                None,
                "the file ends without its ENDF chunk (truncated?)".into(),
            ));
        }
        if bytes.len() - pos < 12 {
            return Err(malformed(
                pos,
                None,
                format!(
                    "{} bytes left, too few for a chunk (truncated?)",
                    bytes.len() - pos
                ),
            ));
        }
        let len = u32::from_le_bytes(bytes[pos..pos + 4].try_into().unwrap()) as usize;
        let kind: [u8; 4] = bytes[pos + 4..pos + 8].try_into().unwrap();
        if !kind.iter().all(|b| b.is_ascii_alphabetic()) {
            return Err(malformed(
                pos + 4,
                None,
                format!("chunk type {kind:02x?} is not four ASCII letters"),
            ));
        }
        if len > MAX_CHUNK || len > bytes.len() - pos - 12 {
            return Err(malformed(
                pos,
                Some(kind),
                format!(
                    "chunk claims {len} bytes of data but only {} remain (truncated?)",
                    bytes.len() - pos - 12
                ),
            ));
        }
        let data = &bytes[pos + 8..pos + 8 + len];
        let stored = u32::from_le_bytes(bytes[pos + 8 + len..pos + 12 + len].try_into().unwrap());
        let mut h = crc32fast::Hasher::new();
        h.update(&kind);
        h.update(data);
        let computed = h.finalize();
        if stored != computed && !cfg!(fuzzing) {
            return Err(malformed(
                pos + 8 + len,
                Some(kind),
                format!(
                    "CRC mismatch: stored {stored:#010x}, computed {computed:#010x} (the chunk is damaged)"
                ),
            ));
        }
        let mut f = Fields::new(data, (pos + 8) as u64, kind);
        let next = pos + 12 + len;
        if warped.is_some() && (kind == CHUNK_RECD || kind == CHUNK_RECS) {
            return Err(malformed(
                pos,
                Some(kind),
                "a file with warped tables (WARP) holds no records chunk".into(),
            ));
        }
        match (&kind, &head) {
            (&CHUNK_HEAD, None) => head = Some(read_head(&mut f)?),
            (_, None) => {
                return Err(malformed(
                    pos,
                    Some(kind),
                    "the first chunk must be HEAD".into(),
                ))
            }
            (&CHUNK_HEAD, Some(_)) => {
                return Err(malformed(pos, Some(kind), "a second HEAD chunk".into()))
            }
            (&CHUNK_SBAS, Some(h)) => {
                if h.spectral.basis != SpectralBasis::Tabulated {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "an SBAS chunk in a file whose basis is not tabulated".into(),
                    ));
                }
                if table.is_some() || !records.is_empty() {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "SBAS must appear once, before the records".into(),
                    ));
                }
                let code = f.u8("precision")?;
                f.zero(3, "reserved")?;
                let (values, storage) = if code == SBAS_QUANTISED {
                    if h.minor < VERSION_MINOR_RANGE {
                        return Err(f.malformed(format!(
                            "a quantised basis (precision 3) is a 1.{VERSION_MINOR_RANGE} feature, \
                             in a 1.{} file",
                            h.minor
                        )));
                    }
                    super::basis_payload::read_quantised(
                        &mut f,
                        h.spectral.terms,
                        h.wavelengths.len(),
                    )?
                } else {
                    let precision = Precision::from_code(code).ok_or_else(|| {
                        f.unsupported(format!("unknown basis precision code {code}"))
                    })?;
                    let count = h.spectral.terms * h.wavelengths.len();
                    let need = 4 + (count * precision.bytes()) as u64;
                    if need != len as u64 {
                        return Err(malformed(
                            pos,
                            Some(kind),
                            format!(
                                "{} terms × {} wavelengths in {} need {need} bytes, the chunk has {len}",
                                h.spectral.terms,
                                h.wavelengths.len(),
                                precision.name()
                            ),
                        ));
                    }
                    let mut values = Vec::with_capacity(count);
                    for _ in 0..count {
                        values.push(f.stored(precision, 1.0, "basis_value")? as f64);
                    }
                    (
                        values,
                        crate::model::basis_storage::BasisStorage::Float(precision),
                    )
                };
                table = Some(crate::model::spectral::BasisTable {
                    nodes: h.wavelengths.iter().map(|&w| w as f64).collect(),
                    values,
                    storage,
                });
            }
            (&CHUNK_FACT, Some(h)) => {
                if factor.is_some()
                    || !records.is_empty()
                    || (h.spectral.basis == SpectralBasis::Tabulated && table.is_none())
                {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "FACT must appear once, after SBAS and before the records".into(),
                    ));
                }
                factor = Some(read_factor(&mut f, h.wavelengths.len())?);
            }
            (&CHUNK_WARP, Some(h)) => {
                if warped.is_some()
                    || !records.is_empty()
                    || (h.spectral.basis == SpectralBasis::Tabulated && table.is_none())
                {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "WARP must appear once, after SBAS and before the records".into(),
                    ));
                }
                warped = Some(Box::new(super::warp_chunk::read_warped(
                    &mut f,
                    h.incidences.len(),
                    h.spectral.terms,
                    h.minor,
                    limits,
                )?));
            }
            (&CHUNK_XVAL, Some(h)) => {
                if seen_xval {
                    return Err(malformed(pos, Some(kind), "a second xval chunk".into()));
                }
                seen_xval = true;
                held_out = read_xval(&mut f, h.incidences.len())?;
            }
            (&CHUNK_RECD, Some(h)) => {
                if h.spectral.basis == SpectralBasis::Tabulated && table.is_none() {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "a tabulated basis needs its SBAS chunk before the records".into(),
                    ));
                }
                if seen_recs {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "a RECD chunk in a file whose records are in RECS".into(),
                    ));
                }
                if records.len() == h.incidences.len() {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        format!(
                            "more than the {} records HEAD announces",
                            h.incidences.len()
                        ),
                    ));
                }
                records.push(read_record(&mut f, h, records.len())?);
            }
            (&CHUNK_RECS, Some(h)) => {
                if h.spectral.basis == SpectralBasis::Tabulated && table.is_none() {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "a tabulated basis needs its SBAS chunk before the records".into(),
                    ));
                }
                if seen_recs || !records.is_empty() {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        "a file holds its records in one RECS chunk or in RECD chunks, once".into(),
                    ));
                }
                seen_recs = true;
                records = read_compact_records(&mut f, h)?;
            }
            (&CHUNK_META, Some(_)) => {
                if metadata.is_some() {
                    return Err(malformed(pos, Some(kind), "a second meta chunk".into()));
                }
                let text = std::str::from_utf8(data).map_err(|e| {
                    malformed(
                        pos + 8 + e.valid_up_to(),
                        Some(kind),
                        "metadata is not UTF-8".into(),
                    )
                })?;
                metadata = Some(text.to_string());
            }
            (&CHUNK_SAMP, Some(h)) => {
                if seen_samp {
                    return Err(malformed(pos, Some(kind), "a second samp chunk".into()));
                }
                samples = Some(read_samp(&mut f, h.incidences.len())?);
                seen_samp = true;
            }
            (&CHUNK_ENDF, Some(h)) => {
                if len != 0 {
                    return Err(malformed(pos, Some(kind), "ENDF must be empty".into()));
                }
                if warped.is_some() {
                    // §3.10: the records of a file with warped tables are implied, empty.
                    records = h
                        .incidences
                        .iter()
                        .map(|&[t, p]| IncidentRecord::empty(t, p))
                        .collect();
                }
                if records.len() != h.incidences.len() {
                    return Err(malformed(
                        pos,
                        Some(kind),
                        format!(
                            "{} records present, HEAD announces {}",
                            records.len(),
                            h.incidences.len()
                        ),
                    ));
                }
                if next != bytes.len() {
                    return Err(malformed(
                        next,
                        None,
                        format!("{} bytes after the ENDF chunk", bytes.len() - next),
                    ));
                }
                break;
            }
            (_, Some(_)) => {
                if kind[0].is_ascii_uppercase() {
                    return Err(Error::Unsupported {
                        at: location(pos, Some(kind)),
                        message: format!(
                            "unknown critical chunk '{}': the file needs a newer sbrdf",
                            String::from_utf8_lossy(&kind)
                        ),
                    });
                }
                // Unknown ancillary chunk: skipped by design.
            }
        }
        pos = next;
    }
    let h = head.expect("loop exits only after HEAD");
    let m = Material {
        version_minor: h.minor,
        spectral: SpectralSpace {
            table,
            ..h.spectral
        },
        sh_level: h.sh_level,
        isotropic: h.isotropic,
        wavelengths: h.wavelengths,
        records,
        metadata,
        sample_positions: samples.flatten(),
        factor,
        held_out,
        warped,
    };
    m.validate()
        .map_err(|message| malformed(SIGNATURE.len(), None, message))?;
    Ok(m)
}
