//! Reading records: a `RECD` chunk (one record, `spec/FORMAT.md` §3.3) or a `RECS` chunk (all
//! of them, compact, §3.9); both end in the same values, read by one function.

use super::consts::*;
use super::fields::{Fields, Head};
use crate::error::Result;
use crate::model::material::*;
use crate::model::sh::sh_count;
use crate::model::Precision;

/// What every record states before its values, whichever chunk holds it (`RECD` §3.3, `RECS`
/// §3.9).
struct RecordHeader {
    theta_p: f32,
    phi_p: f32,
    rel_error: f32,
    critical_angle: f32,
    lobe_count: usize,
    precision: Precision,
    sh_level: usize,
    terms: usize,
    scale: f32,
}

/// A `RECD` chunk: the index and incidence it repeats, then the header and values.
pub(super) fn read_record(
    f: &mut Fields,
    h: &Head,
    expected_index: usize,
) -> Result<IncidentRecord> {
    let index = f.u32("index")? as usize;
    if index != expected_index {
        return Err(f.malformed(format!(
            "record index {index} where record {expected_index} was expected"
        )));
    }
    let theta_i = f.f32("theta_i")?;
    let phi_i = f.f32("phi_i")?;
    let [ht, hp] = h.incidences[index];
    if theta_i.to_bits() != ht.to_bits() || phi_i.to_bits() != hp.to_bits() {
        return Err(f.malformed(format!(
            "record {index} is for incidence ({theta_i}, {phi_i}) but HEAD lists ({ht}, {hp})"
        )));
    }
    let theta_p = f.f32("theta_p")?;
    let phi_p = f.f32("phi_p")?;
    let rel_error = f.f32("rel_error")?;
    let critical_angle = f.f32("critical_angle")?;
    let scale = f.f32("scale")?;
    let lobe_count = read_lobe_count(f)?;
    let precision = read_precision(f)?;
    let sh_level = read_sh_level(f, h)?;
    f.zero(1, "reserved")?;
    let terms = read_terms(f, h)?;
    f.zero(2, "reserved")?;
    check_scale(f, precision, scale)?;
    let header = RecordHeader {
        theta_p,
        phi_p,
        rel_error,
        critical_angle,
        lobe_count,
        precision,
        sh_level,
        terms,
        scale,
    };
    let r = read_record_values(f, header, theta_i, phi_i)?;
    f.finish()?;
    Ok(r)
}

/// A `RECS` chunk (version 1.3): the N records of `HEAD` back to back, each without index and
/// incidence (record i is for incidence i), without reserved bytes, its scale only when f16.
pub(super) fn read_compact_records(f: &mut Fields, h: &Head) -> Result<Vec<IncidentRecord>> {
    // Each record is at least RECS_FIXED bytes, so the count is checked before allocating.
    let n = h.incidences.len();
    if n as u64 * RECS_FIXED as u64 > f.remaining() as u64 {
        return Err(f.malformed(format!(
            "{n} compact records need at least {} bytes, the chunk has {}",
            n as u64 * RECS_FIXED as u64,
            f.remaining()
        )));
    }
    let mut records = Vec::with_capacity(n);
    for &[theta_i, phi_i] in &h.incidences {
        let theta_p = f.f32("theta_p")?;
        let phi_p = f.f32("phi_p")?;
        let rel_error = f.f32("rel_error")?;
        let critical_angle = f.f32("critical_angle")?;
        let lobe_count = read_lobe_count(f)?;
        let precision = read_precision(f)?;
        let sh_level = read_sh_level(f, h)?;
        let terms = read_terms(f, h)?;
        let scale = match precision {
            Precision::F32 => 1.0,
            Precision::F16 => f.f32("scale")?,
        };
        check_scale(f, precision, scale)?;
        let header = RecordHeader {
            theta_p,
            phi_p,
            rel_error,
            critical_angle,
            lobe_count,
            precision,
            sh_level,
            terms,
            scale,
        };
        records.push(read_record_values(f, header, theta_i, phi_i)?);
    }
    f.finish()?;
    Ok(records)
}

fn read_lobe_count(f: &mut Fields) -> Result<usize> {
    let lobe_count = f.u8("lobe_count")? as usize;
    if lobe_count > MAX_LOBES {
        return Err(f.malformed(format!("{lobe_count} lobes exceed {MAX_LOBES}")));
    }
    Ok(lobe_count)
}

fn read_precision(f: &mut Fields) -> Result<Precision> {
    let code = f.u8("precision")?;
    Precision::from_code(code)
        .ok_or_else(|| f.unsupported(format!("unknown storage precision code {code}")))
}

fn read_sh_level(f: &mut Fields, h: &Head) -> Result<usize> {
    let sh_level = f.u8("sh_level")? as usize;
    if sh_level > h.sh_level {
        return Err(f.malformed(format!(
            "record SH level {sh_level} above the file's {}",
            h.sh_level
        )));
    }
    Ok(sh_level)
}

fn read_terms(f: &mut Fields, h: &Head) -> Result<usize> {
    let k = f.u16("terms")? as usize;
    if k == 0 || k > h.spectral.terms {
        return Err(f.malformed(format!(
            "record uses {k} terms, the file allows 1 to {}",
            h.spectral.terms
        )));
    }
    Ok(k)
}

/// §5: exactly 1 for f32 records, a positive power of two for f16 ones.
fn check_scale(f: &Fields, precision: Precision, scale: f32) -> Result<()> {
    let scale_ok = match precision {
        Precision::F32 => scale == 1.0,
        // A positive normal or subnormal power of two: one bit set in the significand field,
        // or a zero significand with a non-zero exponent.
        Precision::F16 => {
            let b = scale.to_bits();
            let (exp, man) = ((b >> 23) & 0xff, b & 0x7f_ffff);
            b >> 31 == 0
                && exp != 0xff
                && ((exp != 0 && man == 0) || (exp == 0 && man.is_power_of_two()))
        }
    };
    if !scale_ok {
        return Err(f.malformed(format!(
            "record scale {scale} is not 1 (f32 records) or a positive power of two (f16)"
        )));
    }
    Ok(())
}

/// A record's SH coefficients and lobes, after its header; each count is checked against the
/// bytes left before anything is allocated for it.
fn read_record_values(
    f: &mut Fields,
    header: RecordHeader,
    theta_i: f32,
    phi_i: f32,
) -> Result<IncidentRecord> {
    let RecordHeader {
        theta_p,
        phi_p,
        rel_error,
        critical_angle,
        lobe_count,
        precision,
        sh_level,
        terms: k,
        scale,
    } = header;
    let p = sh_count(sh_level);
    let s = precision.bytes();
    // Check the fixed-size part against the bytes present before allocating for it.
    if k * p * s > f.remaining() {
        return Err(f.malformed(format!(
            "{k} terms × {p} SH coefficients need {} bytes, the record has {}",
            k * p * s,
            f.remaining()
        )));
    }
    let mut sh = Vec::with_capacity(k * p);
    for _ in 0..k * p {
        sh.push(f.stored(precision, scale, "sh")?);
    }
    let mut lobes = Vec::with_capacity(lobe_count);
    for _ in 0..lobe_count {
        let code = f.u8("lobe_kind")?;
        f.zero(1, "reserved")?;
        let len = f.u16("lobe_length")? as usize;
        if len > f.remaining() {
            return Err(f.malformed(format!(
                "lobe claims {len} bytes, the record has {} left",
                f.remaining()
            )));
        }
        let kind = LobeKind::from_code(code)
            .ok_or_else(|| f.unsupported(format!("unknown lobe kind {code}")))?;
        let (na, np) = (kind.amplitude_count(k), kind.param_count(k));
        let need = na * s + 4 * np;
        if len != need {
            return Err(f.malformed(format!(
                "a {} lobe of {k} terms is {need} bytes, not {len}",
                kind.name()
            )));
        }
        let mut amplitude = Vec::with_capacity(na);
        for _ in 0..na {
            amplitude.push(f.stored(precision, scale, "amplitude")?);
        }
        let mut params = Vec::with_capacity(np);
        for _ in 0..np {
            params.push(f.f32("lobe_parameter")?);
        }
        lobes.push(Lobe {
            kind,
            amplitude,
            params,
        });
    }
    Ok(IncidentRecord {
        terms: k,
        sh_level,
        precision,
        theta_i,
        phi_i,
        theta_p,
        phi_p,
        rel_error,
        critical_angle,
        sh,
        lobes,
    })
}
