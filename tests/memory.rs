//! What an opened material costs in memory, measured by a counting allocator (this test binary's
//! global allocator): the bytes a decoder keeps after `Decoder::from_bytes`, against the file's
//! size and against `Decoder::resident_bytes`, for every golden file. Renderers open thousands
//! of materials; the bound is 4× the file, and for warped tables 64 KiB at 32 × 32 nodes and
//! 192 KiB at 64 × 64. And that evaluating and sampling an opened
//! material allocates nothing (renderers call them from their inner loops, on many threads).

mod common;
use sbrdf::Decoder;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::PathBuf;

struct Counting;

thread_local! {
    /// Allocation calls (alloc and realloc) made by this thread, whatever their size, and the
    /// bytes it holds (allocated minus freed): per thread, because the test harness's other
    /// threads allocate while a test runs (the decoder never hands work to other threads).
    static CALLS: Cell<usize> = const { Cell::new(0) };
    static LIVE: Cell<isize> = const { Cell::new(0) };
}

/// This thread's allocation calls so far.
fn calls() -> usize {
    CALLS.with(Cell::get)
}

/// The bytes this thread holds.
fn live() -> isize {
    LIVE.with(Cell::get)
}

/// Counts a call that changes this thread's bytes by `bytes` (`try_with`: a thread being torn
/// down has no counters left, and its calls are not a test's).
fn count(call: bool, bytes: isize) {
    let _ = CALLS.try_with(|c| c.set(c.get() + call as usize));
    let _ = LIVE.try_with(|c| c.set(c.get() + bytes));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        count(true, l.size() as isize);
        System.alloc(l)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        count(false, -(l.size() as isize));
        System.dealloc(p, l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        count(true, new as isize - l.size() as isize);
        System.realloc(p, l, new)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Every golden file (the MANIFEST's, [`common::golden_files`]) and the shipped sample.
fn materials() -> Vec<PathBuf> {
    let dir = common::samples_dir();
    common::golden_files()
        .iter()
        .map(|f| dir.join("golden").join(f))
        .chain([dir.join("ggx_slices.sbrdf")])
        .collect()
}

#[test]
fn evaluation_at_wavelengths_and_sampling_allocate_nothing() {
    let paths = materials();
    // The SH constants are the process's, built on first use (as in the test below): one
    // evaluation of a file with SH records first.
    let first = Decoder::from_bytes(&std::fs::read(&paths[0]).unwrap()).unwrap();
    first.eval([0.0, 0.3, 0.9], [0.2, 0.1, 0.9], &[550.0], &mut [0.0]);
    drop(first);
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u32 << 24) as f32
    };
    let mut checked = 0;
    for p in &paths {
        let dec = Decoder::from_bytes(&std::fs::read(p).unwrap()).unwrap();
        dec.prepare_sampling();
        let all = dec.material().wavelengths.clone();
        let (one, four) = ([550.0f32], [400.0f32, 500.0, 600.0, 700.0]);
        let mut out = vec![0.0f32; all.len().max(4) * 64];
        // Directions all over the sphere, below the horizon and grazing included.
        let mut pairs: Vec<([f32; 3], [f32; 3])> = Vec::new();
        for _ in 0..512 {
            let mut d = || {
                let (z, a) = (2.0 * uniform() - 1.0, std::f32::consts::TAU * uniform());
                let r = (1.0 - z * z).max(0.0).sqrt();
                [r * a.cos(), r * a.sin(), z]
            };
            pairs.push((d(), d()));
        }
        pairs.push(([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]));
        pairs.push(([1.0, 0.0, 0.0], [-1.0, 0.0, 1e-7]));
        let (wis, wos): (Vec<[f32; 3]>, Vec<[f32; 3]>) = pairs.iter().cloned().unzip();
        let before = calls();
        let mut total = 0.0f64;
        for &(wi, wo) in &pairs {
            for wl in [&one[..], &four[..], &all[..]] {
                dec.eval(wi, wo, wl, &mut out);
                total += out[0] as f64;
            }
            total += dec.pdf(wi, wo) as f64;
            if let Some(s) = dec.sample(wi, [uniform(), uniform()]) {
                total += s.pdf as f64;
            }
            total += dec.eval_linear_srgb(wi, wo, sbrdf::decode::color::Illuminant::D65)[1];
        }
        // The one-wavelength view: made and used without allocating.
        for l in [550.0f32, all[0], f32::NAN] {
            let at = dec.at(l);
            for &(wi, wo) in &pairs {
                total += at.eval(wi, wo) as f64;
            }
            at.eval_batch(&wis[..64], &wos[..64], &mut out).unwrap();
            total += out[0] as f64;
        }
        for (wi, wo) in wis.chunks(64).zip(wos.chunks(64)) {
            for wl in [&one[..], &four[..], &all[..]] {
                dec.eval_batch(wi, wo, wl, &mut out).unwrap();
                dec.eval_batch(&wi[..1], wo, wl, &mut out).unwrap();
                total += out[0] as f64;
            }
        }
        let calls = calls() - before;
        assert!(total.is_finite(), "{}", p.display());
        assert_eq!(
            calls,
            0,
            "{}: {calls} allocations while evaluating",
            p.display()
        );
        checked += 1;
    }
    assert!(checked >= 10, "{checked} materials");
}

#[test]
fn an_opened_material_holds_at_most_four_times_its_file() {
    let paths = materials();
    // The SH constants are shared by every decoder of the process and built on first use,
    // by whichever thread evaluates first: built here, by one evaluation, before counting
    // (opening a file alone does not build them, and the test beside this one may not have
    // evaluated yet).
    let first = Decoder::from_bytes(&std::fs::read(&paths[0]).unwrap()).unwrap();
    first.eval([0.0, 0.3, 0.9], [0.2, 0.1, 0.9], &[550.0], &mut [0.0]);
    drop(first);
    let mut checked = 0;
    for p in &paths {
        let bytes = std::fs::read(p).unwrap();
        // Warped tables are entropy-coded in the file, and a query needs them at random: the
        // decoder holds them packed to the file's own precision with the VNDF's rows and
        // columns (`spec/GPU_LAYOUT.md`, "Warped tables section"), bounded by their grid instead
        // of their file: 64 KiB for 32 × 32 tables, 192 KiB for 64 × 64 (an RGL measurement's
        // tables are 24 or 98 kilo-values; Falcor's GPU port holds 1.2 MiB per material).
        let material = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
        let warped_bound =
            material
                .warped
                .as_ref()
                .map(|w| if w.grid <= 32 { 64 << 10 } else { 192 << 10 });
        drop(material);
        let before = live();
        let dec = Box::new(Decoder::from_bytes(&bytes).unwrap());
        let held = (live() - before) as usize;
        let reported = dec.resident_bytes();
        eprintln!(
            "{}: file {} bytes, decoder holds {held} bytes ({:.2}×), resident_bytes {reported}",
            p.file_name().unwrap().to_string_lossy(),
            bytes.len(),
            held as f64 / bytes.len() as f64
        );
        assert_eq!(
            held,
            reported,
            "{}: resident_bytes is what is held",
            p.display()
        );
        match warped_bound {
            Some(bound) => assert!(
                held <= bound,
                "{}: {held} bytes held for warped tables, over {bound}",
                p.display()
            ),
            None => assert!(
                held <= 4 * bytes.len(),
                "{}: {held} bytes held, over 4× the file",
                p.display()
            ),
        }
        checked += 1;
    }
    assert!(checked >= 9);
}

// The decoder's benchmark materials, built as `benches/decode.rs` builds them.
#[allow(dead_code)]
#[path = "../benches/common/materials.rs"]
mod materials;

/// The figures of the guide's memory paragraph (library.md, "Memory"), held at SLACK: the
/// resident bytes of the smallest golden file and of the compact 1.3 file, the largest ratio to
/// the file over the golden files that are not warped tables, and the benchmark materials'
/// files and resident bytes.
#[test]
fn the_guides_memory_figures() {
    use common::held;
    let golden = common::samples_dir().join("golden");
    let resident = |name: &str| {
        let bytes = std::fs::read(golden.join(name)).unwrap();
        Decoder::from_bytes(&bytes).unwrap().resident_bytes() as f64
    };
    held("tiny.sbrdf, resident bytes", resident("tiny.sbrdf"), 1697.0);
    held(
        "ggx_3inc_compact_v13.sbrdf, resident bytes",
        resident("ggx_3inc_compact_v13.sbrdf"),
        2731.0,
    );
    let mut largest = 0.0f64;
    for f in common::golden_files() {
        let bytes = std::fs::read(golden.join(&f)).unwrap();
        let material = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
        if material.warped.is_none() {
            let kept = Decoder::from_bytes(&bytes).unwrap().resident_bytes();
            largest = largest.max(kept as f64 / bytes.len() as f64);
        }
    }
    held("golden files, resident / file", largest, 3.92);
    // Warped tables, as a renderer opens them (compact) and as a tool does (exact).
    for (name, compact, exact) in [
        ("rgl_paper_warp_v14.sbrdf", 43683.0, 339188.0),
        ("rgl_satin_warp_v15.sbrdf", 60835.0, 340757.0),
        ("rgl_satin64_warp_v15.sbrdf", 176339.0, 1237115.0),
    ] {
        let bytes = std::fs::read(golden.join(name)).unwrap();
        held(&format!("{name}, resident bytes"), resident(name), compact);
        let exact_dec =
            Decoder::from_bytes_with(&bytes, &sbrdf::Limits::default(), sbrdf::Residency::Exact)
                .unwrap();
        held(
            &format!("{name}, resident bytes, exact"),
            exact_dec.resident_bytes() as f64,
            exact,
        );
    }
    // (name, file bytes, resident bytes) as stated: 1 057: 3 725, 1 206: 3 932, 15 860: 18 404.
    // Each file opened afresh: the benchmarks' decoder has served their table (PTFE's table is
    // resampled from the decoder, which builds its `Material` view), and a renderer's has not.
    for (name, file, kept) in [
        ("phong9", 1057.0, 3725.0),
        ("ggx7", 1206.0, 3932.0),
        ("ptfe6", 15860.0, 18404.0),
    ] {
        let (_, _, bytes, _, _) = materials::material(name).unwrap();
        held(&format!("{name}, file bytes"), bytes.len() as f64, file);
        held(
            &format!("{name}, resident bytes"),
            Decoder::from_bytes(&bytes).unwrap().resident_bytes() as f64,
            kept,
        );
    }
}
