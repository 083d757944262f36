//! The bytes of a `WARP` chunk (`spec/FORMAT.md` §3.10): read with every count checked before
//! anything is allocated and the inflated payload bounded, and written.

use super::fields::Fields;
use crate::error::Result;
use crate::model::warped::{PayloadCoding, TableTransform, WarpedModel};
use crate::model::warped::{MAX_GRID, MAX_NDF, MAX_WARP_GRID};
use crate::model::warped::{MAX_LEVEL, MAX_WARP_VALUES, MIN_WARP_GRID};
use crate::model::Precision;
use miniz_oxide::inflate::core::{decompress, inflate_flags, DecompressorOxide};
use miniz_oxide::inflate::TINFLStatus;

/// The arrangement (the low three bits of `layout`) of isotropic tables, each standing alone.
pub(crate) const LAYOUT_ISOTROPIC: u8 = 1;
/// The arrangement (format 1.7) of isotropic tables with a prediction flag per incidence: a
/// flagged incidence's coefficients are the difference to the previous incidence's.
pub(crate) const LAYOUT_ISOTROPIC_PREDICTED: u8 = 2;
/// `layout` bit 3 (format 1.6): the payload is range-coded (`super::warp_levels`), not zlib.
pub(crate) const LAYOUT_RANGE_CODED: u8 = 8;

/// DEFLATE never expands more than 1032:1; with the zlib header and trailer a payload of P bytes
/// cannot inflate past this, which bounds the output buffer by the bytes present.
fn inflate_bound(p: usize) -> usize {
    p.saturating_mul(1032).saturating_add(64)
}

/// Reads a `WARP` chunk for a file of `n` incidences and `k` terms.
pub(super) fn read_warped(
    f: &mut Fields,
    n: usize,
    k: usize,
    minor: u16,
    limits: &super::Limits,
) -> Result<WarpedModel> {
    let layout = f.u8("layout")?;
    let arrangement = layout & 0x07;
    if arrangement != LAYOUT_ISOTROPIC && arrangement != LAYOUT_ISOTROPIC_PREDICTED {
        return Err(f.unsupported(format!(
            "unknown warped-table arrangement {arrangement} (layout {layout:#04x})"
        )));
    }
    let coding = if layout & LAYOUT_RANGE_CODED != 0 {
        PayloadCoding::Range
    } else {
        PayloadCoding::Deflate
    };
    if coding == PayloadCoding::Range && minor < super::VERSION_MINOR_RANGE {
        return Err(f.malformed(format!(
            "a range-coded payload (layout {layout:#04x}) is a 1.{} feature, in a 1.{minor} file",
            super::VERSION_MINOR_RANGE
        )));
    }
    let predicted = arrangement == LAYOUT_ISOTROPIC_PREDICTED;
    if predicted && minor < super::VERSION_MINOR_PREDICTED {
        return Err(f.malformed(format!(
            "prediction flags (layout {layout:#04x}) are a 1.{} feature, in a 1.{minor} file",
            super::VERSION_MINOR_PREDICTED
        )));
    }
    if predicted && coding != PayloadCoding::Range {
        return Err(f.malformed(format!(
            "prediction flags (layout {layout:#04x}) need a range-coded payload (bit 3)"
        )));
    }
    let transform = TableTransform::from_code(layout >> 4).ok_or_else(|| {
        f.unsupported(format!(
            "unknown warped-table transform {} (layout {layout:#04x})",
            layout >> 4
        ))
    })?;
    if transform == TableTransform::Wavelet53 && minor < super::VERSION_MINOR_WAVELET {
        return Err(f.malformed(format!(
            "the wavelet transform (layout {layout:#04x}) is a 1.{} feature, in a 1.{minor} file",
            super::VERSION_MINOR_WAVELET
        )));
    }
    let code = f.u8("ndf_precision")?;
    let ndf_precision = Precision::from_code(code)
        .ok_or_else(|| f.unsupported(format!("unknown NDF precision code {code}")))?;
    let r = f.u16("grid")? as usize;
    let g = f.u16("warp_grid")? as usize;
    let m = f.u16("ndf_count")? as usize;
    if !(2..=MAX_GRID).contains(&r)
        || !(MIN_WARP_GRID..=MAX_WARP_GRID).contains(&g)
        || !(2..=MAX_NDF).contains(&m)
    {
        return Err(f.malformed(format!(
            "warped tables of side {r}, VNDF grid {g}, {m} NDF nodes (2 to {MAX_GRID}, \
             {MIN_WARP_GRID} to {MAX_WARP_GRID}, 2 to {MAX_NDF})"
        )));
    }
    let values = (n as u64) * (k as u64) * (r * r) as u64;
    if values > MAX_WARP_VALUES || (n as u64) * (g * g) as u64 > MAX_WARP_VALUES {
        return Err(f.malformed(format!(
            "{n} incidences × {k} terms of {r}² values, or × {g}² VNDF nodes, exceed \
             {MAX_WARP_VALUES}"
        )));
    }
    let work = (m as u64 + n as u64) * (g * g) as u64 + 2 * values * r as u64;
    if work > limits.max_warp_work {
        return Err(crate::error::Error::LimitsExceeded(format!(
            "warped tables that cost {work} operations to open ((M + N)·G² + 2·N·K·R³ with \
             M = {m}, N = {n}, G = {g}, K = {k}, R = {r}), above the limit of {}",
            limits.max_warp_work
        )));
    }
    let sigma_scale = f.f32("sigma_scale")?;
    // Format 1.6 codes the NDF and steps in the payload too; before it they are stored raw.
    let raw = match coding {
        PayloadCoding::Deflate => ndf_precision.bytes() * m + 4 * n * k,
        PayloadCoding::Range => 0,
    };
    if f.remaining() < raw + 4 {
        return Err(f.malformed(format!(
            "the NDF, steps and payload length need {} bytes, the chunk has {} left",
            raw + 4,
            f.remaining()
        )));
    }
    let (mut ndf, mut steps, mut flags_read) = (Vec::new(), Vec::new(), Vec::new());
    if coding == PayloadCoding::Deflate {
        ndf = (0..m)
            .map(|_| f.stored(ndf_precision, 1.0, "ndf"))
            .collect::<Result<Vec<_>>>()?;
        steps = (0..n * k)
            .map(|_| f.f32("step"))
            .collect::<Result<Vec<_>>>()?;
    }
    let p = f.u32("payload_length")? as usize;
    if p == 0 || p != f.remaining() {
        return Err(f.malformed(format!(
            "payload_length {p}, but {} bytes follow it in the chunk",
            f.remaining()
        )));
    }
    let at = f.at();
    let payload = f.take(p, "payload")?;
    let format_error = |message| crate::error::Error::Format {
        at: at.clone(),
        message,
    };
    let levels = match coding {
        PayloadCoding::Deflate => {
            let bound = (5 * values as usize).min(inflate_bound(p));
            inflate(payload, bound)
                .and_then(|b| varints(&b, values as usize, r, transform))
                .map_err(format_error)?
        }
        PayloadCoding::Range => {
            // Each coded bit costs at least −log2(4081/4096) = 1/189 of a bit, so P bytes hold
            // at most 1512·P decisions: more integers than 1600·P cannot be there, which bounds
            // what is allocated by the bytes present.
            let flags = if predicted { n as u64 - 1 } else { 0 };
            let integers = m as u64 + (n * k) as u64 + flags + values;
            if integers > 1600 * p as u64 {
                return Err(format_error(format!(
                    "a range-coded payload of {p} bytes cannot hold {integers} integers \
                     (at most 1600 a byte)"
                )));
            }
            let decoded = super::warp_payload::decode_payload(
                payload,
                m,
                ndf_precision,
                n * k,
                predicted.then_some(n),
                k,
                r,
                transform,
            )
            .map_err(format_error)?;
            (ndf, steps, flags_read) = (decoded.ndf, decoded.steps, decoded.predicted);
            decoded.levels
        }
    };
    f.finish()?;
    Ok(WarpedModel {
        transform,
        coding,
        grid: r,
        warp_grid: g,
        sigma_scale,
        ndf_precision,
        ndf,
        steps,
        levels,
        predicted: flags_read,
    })
}

/// Inflates a zlib stream into at most `bound` bytes; the stream must end exactly at the end of
/// `payload`, its Adler-32 checked.
fn inflate(payload: &[u8], bound: usize) -> std::result::Result<Vec<u8>, String> {
    // One byte more than allowed tells "too long" from "exactly at the bound".
    let mut out = vec![0u8; bound + 1];
    let mut state = DecompressorOxide::new();
    let flags = inflate_flags::TINFL_FLAG_PARSE_ZLIB_HEADER
        | inflate_flags::TINFL_FLAG_USING_NON_WRAPPING_OUTPUT_BUF
        | inflate_flags::TINFL_FLAG_COMPUTE_ADLER32;
    let (status, consumed, written) = decompress(&mut state, payload, &mut out, 0, flags);
    match status {
        TINFLStatus::Done => {}
        TINFLStatus::HasMoreOutput => {
            return Err(format!(
                "the payload inflates to more than the {bound} bytes its tables can need"
            ))
        }
        TINFLStatus::NeedsMoreInput | TINFLStatus::FailedCannotMakeProgress => {
            return Err("the payload's zlib stream ends early (truncated?)".into())
        }
        TINFLStatus::Adler32Mismatch => {
            return Err("the payload's zlib stream fails its Adler-32 check".into())
        }
        other => {
            return Err(format!(
                "the payload is not a valid zlib stream ({other:?})"
            ))
        }
    }
    if consumed != payload.len() {
        return Err(format!(
            "{} bytes after the payload's zlib stream",
            payload.len() - consumed
        ));
    }
    if written > bound {
        return Err(format!(
            "the payload inflates to more than the {bound} bytes its tables can need"
        ));
    }
    out.truncate(written);
    Ok(out)
}

/// Exactly `count` zigzag LEB128 integers, tables of `r`² in the transform's order, returned
/// in row-major coefficient order.
fn varints(
    bytes: &[u8],
    count: usize,
    r: usize,
    transform: TableTransform,
) -> std::result::Result<Vec<i32>, String> {
    let order = transform.order(r);
    let rr = r * r;
    let mut out = vec![0i32; count];
    let mut pos = 0usize;
    for i in 0..count {
        let mut u: u64 = 0;
        let mut shift = 0;
        loop {
            let Some(&b) = bytes.get(pos) else {
                return Err(format!(
                    "the payload inflates to {} integers, the tables need {count}",
                    i
                ));
            };
            pos += 1;
            if shift == 35 {
                return Err(format!("a varint longer than 5 bytes (integer {i})"));
            }
            u |= ((b & 0x7F) as u64) << shift;
            shift += 7;
            if b & 0x80 == 0 {
                break;
            }
        }
        let z = if u & 1 == 0 {
            (u >> 1) as i64
        } else {
            -((u >> 1) as i64) - 1
        };
        if !(-MAX_LEVEL..MAX_LEVEL).contains(&z) {
            return Err(format!("integer {i} is {z}, outside [−2³⁰, 2³⁰ − 1]"));
        }
        out[(i / rr) * rr + order[i % rr]] = z as i32;
    }
    if pos != bytes.len() {
        return Err(format!(
            "{} bytes left in the inflated payload after its {count} integers",
            bytes.len() - pos
        ));
    }
    Ok(out)
}

/// The data of a `WARP` chunk of a material of `k` spectral terms.
pub(super) fn warp_chunk(w: &WarpedModel, k: usize) -> Vec<u8> {
    let mut d = Vec::new();
    let coded = match w.coding {
        PayloadCoding::Deflate => 0,
        PayloadCoding::Range => LAYOUT_RANGE_CODED,
    };
    let arrangement = if w.predicted.is_empty() {
        LAYOUT_ISOTROPIC
    } else {
        LAYOUT_ISOTROPIC_PREDICTED
    };
    d.push(arrangement | coded | w.transform.code() << 4);
    d.push(w.ndf_precision.code());
    d.extend_from_slice(&(w.grid as u16).to_le_bytes());
    d.extend_from_slice(&(w.warp_grid as u16).to_le_bytes());
    d.extend_from_slice(&(w.ndf.len() as u16).to_le_bytes());
    d.extend_from_slice(&w.sigma_scale.to_le_bytes());
    if w.coding == PayloadCoding::Deflate {
        for v in &w.ndf {
            match w.ndf_precision {
                Precision::F32 => d.extend_from_slice(&v.to_le_bytes()),
                Precision::F16 => d.extend_from_slice(&half::f16::from_f32(*v).to_le_bytes()),
            }
        }
        for v in &w.steps {
            d.extend_from_slice(&v.to_le_bytes());
        }
    }
    let payload = payload(w, k);
    d.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    d.extend_from_slice(&payload);
    d
}

/// The bytes of a `WARP` chunk's payload for these tables of `k` spectral terms, as the writer
/// writes it in the model's coding (the encoder compares transforms by it).
pub fn warp_payload_len(w: &WarpedModel, k: usize) -> usize {
    payload(w, k).len()
}

/// The payload as the model's coding writes it, for tables of `k` spectral terms.
pub(crate) fn payload(w: &WarpedModel, k: usize) -> Vec<u8> {
    match w.coding {
        PayloadCoding::Deflate => miniz_oxide::deflate::compress_to_vec_zlib(&payload_bytes(w), 10),
        PayloadCoding::Range => super::warp_payload::encode_payload(
            &super::warp_payload::Payload {
                ndf: w.ndf.clone(),
                steps: w.steps.clone(),
                predicted: w.predicted.clone(),
                levels: w.levels.clone(),
            },
            w.ndf_precision,
            k,
            w.grid,
            w.transform,
        ),
    }
}

/// The inflated payload: every table's integers in the transform's order, zigzag LEB128.
pub(crate) fn payload_bytes(w: &WarpedModel) -> Vec<u8> {
    let rr = w.grid * w.grid;
    let order = w.transform.order(w.grid);
    let mut out = Vec::with_capacity(w.levels.len() * 2);
    for t in 0..w.tables() {
        for &o in &order {
            let z = w.levels[t * rr + o] as i64;
            let mut u = if z >= 0 {
                (z as u64) << 1
            } else {
                ((-z - 1) as u64) << 1 | 1
            };
            while u >= 0x80 {
                out.push((u as u8 & 0x7F) | 0x80);
                u >>= 7;
            }
            out.push(u as u8);
        }
    }
    out
}
