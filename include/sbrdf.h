/* sbrdf: decoder for compact spectral BRDF files (.sbrdf). C ABI of the Rust crate `sbrdf`.
 *
 * Link target/release/libsbrdf.a (with -lpthread -ldl -lm) or libsbrdf.so. Build a lean library
 * with `cargo build --release --lib --no-default-features`; the shared library with
 * `cargo rustc --release --lib --no-default-features --crate-type cdylib` (the crate's own
 * crate types are rlib and staticlib).
 *
 * Conventions: wi points from the surface toward the light, wo toward the viewer; both are unit
 * vectors in the local shading frame with z the surface normal. Values are in 1/sr, wavelengths
 * in nm. Below the horizon (wi.z < 0 or wo.z < 0) the value is 0; it is never negative. A handle
 * is immutable once open: it may be shared by any number of threads. No function lets a Rust
 * panic cross into C.
 * Kept in sync with src/decode/capi.rs by tests/c_api.rs.
 */
#ifndef SBRDF_H
#define SBRDF_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sbrdf_t sbrdf_t;

#define SBRDF_OK 0
#define SBRDF_ERR_NULL 1
#define SBRDF_ERR_IO 2
#define SBRDF_ERR_FORMAT 3
#define SBRDF_ERR_UNSUPPORTED 4
#define SBRDF_ERR_LIMITS 5
#define SBRDF_ERR_ARGUMENT 6
#define SBRDF_ERR_INTERNAL 7

int  sbrdf_open_file(const char *path, sbrdf_t **out);        /* 0 on success, else an error code */
int  sbrdf_open_memory(const uint8_t *data, size_t len, sbrdf_t **out);
int  sbrdf_eval(const sbrdf_t *b, const float wi[3], const float wo[3],
                const float *wavelengths_nm, size_t count, float *out);
/* Many pairs per call (a wavefront, a tile): pair i is the 3 floats at wi + i*wi_stride and at
 * wo + i*wo_stride (strides in floats: 3 = packed, 0 = one vector for every pair); its count
 * values go to out[i*count ...]. The same values as sbrdf_eval pair by pair, bit for bit,
 * whatever the batch or the CPU (a zero or non-finite vector gives 0 rather than an error);
 * work that depends on wi alone is done once per run of pairs with the same wi. Thread-safe,
 * no allocation. */
int  sbrdf_eval_batch(const sbrdf_t *b, size_t n, const float *wi, size_t wi_stride,
                      const float *wo, size_t wo_stride, const float *wavelengths_nm,
                      size_t count, float *out);
/* Importance sampling, the same for every wavelength: draws wo (toward the viewer) for wi (toward
 * the light) from u1, u2 uniform in [0, 1), and its density *pdf (1/sr, over solid angle), which
 * is exactly what sbrdf_pdf returns for that wo. wi below the horizon: wo = (0, 0, 0), *pdf = 0.
 * A path tracer that knows the viewer's direction passes it as wi and takes wo as the light's:
 * right as far as the material is reciprocal. */
int  sbrdf_sample(const sbrdf_t *b, const float wi[3], float u1, float u2, float wo[3], float *pdf);
int  sbrdf_pdf(const sbrdf_t *b, const float wi[3], const float wo[3], float *pdf);
/* The flat device layout of the material (spec/GPU_LAYOUT.md): 32-bit little-endian words for a
 * GPU kernel. *word_count always receives the words it needs (0 on error); they are written
 * only when words is not NULL and capacity (in words) holds them. Query with words = NULL first;
 * a buffer too small is SBRDF_ERR_ARGUMENT, nothing written. Every file is covered; files with
 * warped tables (WARP, the RGL measurements) from layout version 4 on. */
int  sbrdf_gpu_layout(const sbrdf_t *b, uint32_t *words, size_t capacity, size_t *word_count);
/* Several materials in one buffer, as a renderer uploads it (sbrdf::gpu::pack): the layouts of
 * materials[0 .. count) one after another, bases[i] the word offset of material i's (the base the
 * shader's functions take). *word_count and the buffer as for sbrdf_gpu_layout; the count bases
 * are written with the words, and bases must then not be NULL. A NULL material is SBRDF_ERR_NULL;
 * count = 0 is SBRDF_ERR_ARGUMENT. Every file is covered, as for sbrdf_gpu_layout. */
int  sbrdf_gpu_pack(const sbrdf_t *const *materials, size_t count, uint32_t *words,
                    size_t capacity, size_t *word_count, uint32_t *bases);
void sbrdf_close(sbrdf_t *b);
const char *sbrdf_error_message(int code);                    /* static string, never NULL */

#ifdef __cplusplus
}
#endif

#endif /* SBRDF_H */
