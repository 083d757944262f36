//! Damaged and hostile files: every truncation and every single-bit flip of every golden file
//! (the MANIFEST's) is refused with a message; chunk rules for extension and versions hold.

mod common;
// What the decode fuzz targets ask of every file that opens, shared with them.
#[path = "../fuzz/fuzz_targets/decode_checks.rs"]
mod decode_checks;
use sbrdf::{read_material, Error, Limits};

fn golden(name: &str) -> Vec<u8> {
    std::fs::read(common::samples_dir().join("golden").join(name)).unwrap()
}

#[test]
fn every_truncation_is_refused() {
    for f in &common::golden_files() {
        let bytes = golden(f);
        assert!(read_material(&bytes, &Limits::default()).is_ok());
        for len in 0..bytes.len() {
            let e = read_material(&bytes[..len], &Limits::default())
                .expect_err(&format!("{f} truncated to {len} bytes was accepted"));
            assert!(!e.to_string().is_empty());
        }
    }
}

#[test]
fn every_single_bit_flip_is_refused() {
    for f in &common::golden_files() {
        let bytes = golden(f);
        let mut copy = bytes.clone();
        for i in 0..bytes.len() {
            for bit in 0..8 {
                copy[i] ^= 1 << bit;
                let r = read_material(&copy, &Limits::default());
                assert!(
                    r.is_err(),
                    "{f}: flipping bit {bit} of byte {i} went unnoticed"
                );
                copy[i] ^= 1 << bit;
            }
        }
    }
}

/// Splits a file into (type, data) chunks after the signature.
fn chunks(bytes: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
    let mut v = Vec::new();
    let mut pos = 10;
    while pos < bytes.len() {
        let len = u32::from_le_bytes(bytes[pos..pos + 4].try_into().unwrap()) as usize;
        let kind: [u8; 4] = bytes[pos + 4..pos + 8].try_into().unwrap();
        v.push((kind, bytes[pos + 8..pos + 8 + len].to_vec()));
        pos += 12 + len;
    }
    v
}

fn assemble(chunks: &[([u8; 4], Vec<u8>)]) -> Vec<u8> {
    let mut out = sbrdf::format::SIGNATURE.to_vec();
    for (kind, data) in chunks {
        out.extend_from_slice(&(data.len() as u32).to_le_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        let mut h = crc32fast::Hasher::new();
        h.update(kind);
        h.update(data);
        out.extend_from_slice(&h.finalize().to_le_bytes());
    }
    out
}

#[test]
fn unknown_ancillary_chunks_are_skipped_and_critical_ones_refused() {
    let bytes = golden("phong_3inc_paper.sbrdf");
    let original = read_material(&bytes, &Limits::default()).unwrap();
    let mut c = chunks(&bytes);
    assert_eq!(
        assemble(&c),
        bytes,
        "test helper must rebuild the file exactly"
    );
    c.insert(2, (*b"zzzz", b"future ancillary data".to_vec()));
    let m = read_material(&assemble(&c), &Limits::default()).unwrap();
    assert_eq!(m, original);
    c[2].0 = *b"Zzzz";
    match read_material(&assemble(&c), &Limits::default()) {
        Err(Error::Unsupported { message, .. }) => {
            assert!(
                message.contains("unknown critical chunk 'Zzzz'"),
                "{message}"
            )
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

#[test]
fn versions() {
    let bytes = golden("tiny.sbrdf");
    let mut c = chunks(&bytes);
    // A newer minor version is read (it may only add ancillary chunks and new enum values).
    c[0].1[2..4].copy_from_slice(&7u16.to_le_bytes());
    let m = read_material(&assemble(&c), &Limits::default()).unwrap();
    assert_eq!(m.version_minor, 7);
    // A newer major version is refused, saying so.
    c[0].1[0..2].copy_from_slice(&2u16.to_le_bytes());
    match read_material(&assemble(&c), &Limits::default()) {
        Err(Error::Unsupported { message, .. }) => {
            assert!(message.contains("format version 2.7"), "{message}");
            assert!(message.contains("upgrade"), "{message}");
        }
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

#[test]
fn hostile_counts_and_structure_are_refused_without_allocating() {
    let bytes = golden("tiny.sbrdf");
    let c = chunks(&bytes);
    // HEAD claiming 2³² − 1 wavelengths: refused by the byte count, not by running out of memory.
    let mut h = c.clone();
    h[0].1[32..36].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = read_material(&assemble(&h), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("need"), "{e}");
    // A samp chunk claiming a huge list.
    let samp = c.iter().position(|x| &x.0 == b"samp").unwrap();
    let mut s = c.clone();
    s[samp].1 = [
        1u32.to_le_bytes().to_vec(),
        vec![1],
        u32::MAX.to_le_bytes().to_vec(),
    ]
    .concat();
    assert!(read_material(&assemble(&s), &Limits::default()).is_err());
    // Records out of order, missing, duplicated; chunks after ENDF; HEAD not first.
    let mut r = c.clone();
    let recd = r.iter().position(|x| &x.0 == b"RECD").unwrap();
    r.remove(recd);
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("0 records present"), "{e}");
    let mut r = c.clone();
    r.insert(recd, r[recd].clone());
    assert!(read_material(&assemble(&r), &Limits::default()).is_err());
    let mut tail = bytes.clone();
    tail.extend_from_slice(b"garbage");
    let e = read_material(&tail, &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("after the ENDF"), "{e}");
    let mut r = c.clone();
    r.swap(0, 1);
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("first chunk must be HEAD"), "{e}");
    // A file over the size limit is refused before parsing.
    let e = read_material(
        &bytes,
        &Limits {
            max_file_bytes: 100,
            ..Limits::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, Error::LimitsExceeded(_)));
    // Non-finite and out-of-range values in a record.
    let mut r = c.clone();
    r[recd].1[40..44].copy_from_slice(&f32::NAN.to_le_bytes());
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("not finite"), "{e}");
    let mut r = c.clone();
    let last_param = r[recd].1.len() - 4;
    r[recd].1[last_param..].copy_from_slice(&0f32.to_le_bytes());
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("lobe width"), "{e}");
}

#[test]
fn text_mode_damage_is_named() {
    let mut bytes = golden("tiny.sbrdf");
    // A CRLF → LF translation removes the 0x0D of the signature.
    bytes.remove(6);
    let e = read_material(&bytes, &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("text-mode"), "{e}");
}

#[test]
fn record_level_rules() {
    let bytes = golden("tiny.sbrdf");
    let c = chunks(&bytes);
    let recd = c.iter().position(|x| &x.0 == b"RECD").unwrap();
    // An f32 record must have scale 1.
    let mut r = c.clone();
    r[recd].1[28..32].copy_from_slice(&3.0f32.to_le_bytes());
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("scale"), "{e}");
    // A record may not use more terms or a higher SH level than HEAD allows.
    let mut r = c.clone();
    r[recd].1[36..38].copy_from_slice(&4u16.to_le_bytes());
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("terms"), "{e}");
    let mut r = c.clone();
    r[recd].1[34] = 2;
    let e = read_material(&assemble(&r), &Limits::default()).unwrap_err();
    assert!(e.to_string().contains("SH level"), "{e}");
    // An unknown lobe kind is unsupported (a newer file), not malformed.
    let lobe = 40 + 3 * 4 * 4;
    let mut r = c.clone();
    r[recd].1[lobe] = 99;
    match read_material(&assemble(&r), &Limits::default()) {
        Err(Error::Unsupported { message, .. }) => assert!(message.contains("lobe kind 99")),
        other => panic!("expected Unsupported, got {other:?}"),
    }
    // An unknown direction-set kind in the ancillary samp chunk: the chunk is skipped.
    let samp = c.iter().position(|x| &x.0 == b"samp").unwrap();
    let mut r = c.clone();
    r[samp].1[4] = 7;
    let m = read_material(&assemble(&r), &Limits::default()).unwrap();
    assert!(m.sample_positions.is_none());
    // -0 is not an angle a writer produces: refused, so one material has one byte form.
    let mut r = c.clone();
    r[recd].1[8..12].copy_from_slice(&(-0.0f32).to_le_bytes());
    r[0].1[40 + 4 * 4 + 4..40 + 4 * 4 + 8].copy_from_slice(&(-0.0f32).to_le_bytes());
    assert!(read_material(&assemble(&r), &Limits::default()).is_err());
}

/// Version 1.1's wavelength range (`HEAD` flag bit 1): the wavelengths the 1.0 file of the same
/// material lists; a file without the range stays 1.0; hostile ranges are refused without
/// allocating for W; unknown flags are unsupported before HEAD's length is looked at.
#[test]
fn wavelength_ranges() {
    let v11 = golden("ggx_3inc_range_v11.sbrdf");
    let v10 = golden("ggx_3inc_default.sbrdf");
    let a = read_material(&v11, &Limits::default()).unwrap();
    let b = read_material(&v10, &Limits::default()).unwrap();
    assert_eq!((a.version_minor, b.version_minor), (1, 0));
    assert_eq!(
        a.wavelengths, b.wavelengths,
        "the range gives the listed wavelengths"
    );
    assert_eq!(chunks(&v11)[0].1.len(), 40 + 8 + 8 * 3);
    // The writer uses the range only where the material allows 1.1: version 0 writes 1.0.
    let mut as10 = a.clone();
    as10.version_minor = 0;
    let bytes10 = sbrdf::write_material(&as10).unwrap();
    assert_eq!(chunks(&bytes10)[0].1.len(), 40 + 4 * 31 + 8 * 3);
    assert_eq!(&chunks(&bytes10)[0].1[2..4], &[0, 0], "written as 1.0");
    // Wavelengths that are not evenly spaced are listed, even in a 1.1 material.
    let mut uneven = a.clone();
    uneven.wavelengths[5] += 0.25;
    if let Some(t) = &mut uneven.spectral.table {
        t.nodes[5] = uneven.wavelengths[5] as f64;
    }
    let bytes = sbrdf::write_material(&uneven).unwrap();
    assert_eq!(chunks(&bytes)[0].1.len(), 40 + 4 * 31 + 8 * 3);
    assert_eq!(&chunks(&bytes)[0].1[2..4], &[0, 0]);

    let head = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut c = chunks(&v11);
        f(&mut c[0].1);
        read_material(&assemble(&c), &Limits::default())
    };
    let malformed = |r: sbrdf::Result<sbrdf::Material>, what: &str| match r {
        Err(Error::Format { .. }) => {}
        other => panic!("{what}: expected malformed, got {other:?}"),
    };
    // W = 1 with the range flag; W beyond the format's limit (no 2^32-value allocation); a
    // range running backwards; equal ends.
    malformed(
        head(&|h| h[32..36].copy_from_slice(&1u32.to_le_bytes())),
        "W = 1",
    );
    malformed(
        head(&|h| h[32..36].copy_from_slice(&u32::MAX.to_le_bytes())),
        "W = 2^32 - 1",
    );
    malformed(
        head(&|h| h[32..36].copy_from_slice(&65_537u32.to_le_bytes())),
        "W = 65 537",
    );
    malformed(
        head(&|h| {
            let (first, last) = (h[40..44].to_vec(), h[44..48].to_vec());
            h[40..44].copy_from_slice(&last);
            h[44..48].copy_from_slice(&first);
        }),
        "decreasing range",
    );
    malformed(
        head(&|h| {
            let first = h[40..44].to_vec();
            h[44..48].copy_from_slice(&first);
        }),
        "empty range",
    );
    // The range flag cleared: HEAD's length no longer matches.
    malformed(head(&|h| h[4] &= !2), "range flag cleared");
    // An unknown flag bit is unsupported, whatever HEAD's length says (bit 2 is 1.7's θi
    // alone, tests/warped.rs).
    for bit in [3u32, 31] {
        match head(&|h| {
            let f = u32::from_le_bytes(h[4..8].try_into().unwrap()) | (1 << bit);
            h[4..8].copy_from_slice(&f.to_le_bytes());
            h.truncate(45);
        }) {
            Err(Error::Unsupported { message, .. }) => {
                assert!(message.contains("flag"), "{message}")
            }
            other => panic!("flag bit {bit}: expected unsupported, got {other:?}"),
        }
    }
}

/// Version 1.3's compact records (`spec/FORMAT.md` §3.9): one `RECS` chunk reads to the records
/// the N `RECD` chunks of the same material hold, 27 bytes fewer per f16 record; the writer uses
/// it exactly when the material allows 1.3; and every structural rule of §2.5 and §3.9 refuses a
/// hostile file without allocating for counts the bytes do not back.
#[test]
fn compact_records() {
    let v13 = golden("ggx_3inc_compact_v13.sbrdf");
    let m = read_material(&v13, &Limits::default()).unwrap();
    assert_eq!(m.version_minor, 3);
    let c = chunks(&v13);
    let kinds: Vec<[u8; 4]> = c.iter().map(|x| x.0).collect();
    assert!(kinds.contains(b"RECS") && !kinds.contains(b"RECD"));
    // The same material as 1.2: N RECD chunks, the same records when read back.
    let mut as12 = m.clone();
    as12.version_minor = 2;
    let v12 = sbrdf::write_material(&as12).unwrap();
    let c12 = chunks(&v12);
    assert_eq!(c12.iter().filter(|x| &x.0 == b"RECD").count(), 3);
    assert!(!c12.iter().any(|x| &x.0 == b"RECS"));
    assert_eq!(
        &c12[0].1[2..4],
        &[1, 0],
        "without RECS, the range makes it 1.1"
    );
    let back = read_material(&v12, &Limits::default()).unwrap();
    assert_eq!(
        back.records, m.records,
        "RECS and RECD hold the same records"
    );
    assert!(m
        .records
        .iter()
        .all(|r| r.precision == sbrdf::Precision::F16));
    assert_eq!(
        v12.len() - v13.len(),
        27 * 3 - 12,
        "27 bytes per f16 record, 12 once"
    );
    // Written back at 1.3, the golden file's bytes come out again.
    assert_eq!(sbrdf::write_material(&m).unwrap(), v13);
    // An f32 record has no scale field: 4 bytes fewer still.
    let mut f32s = m.clone();
    for r in &mut f32s.records {
        r.precision = sbrdf::Precision::F32;
    }
    let b32 = sbrdf::write_material(&f32s).unwrap();
    assert_eq!(read_material(&b32, &Limits::default()).unwrap(), f32s);
    let recs_len = |b: &[u8]| {
        chunks(b)
            .into_iter()
            .find(|x| &x.0 == b"RECS")
            .unwrap()
            .1
            .len()
    };
    let values: usize = m
        .records
        .iter()
        .map(|r| {
            2 * r.sh.len()
                + r.lobes
                    .iter()
                    .map(|l| 4 + 2 * l.amplitude.len() + 4 * l.params.len())
                    .sum::<usize>()
        })
        .sum();
    assert_eq!(recs_len(&v13), 3 * 25 + values);
    let amps: usize = m
        .records
        .iter()
        .map(|r| r.sh.len() + r.lobes.iter().map(|l| l.amplitude.len()).sum::<usize>())
        .sum();
    assert_eq!(recs_len(&b32), 3 * 21 + values + 2 * amps);

    let recs = kinds.iter().position(|k| k == b"RECS").unwrap();
    let refused = |c: &[([u8; 4], Vec<u8>)], what: &str| match read_material(
        &assemble(c),
        &Limits::default(),
    ) {
        Err(Error::Format { message, .. }) => message,
        other => panic!("{what}: expected malformed, got {other:?}"),
    };
    // A RECD beside RECS, after or before it; a second RECS; RECS before SBAS.
    let recd = chunks(&v12).into_iter().find(|x| &x.0 == b"RECD").unwrap();
    let mut x = c.clone();
    x.insert(recs + 1, recd.clone());
    assert!(refused(&x, "RECD after RECS").contains("RECS"));
    let mut x = c.clone();
    x.insert(recs, recd);
    refused(&x, "RECS after RECD");
    let mut x = c.clone();
    x.insert(recs, c[recs].clone());
    refused(&x, "two RECS");
    let sbas = kinds.iter().position(|k| k == b"SBAS").unwrap();
    let mut x = c.clone();
    let moved = x.remove(recs);
    x.insert(sbas, moved);
    assert!(refused(&x, "RECS before SBAS").contains("SBAS"));
    // A byte left over; a record running past the chunk; fewer than 21·N bytes; N records
    // claimed by a HEAD whose incidence count is huge (refused by HEAD's length, not allocated).
    let mut x = c.clone();
    x[recs].1.push(0);
    assert!(refused(&x, "a byte after the last record").contains("unexpected bytes"));
    let mut x = c.clone();
    x[recs].1.pop();
    refused(&x, "the last record cut short");
    let mut x = c.clone();
    x[recs].1.truncate(20);
    assert!(refused(&x, "fewer than 21 N bytes").contains("at least 63 bytes"));
    // The record rules hold in a compact record: a zero scale, a level above HEAD's, 0 terms,
    // −0 as the peak's θ; an unknown precision is unsupported.
    for (offset, bytes, what) in [
        (21usize, 0f32.to_le_bytes().to_vec(), "zero scale"),
        (18, vec![7], "level above HEAD's"),
        (19, vec![0, 0], "zero terms"),
        (0, (-0f32).to_le_bytes().to_vec(), "θp = −0"),
    ] {
        let mut x = c.clone();
        x[recs].1[offset..offset + bytes.len()].copy_from_slice(&bytes);
        refused(&x, what);
    }
    let mut x = c.clone();
    x[recs].1[17] = 9;
    match read_material(&assemble(&x), &Limits::default()) {
        Err(Error::Unsupported { message, .. }) => {
            assert!(message.contains("precision"), "{message}")
        }
        other => panic!("unknown precision: expected unsupported, got {other:?}"),
    }
}

/// Rewrites the CRC of every whole chunk, so that bytes a fuzzer found (its builds skip CRC
/// checks) reach the same code here.
fn with_crcs_fixed(mut b: Vec<u8>) -> Vec<u8> {
    let mut p = 10;
    while p + 12 <= b.len() {
        let len = u32::from_le_bytes(b[p..p + 4].try_into().unwrap()) as usize;
        let Some(end) = (p + 8).checked_add(len).filter(|&e| e + 4 <= b.len()) else {
            break;
        };
        let crc = crc32fast::hash(&b[p + 4..end]);
        b[end..end + 4].copy_from_slice(&crc.to_le_bytes());
        p = end + 4;
    }
    b
}

#[test]
fn every_fuzz_crash_kept_opens_or_is_refused_and_evaluates_without_nan() {
    // fuzz/regressions/<target>/: each input a fuzz target once crashed on (fuzz/README.md).
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut replayed = 0;
    for target in ["decode", "decode_full"] {
        let Ok(dir) = std::fs::read_dir(root.join(target)) else {
            continue;
        };
        for entry in dir {
            let path = entry.unwrap().path();
            let bytes = with_crcs_fixed(std::fs::read(&path).unwrap());
            replayed += 1;
            let Ok(dec) = sbrdf::Decoder::from_bytes(&bytes) else {
                continue;
            };
            // The fuzz targets' own checks: a few evaluations, none NaN.
            eprintln!("replaying {}", path.display());
            decode_checks::evaluate(&dec);
            sbrdf::write_material(dec.material()).expect("what was read can be written");
        }
    }
    assert!(replayed >= 1, "the kept crashes are replayed");
}

#[test]
fn tables_beyond_single_precision_are_refused_at_open() {
    // What the decode_full crash (fuzz/regressions/decode_full/crash-06a2…) reached: a step so
    // large that a table's values pass f32's range made the packed tables' code count 0, and
    // its bit width overflowed. The same here from a golden file with one step raised.
    let good = golden("rgl_satin_warp_v16.sbrdf");
    let mut m = read_material(&good, &Limits::default()).unwrap();
    let w = m.warped.as_mut().unwrap();
    w.steps[0] = 3.0e38;
    let bytes = sbrdf::write_material(&m).unwrap();
    let e = sbrdf::Decoder::from_bytes(&bytes).unwrap_err().to_string();
    assert!(e.contains("beyond single precision"), "{e}");
}
