//! The C ABI: one header (`include/sbrdf.h`) and `libsbrdf.a` / `libsbrdf.so` (the shared
//! library from `cargo rustc --release --lib --crate-type cdylib`).
//!
//! Every function catches panics, so none crosses into C; pointers are checked for null; a
//! decoder is immutable after opening, so one handle may be used from many threads at once.

#![allow(non_camel_case_types, clippy::missing_safety_doc)]

use crate::{Decoder, Error};
use std::ffi::{c_char, c_int, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// An open material (opaque to C).
pub struct sbrdf_t(Decoder);

/// Success.
pub const SBRDF_OK: c_int = 0;
/// A required pointer argument was null.
pub const SBRDF_ERR_NULL: c_int = 1;
/// Reading the file failed ([`Error::Io`]).
pub const SBRDF_ERR_IO: c_int = 2;
/// The file is damaged or not an sbrdf file ([`Error::Format`]).
pub const SBRDF_ERR_FORMAT: c_int = 3;
/// The file needs a newer reader ([`Error::Unsupported`]).
pub const SBRDF_ERR_UNSUPPORTED: c_int = 4;
/// The file exceeds the default [`Limits`](crate::Limits) ([`Error::LimitsExceeded`]).
pub const SBRDF_ERR_LIMITS: c_int = 5;
/// An invalid argument: a path that is not UTF-8, a non-finite direction or uniform number, a
/// batch size or stride that overflows ([`Error::Parameter`], [`Error::Input`]).
pub const SBRDF_ERR_ARGUMENT: c_int = 6;
/// A panic inside the library, caught before it reached C.
pub const SBRDF_ERR_INTERNAL: c_int = 7;

fn code_of(e: &Error) -> c_int {
    match e {
        Error::Io { .. } => SBRDF_ERR_IO,
        Error::Format { .. } => SBRDF_ERR_FORMAT,
        Error::Unsupported { .. } => SBRDF_ERR_UNSUPPORTED,
        Error::LimitsExceeded(_) => SBRDF_ERR_LIMITS,
        Error::Parameter(_) | Error::Input(_) => SBRDF_ERR_ARGUMENT,
    }
}

fn guarded(f: impl FnOnce() -> c_int) -> c_int {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(SBRDF_ERR_INTERNAL)
}

unsafe fn finish_open(r: crate::Result<Decoder>, out: *mut *mut sbrdf_t) -> c_int {
    match r {
        Ok(d) => {
            *out = Box::into_raw(Box::new(sbrdf_t(d)));
            SBRDF_OK
        }
        Err(e) => code_of(&e),
    }
}

/// Opens a file. On success stores a handle in `*out` (free it with `sbrdf_close`).
#[no_mangle]
pub unsafe extern "C" fn sbrdf_open_file(path: *const c_char, out: *mut *mut sbrdf_t) -> c_int {
    guarded(|| {
        if path.is_null() || out.is_null() {
            return SBRDF_ERR_NULL;
        }
        *out = std::ptr::null_mut();
        let Ok(p) = CStr::from_ptr(path).to_str() else {
            return SBRDF_ERR_ARGUMENT;
        };
        finish_open(Decoder::open(p), out)
    })
}

/// Opens a file held in memory (the bytes are copied as needed; the buffer may be freed after).
#[no_mangle]
pub unsafe extern "C" fn sbrdf_open_memory(
    data: *const u8,
    len: usize,
    out: *mut *mut sbrdf_t,
) -> c_int {
    guarded(|| {
        if data.is_null() || out.is_null() {
            return SBRDF_ERR_NULL;
        }
        *out = std::ptr::null_mut();
        let bytes = std::slice::from_raw_parts(data, len);
        finish_open(Decoder::from_bytes(bytes), out)
    })
}

/// ρ(wi, wo, λ) in 1/sr for `count` wavelengths (nm) into `out`. `wi` points toward the light,
/// `wo` toward the viewer, both unit vectors in the local frame with z the normal. Below the
/// horizon the value is 0. Allocates nothing.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_eval(
    b: *const sbrdf_t,
    wi: *const f32,
    wo: *const f32,
    wavelengths_nm: *const f32,
    count: usize,
    out: *mut f32,
) -> c_int {
    guarded(|| {
        if b.is_null() || wi.is_null() || wo.is_null() {
            return SBRDF_ERR_NULL;
        }
        if count == 0 {
            return SBRDF_OK;
        }
        if wavelengths_nm.is_null() || out.is_null() {
            return SBRDF_ERR_NULL;
        }
        let wi = [*wi, *wi.add(1), *wi.add(2)];
        let wo = [*wo, *wo.add(1), *wo.add(2)];
        if !wi.iter().chain(&wo).all(|v| v.is_finite()) {
            return SBRDF_ERR_ARGUMENT;
        }
        let wl = std::slice::from_raw_parts(wavelengths_nm, count);
        let out = std::slice::from_raw_parts_mut(out, count);
        (*b).0.eval(wi, wo, wl, out);
        SBRDF_OK
    })
}

/// ρ for `n` direction pairs in one call: pair i is the three floats at `wi + i·wi_stride` and
/// at `wo + i·wo_stride` (strides in floats: 3 for packed vectors, 0 to use one vector for every
/// pair), for `count` wavelengths (nm); its values go to `out[i·count .. i·count + count]`.
/// What `sbrdf_eval` gives pair by pair, bit for bit ([`crate::Decoder::eval_batch`]), except that a
/// pair with a zero or non-finite vector gives 0 instead of an error. The incident side of the query is computed once per run
/// of pairs with the same `wi`, the spectral basis once per wavelength. Allocates nothing.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_eval_batch(
    b: *const sbrdf_t,
    n: usize,
    wi: *const f32,
    wi_stride: usize,
    wo: *const f32,
    wo_stride: usize,
    wavelengths_nm: *const f32,
    count: usize,
    out: *mut f32,
) -> c_int {
    guarded(|| {
        if b.is_null() {
            return SBRDF_ERR_NULL;
        }
        if n == 0 || count == 0 {
            return SBRDF_OK;
        }
        if wi.is_null() || wo.is_null() || wavelengths_nm.is_null() || out.is_null() {
            return SBRDF_ERR_NULL;
        }
        let Some(total) = n.checked_mul(count) else {
            return SBRDF_ERR_ARGUMENT;
        };
        // The last vector's offset must be addressable.
        let last = |stride: usize| (n - 1).checked_mul(stride).and_then(|x| x.checked_add(3));
        if last(wi_stride).is_none() || last(wo_stride).is_none() {
            return SBRDF_ERR_ARGUMENT;
        }
        let wl = std::slice::from_raw_parts(wavelengths_nm, count);
        let out = std::slice::from_raw_parts_mut(out, total);
        let read = |p: *const f32, stride: usize, i: usize| {
            let q = p.add(i * stride);
            [*q, *q.add(1), *q.add(2)]
        };
        (*b).0.eval_batch_with(
            n,
            |i| read(wi, wi_stride, i),
            |i| read(wo, wo_stride, i),
            wl,
            out,
        );
        SBRDF_OK
    })
}

/// Draws an outgoing direction `wo` (toward the viewer) for the incident direction `wi` (toward
/// the light) from two uniform numbers in [0, 1) (1 is taken as just below 1), and stores the
/// density it was drawn with (1/sr, over solid angle; the same for every wavelength) in `*pdf`:
/// exactly what `sbrdf_pdf` gives for that `wo`. When `wi` is below the horizon or zero there is
/// no direction: `wo` = (0, 0, 0) and `*pdf` = 0, still `SBRDF_OK`. A non-finite `wi`, `u1`
/// or `u2` is `SBRDF_ERR_ARGUMENT`. Allocates nothing.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_sample(
    b: *const sbrdf_t,
    wi: *const f32,
    u1: f32,
    u2: f32,
    wo: *mut f32,
    pdf: *mut f32,
) -> c_int {
    guarded(|| {
        if b.is_null() || wi.is_null() || wo.is_null() || pdf.is_null() {
            return SBRDF_ERR_NULL;
        }
        let wi = [*wi, *wi.add(1), *wi.add(2)];
        if !wi.iter().all(|v| v.is_finite()) || !u1.is_finite() || !u2.is_finite() {
            return SBRDF_ERR_ARGUMENT;
        }
        let (dir, p) = match (*b).0.sample(wi, [u1, u2]) {
            Some(s) => (s.wo, s.pdf),
            None => ([0.0; 3], 0.0),
        };
        for (i, v) in dir.iter().enumerate() {
            *wo.add(i) = *v;
        }
        *pdf = p;
        SBRDF_OK
    })
}

/// The density (1/sr, over solid angle) with which `sbrdf_sample` draws `wo` for `wi`, into
/// `*pdf`: 0 when either direction is below the horizon or zero. A non-finite vector is
/// `SBRDF_ERR_ARGUMENT`. Allocates nothing.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_pdf(
    b: *const sbrdf_t,
    wi: *const f32,
    wo: *const f32,
    pdf: *mut f32,
) -> c_int {
    guarded(|| {
        if b.is_null() || wi.is_null() || wo.is_null() || pdf.is_null() {
            return SBRDF_ERR_NULL;
        }
        let wi = [*wi, *wi.add(1), *wi.add(2)];
        let wo = [*wo, *wo.add(1), *wo.add(2)];
        if !wi.iter().chain(&wo).all(|v| v.is_finite()) {
            return SBRDF_ERR_ARGUMENT;
        }
        *pdf = (*b).0.pdf(wi, wo);
        SBRDF_OK
    })
}

/// Frees a handle; null is allowed.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_close(b: *mut sbrdf_t) {
    if !b.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| drop(Box::from_raw(b))));
    }
}

/// The flat device layout (`spec/GPU_LAYOUT.md`, [`crate::Decoder::gpu_layout`]) into a
/// caller's buffer. `*word_count` always receives the number of 32-bit words the layout needs
/// (0 on error); the words are written only when `words` is not NULL and `capacity` (in words)
/// holds them all. Ask the size first with `words` = NULL; a non-NULL buffer that is too small
/// is `SBRDF_ERR_ARGUMENT` with nothing written. Every file is covered (warped tables, `WARP`,
/// from layout version 4). Builds the layout on every call.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_gpu_layout(
    b: *const sbrdf_t,
    words: *mut u32,
    capacity: usize,
    word_count: *mut usize,
) -> c_int {
    guarded(|| {
        if b.is_null() || word_count.is_null() {
            return SBRDF_ERR_NULL;
        }
        *word_count = 0;
        let layout = match (*b).0.gpu_layout() {
            Ok(l) => l,
            Err(e) => return code_of(&e),
        };
        *word_count = layout.len();
        if words.is_null() {
            return SBRDF_OK;
        }
        if capacity < layout.len() {
            return SBRDF_ERR_ARGUMENT;
        }
        std::slice::from_raw_parts_mut(words, layout.len()).copy_from_slice(&layout);
        SBRDF_OK
    })
}

/// Several materials' flat device layouts in one buffer ([`crate::gpu::pack`]): the layouts of
/// `materials[0..count)` one after another, and `bases[i]` the word offset of material i's (the
/// `base` the shader's functions take). `*word_count` always receives the number of words the
/// buffer needs (0 on error); the words and the `count` bases are written only when `words` is
/// not NULL and `capacity` (in words) holds them all, and then `bases` must not be NULL. Ask the
/// size first with `words` = NULL; a non-NULL buffer that is too small is `SBRDF_ERR_ARGUMENT`
/// with nothing written. A NULL material is `SBRDF_ERR_NULL`; no material (`count` = 0) is
/// `SBRDF_ERR_ARGUMENT` (every file is covered, warped tables included). Builds the layouts on
/// every call.
#[no_mangle]
pub unsafe extern "C" fn sbrdf_gpu_pack(
    materials: *const *const sbrdf_t,
    count: usize,
    words: *mut u32,
    capacity: usize,
    word_count: *mut usize,
    bases: *mut u32,
) -> c_int {
    guarded(|| {
        if word_count.is_null() || (materials.is_null() && count > 0) {
            return SBRDF_ERR_NULL;
        }
        *word_count = 0;
        let handles: &[*const sbrdf_t] = if count == 0 {
            &[]
        } else {
            std::slice::from_raw_parts(materials, count)
        };
        if handles.iter().any(|h| h.is_null()) {
            return SBRDF_ERR_NULL;
        }
        let decoders: Vec<&Decoder> = handles.iter().map(|&h| &(*h).0).collect();
        let packed = match super::gpu_layout::pack::pack(&decoders) {
            Ok(p) => p,
            Err(e) => return code_of(&e),
        };
        *word_count = packed.words.len();
        if words.is_null() {
            return SBRDF_OK;
        }
        if bases.is_null() {
            return SBRDF_ERR_NULL;
        }
        if capacity < packed.words.len() {
            return SBRDF_ERR_ARGUMENT;
        }
        std::slice::from_raw_parts_mut(words, packed.words.len()).copy_from_slice(&packed.words);
        std::slice::from_raw_parts_mut(bases, count).copy_from_slice(&packed.bases);
        SBRDF_OK
    })
}

/// A static, never-NULL description of an error code.
#[no_mangle]
pub extern "C" fn sbrdf_error_message(code: c_int) -> *const c_char {
    let s: &'static [u8] = match code {
        SBRDF_OK => b"success\0",
        SBRDF_ERR_NULL => b"a required pointer argument is NULL\0",
        SBRDF_ERR_IO => b"the file could not be read\0",
        SBRDF_ERR_FORMAT => b"the data is not a valid sbrdf file (damaged or truncated)\0",
        SBRDF_ERR_UNSUPPORTED => {
            b"the file needs a newer sbrdf (newer version or unknown feature)\0"
        }
        SBRDF_ERR_LIMITS => b"the file exceeds the decoder's size limits\0",
        SBRDF_ERR_ARGUMENT => {
            b"an argument is invalid (a non-finite vector or number, a path that is not UTF-8)\0"
        }
        SBRDF_ERR_INTERNAL => b"internal error in sbrdf (please report it)\0",
        _ => b"unknown sbrdf error code\0",
    };
    s.as_ptr() as *const c_char
}
