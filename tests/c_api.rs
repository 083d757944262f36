//! The C ABI called as C calls it, and include/sbrdf.h kept in sync with src/decode/capi.rs.

use sbrdf::decode::capi::*;
use std::ffi::{CStr, CString};
use std::path::Path;

fn golden(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("samples/golden")
        .join(name)
}

#[test]
fn header_declares_exactly_the_exported_api() {
    let h = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("include/sbrdf.h"))
        .unwrap();
    let squash = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    let header = squash(&h);
    for proto in [
        "typedef struct sbrdf_t sbrdf_t;",
        "int sbrdf_open_file(const char *path, sbrdf_t **out);",
        "int sbrdf_open_memory(const uint8_t *data, size_t len, sbrdf_t **out);",
        "int sbrdf_eval(const sbrdf_t *b, const float wi[3], const float wo[3], const float *wavelengths_nm, size_t count, float *out);",
        "int sbrdf_sample(const sbrdf_t *b, const float wi[3], float u1, float u2, float wo[3], float *pdf);",
        "int sbrdf_pdf(const sbrdf_t *b, const float wi[3], const float wo[3], float *pdf);",
        "int sbrdf_eval_batch(const sbrdf_t *b, size_t n, const float *wi, size_t wi_stride, const float *wo, size_t wo_stride, const float *wavelengths_nm, size_t count, float *out);",
        "int sbrdf_gpu_layout(const sbrdf_t *b, uint32_t *words, size_t capacity, size_t *word_count);",
        "int sbrdf_gpu_pack(const sbrdf_t *const *materials, size_t count, uint32_t *words, size_t capacity, size_t *word_count, uint32_t *bases);",
        "void sbrdf_close(sbrdf_t *b);",
        "const char *sbrdf_error_message(int code);",
    ] {
        assert!(header.contains(&squash(proto)), "header lacks: {proto}");
    }
    for (name, value) in [
        ("SBRDF_OK", SBRDF_OK),
        ("SBRDF_ERR_NULL", SBRDF_ERR_NULL),
        ("SBRDF_ERR_IO", SBRDF_ERR_IO),
        ("SBRDF_ERR_FORMAT", SBRDF_ERR_FORMAT),
        ("SBRDF_ERR_UNSUPPORTED", SBRDF_ERR_UNSUPPORTED),
        ("SBRDF_ERR_LIMITS", SBRDF_ERR_LIMITS),
        ("SBRDF_ERR_ARGUMENT", SBRDF_ERR_ARGUMENT),
        ("SBRDF_ERR_INTERNAL", SBRDF_ERR_INTERNAL),
    ] {
        assert!(
            header.contains(&format!("#define {name} {value}")),
            "header lacks {name} = {value}"
        );
    }
    // Every function the header names is exported by the library source.
    let src =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/decode/capi.rs"))
            .unwrap();
    for f in [
        "sbrdf_open_file",
        "sbrdf_open_memory",
        "sbrdf_eval",
        "sbrdf_sample",
        "sbrdf_pdf",
        "sbrdf_eval_batch",
        "sbrdf_gpu_layout",
        "sbrdf_gpu_pack",
        "sbrdf_close",
        "sbrdf_error_message",
    ] {
        assert!(
            src.contains(&format!("extern \"C\" fn {f}(")),
            "{f} not exported"
        );
    }
}

#[test]
fn c_calls_agree_with_the_rust_decoder_and_refuse_bad_input() {
    let path = golden("ggx_3inc_default.sbrdf");
    let c_path = CString::new(path.to_str().unwrap()).unwrap();
    let mut h: *mut sbrdf_t = std::ptr::null_mut();
    assert_eq!(
        unsafe { sbrdf_open_file(c_path.as_ptr(), &mut h) },
        SBRDF_OK
    );
    assert!(!h.is_null());
    let dec = sbrdf::Decoder::open(&path).unwrap();
    let wl = [420.0f32, 550.0, 690.0];
    for (wi, wo) in [
        ([0.0f32, 0.0, 1.0], [0.3f32, 0.1, 0.948_683_3]),
        ([0.5, 0.0, 0.866_025_4], [-0.5, 0.0, 0.866_025_4]),
        ([0.2, 0.6, 0.774_596_7], [-0.7, 0.2, 0.685]),
    ] {
        let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
        assert_eq!(
            unsafe { sbrdf_eval(h, wi.as_ptr(), wo.as_ptr(), wl.as_ptr(), 3, a.as_mut_ptr()) },
            SBRDF_OK
        );
        dec.eval(wi, wo, &wl, &mut b);
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-6 * b[k].abs(),
                "{} vs {}",
                a[k],
                b[k]
            );
        }
    }
    // Bad arguments: error codes, never a crash.
    let mut out = [0.0f32; 3];
    let wi = [0.0f32, 0.0, 1.0];
    let nan = [f32::NAN, 0.0, 1.0];
    unsafe {
        assert_eq!(
            sbrdf_eval(
                std::ptr::null(),
                wi.as_ptr(),
                wi.as_ptr(),
                wl.as_ptr(),
                3,
                out.as_mut_ptr()
            ),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_eval(
                h,
                nan.as_ptr(),
                wi.as_ptr(),
                wl.as_ptr(),
                3,
                out.as_mut_ptr()
            ),
            SBRDF_ERR_ARGUMENT
        );
        assert_eq!(
            sbrdf_eval(
                h,
                wi.as_ptr(),
                wi.as_ptr(),
                std::ptr::null(),
                3,
                out.as_mut_ptr()
            ),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_eval(
                h,
                wi.as_ptr(),
                wi.as_ptr(),
                std::ptr::null(),
                0,
                std::ptr::null_mut()
            ),
            SBRDF_OK
        );
        sbrdf_close(h);
        sbrdf_close(std::ptr::null_mut());
    }
    let junk: Vec<u8> = (0..200u32).map(|i| (i * 37 + 11) as u8).collect();
    let mut j: *mut sbrdf_t = std::ptr::null_mut();
    let rc = unsafe { sbrdf_open_memory(junk.as_ptr(), junk.len(), &mut j) };
    assert_eq!(rc, SBRDF_ERR_FORMAT);
    assert!(j.is_null());
    let missing = CString::new("/no/such/file.sbrdf").unwrap();
    assert_eq!(
        unsafe { sbrdf_open_file(missing.as_ptr(), &mut j) },
        SBRDF_ERR_IO
    );
    assert_eq!(
        unsafe { sbrdf_open_file(std::ptr::null(), &mut j) },
        SBRDF_ERR_NULL
    );
    for code in -1..10 {
        let msg = unsafe { CStr::from_ptr(sbrdf_error_message(code)) };
        assert!(!msg.to_bytes().is_empty());
    }
}

#[test]
fn c_sampling_agrees_with_the_rust_decoder_and_refuses_bad_input() {
    let path = golden("ggx_3inc_default.sbrdf");
    let c_path = CString::new(path.to_str().unwrap()).unwrap();
    let mut h: *mut sbrdf_t = std::ptr::null_mut();
    assert_eq!(
        unsafe { sbrdf_open_file(c_path.as_ptr(), &mut h) },
        SBRDF_OK
    );
    let dec = sbrdf::Decoder::open(&path).unwrap();
    let wi = [0.3f32, 0.2, 0.932_737_9];
    for (u1, u2) in [
        (0.1f32, 0.7f32),
        (0.5, 0.5),
        (0.95, 0.02),
        (0.0, 0.0),
        (1.0, 1.0),
    ] {
        let (mut wo, mut pdf, mut again) = ([0.0f32; 3], 0.0f32, 0.0f32);
        assert_eq!(
            unsafe { sbrdf_sample(h, wi.as_ptr(), u1, u2, wo.as_mut_ptr(), &mut pdf) },
            SBRDF_OK
        );
        let s = dec
            .sample(wi, [u1, u2])
            .expect("a direction above the horizon");
        assert_eq!((wo, pdf), (s.wo, s.pdf), "u = ({u1}, {u2})");
        assert!(pdf > 0.0 && wo[2] >= 0.0);
        assert_eq!(
            unsafe { sbrdf_pdf(h, wi.as_ptr(), wo.as_ptr(), &mut again) },
            SBRDF_OK
        );
        assert_eq!(
            again, pdf,
            "u = ({u1}, {u2}): sbrdf_pdf differs from the sample's"
        );
    }
    // Below the horizon there is nothing to draw: a zero direction and density, not an error.
    let below = [0.0f32, 0.6, -0.8];
    let (mut wo, mut pdf) = ([1.0f32; 3], 1.0f32);
    assert_eq!(
        unsafe { sbrdf_sample(h, below.as_ptr(), 0.5, 0.5, wo.as_mut_ptr(), &mut pdf) },
        SBRDF_OK
    );
    assert_eq!((wo, pdf), ([0.0; 3], 0.0));
    assert_eq!(
        unsafe { sbrdf_pdf(h, below.as_ptr(), wi.as_ptr(), &mut pdf) },
        SBRDF_OK
    );
    assert_eq!(pdf, 0.0);
    let nan = [f32::NAN, 0.0, 1.0];
    unsafe {
        assert_eq!(
            sbrdf_sample(h, nan.as_ptr(), 0.5, 0.5, wo.as_mut_ptr(), &mut pdf),
            SBRDF_ERR_ARGUMENT
        );
        assert_eq!(
            sbrdf_sample(h, wi.as_ptr(), f32::NAN, 0.5, wo.as_mut_ptr(), &mut pdf),
            SBRDF_ERR_ARGUMENT
        );
        assert_eq!(
            sbrdf_pdf(h, wi.as_ptr(), nan.as_ptr(), &mut pdf),
            SBRDF_ERR_ARGUMENT
        );
        assert_eq!(
            sbrdf_sample(h, wi.as_ptr(), 0.5, 0.5, std::ptr::null_mut(), &mut pdf),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_pdf(std::ptr::null(), wi.as_ptr(), wi.as_ptr(), &mut pdf),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_pdf(h, wi.as_ptr(), wi.as_ptr(), std::ptr::null_mut()),
            SBRDF_ERR_NULL
        );
        sbrdf_close(h);
    }
}

#[test]
fn a_batch_through_the_c_abi_is_eval_pair_by_pair() {
    let path = CString::new(golden("ggx_3inc_default.sbrdf").to_str().unwrap()).unwrap();
    let mut h: *mut sbrdf_t = std::ptr::null_mut();
    assert_eq!(unsafe { sbrdf_open_file(path.as_ptr(), &mut h) }, SBRDF_OK);
    // Six pairs, packed; the incident directions repeat in runs; one hostile pair.
    let wi: [f32; 18] = [
        0.3,
        0.1,
        0.9,
        0.3,
        0.1,
        0.9,
        0.0,
        0.0,
        1.0,
        0.6,
        -0.2,
        0.7,
        0.6,
        -0.2,
        0.7,
        f32::NAN,
        0.0,
        1.0,
    ];
    let wo: [f32; 18] = [
        -0.3, -0.1, 0.9, 0.2, 0.5, 0.8, 0.1, 0.0, 0.99, -0.5, 0.3, 0.8, 0.0, 0.0, 1.0, -0.2, 0.0,
        0.9,
    ];
    let wl = [450.0f32, 555.0, 690.0];
    let mut batch = [f32::NAN; 18];
    let rc = unsafe {
        sbrdf_eval_batch(
            h,
            6,
            wi.as_ptr(),
            3,
            wo.as_ptr(),
            3,
            wl.as_ptr(),
            3,
            batch.as_mut_ptr(),
        )
    };
    assert_eq!(rc, SBRDF_OK);
    for i in 0..6 {
        let mut one = [f32::NAN; 3];
        let rc = unsafe {
            sbrdf_eval(
                h,
                wi[3 * i..].as_ptr(),
                wo[3 * i..].as_ptr(),
                wl.as_ptr(),
                3,
                one.as_mut_ptr(),
            )
        };
        if i == 5 {
            assert_eq!(rc, SBRDF_ERR_ARGUMENT, "sbrdf_eval refuses a NaN vector");
            assert_eq!(&batch[15..18], &[0.0; 3], "the batch gives 0 for it");
        } else {
            assert_eq!(rc, SBRDF_OK);
            assert_eq!(&batch[3 * i..3 * i + 3], &one, "pair {i}");
        }
    }
    // Stride 0: one incident direction for every pair.
    let mut shared = [f32::NAN; 15];
    let rc = unsafe {
        sbrdf_eval_batch(
            h,
            5,
            wi.as_ptr(),
            0,
            wo.as_ptr(),
            3,
            wl.as_ptr(),
            3,
            shared.as_mut_ptr(),
        )
    };
    assert_eq!(rc, SBRDF_OK);
    assert_eq!(&shared[..6], &batch[..6]);
    // Nothing to do, and null pointers.
    let null = std::ptr::null();
    assert_eq!(
        unsafe { sbrdf_eval_batch(h, 0, null, 3, null, 3, null, 3, std::ptr::null_mut()) },
        SBRDF_OK
    );
    assert_eq!(
        unsafe {
            sbrdf_eval_batch(
                h,
                2,
                null,
                3,
                wo.as_ptr(),
                3,
                wl.as_ptr(),
                3,
                shared.as_mut_ptr(),
            )
        },
        SBRDF_ERR_NULL
    );
    assert_eq!(
        unsafe {
            sbrdf_eval_batch(
                std::ptr::null(),
                2,
                wi.as_ptr(),
                3,
                wo.as_ptr(),
                3,
                wl.as_ptr(),
                3,
                shared.as_mut_ptr(),
            )
        },
        SBRDF_ERR_NULL
    );
    unsafe { sbrdf_close(h) };
}

#[test]
fn c_gpu_layout_is_the_decoders_and_checks_its_buffer() {
    unsafe {
        let open = |name: &str| {
            let path = CString::new(golden(name).to_str().unwrap()).unwrap();
            let mut b = std::ptr::null_mut();
            assert_eq!(sbrdf_open_file(path.as_ptr(), &mut b), SBRDF_OK);
            b
        };
        let b = open("ggx_3inc_default.sbrdf");
        let want = sbrdf::Decoder::open(golden("ggx_3inc_default.sbrdf"))
            .unwrap()
            .gpu_layout()
            .unwrap();
        // The size query, then a buffer one word short (nothing written), then one that fits.
        let mut count = 0usize;
        assert_eq!(
            sbrdf_gpu_layout(b, std::ptr::null_mut(), 0, &mut count),
            SBRDF_OK
        );
        assert_eq!(count, want.len());
        let mut words = vec![0xdead_beefu32; count];
        let mut again = 0usize;
        assert_eq!(
            sbrdf_gpu_layout(b, words.as_mut_ptr(), count - 1, &mut again),
            SBRDF_ERR_ARGUMENT
        );
        assert_eq!(again, count);
        assert!(words.iter().all(|&w| w == 0xdead_beef));
        assert_eq!(
            sbrdf_gpu_layout(b, words.as_mut_ptr(), count, &mut again),
            SBRDF_OK
        );
        assert_eq!(words, want);
        assert_eq!(
            sbrdf_gpu_layout(std::ptr::null(), words.as_mut_ptr(), count, &mut again),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_gpu_layout(b, words.as_mut_ptr(), count, std::ptr::null_mut()),
            SBRDF_ERR_NULL
        );
        sbrdf_close(b);
        // Warped tables (layout version 4): the decoder's own words too.
        let warp = open("rgl_paper_warp_v14.sbrdf");
        let want = sbrdf::Decoder::open(golden("rgl_paper_warp_v14.sbrdf"))
            .unwrap()
            .gpu_layout()
            .unwrap();
        let mut count = 7usize;
        assert_eq!(
            sbrdf_gpu_layout(warp, std::ptr::null_mut(), 0, &mut count),
            SBRDF_OK
        );
        assert_eq!(count, want.len());
        let mut words = vec![0u32; count];
        assert_eq!(
            sbrdf_gpu_layout(warp, words.as_mut_ptr(), count, &mut count),
            SBRDF_OK
        );
        assert_eq!(words, want);
        sbrdf_close(warp);
    }
}

#[test]
fn c_gpu_pack_is_the_crates_and_checks_its_arguments() {
    unsafe {
        let open = |name: &str| {
            let path = CString::new(golden(name).to_str().unwrap()).unwrap();
            let mut b = std::ptr::null_mut();
            assert_eq!(sbrdf_open_file(path.as_ptr(), &mut b), SBRDF_OK);
            b as *const sbrdf_t
        };
        let names = ["ggx_3inc_default.sbrdf", "krylon_shared_v11.sbrdf"];
        let handles = [open(names[0]), open(names[1])];
        let decoders: Vec<sbrdf::Decoder> = names
            .iter()
            .map(|n| sbrdf::Decoder::open(golden(n)).unwrap())
            .collect();
        let want = sbrdf::gpu::pack(&decoders.iter().collect::<Vec<_>>()).unwrap();
        // The size query, a buffer one word short (nothing written), then one that fits.
        let mut count = 0usize;
        let p = handles.as_ptr();
        assert_eq!(
            sbrdf_gpu_pack(
                p,
                2,
                std::ptr::null_mut(),
                0,
                &mut count,
                std::ptr::null_mut()
            ),
            SBRDF_OK
        );
        assert_eq!(count, want.words.len());
        let mut words = vec![0xdead_beefu32; count];
        let mut bases = [7u32; 2];
        let mut again = 0usize;
        let w = words.as_mut_ptr();
        assert_eq!(
            sbrdf_gpu_pack(p, 2, w, count - 1, &mut again, bases.as_mut_ptr()),
            SBRDF_ERR_ARGUMENT
        );
        assert!(words.iter().all(|&w| w == 0xdead_beef) && bases == [7, 7]);
        assert_eq!(
            sbrdf_gpu_pack(p, 2, w, count, &mut again, bases.as_mut_ptr()),
            SBRDF_OK
        );
        assert_eq!((words, bases.to_vec()), (want.words, want.bases));
        // NULL pointers, no material.
        let mut words = vec![0u32; count];
        let w = words.as_mut_ptr();
        assert_eq!(
            sbrdf_gpu_pack(p, 2, w, count, &mut again, std::ptr::null_mut()),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_gpu_pack(p, 2, w, count, std::ptr::null_mut(), bases.as_mut_ptr()),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_gpu_pack(
                std::ptr::null(),
                2,
                w,
                count,
                &mut again,
                bases.as_mut_ptr()
            ),
            SBRDF_ERR_NULL
        );
        let with_null = [handles[0], std::ptr::null()];
        assert_eq!(
            sbrdf_gpu_pack(
                with_null.as_ptr(),
                2,
                w,
                count,
                &mut again,
                bases.as_mut_ptr()
            ),
            SBRDF_ERR_NULL
        );
        assert_eq!(
            sbrdf_gpu_pack(p, 0, w, count, &mut again, bases.as_mut_ptr()),
            SBRDF_ERR_ARGUMENT
        );
        // Warped tables are covered (layout version 4): the size query counts their words.
        let warp = open("rgl_paper_warp_v14.sbrdf");
        let with_warp = [handles[0], warp];
        let mut n = 7usize;
        assert_eq!(
            sbrdf_gpu_pack(
                with_warp.as_ptr(),
                2,
                std::ptr::null_mut(),
                0,
                &mut n,
                std::ptr::null_mut()
            ),
            SBRDF_OK
        );
        let mut one = 0usize;
        assert_eq!(
            sbrdf_gpu_layout(warp, std::ptr::null_mut(), 0, &mut one),
            SBRDF_OK
        );
        assert!(
            one > 0 && n > one,
            "{n} words for both, {one} for the warped one"
        );
        for h in [handles[0], handles[1], warp] {
            sbrdf_close(h as *mut sbrdf_t);
        }
    }
}
