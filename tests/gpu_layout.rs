//! The flat device layout (`spec/GPU_LAYOUT.md`): its size against the file's for every golden
//! file (the bound is 1.5× for records and factor models; warped tables, which a kernel needs
//! unpacked from the file's entropy coding, 64 KiB at 32 × 32 nodes and 192 KiB at 64 × 64), that
//! it is deterministic and the same whichever residency the decoder has, that every offset in it
//! points inside it, and that damaged files neither panic nor lay out. Agreement of its values
//! with `sbrdf eval` is checked by `tests/python/check_gpu_layout.py` (through the reference
//! decoder).

mod common;
use sbrdf::Decoder;

const MAGIC: u32 = u32::from_le_bytes(*b"SBGL");

fn golden(name: &str) -> Vec<u8> {
    std::fs::read(common::samples_dir().join("golden").join(name)).unwrap()
}

/// Every offset and count in a layout stays inside it: what a kernel reading it relies on.
fn check_bounds(w: &[u32], name: &str) {
    let total = w.len();
    assert_eq!(w[0], MAGIC, "{name}");
    assert_eq!(w[1], 4, "{name}: layout version");
    assert_eq!(w[2] as usize, total, "{name}: total words");
    let (k, wl, n, t, p) = (
        w[5] as usize,
        w[7] as usize,
        w[8] as usize,
        w[9] as usize,
        w[10] as usize,
    );
    let within = |off: u32, len: usize, what: &str| {
        assert!(
            off as usize + len <= total,
            "{name}: {what} at {off} + {len} past {total}"
        );
    };
    within(w[13], wl, "wavelengths");
    if w[4] == 3 {
        within(w[14], k * wl, "basis table");
    } else {
        assert_eq!(
            w[14], 0,
            "{name}: a basis table offset for an analytic basis"
        );
    }
    within(w[15], t, "θi");
    within(w[16], p, "φi");
    within(w[17], 12 * n, "record table");
    for r in 0..n {
        let e = &w[w[17] as usize + 12 * r..][..12];
        let (level, terms, m, enc) = (e[4] as usize, e[5] as usize, e[6] as usize, e[7]);
        assert!(enc == 1 || enc == 2, "{name}: record {r} encoding {enc}");
        let words = |count: usize| if enc == 1 { count } else { count.div_ceil(2) };
        within(e[9], words(terms * (level + 1) * (level + 1)), "SH values");
        within(e[10], 3 * m, "lobe table");
        for li in 0..m {
            let l = &w[e[10] as usize + 3 * li..][..3];
            let (amps, params) = match l[0] {
                1 => (terms, terms),
                2 | 3 => (4 * terms, 3),
                4 => (terms, 1),
                5 => (4 * terms, 6),
                other => panic!("{name}: lobe kind {other}"),
            };
            within(l[1], words(amps), "amplitudes");
            within(l[2], params, "parameters");
        }
    }
    // The warped tables (model section kind 2): no sampling section, every array inside.
    if w[19] != 0 && w[w[19] as usize] == 2 {
        assert_eq!(w[18], 0, "{name}: warped tables with a sampling section");
        check_warped_section(&w[w[19] as usize..], name);
        return;
    }
    // The sampling section (word 18): a record index, then per record 1 + 2M f32 weights.
    let s = w[18];
    assert!(
        s != 0,
        "{name}: a records-based layout without a sampling section"
    );
    within(s, n, "sampling record index");
    for r in 0..n {
        let m = w[w[17] as usize + 12 * r + 6] as usize;
        let at = w[s as usize + r];
        within(at, 1 + 2 * m, "sampling weights");
        for i in 0..1 + 2 * m {
            let v = f32::from_bits(w[at as usize + i]);
            assert!(v.is_finite(), "{name}: record {r} sampling word {i} is {v}");
            // Lobe energies (odd positions) are ≥ 0; the background's may be negative.
            assert!(i % 2 == 0 || v >= 0.0, "{name}: record {r} lobe energy {v}");
        }
    }
    // The model section (word 19): a factor model's fixed part, component entries and values.
    let m = w[19];
    if m != 0 {
        within(m, 14 + 4 * 8, "model section");
        let at = m as usize;
        assert_eq!(w[at], 1, "{name}: model kind");
        let enc = w[at + 1];
        assert!(enc == 1 || enc == 2, "{name}: model encoding {enc}");
        let c = w[at + 2] as usize;
        assert!((1..=8).contains(&c), "{name}: {c} components");
        within(m, 14 + 4 * c, "component entries");
        for ci in 0..c {
            let e = &w[at + 14 + 4 * ci..][..4];
            let (rank, nf, codes) = (e[0] as usize, e[1] as usize, e[2]);
            assert!(
                (1..=8).contains(&rank) && (1..=6).contains(&nf),
                "{name}: component {ci}"
            );
            let nodes: usize = (0..nf)
                .map(|k| match (codes >> (4 * k)) & 15 {
                    1 => 23,
                    2 => 10,
                    3 | 4 => 12,
                    5 => 9,
                    6 => 63,
                    other => panic!("{name}: component {ci} feature code {other}"),
                })
                .sum();
            assert_eq!(codes >> (4 * nf), 0, "{name}: bits past the feature codes");
            let values = rank * (wl + nodes);
            within(
                e[3],
                if enc == 1 { values } else { values.div_ceil(2) },
                "model values",
            );
        }
    }
}

/// A warped-tables section (`spec/GPU_LAYOUT.md`, "Warped tables section"): its sizes in
/// range, every array and every table's codes inside it, P_b ≤ G, bits ≤ 24, values finite.
fn check_warped_section(w: &[u32], name: &str) {
    let (n, k, r, g, m) = (
        w[1] as usize,
        w[2] as usize,
        w[3] as usize,
        w[4] as usize,
        w[5] as usize,
    );
    assert!(n >= 1 && k >= 1 && (2..=64).contains(&r) && (3..=256).contains(&g) && m >= 2);
    let total = w.len();
    let within = |off: u32, len: usize, what: &str| {
        assert!(
            off as usize + len <= total,
            "{name}: warped {what} at {off} + {len} past {total}"
        );
    };
    let finite = |off: u32, len: usize, what: &str| {
        within(off, len, what);
        let at = off as usize;
        assert!(
            w[at..at + len]
                .iter()
                .all(|&v| f32::from_bits(v).is_finite()),
            "{name}: warped {what} not finite"
        );
    };
    finite(w[6], 6 * n, "incidences");
    finite(w[7], m, "NDF");
    finite(w[8], m, "σ");
    finite(w[9], 5 * g, "columns");
    finite(w[10], g, "row cosines");
    within(w[11], n * g, "VNDF rows");
    for &row in &w[w[11] as usize..][..n * g] {
        assert!((row & 511) as usize <= g, "{name}: a positive run past G");
    }
    within(w[12], 4 * n * k, "table entries");
    finite(w[13], 5 * n * r, "values rows");
    finite(w[14], k, "basis means");
    for t in 0..n * k {
        let e = &w[w[12] as usize + 4 * t..][..4];
        assert!(e[1] <= 24, "{name}: table {t} of {} bits", e[1]);
        assert!(f32::from_bits(e[2]).is_finite() && f32::from_bits(e[3]).is_finite());
        // The codes, and the word a two-word read of the last one may touch.
        within(
            e[0],
            (r * r * e[1] as usize).div_ceil(32) + 1,
            "table codes",
        );
    }
}

#[test]
fn golden_files_are_laid_out_within_their_bounds() {
    let mut laid_out = 0;
    let mut warped = 0;
    for name in common::golden_files() {
        let bytes = golden(&name);
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let m = dec.material();
        let words = dec.gpu_layout().unwrap();
        let size = 4 * words.len();
        let ratio = size as f64 / bytes.len() as f64;
        println!(
            "{name}: file {} B, layout {size} B, ratio {ratio:.3}",
            bytes.len()
        );
        check_bounds(&words, &name);
        match &m.warped {
            // Warped tables: unpacked for random access, bounded by their grid (the tables of
            // an RGL measurement are 24 kilo-values at 32 × 32, 98 at 64 × 64).
            Some(w) => {
                let bound = if w.grid <= 32 { 64 << 10 } else { 192 << 10 };
                assert!(size <= bound, "{name}: layout {size} B over {bound}");
                assert_eq!(words[words[19] as usize], 2, "{name}: model section kind");
                warped += 1;
            }
            None => {
                assert!(ratio <= 1.5, "{name}: layout {ratio:.3}× the file");
                assert_eq!(
                    words[19] != 0,
                    m.factor.is_some(),
                    "{name}: a model section exactly when the file has a factor model"
                );
            }
        }
        assert_eq!(
            words,
            Decoder::from_bytes(&bytes).unwrap().gpu_layout().unwrap(),
            "{name}: not deterministic"
        );
        let exact =
            Decoder::from_bytes_with(&bytes, &sbrdf::Limits::default(), sbrdf::Residency::Exact)
                .unwrap();
        assert_eq!(
            words,
            exact.gpu_layout().unwrap(),
            "{name}: the exact residency lays out other words"
        );
        laid_out += 1;
    }
    assert!(laid_out >= 13, "only {laid_out} golden files laid out");
    assert!(warped >= 3, "only {warped} golden files with warped tables");
}

#[test]
fn f16_records_are_packed_two_values_a_word() {
    let words = Decoder::from_bytes(&golden("phong_3inc_direct_f16.sbrdf"))
        .unwrap()
        .gpu_layout()
        .unwrap();
    let first_record = words[17] as usize;
    assert_eq!(words[first_record + 7], 2, "encoding of the first record");
}

#[test]
fn damaged_files_do_not_panic() {
    for name in common::golden_files() {
        let bytes = golden(&name);
        // Cut short and one byte flipped at several places: refused at open (CRCs), or laid out
        // within bounds; never a panic.
        for cut in [0, 1, 12, bytes.len() / 3, bytes.len() / 2, bytes.len() - 1] {
            if let Ok(dec) = Decoder::from_bytes(&bytes[..cut]) {
                if let Ok(w) = dec.gpu_layout() {
                    check_bounds(&w, &name);
                }
            }
        }
        for at in (0..bytes.len()).step_by((bytes.len() / 17).max(1)) {
            let mut b = bytes.clone();
            b[at] ^= 0x5a;
            if let Ok(dec) = Decoder::from_bytes(&b) {
                if let Ok(w) = dec.gpu_layout() {
                    check_bounds(&w, &name);
                }
            }
        }
    }
}

/// Incidences that are not a lattice, a cosine basis and f16 records with an odd number of SH
/// coefficients: the layout's other incidence layout, basis and packing. The golden files have
/// no scattered or cosine-basis file.
#[test]
fn scattered_cosine_f16_material_is_laid_out_within_bounds() {
    let set = common::paper_samples(15.0, 15.0, &[(20.0, 0.0), (20.0, 45.0), (40.0, 0.0)]);
    let enc = common::encode_with(&set, |o| {
        o.basis = sbrdf::model::SpectralBasis::Cosine;
        o.precision = sbrdf::model::Precision::F16;
        o.sh_level = Some(2); // 9 coefficients a term: odd, so a half word is left
    });
    let bytes = sbrdf::write_material(&enc.material).unwrap();
    let words = Decoder::from_bytes(&bytes).unwrap().gpu_layout().unwrap();
    check_bounds(&words, "scattered");
    assert_eq!(words[3], 2, "incidence layout: scattered");
    assert_eq!(words[4], 2, "basis: cosine");
    let first_record = words[17] as usize;
    assert_eq!(words[first_record + 7], 2, "f16 pairs");
    let ratio = (4 * words.len()) as f64 / bytes.len() as f64;
    println!("scattered cosine f16: ratio {ratio:.3}");
    assert!(ratio <= 1.5);
}
