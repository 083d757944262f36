//! What an opened material costs in memory, measured by a counting allocator (this test binary's
//! global allocator): the bytes a decoder keeps after `Decoder::from_bytes`, against the file's
//! size and against `Decoder::resident_bytes`, for every golden file. Renderers open thousands
//! of materials; the bound is 4× the file.

use sbrdf::Decoder;
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicIsize, Ordering};

struct Counting;
static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size() as isize, Ordering::SeqCst);
        System.alloc(l)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size() as isize, Ordering::SeqCst);
        System.dealloc(p, l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        LIVE.fetch_add(new as isize - l.size() as isize, Ordering::SeqCst);
        System.realloc(p, l, new)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[test]
fn an_opened_material_holds_at_most_four_times_its_file() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir.join("golden"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sbrdf"))
        .collect();
    paths.push(dir.join("ggx_slices.sbrdf"));
    paths.sort();
    // The SH constants are shared by every decoder of the process: built before counting.
    drop(Decoder::from_bytes(&std::fs::read(&paths[0]).unwrap()).unwrap());
    let mut checked = 0;
    for p in &paths {
        let bytes = std::fs::read(p).unwrap();
        // Warped tables are compressed: the decoder expands them, as FORMAT.md §8 states, to
        // binary64 tables (N·K·R²), the VNDF warps (2·N·G² + 2·N·G) and the sampling warps of
        // the tables' values (2·N·R² + 2·N·R), beside the stored integers and the NDF and σ
        // nodes; that expansion is their bound, on top of the 4× of the rest.
        let material = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
        let (n, k) = (material.records.len(), material.spectral.terms);
        let expansion = material.warped.as_ref().map_or(0, |w| {
            let (r, g, m) = (w.grid, w.warp_grid, w.ndf.len());
            12 * n * k * r * r
                + 8 * (2 * n * g * g + 2 * n * g)
                + 8 * (2 * n * r * r + 2 * n * r)
                + 12 * m
                + 8 * n
                + 4096
        });
        drop(material);
        let before = LIVE.load(Ordering::SeqCst);
        let dec = Box::new(Decoder::from_bytes(&bytes).unwrap());
        let held = (LIVE.load(Ordering::SeqCst) - before) as usize;
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
        assert!(
            held <= 4 * bytes.len() + expansion,
            "{}: {held} bytes held ({expansion} of them allowed for warped tables)",
            p.display()
        );
        checked += 1;
    }
    assert!(checked >= 9);
}
