// sbrdf.wgsl: evaluation of an sbrdf material from its flat device layout
// (spec/GPU_LAYOUT.md, layout versions 1 to 4) in WGSL, all in f32.
//
// HOW TO USE. Paste (or concatenate) this text after the host shader's own declarations. It
// declares NO binding itself: it reads the layout words from a storage array named
// `sbrdf_words` that the host must declare, for example
//
//     @group(0) @binding(0) var<storage, read> sbrdf_words: array<u32>;
//
// filled with the words `Decoder::gpu_layout()` returns (several materials may be concatenated,
// as `sbrdf::gpu::pack` does; a material is addressed by the word offset `base` where its layout
// starts). Every identifier this module declares starts with `sbrdf_` / `SBRDF_` / `Sbrdf`.
//
// FUNCTIONS.
//   sbrdf_eval(base, wi, wo, lambda_nm) -> f32
//       rho(wi, wo, lambda) in 1/sr, as `Decoder::eval` computes it: never negative.
//   sbrdf_eval4(base, wi, wo, lambda_nm: vec4<f32>) -> vec4<f32>
//       rho at four wavelengths, the directions' work done once: component i equals
//       sbrdf_eval(base, wi, wo, lambda_nm[i]).
//   sbrdf_eval_rgb(base, wi, wo) -> vec3<f32>
//       linear sRGB under D65, as `Decoder::eval_linear_srgb(wi, wo, Illuminant::D65)`:
//       the spectrum at 380..780 nm every 5 nm (each value clamped at 0), weighted by
//       D65 times the CIE 1931 2-degree observer, normalised so that Y of a constant 1 is 1,
//       then the IEC 61966-2-1 XYZ -> linear sRGB matrix.
//   sbrdf_pdf(base, wi, wo) -> f32
//   sbrdf_sample(base, wi, u) -> vec4<f32>
//       importance sampling: the density (1/sr) and a drawn direction (xyz) with its density
//       (w), as `Decoder::pdf` and `Decoder::sample` (see "importance sampling" below).
//
// CONVENTIONS (those of `Decoder::eval`, spec/EVALUATION.md). wi points toward the light and
// wo toward the viewer, both in the local frame with z the surface normal. They need not be of
// unit length (they are normalised here, as the CPU decoder does); a zero, non-finite or
// below-horizon (z < 0 after normalisation) direction gives 0. Wavelengths are in nm; a
// non-finite wavelength gives 0; a wavelength outside the file's range is held at the range's
// end (the spectral basis clamps it). The layout is assumed valid (made by `gpu_layout()`):
// nothing here bounds-checks offsets.
//
// EVERY FILE. A layout without a sampling section (version 1) samples the cosine. A factor
// model (FACT) is the model section of kind 1 (header word 19, 0 in versions 1 and 2): its F is
// added to the records' series. Warped tables (WARP, the RGL measurements) are the model
// section of kind 2 (version 4): such a file has no records and no sampling section; the
// section answers evaluation (its coefficients take the records' place in the same spectral
// sum) and sampling itself, reading the compact form the CPU decoder also holds. No check of
// the header's magic or version is made per query: the host checks them once.
//
// PRIVATE MEMORY. Nothing here is sized by a material: the spherical harmonics are evaluated by
// their recurrence and folded into the sums as each Y_lm is produced; the spectral terms are
// taken four at a time (a vec4 of basis values, one chunk for files of up to four terms, as the
// encoder's defaults make them); the factor model's angular terms are used as they are computed;
// the sampling mixture's components are recomputed where they are needed instead of being
// stored. WGSL cannot size a function-scope array by a pipeline constant (only workgroup arrays),
// and a host-generated size would make the text depend on the materials: streaming keeps one
// text for every layout. No `const` array is indexed at run time either (a SPIR-V writer copies
// such an array into private memory to index it): the colour weights and the factor model's
// nodes are `switch` functions. gpu/tests/private_memory.rs bounds what each entry point may
// keep (at most 256 bytes, from naga's IR).
//
// PRECISION. Everything is f32; the CPU decoder computes in f64. The places where f32 would
// lose more than a few units in the last place are written specially; each says why below.
// The WGSL built-ins sin/cos/atan2/log/pow carry loose precision guarantees (sin and cos only
// an absolute 2^-11 in the Vulkan rules, log an absolute 2^-21 near 1, pow inherits exp2(log2))
// so this module carries its own sine/cosine, arctangent and logarithm; only exp and sqrt are
// the built-ins. Known limit: the SH background is summed in f32, so a record whose SH
// coefficients cancel strongly loses accuracy in proportion (samples/golden/
// phong_3inc_direct_f16.sbrdf sums terms of magnitude ~200 to values ~0.1, and rounding its
// SH functions to f32 alone moves the value by 2e-6): measured on lavapipe against the CPU, up
// to 12 times the tolerance 1e-5 relative plus 1e-7 of the file's largest value, which every
// other covered golden file meets.

// BEGIN GENERATED LAYOUT WORDS
// Generated from src/decode/gpu_layout/words.rs, the one definition of spec/GPU_LAYOUT.md's word
// offsets; do not edit (the test gpu::tests::layout_words_match_the_rust_table says how to
// regenerate). Offsets are in words, relative to what each table's comment says.
// Header (20 words), relative to base
const SBRDF_HDR_MAGIC: u32 = 0u; // u32: magic
const SBRDF_HDR_VERSION: u32 = 1u; // u32: layout version
const SBRDF_HDR_TOTAL: u32 = 2u; // u32: total_words
const SBRDF_HDR_INCIDENCE: u32 = 3u; // u32: incidence layout
const SBRDF_HDR_BASIS: u32 = 4u; // u32: spectral basis
const SBRDF_HDR_TERMS: u32 = 5u; // u32: K, the basis's number of terms
const SBRDF_HDR_SH_LEVEL: u32 = 6u; // u32: sh_level
const SBRDF_HDR_WAVES: u32 = 7u; // u32: W, the number of wavelengths
const SBRDF_HDR_RECORDS: u32 = 8u; // u32: N, the number of records
const SBRDF_HDR_THETAS: u32 = 9u; // u32: T, the number of distinct stored θi
const SBRDF_HDR_PHIS: u32 = 10u; // u32: P, the number of distinct stored φi
const SBRDF_HDR_LAMBDA_MIN: u32 = 11u; // f32: λmin (nm)
const SBRDF_HDR_LAMBDA_MAX: u32 = 12u; // f32: λmax (nm)
const SBRDF_HDR_OFF_WAVES: u32 = 13u; // u32: offset of the wavelengths
const SBRDF_HDR_OFF_BASIS_TABLE: u32 = 14u; // u32: offset of the basis table
const SBRDF_HDR_OFF_THETAS: u32 = 15u; // u32: offset of the stored θi
const SBRDF_HDR_OFF_PHIS: u32 = 16u; // u32: offset of the stored φi
const SBRDF_HDR_OFF_RECORDS: u32 = 17u; // u32: offset of the record table
const SBRDF_HDR_OFF_SAMPLING: u32 = 18u; // u32: offset of the sampling section
const SBRDF_HDR_OFF_MODEL: u32 = 19u; // u32: offset of the model section
const SBRDF_HDR_WORDS: u32 = 20u;
// Record table entry (12 words), relative to a record table entry
const SBRDF_REC_THETA_I: u32 = 0u; // f32: θi (degrees)
const SBRDF_REC_PHI_I: u32 = 1u; // f32: φi
const SBRDF_REC_THETA_P: u32 = 2u; // f32: θp, the peak's polar angle
const SBRDF_REC_PHI_P: u32 = 3u; // f32: φp
const SBRDF_REC_LEVEL: u32 = 4u; // u32: the record's SH level L
const SBRDF_REC_TERMS: u32 = 5u; // u32: terms
const SBRDF_REC_LOBES: u32 = 6u; // u32: lobe count M
const SBRDF_REC_ENCODING: u32 = 7u; // u32: value encoding
const SBRDF_REC_SCALE: u32 = 8u; // f32: scale
const SBRDF_REC_OFF_SH: u32 = 9u; // u32: offset of the SH coefficients
const SBRDF_REC_OFF_LOBES: u32 = 10u; // u32: offset of the lobe table
const SBRDF_REC_RESERVED: u32 = 11u; // u32: 0 (reserved)
const SBRDF_REC_WORDS: u32 = 12u;
// Lobe table entry (3 words), relative to a lobe table entry
const SBRDF_LOBE_KIND: u32 = 0u; // u32: kind
const SBRDF_LOBE_OFF_AMPLITUDES: u32 = 1u; // u32: offset of its amplitudes
const SBRDF_LOBE_OFF_PARAMETERS: u32 = 2u; // u32: offset of its parameters
const SBRDF_LOBE_WORDS: u32 = 3u;
// Sampling section, its record index (1 words), relative to the sampling section (header word 18) + r
const SBRDF_SMP_OFF_WEIGHTS: u32 = 0u; // u32: offset of record r's weights
const SBRDF_SMP_WORDS: u32 = 1u;
// Sampling section, a record's weights (1 words), relative to a record's weights
const SBRDF_SW_BACKGROUND: u32 = 0u; // f32: E_bg
const SBRDF_SW_WORDS: u32 = 1u;
// Sampling section, a lobe's weights in its record's (2 words), relative to a record's weights + 1 + 2 l
const SBRDF_SWL_ENERGY: u32 = 0u; // f32: E_l
const SBRDF_SWL_LN_WIDTH: u32 = 1u; // f32: ln b_l
const SBRDF_SWL_WORDS: u32 = 2u;
// Model section, every kind (1 words), relative to the model section (header word 19)
const SBRDF_MODEL_KIND: u32 = 0u; // u32: kind
const SBRDF_MODEL_WORDS: u32 = 1u;
// Model section of kind 1, the factor model (14 words), relative to the model section of kind 1
const SBRDF_FACT_ENCODING: u32 = 1u; // u32: value encoding of the model's values
const SBRDF_FACT_COMPONENTS: u32 = 2u; // u32: C, the number of components
const SBRDF_FACT_RESERVED: u32 = 3u; // u32: 0 (reserved)
const SBRDF_FACT_RANGES: u32 = 4u; // 10 f32 words, to 13: the ranges
const SBRDF_FACT_WORDS: u32 = 14u;
// Factor model, a component's entry (4 words), relative to the model section of kind 1 + 14 + 4 c
const SBRDF_FACT_C_RANK: u32 = 0u; // u32: rank R_c
const SBRDF_FACT_C_FEATURES: u32 = 1u; // u32: feature count F_c
const SBRDF_FACT_C_CODES: u32 = 2u; // u32: feature codes
const SBRDF_FACT_C_OFF_VALUES: u32 = 3u; // u32: offset of its values
const SBRDF_FACT_C_WORDS: u32 = 4u;
// Model section of kind 2, warped tables (16 words), relative to the model section of kind 2
const SBRDF_WARP_KIND: u32 = 0u; // u32: kind: 2 warped tables
const SBRDF_WARP_N: u32 = 1u; // u32: N, stored incidences
const SBRDF_WARP_K: u32 = 2u; // u32: K, spectral terms
const SBRDF_WARP_R: u32 = 3u; // u32: R, table side
const SBRDF_WARP_G: u32 = 4u; // u32: G, VNDF grid side
const SBRDF_WARP_M: u32 = 5u; // u32: M, NDF nodes
const SBRDF_WARP_OFF_INCIDENCES: u32 = 6u; // u32: offset of the incidences
const SBRDF_WARP_OFF_NDF: u32 = 7u; // u32: offset of the NDF
const SBRDF_WARP_OFF_SIGMA: u32 = 8u; // u32: offset of σ
const SBRDF_WARP_OFF_COLUMNS: u32 = 9u; // u32: offset of the columns
const SBRDF_WARP_OFF_ROW_COSINES: u32 = 10u; // u32: offset of the rows' cosines
const SBRDF_WARP_OFF_VNDF_ROWS: u32 = 11u; // u32: offset of the VNDF rows
const SBRDF_WARP_OFF_TABLES: u32 = 12u; // u32: offset of the table entries
const SBRDF_WARP_OFF_VALUES_ROWS: u32 = 13u; // u32: offset of the values rows
const SBRDF_WARP_OFF_BASIS_MEANS: u32 = 14u; // u32: offset of the basis means
const SBRDF_WARP_RESERVED: u32 = 15u; // u32: 0 (reserved)
const SBRDF_WARP_WORDS: u32 = 16u;
// Warped tables, a stored incidence (6 words), relative to an incidence entry
const SBRDF_WARP_INC_THETA: u32 = 0u; // f32: θ_i (radians)
const SBRDF_WARP_INC_SIN: u32 = 1u; // f32: sin θ_i
const SBRDF_WARP_INC_COS: u32 = 2u; // f32: cos θ_i
const SBRDF_WARP_INC_VNDF_SCALE: u32 = 3u; // f32: 1/I_i
const SBRDF_WARP_INC_VALUES_SCALE: u32 = 4u; // f32: the values' density: 1 over its total
const SBRDF_WARP_INC_VALUES_FLOOR: u32 = 5u; // f32: the values' floor
const SBRDF_WARP_INC_WORDS: u32 = 6u;
// Warped tables, a VNDF column (5 words), relative to a column entry
const SBRDF_WARP_COL_F: u32 = 0u; // f32: f_a
const SBRDF_WARP_COL_SIN: u32 = 1u; // f32: sin θm_a
const SBRDF_WARP_COL_COS: u32 = 2u; // f32: cos θm_a
const SBRDF_WARP_COL_U: u32 = 3u; // f32: U[a]
const SBRDF_WARP_COL_V: u32 = 4u; // f32: V[a]
const SBRDF_WARP_COL_WORDS: u32 = 5u;
// Warped tables, a table's entry (4 words), relative to a table entry
const SBRDF_WARP_TAB_OFF_CODES: u32 = 0u; // u32: offset of its codes
const SBRDF_WARP_TAB_BITS: u32 = 1u; // u32: bits per code
const SBRDF_WARP_TAB_LO: u32 = 2u; // f32: least value
const SBRDF_WARP_TAB_STEP: u32 = 3u; // f32: step
const SBRDF_WARP_TAB_WORDS: u32 = 4u;
// Warped tables, a values row (5 words), relative to a values row
const SBRDF_WARP_VAL_TOTAL: u32 = 0u; // f32: the row's total
const SBRDF_WARP_VAL_MARG: u32 = 1u; // f32: its marginal
const SBRDF_WARP_VAL_MARKS: u32 = 2u; // 3 f32 words, to 4: conditional integrals at columns
const SBRDF_WARP_VAL_WORDS: u32 = 5u;
// Codes the words hold
const SBRDF_INCIDENCE_ISOTROPIC: u32 = 0u; // header word 3
const SBRDF_INCIDENCE_LATTICE: u32 = 1u; // header word 3
const SBRDF_INCIDENCE_SCATTERED: u32 = 2u; // header word 3
const SBRDF_ENCODING_F32: u32 = 1u; // one f32 per word
const SBRDF_ENCODING_F16_PAIRS: u32 = 2u; // two f16 per word
const SBRDF_MODEL_FACTOR: u32 = 1u; // model kind 1: the factor model
const SBRDF_MODEL_WARPED: u32 = 2u; // model kind 2: warped tables
const SBRDF_WARP_POSITIVE_BITS: u32 = 9u; // a VNDF row's positive run below, its marginal above
const SBRDF_WARP_MARKS: u32 = 3u; // conditional integrals kept per values row
const SBRDF_LAYOUT_MAGIC: u32 = 0x4c474253u; // header word 0: the bytes SBGL
// END GENERATED LAYOUT WORDS

const SBRDF_MAX_TERMS: u32 = 256u; // K <= 256 (spec/FORMAT.md)
const SBRDF_MAX_LEVEL: u32 = 20u; // SH level <= 20
const SBRDF_MAX_BLEND: u32 = 4u; // at most 4 records are blended (2 when isotropic)
const SBRDF_MAX_LOBES: u32 = 8u; // at most 8 lobes per record
const SBRDF_PI: f32 = 3.14159265358979;
const SBRDF_DEG: f32 = 0.0174532925199433; // pi / 180
const SBRDF_RAD: f32 = 57.2957795130823; // 180 / pi

// ------------------------------------------------------------------ words

fn sbrdf_u(i: u32) -> u32 {
    return sbrdf_words[i];
}

fn sbrdf_f(i: u32) -> f32 {
    return bitcast<f32>(sbrdf_words[i]);
}

// Value i of a record's array at absolute word `o` (GPU_LAYOUT.md, "Value encodings").
fn sbrdf_value(o: u32, i: u32, enc: u32, scale: f32) -> f32 {
    if (enc == SBRDF_ENCODING_F32) {
        return sbrdf_f(o + i);
    }
    let pair = unpack2x16float(sbrdf_words[o + (i >> 1u)]);
    return select(pair.x, pair.y, (i & 1u) == 1u) * scale;
}

// Values i, i + d, i + 2d, i + 3d of an array: the first n (0 to 4) read, the others 0 and not
// read (past a record's terms, the words belong to something else).
fn sbrdf_values4(o: u32, i: u32, d: u32, n: u32, enc: u32, scale: f32) -> vec4<f32> {
    var v = vec4<f32>(0.0);
    if (n > 0u) {
        v.x = sbrdf_value(o, i, enc, scale);
    }
    if (n > 1u) {
        v.y = sbrdf_value(o, i + d, enc, scale);
    }
    if (n > 2u) {
        v.z = sbrdf_value(o, i + 2u * d, enc, scale);
    }
    if (n > 3u) {
        v.w = sbrdf_value(o, i + 3u * d, enc, scale);
    }
    return v;
}

// The number of terms k0, k0 + 1, ... below `terms`, at most 4: a chunk's width.
fn sbrdf_chunk(k0: u32, terms: u32) -> u32 {
    return select(0u, min(terms - k0, 4u), k0 < terms);
}

// The absolute word of record r's table entry.
fn sbrdf_rec(base: u32, r: u32) -> u32 {
    return base + sbrdf_u(base + SBRDF_HDR_OFF_RECORDS) + SBRDF_REC_WORDS * r;
}

// The absolute word of lobe li's table entry in the record whose entry is at e.
fn sbrdf_lobe(base: u32, e: u32, li: u32) -> u32 {
    return base + sbrdf_u(e + SBRDF_REC_OFF_LOBES) + SBRDF_LOBE_WORDS * li;
}

// Not NaN and not +-Inf, from the bits: a comparison-based test can be folded away by a
// compiler allowed to assume finite arithmetic.
fn sbrdf_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}


// ------------------------------------------------------------------ elementary functions

// sin and cos of x (radians, |x| <= pi/4 + a little) rotated by `quadrant` quarter turns.
// Taylor polynomials to x^11 / x^12: the truncation error at pi/4 is below 1e-11, so the result
// is the f32 rounding of the products alone.
fn sbrdf_sincos_reduced(x: f32, quadrant: i32) -> vec2<f32> {
    let x2 = x * x;
    let s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0
        + x2 * (1.0 / 362880.0 + x2 * (-1.0 / 39916800.0))))));
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0
        + x2 * (-1.0 / 3628800.0 + x2 * (1.0 / 479001600.0))))));
    let q = quadrant & 3;
    if (q == 0) {
        return vec2<f32>(s, c);
    } else if (q == 1) {
        return vec2<f32>(c, -s);
    } else if (q == 2) {
        return vec2<f32>(-s, -c);
    }
    return vec2<f32>(-c, s);
}


// (sin, cos) of an angle in degrees. The reduction by quarter turns is done in degrees, where
// it is exact for the stored angles (a - 90q is exact in f32 for |a| < 2^17), so only the final
// conversion of |r| <= 45 degrees to radians rounds; radians first would round pi/2 multiples.
fn sbrdf_sincos_deg(a: f32) -> vec2<f32> {
    let q = round(a / 90.0);
    let r = a - q * 90.0;
    return sbrdf_sincos_reduced(r * SBRDF_DEG, i32(q));
}


// (sin, cos) of 2 pi p, p in turns (the spectral bases' phases, already reduced to [0, 1)).
fn sbrdf_sincos_turns(p: f32) -> vec2<f32> {
    let q = round(p * 4.0);
    let r = p - q * 0.25;
    return sbrdf_sincos_reduced(r * (2.0 * SBRDF_PI), i32(q));
}


// The unit vector of (theta, phi) in degrees ("Directions").
fn sbrdf_dir(theta: f32, phi: f32) -> vec3<f32> {
    let t = sbrdf_sincos_deg(theta);
    let p = sbrdf_sincos_deg(phi);
    return vec3<f32>(t.x * p.y, t.x * p.x, t.y);
}


// atan(x) for 0 <= x <= 1, radians: Abramowitz & Stegun 4.4.49 (the polynomial the CPU decoder
// uses for theta), written as x times a polynomial in x^2 so that it stays accurate relative to
// the result for small x (a small angle keeps its relative precision).
fn sbrdf_atan01(x: f32) -> f32 {
    let x2 = x * x;
    let p = -0.3333314528 + x2 * (0.1999355085 + x2 * (-0.1420889944 + x2 * (0.1065626393
        + x2 * (-0.0752896400 + x2 * (0.0429096138 + x2 * (-0.0161657367
        + x2 * 0.0028662257))))));
    return x + x * x2 * p;
}


// atan2(y, x) in degrees, in (-180, 180]; 0 for (0, 0). The complement to 90 and 180 is taken
// in degrees, where 90 and 180 are exact (pi/2 in f32 is not).
fn sbrdf_atan2_deg(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let hi = max(ax, ay);
    if (hi == 0.0) {
        return 0.0;
    }
    var a = sbrdf_atan01(min(ax, ay) / hi) * SBRDF_RAD;
    if (ay > ax) {
        a = 90.0 - a;
    }
    if (x < 0.0) {
        a = 180.0 - a;
    }
    if (y < 0.0) {
        a = -a;
    }
    return a;
}


// atan2(y, x) in radians for y >= 0, x >= 0 (angles between two directions: both are lengths).
fn sbrdf_atan2_pos(y: f32, x: f32) -> f32 {
    let hi = max(x, y);
    if (hi == 0.0) {
        return 0.0;
    }
    let a = sbrdf_atan01(min(x, y) / hi);
    return select(a, 0.5 * SBRDF_PI - a, y > x);
}


// log(1 + f) for |f| <= 0.42: 2 atanh(f / (2 + f)) as its odd series. |t| <= 0.27, t^2 <= 0.073,
// the series to t^17 leaves a truncation error below 1e-10. Exact near f = 0 relative to the
// result, which the built-in log (absolute 2^-21 near 1) is not: a cosine power or a microfacet
// distribution raises this logarithm's argument to large exponents.
fn sbrdf_log1p_small(f: f32) -> f32 {
    let t = f / (2.0 + f);
    let t2 = t * t;
    let s = 1.0 + t2 * (1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (1.0 / 7.0 + t2 * (1.0 / 9.0
        + t2 * (1.0 / 11.0 + t2 * (1.0 / 13.0 + t2 * (1.0 / 15.0 + t2 * (1.0 / 17.0))))))));
    return 2.0 * t * s;
}


// Natural logarithm of x > 0 (finite, normal or subnormal): x = m 2^e with m in
// [sqrt(1/2), sqrt(2)), log m from the series above (m - 1 is exact there), e ln 2 split in two
// parts so that it adds no rounding of its own beyond the final sum.
fn sbrdf_ln(x: f32) -> f32 {
    let fe = frexp(x);
    var m = fe.fract;
    var e = f32(fe.exp);
    if (m < 0.70710678) {
        m = m * 2.0;
        e = e - 1.0;
    }
    let ln2_hi = 0.693145752; // 0x3f317200: e * ln2_hi is exact for |e| < 2^8
    let ln2_lo = 1.42860677e-6;
    return e * ln2_hi + (e * ln2_lo + sbrdf_log1p_small(m - 1.0));
}


// log(1 + x), x > -1, accurate relative to the result for small x.
fn sbrdf_log1p(x: f32) -> f32 {
    if (abs(x) <= 0.41) {
        return sbrdf_log1p_small(x);
    }
    return sbrdf_ln(1.0 + x);
}


// ------------------------------------------------------------------ spherical harmonics

// Terms k0 .. k0 + 3 of a record's SH background at the unit vector w: sum_j c[k][j] Y_j(w)
// ("Spherical harmonics", Cartesian form), 0 past the record's terms. The Y_j are produced by
// their recurrence and folded into the four sums as they come (nothing is stored), in the
// recurrence's order (m, then l). The associated Legendre part is carried already normalised
// (the recurrence of K_l^m Q_l^m): the unnormalised Q_l^m and the factorial ratio of K_l^m
// overflow f32 from level 17 on ((2m-1)!! and (l+m)! up to 40!), and their product would lose
// precision.
fn sbrdf_sh4(base: u32, e: u32, w: vec3<f32>, k0: u32) -> vec4<f32> {
    let n = sbrdf_chunk(k0, sbrdf_u(e + SBRDF_REC_TERMS));
    if (n == 0u) {
        return vec4<f32>(0.0);
    }
    let level = min(sbrdf_u(e + SBRDF_REC_LEVEL), SBRDF_MAX_LEVEL);
    let pr = (level + 1u) * (level + 1u);
    let enc = sbrdf_u(e + SBRDF_REC_ENCODING);
    let scale = sbrdf_f(e + SBRDF_REC_SCALE);
    // Coefficient j of term k is value k pr + j; term k0's first is at k0 pr.
    let o = base + sbrdf_u(e + SBRDF_REC_OFF_SH);
    let at = k0 * pr;
    var acc = vec4<f32>(0.0);
    var c = 1.0; // C_m
    var s = 0.0; // S_m
    var pmm = 0.28209479177387814; // K_0^0 Q_0^0 = sqrt(1 / (4 pi))
    for (var m = 0u; m <= level; m = m + 1u) {
        if (m > 0u) {
            let c2 = w.x * c - w.y * s;
            s = w.y * c + w.x * s;
            c = c2;
            let fm = f32(m);
            pmm = pmm * sqrt((2.0 * fm + 1.0) / (2.0 * fm));
        }
        let fm = f32(m);
        var p2 = 0.0; // P_{l-2}^m
        var p1 = pmm; // P_{l-1}^m
        for (var l = m; l <= level; l = l + 1u) {
            var p = pmm;
            let fl = f32(l);
            if (l == m + 1u) {
                p = sqrt(2.0 * fm + 3.0) * w.z * pmm;
            } else if (l > m + 1u) {
                let a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
                let b = sqrt(((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0));
                p = a * (w.z * p1 - b * p2);
            }
            if (l > m) {
                p2 = p1;
                p1 = p;
            }
            // Y_{l,0} = p at index l(l+1); Y_{l,+-m} = sqrt(2) p C_m, sqrt(2) p S_m at l(l+1) +- m.
            let centre = at + l * (l + 1u);
            if (m == 0u) {
                acc = acc + p * sbrdf_values4(o, centre, pr, n, enc, scale);
            } else {
                let q = 1.41421356237 * p;
                acc = acc + (q * c) * sbrdf_values4(o, centre + m, pr, n, enc, scale);
                acc = acc + (q * s) * sbrdf_values4(o, centre - m, pr, n, enc, scale);
            }
        }
    }
    return acc;
}

// ------------------------------------------------------------------ lobes

// The angle between two unit vectors, radians, as 2 atan2(|a - b|, |a + b|): exact relative to
// a small angle, where acos(dot) or atan2(|a x b|, a . b) lose it (1 - cos of a 1e-3 rad angle
// is 5e-7, a few f32 units of 1). Angle Gaussians with tiny widths square this angle.
fn sbrdf_angle(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return 2.0 * sbrdf_atan2_pos(length(a - b), length(a + b));
}


// max(0, w . p)^n (kind 4). Written as exp(n log(1 - 2 sin^2(alpha/2))) with
// sin^2(alpha/2) = |w - p|^2 / 4: near the peak, where a large n makes the value sensitive,
// 1 - cos is then known to its relative precision instead of the absolute 6e-8 of a dot product
// (n = 10^4 would turn the latter into 6e-4 of relative error).
fn sbrdf_cos_power(w: vec3<f32>, p: vec3<f32>, n: f32) -> f32 {
    let cos_a = dot(w, p);
    if (n == 0.0) {
        return 1.0; // 0^0 = 1, as the reference decoder's ** gives
    }
    if (cos_a <= 0.0) {
        return 0.0;
    }
    let d = w - p;
    let x = min(0.5 * dot(d, d), 1.0); // 1 - cos alpha
    if (x >= 1.0) {
        return 0.0;
    }
    return exp(n * sbrdf_log1p(-x));
}


// Microfacet geometry and the four variants of kinds 2, 3 and 5 ("Lobes"). `kind` 2 or 3 with
// (b, c, a) in p.xyz; kind 5 with (bx, by, c) in p.xyz and (ax, ay, psi) in q.xyz.
fn sbrdf_microfacet(kind: u32, p: vec3<f32>, q: vec3<f32>, wi: vec3<f32>, w: vec3<f32>) -> vec4<f32> {
    let sv = wi + w;
    let s2 = dot(sv, sv);
    if (s2 == 0.0) {
        return vec4<f32>(0.0);
    }
    let sn = sqrt(s2);
    let h = sv / sn;
    let ch = clamp(h.z, 0.0, 1.0);
    // 1 - wi.h = |wi - h|^2 / 2 for unit vectors: F = (1 - cd)^5 keeps its relative precision
    // near cd = 1 (cd clamped to [1e-6, 1] as the spec says, so 1 - cd <= 1 - 1e-6).
    let dh = wi - h;
    let one_minus_cd = clamp(0.5 * dot(dh, dh), 0.0, 1.0 - 1e-6);
    let cd = clamp(dot(wi, h), 1e-6, 1.0);
    let ci = max(wi.z, 1e-6);
    let co = max(w.z, 1e-6);
    let vc = min(1.0 / (ci * co), min(2.0 * ch / (cd * ci), 2.0 * ch / (cd * co)));
    let f2 = one_minus_cd * one_minus_cd;
    let f = f2 * f2 * one_minus_cd;
    // The horizontal part of s: 1 - h.z and 1 - h.z^2 are taken from it, not by subtracting
    // h.z from 1, because the distribution (1 + b x)^-c with a large b (a small roughness)
    // multiplies x's error by b.
    let r2 = sv.x * sv.x + sv.y * sv.y;
    var dist = 0.0;
    var vs = 0.0;
    if (kind == 5u) {
        let cs = sbrdf_sincos_deg(q.z);
        let hu = h.x * cs.y + h.y * cs.x;
        let hv = h.y * cs.y - h.x * cs.x;
        let iu = wi.x * cs.y + wi.y * cs.x;
        let iv = wi.y * cs.y - wi.x * cs.x;
        let ou = w.x * cs.y + w.y * cs.x;
        let ov = w.y * cs.y - w.x * cs.x;
        dist = exp(-p.z * sbrdf_log1p(p.x * hu * hu + p.y * hv * hv));
        vs = 1.0 / (co * sqrt(ci * ci + q.x * q.x * iu * iu + q.y * q.y * iv * iv)
            + ci * sqrt(co * co + q.x * q.x * ou * ou + q.y * q.y * ov * ov));
    } else {
        var x = 1.0;
        if (sv.z > 0.0) {
            if (kind == 2u) {
                x = r2 / (sn * (sn + sv.z)); // 1 - h.z
            } else {
                x = r2 / s2; // 1 - h.z^2
            }
        }
        dist = exp(-p.y * sbrdf_log1p(p.x * x));
        let a2 = p.z * p.z;
        vs = 1.0 / (co * sqrt(a2 + (1.0 - a2) * ci * ci) + ci * sqrt(a2 + (1.0 - a2) * co * co));
    }
    return vec4<f32>(dist * vs, dist * vs * f, dist * vc, dist * vc * f);
}


// exp(-a2 / width_k) for the first n of the widths at word `par` from index k0 (an angle
// Gaussian's terms), 0 in the other lanes.
fn sbrdf_gauss4(a2: f32, par: u32, k0: u32, n: u32) -> vec4<f32> {
    var g = vec4<f32>(0.0);
    if (n > 0u) {
        g.x = exp(-a2 / sbrdf_f(par + k0));
    }
    if (n > 1u) {
        g.y = exp(-a2 / sbrdf_f(par + k0 + 1u));
    }
    if (n > 2u) {
        g.z = exp(-a2 / sbrdf_f(par + k0 + 2u));
    }
    if (n > 3u) {
        g.w = exp(-a2 / sbrdf_f(par + k0 + 3u));
    }
    return g;
}

// ------------------------------------------------------------------ the query

// The incident side of a query, shared by evaluation and sampling ("Reconstruction", steps 3
// and 4; "Between stored incidences"): the records blended, in the order the CPU's lattice
// first meets them, with their weights (all > 0); the evaluation incidence and its direction in
// the records' frame; the turn (cos, sin) into that frame (isotropic files; (1, 0) otherwise);
// the blended records' largest term count (T*) and lobe count.
struct SbrdfQuery {
    n: u32,
    rec: array<u32, 4>,
    w: array<f32, 4>,
    theta: f32,
    phi: f32,
    wi: vec3<f32>,
    // Warped tables (model section kind 2): the section's absolute word, 0 for every other
    // file. A warped query blends no records (n = 0, tmax = K); rec and w then hold what the
    // pair reads of the tables (sbrdf_warp_query). (Here, after the vec3, the word costs no
    // space: private memory is what a GPU is short of.)
    warp: u32,
    rot: vec2<f32>,
    tmax: u32,
    mmax: u32,
}

// v / |v| with (1, 1, 1, 1) in .w, or all 0 when v is zero, not finite, or below the horizon
// (the CPU decoder's `upper`). Scaled by its largest component first so that |v|^2 neither
// overflows nor underflows in f32 (the CPU widens to f64).
fn sbrdf_upper(v: vec3<f32>) -> vec4<f32> {
    if (!(sbrdf_finite(v.x) && sbrdf_finite(v.y) && sbrdf_finite(v.z))) {
        return vec4<f32>(0.0);
    }
    let m = max(abs(v.x), max(abs(v.y), abs(v.z)));
    if (m == 0.0) {
        return vec4<f32>(0.0);
    }
    let u = v / m;
    let n = u / length(u);
    if (n.z < 0.0) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(n, 1.0);
}


fn sbrdf_wrap360(x: f32) -> f32 {
    var r = x % 360.0;
    if (r < 0.0) {
        r = r + 360.0;
    }
    return select(r, 0.0, r >= 360.0);
}


// "Between stored incidences", Bracketing, over n f32 words at `o`: (i, t) in (.x as bits, .y).
fn sbrdf_bracket(o: u32, n: u32, x: f32) -> vec2<f32> {
    if (n == 1u || x <= sbrdf_f(o)) {
        return vec2<f32>(0.0, 0.0);
    }
    if (x >= sbrdf_f(o + n - 1u)) {
        return vec2<f32>(bitcast<f32>(n - 2u), 1.0);
    }
    // Largest i with xs[i] <= x < xs[i + 1]: binary search, 32 steps bound any u32 count.
    var lo = 0u;
    var hi = n - 1u;
    for (var it = 0u; it < 32u; it = it + 1u) {
        if (hi - lo <= 1u) {
            break;
        }
        let mid = (lo + hi) >> 1u;
        if (sbrdf_f(o + mid) <= x) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = sbrdf_f(o + lo);
    let b = sbrdf_f(o + lo + 1u);
    return vec2<f32>(bitcast<f32>(lo), (x - a) / (b - a));
}


// Record rec with weight w added to the blend as the CPU's Blend::push adds it: a weight <= 0
// is dropped, a record already there gets the weight added, records stay in the order they were
// first added (the sampling mixture's components follow this order, and u.x picks among them
// in it).
fn sbrdf_push(q: ptr<function, SbrdfQuery>, rec: u32, w: f32) {
    if (!(w > 0.0)) {
        return;
    }
    for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
        if (i >= (*q).n) {
            break;
        }
        if ((*q).rec[i] == rec) {
            (*q).w[i] = (*q).w[i] + w;
            return;
        }
    }
    let n = (*q).n;
    (*q).rec[n] = rec;
    (*q).w[n] = w;
    (*q).n = n + 1u;
}

// The query's incident side for the unit incident vector ui (z >= 0), into q.
fn sbrdf_query(base: u32, ui: vec3<f32>, q: ptr<function, SbrdfQuery>) {
    let inc_layout = sbrdf_u(base + SBRDF_HDR_INCIDENCE);
    let isotropic = inc_layout == SBRDF_INCIDENCE_ISOTROPIC;
    (*q).n = 0u;
    (*q).warp = 0u;
    (*q).rot = vec2<f32>(1.0, 0.0);
    // theta of the query from its horizontal length and height (atan2, so that it keeps its
    // precision near the normal, where acos(z) does not).
    let r = sqrt(ui.x * ui.x + ui.y * ui.y);
    let theta_q = sbrdf_atan2_deg(r, ui.z);
    var wq = ui;
    var phi_q = 0.0;
    if (isotropic) {
        // Step 3: the turn that gives wi azimuth 0, its cosine and sine taken from the vector
        // (no trigonometry).
        if (r > 0.0) {
            (*q).rot = vec2<f32>(ui.x / r, ui.y / r);
        }
        wq = vec3<f32>(r, 0.0, ui.z);
    } else if (r > 0.0) {
        phi_q = sbrdf_wrap360(sbrdf_atan2_deg(ui.y, ui.x));
    }
    // Step 4: the records to blend and the evaluation incidence.
    if (inc_layout == SBRDF_INCIDENCE_SCATTERED) {
        // The nearest stored incidence (largest cosine, the lowest index on ties).
        let n_rec = sbrdf_u(base + SBRDF_HDR_RECORDS);
        var best = 0u;
        var best_cos = -2.0;
        for (var i = 0u; i < n_rec; i = i + 1u) {
            let e = sbrdf_rec(base, i);
            let cs = dot(sbrdf_dir(sbrdf_f(e + SBRDF_REC_THETA_I), sbrdf_f(e + SBRDF_REC_PHI_I)), ui);
            if (cs > best_cos) {
                best_cos = cs;
                best = i;
            }
        }
        let e = sbrdf_rec(base, best);
        (*q).n = 1u;
        (*q).rec[0] = best;
        (*q).w[0] = 1.0;
        (*q).theta = sbrdf_f(e + SBRDF_REC_THETA_I);
        (*q).phi = sbrdf_f(e + SBRDF_REC_PHI_I);
        (*q).wi = sbrdf_dir((*q).theta, (*q).phi);
    } else {
        let n_theta = sbrdf_u(base + SBRDF_HDR_THETAS);
        let n_phi = sbrdf_u(base + SBRDF_HDR_PHIS);
        let off_th = base + sbrdf_u(base + SBRDF_HDR_OFF_THETAS);
        let off_ph = base + sbrdf_u(base + SBRDF_HDR_OFF_PHIS);
        let theta = clamp(theta_q, sbrdf_f(off_th), sbrdf_f(off_th + n_theta - 1u));
        (*q).theta = theta;
        let bt = sbrdf_bracket(off_th, n_theta, theta_q);
        let i = bitcast<u32>(bt.x);
        let t = bt.y;
        let i2 = min(i + 1u, n_theta - 1u);
        if (isotropic) {
            sbrdf_push(q, i, 1.0 - t);
            sbrdf_push(q, i2, t);
            (*q).phi = 0.0;
            // theta unclamped: the evaluation direction is the query's own vector (more
            // precise than rebuilding it from an f32 angle).
            (*q).wi = select(sbrdf_dir(theta, 0.0), wq, theta == theta_q);
        } else {
            var j = 0u;
            var j2 = 0u;
            var u = 0.0;
            if (n_phi > 1u) {
                let p0 = sbrdf_f(off_ph);
                let p1 = sbrdf_f(off_ph + n_phi - 1u);
                if (phi_q < p0 || phi_q >= p1) {
                    j = n_phi - 1u;
                    j2 = 0u;
                    u = sbrdf_wrap360(phi_q - p1) / (p0 + 360.0 - p1);
                } else {
                    let bp = sbrdf_bracket(off_ph, n_phi, phi_q);
                    j = bitcast<u32>(bp.x);
                    u = bp.y;
                    j2 = j + 1u;
                }
            }
            sbrdf_push(q, i * n_phi + j, (1.0 - t) * (1.0 - u));
            sbrdf_push(q, i * n_phi + j2, (1.0 - t) * u);
            sbrdf_push(q, i2 * n_phi + j, t * (1.0 - u));
            sbrdf_push(q, i2 * n_phi + j2, t * u);
            if ((*q).n == 0u) {
                sbrdf_push(q, i * n_phi + j, 1.0); // as the CPU (no weight > 0)
            }
            if (n_phi == 1u) {
                (*q).phi = sbrdf_f(off_ph); // a single stored azimuth is clamped to, like theta
                (*q).wi = sbrdf_dir(theta, (*q).phi);
            } else {
                (*q).phi = phi_q;
                (*q).wi = select(sbrdf_dir(theta, phi_q), ui, theta == theta_q);
            }
        }
    }
    // The blended records' largest term and lobe counts.
    var tmax = 1u;
    var mmax = 0u;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b >= (*q).n) {
            break;
        }
        let e = sbrdf_rec(base, (*q).rec[b]);
        tmax = max(tmax, sbrdf_u(e + SBRDF_REC_TERMS));
        mmax = max(mmax, sbrdf_u(e + SBRDF_REC_LOBES));
    }
    (*q).tmax = min(tmax, SBRDF_MAX_TERMS);
    (*q).mmax = min(mmax, SBRDF_MAX_LOBES);
}

// The query of an evaluation at unit ui, uo: sbrdf_query's incident side, or for warped
// tables (whose tables follow the viewer's direction, so that the query depends on both) the
// section's query, no records, tmax = K.
fn sbrdf_query_pair(base: u32, ui: vec3<f32>, uo: vec3<f32>, q: ptr<function, SbrdfQuery>) {
    let w = sbrdf_warp_section(base);
    if (w == 0u) {
        sbrdf_query(base, ui, q);
        return;
    }
    (*q).n = 0u;
    (*q).rot = vec2<f32>(1.0, 0.0);
    (*q).wi = ui;
    (*q).tmax = min(sbrdf_u(w + SBRDF_WARP_K), SBRDF_MAX_TERMS);
    (*q).mmax = 0u;
    (*q).warp = w;
    sbrdf_warp_query(w, ui, uo, q);
}

// A local-frame vector in the records' frame, and back.
fn sbrdf_to_records(q: ptr<function, SbrdfQuery>, v: vec3<f32>) -> vec3<f32> {
    let c = (*q).rot;
    return vec3<f32>(c.x * v.x + c.y * v.y, -c.y * v.x + c.x * v.y, v.z);
}

fn sbrdf_from_records(q: ptr<function, SbrdfQuery>, v: vec3<f32>) -> vec3<f32> {
    let c = (*q).rot;
    return vec3<f32>(c.x * v.x - c.y * v.y, c.y * v.x + c.x * v.y, v.z);
}

// ------------------------------------------------------------------ lobes by position

// The peak direction of the record whose entry is at e.
fn sbrdf_rec_peak(e: u32) -> vec3<f32> {
    return sbrdf_dir(sbrdf_f(e + SBRDF_REC_THETA_P), sbrdf_f(e + SBRDF_REC_PHI_P));
}

// The kind of lobe li when every blended record (more than one) has a lobe of that one kind
// there ("Lobes by position": shared); 0 otherwise.
fn sbrdf_shared_kind(base: u32, q: ptr<function, SbrdfQuery>, li: u32) -> u32 {
    if ((*q).n < 2u) {
        return 0u;
    }
    var shared_kind = 0xffffffffu;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b >= (*q).n) {
            break;
        }
        let e = sbrdf_rec(base, (*q).rec[b]);
        var kind = 0u;
        if (li < sbrdf_u(e + SBRDF_REC_LOBES)) {
            kind = sbrdf_u(sbrdf_lobe(base, e, li) + SBRDF_LOBE_KIND);
        }
        if (kind == 0u || (shared_kind != 0xffffffffu && kind != shared_kind)) {
            return 0u;
        }
        shared_kind = kind;
    }
    return shared_kind;
}

// Parameter i of lobe li of blended record b.
fn sbrdf_shared_par(base: u32, q: ptr<function, SbrdfQuery>, b: u32, li: u32, i: u32) -> f32 {
    let lt = sbrdf_lobe(base, sbrdf_rec(base, (*q).rec[b]), li);
    return sbrdf_f(base + sbrdf_u(lt + SBRDF_LOBE_OFF_PARAMETERS) + i);
}

// Weighted geometric mean of parameter i over the blended records: exp(sum w log x).
fn sbrdf_shared_geo(base: u32, q: ptr<function, SbrdfQuery>, li: u32, i: u32) -> f32 {
    var s = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            s = s + (*q).w[b] * sbrdf_ln(sbrdf_shared_par(base, q, b, li, i));
        }
    }
    return exp(s);
}

// Weighted arithmetic mean of parameter i over the blended records.
fn sbrdf_shared_lin(base: u32, q: ptr<function, SbrdfQuery>, li: u32, i: u32) -> f32 {
    var s = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            s = s + (*q).w[b] * sbrdf_shared_par(base, q, b, li, i);
        }
    }
    return s;
}

// The axis angle psi (parameter 5 of kind 5) of lobe li blended as an axis: the doubled angles'
// weighted mean, halved back to [0, 180); the first record's psi when that mean vanishes.
fn sbrdf_shared_axis(base: u32, q: ptr<function, SbrdfQuery>, li: u32) -> f32 {
    var x = 0.0;
    var yv = 0.0;
    var tw = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            let cs = sbrdf_sincos_deg(2.0 * sbrdf_shared_par(base, q, b, li, 5u));
            x = x + (*q).w[b] * cs.y;
            yv = yv + (*q).w[b] * cs.x;
            tw = tw + abs((*q).w[b]);
        }
    }
    var psi = sbrdf_shared_par(base, q, 0u, li, 5u);
    if (sqrt(x * x + yv * yv) > 1e-9 * tw) {
        psi = 0.5 * sbrdf_atan2_deg(yv, x);
        if (psi < 0.0) {
            psi = psi + 180.0;
        }
        if (psi >= 180.0) {
            psi = 0.0;
        }
    }
    return psi;
}

// "Blended peak direction" of a lobe shared by the blended records (kinds 1 and 4).
// Isotropic files: the weighted sum of the records' peak directions, normalised; vec4(0) in .w
// when it cannot be (zero or not finite), vec4(p, 1) otherwise.
fn sbrdf_blended_peak_sum(base: u32, q: ptr<function, SbrdfQuery>) -> vec4<f32> {
    var v = vec3<f32>(0.0);
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            v = v + (*q).w[b] * sbrdf_rec_peak(sbrdf_rec(base, (*q).rec[b]));
        }
    }
    let n = length(v);
    if (n != 0.0 && sbrdf_finite(n)) {
        return vec4<f32>(v / n, 1.0);
    }
    return vec4<f32>(0.0);
}

fn sbrdf_blended_peak(base: u32, q: ptr<function, SbrdfQuery>) -> vec3<f32> {
    if (sbrdf_u(base + SBRDF_HDR_INCIDENCE) == SBRDF_INCIDENCE_ISOTROPIC) {
        let p = sbrdf_blended_peak_sum(base, q);
        if (p.w != 0.0) {
            return p.xyz;
        }
    }
    var dt = 0.0;
    var dp = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            let e = sbrdf_rec(base, (*q).rec[b]);
            let ti = sbrdf_f(e + SBRDF_REC_THETA_I);
            let pi = sbrdf_f(e + SBRDF_REC_PHI_I);
            let tp = sbrdf_f(e + SBRDF_REC_THETA_P);
            let pp = sbrdf_f(e + SBRDF_REC_PHI_P);
            dt = dt + (*q).w[b] * (tp - ti);
            if (tp != 0.0) {
                var off = (pp - (pi + 180.0)) % 360.0;
                if (off > 180.0) {
                    off = off - 360.0;
                } else if (off <= -180.0) {
                    off = off + 360.0;
                }
                dp = dp + (*q).w[b] * off;
            }
        }
    }
    return sbrdf_dir((*q).theta + dt, sbrdf_wrap360((*q).phi + 180.0) + dp);
}

// Terms k0 .. k0 + 3 of one record's lobe li at the evaluation incidence wis and the outgoing
// w (records' frame): its amplitudes times the lobe's shape, 0 past the record's terms.
fn sbrdf_lobe4(base: u32, e: u32, li: u32, wis: vec3<f32>, w: vec3<f32>, k0: u32) -> vec4<f32> {
    let terms = sbrdf_u(e + SBRDF_REC_TERMS);
    let n = sbrdf_chunk(k0, terms);
    if (n == 0u) {
        return vec4<f32>(0.0);
    }
    let enc = sbrdf_u(e + SBRDF_REC_ENCODING);
    let scale = sbrdf_f(e + SBRDF_REC_SCALE);
    let lt = sbrdf_lobe(base, e, li);
    let kind = sbrdf_u(lt + SBRDF_LOBE_KIND);
    let amp = base + sbrdf_u(lt + SBRDF_LOBE_OFF_AMPLITUDES);
    let par = base + sbrdf_u(lt + SBRDF_LOBE_OFF_PARAMETERS);
    if (kind == 1u || kind == 4u) {
        let peak = sbrdf_rec_peak(e);
        let a = sbrdf_values4(amp, k0, 1u, n, enc, scale);
        if (kind == 1u) {
            let angle = sbrdf_angle(w, peak);
            return a * sbrdf_gauss4(angle * angle, par, k0, n);
        }
        return a * sbrdf_cos_power(w, peak, sbrdf_f(par));
    }
    // Microfacet kinds 2, 3 and 5: (b, c, a) or (bx, by, c, ax, ay, psi), four variants.
    var q = vec3<f32>(0.0);
    if (kind == 5u) {
        q = vec3<f32>(sbrdf_f(par + 3u), sbrdf_f(par + 4u), sbrdf_f(par + 5u));
    }
    let p = vec3<f32>(sbrdf_f(par), sbrdf_f(par + 1u), sbrdf_f(par + 2u));
    let v = sbrdf_microfacet(kind, p, q, wis, w);
    return v.x * sbrdf_values4(amp, k0, 1u, n, enc, scale)
        + v.y * sbrdf_values4(amp, terms + k0, 1u, n, enc, scale)
        + v.z * sbrdf_values4(amp, 2u * terms + k0, 1u, n, enc, scale)
        + v.w * sbrdf_values4(amp, 3u * terms + k0, 1u, n, enc, scale);
}

// Terms k0 .. k0 + 3 of the blended amplitudes (variant j) of the shared lobe li: the sum over
// the records of weight times amplitude ("Lobes by position"); a record with fewer terms adds 0.
fn sbrdf_shared_amp4(base: u32, q: ptr<function, SbrdfQuery>, li: u32, j: u32, k0: u32) -> vec4<f32> {
    var a = vec4<f32>(0.0);
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            let e = sbrdf_rec(base, (*q).rec[b]);
            let terms = sbrdf_u(e + SBRDF_REC_TERMS);
            let lt = sbrdf_lobe(base, e, li);
            let amp = base + sbrdf_u(lt + SBRDF_LOBE_OFF_AMPLITUDES);
            a = a + (*q).w[b] * sbrdf_values4(amp, j * terms + k0, 1u, sbrdf_chunk(k0, terms),
                sbrdf_u(e + SBRDF_REC_ENCODING), sbrdf_f(e + SBRDF_REC_SCALE));
        }
    }
    return a;
}

// ln of the blended width of each of the terms k0 .. k0 + 3 of the shared angle Gaussian li:
// the weighted mean of the logarithms over the records that have the term, their weights
// renormalised (lanes past T* are not used).
fn sbrdf_shared_ln_widths4(base: u32, q: ptr<function, SbrdfQuery>, li: u32, k0: u32) -> vec4<f32> {
    var s = vec4<f32>(0.0);
    var ws = vec4<f32>(0.0);
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            let e = sbrdf_rec(base, (*q).rec[b]);
            let nb = sbrdf_chunk(k0, sbrdf_u(e + SBRDF_REC_TERMS));
            let par = base + sbrdf_u(sbrdf_lobe(base, e, li) + SBRDF_LOBE_OFF_PARAMETERS) + k0;
            let wb = (*q).w[b];
            if (nb > 0u) {
                s.x = s.x + wb * sbrdf_ln(sbrdf_f(par));
                ws.x = ws.x + wb;
            }
            if (nb > 1u) {
                s.y = s.y + wb * sbrdf_ln(sbrdf_f(par + 1u));
                ws.y = ws.y + wb;
            }
            if (nb > 2u) {
                s.z = s.z + wb * sbrdf_ln(sbrdf_f(par + 2u));
                ws.z = ws.z + wb;
            }
            if (nb > 3u) {
                s.w = s.w + wb * sbrdf_ln(sbrdf_f(par + 3u));
                ws.w = ws.w + wb;
            }
        }
    }
    return s / ws;
}

// exp(-a2 / exp(ln_w)) at the first n lanes, 0 in the others: an angle Gaussian of widths
// exp(ln_w).
fn sbrdf_gauss_ln4(a2: f32, ln_w: vec4<f32>, n: u32) -> vec4<f32> {
    var g = vec4<f32>(0.0);
    if (n > 0u) {
        g.x = exp(-a2 / exp(ln_w.x));
    }
    if (n > 1u) {
        g.y = exp(-a2 / exp(ln_w.y));
    }
    if (n > 2u) {
        g.z = exp(-a2 / exp(ln_w.z));
    }
    if (n > 3u) {
        g.w = exp(-a2 / exp(ln_w.w));
    }
    return g;
}

// Terms k0 .. k0 + 3 of a shared microfacet lobe li whose four variants' values are v: the
// variants' blended amplitudes weighted by them.
fn sbrdf_shared_variants4(base: u32, q: ptr<function, SbrdfQuery>, li: u32, k0: u32, v: vec4<f32>) -> vec4<f32> {
    return v.x * sbrdf_shared_amp4(base, q, li, 0u, k0) + v.y * sbrdf_shared_amp4(base, q, li, 1u, k0)
        + v.z * sbrdf_shared_amp4(base, q, li, 2u, k0) + v.w * sbrdf_shared_amp4(base, q, li, 3u, k0);
}

// Terms k0 .. k0 + 3 of the lobe li shared by every blended record, of the given kind:
// amplitudes blended linearly, shape parameters as "Lobes by position" says, evaluated once.
fn sbrdf_shared_lobe4(base: u32, q: ptr<function, SbrdfQuery>, kind: u32, li: u32, w: vec3<f32>,
    k0: u32) -> vec4<f32> {
    if (kind == 1u) {
        let angle = sbrdf_angle(w, sbrdf_blended_peak(base, q));
        let g = sbrdf_gauss_ln4(angle * angle, sbrdf_shared_ln_widths4(base, q, li, k0),
            sbrdf_chunk(k0, (*q).tmax));
        return sbrdf_shared_amp4(base, q, li, 0u, k0) * g;
    }
    if (kind == 4u) {
        let f = sbrdf_cos_power(w, sbrdf_blended_peak(base, q), sbrdf_shared_geo(base, q, li, 0u));
        return sbrdf_shared_amp4(base, q, li, 0u, k0) * f;
    }
    if (kind == 5u) {
        let p = vec3<f32>(sbrdf_shared_geo(base, q, li, 0u), sbrdf_shared_geo(base, q, li, 1u),
            sbrdf_shared_geo(base, q, li, 2u));
        let pq = vec3<f32>(sbrdf_shared_lin(base, q, li, 3u), sbrdf_shared_lin(base, q, li, 4u),
            sbrdf_shared_axis(base, q, li));
        return sbrdf_shared_variants4(base, q, li, k0, sbrdf_microfacet(kind, p, pq, (*q).wi, w));
    }
    let p = vec3<f32>(sbrdf_shared_geo(base, q, li, 0u), sbrdf_shared_geo(base, q, li, 1u),
        sbrdf_shared_lin(base, q, li, 2u));
    return sbrdf_shared_variants4(base, q, li, k0, sbrdf_microfacet(kind, p, vec3<f32>(0.0), (*q).wi, w));
}

// ------------------------------------------------------------------ the records' series

// Terms k0 .. k0 + 3 of the blended spectral coefficients at the outgoing direction wo in the
// records' frame ("Reconstruction": the SH background, then the lobes by position), 0 past T*.
fn sbrdf_coef4(base: u32, q: ptr<function, SbrdfQuery>, wo: vec3<f32>, k0: u32) -> vec4<f32> {
    var c = vec4<f32>(0.0);
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b >= (*q).n) {
            break;
        }
        c = c + (*q).w[b] * sbrdf_sh4(base, sbrdf_rec(base, (*q).rec[b]), wo, k0);
    }
    for (var li = 0u; li < SBRDF_MAX_LOBES; li = li + 1u) {
        if (li >= (*q).mmax) {
            break;
        }
        let kind = sbrdf_shared_kind(base, q, li);
        if (kind != 0u) {
            c = c + sbrdf_shared_lobe4(base, q, kind, li, wo, k0);
            continue;
        }
        for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
            if (b >= (*q).n) {
                break;
            }
            let e = sbrdf_rec(base, (*q).rec[b]);
            if (li < sbrdf_u(e + SBRDF_REC_LOBES)) {
                c = c + (*q).w[b] * sbrdf_lobe4(base, e, li, (*q).wi, wo, k0);
            }
        }
    }
    return c;
}

// k u mod 1 for an integer k < 2^12 and u in [0, 1], accurate to the rounding of u itself:
// u is split into a head of 12 bits (k times it is exact in f32, so its fraction is exact)
// and a tail (whose product rounds at 2^-24 of a value below 2^-12 k). A plain fract(k u)
// would lose log2(k) bits, and the Fourier basis goes up to k = 128 (K <= 256).
fn sbrdf_frac_mul(k: f32, u: f32) -> f32 {
    let head = floor(u * 4096.0) / 4096.0;
    let tail = u - head;
    return fract(fract(k * head) + k * tail);
}


// B_k(lambda) of basis `basis` for term k ("Spectral basis"): tabulated (3) from row k of the
// basis table (absolute word tab, nw wavelengths a row) between wavelengths i and i + 1 at
// fraction f; Fourier (1) and cosine (2) at
// u = (lambda - lambda_min) / (lambda_max - lambda_min) in [0, 1].
fn sbrdf_basis_term(basis: u32, tab: u32, nw: u32, k: u32, i: u32, f: f32, u: f32) -> f32 {
    if (basis == 3u) {
        let row = tab + k * nw;
        var bk = sbrdf_f(row + i);
        if (f != 0.0) {
            bk = bk + f * (sbrdf_f(row + i + 1u) - bk);
        }
        return bk;
    }
    if (basis == 1u) {
        // Fourier: 1/2, cos(2 pi j u), sin(2 pi j u), ... with the phase j u reduced in turns.
        if (k == 0u) {
            return 0.5;
        }
        let cs = sbrdf_sincos_turns(sbrdf_frac_mul(f32((k + 1u) / 2u), u));
        return select(cs.x, cs.y, (k & 1u) == 1u);
    }
    // Cosine: cos(pi k u) = cos(2 pi (k u / 2)); k u / 2 in turns, reduced exactly.
    return sbrdf_sincos_turns(sbrdf_frac_mul(f32(k), 0.5 * u)).y;
}

// B_k(lambda) for the terms k = k0 .. k0 + 3 below tmax, 0 past them.
fn sbrdf_basis4(base: u32, k0: u32, tmax: u32, lambda: f32) -> vec4<f32> {
    let basis = sbrdf_u(base + SBRDF_HDR_BASIS);
    let nw = sbrdf_u(base + SBRDF_HDR_WAVES);
    let tab = base + sbrdf_u(base + SBRDF_HDR_OFF_BASIS_TABLE);
    var i = 0u;
    var f = 0.0;
    var u = 0.0;
    if (basis == 3u) {
        // Tabulated: linear between the wavelengths, held at the ends.
        let ow = base + sbrdf_u(base + SBRDF_HDR_OFF_WAVES);
        if (nw > 1u && lambda > sbrdf_f(ow)) {
            let bw = sbrdf_bracket(ow, nw, lambda);
            i = bitcast<u32>(bw.x);
            f = bw.y;
        }
    } else {
        let lo = sbrdf_f(base + SBRDF_HDR_LAMBDA_MIN);
        let hi = sbrdf_f(base + SBRDF_HDR_LAMBDA_MAX);
        if (hi > lo) {
            u = clamp((clamp(lambda, lo, hi) - lo) / (hi - lo), 0.0, 1.0);
        }
    }
    let n = sbrdf_chunk(k0, tmax);
    var b = vec4<f32>(0.0);
    if (n > 0u) {
        b.x = sbrdf_basis_term(basis, tab, nw, k0, i, f, u);
    }
    if (n > 1u) {
        b.y = sbrdf_basis_term(basis, tab, nw, k0 + 1u, i, f, u);
    }
    if (n > 2u) {
        b.z = sbrdf_basis_term(basis, tab, nw, k0 + 2u, i, f, u);
    }
    if (n > 3u) {
        b.w = sbrdf_basis_term(basis, tab, nw, k0 + 3u, i, f, u);
    }
    return b;
}

// ------------------------------------------------------------------ the factor model

// The model section of kind 1 (spec/GPU_LAYOUT.md, "Model section"; spec/EVALUATION.md, "Factor
// model"): F(wi, wo, lambda) = sum_c exp(min(eta_c, 60)), added to the records' series before
// the clamp at 0. Each angular term T_cr (a sum of table lookups, depending on the directions
// only) is computed once per query and used at once for every wavelength asked.

// The theta_h axis's nodes (code 1), 23 of them.
fn sbrdf_fact_node_h(i: u32) -> f32 {
    switch (i) {
        case 0u: { return 0.0; }
        case 1u: { return 0.25; }
        case 2u: { return 0.5; }
        case 3u: { return 0.75; }
        case 4u: { return 1.0; }
        case 5u: { return 1.5; }
        case 6u: { return 2.0; }
        case 7u: { return 3.0; }
        case 8u: { return 4.0; }
        case 9u: { return 5.0; }
        case 10u: { return 6.5; }
        case 11u: { return 8.0; }
        case 12u: { return 10.0; }
        case 13u: { return 13.0; }
        case 14u: { return 16.0; }
        case 15u: { return 20.0; }
        case 16u: { return 25.0; }
        case 17u: { return 30.0; }
        case 18u: { return 40.0; }
        case 19u: { return 50.0; }
        case 20u: { return 60.0; }
        case 21u: { return 75.0; }
        default: { return 90.0; }
    }
}

// U = 1/cos at the polar axis's nodes (codes 3 and 4: 0, 10, ..., 70, 75, 80, 85, 88 degrees),
// computed in f64 and rounded to f32.
fn sbrdf_fact_u_polar(i: u32) -> f32 {
    switch (i) {
        case 0u: { return 1.0; }
        case 1u: { return 1.015426636; }
        case 2u: { return 1.064177752; }
        case 3u: { return 1.154700518; }
        case 4u: { return 1.305407286; }
        case 5u: { return 1.555723786; }
        case 6u: { return 2.0; }
        case 7u: { return 2.923804283; }
        case 8u: { return 3.863703251; }
        case 9u: { return 5.758770466; }
        case 10u: { return 11.47371292; }
        default: { return 28.6537075; }
    }
}

// The index on the polar axis of node i of `axis`: 2, theta_i / theta_o, itself; 3, the coarse
// theta_i axis of code 6 (0, 20, 40, 60, 70, 80, 88 degrees: polar nodes 0, 2, 4, 6, 7, 9, 11).
fn sbrdf_fact_polar_index(axis: u32, i: u32) -> u32 {
    if (axis == 3u) {
        return select(2u * i, 2u * i - 1u, i >= 4u);
    }
    return i;
}

// Node i of `axis` (0 theta_h; 2 and 3 as sbrdf_fact_polar_index), degrees.
fn sbrdf_fact_node(axis: u32, i: u32) -> f32 {
    if (axis == 0u) {
        return sbrdf_fact_node_h(i);
    }
    let p = sbrdf_fact_polar_index(axis, i);
    if (p <= 7u) {
        return 10.0 * f32(p);
    }
    return min(75.0 + 5.0 * f32(p - 8u), 88.0);
}

// (j, a) of v on an axis ("Tables": the largest j with n_j <= v, at most m - 2; a linear in U,
// clamped to [0, 1]): axis 0 theta_h, 1 theta_d (every 10 degrees), 2 theta_i / theta_o
// (in 1/cos, u = 1/cos of v), 3 the coarse theta_i axis of code 6 (likewise), 4 x (every 0.25).
// v is already clamped to the stored range, which lies within the nodes.
fn sbrdf_fact_locate(axis: u32, v: f32, u: f32) -> vec2<f32> {
    var j = 0u;
    var a = 0.0;
    if (axis == 1u) {
        j = min(u32(max(floor(v / 10.0), 0.0)), 8u);
        a = (v - 10.0 * f32(j)) / 10.0;
    } else if (axis == 4u) {
        j = min(u32(max(floor((v + 1.0) * 4.0), 0.0)), 7u);
        a = (v - (-1.0 + 0.25 * f32(j))) * 4.0;
    } else {
        // Binary search over the m nodes (23, 12 or 7).
        let m = select(select(7u, 12u, axis == 2u), 23u, axis == 0u);
        var hi = m - 1u;
        for (var it = 0u; it < 8u; it = it + 1u) {
            if (hi - j <= 1u) {
                break;
            }
            let mid = (j + hi) >> 1u;
            if (sbrdf_fact_node(axis, mid) <= v) {
                j = mid;
            } else {
                hi = mid;
            }
        }
        if (axis == 0u) {
            let n0 = sbrdf_fact_node_h(j);
            a = (v - n0) / (sbrdf_fact_node_h(j + 1u) - n0);
        } else {
            let u0 = sbrdf_fact_u_polar(sbrdf_fact_polar_index(axis, j));
            a = (u - u0) / (sbrdf_fact_u_polar(sbrdf_fact_polar_index(axis, j + 1u)) - u0);
        }
    }
    return vec2<f32>(bitcast<f32>(j), clamp(a, 0.0, 1.0));
}

// U = 1/cos(v degrees) of a polar feature v clamped to [0, 88]. `z` is the direction's own
// cosine: when v is the unclamped angle of that direction, 1/z is U to f32 rounding, more
// precise than the cosine of an f32 angle (which near 88 degrees loses tan(88) = 29 times).
fn sbrdf_fact_secant(v: f32, raw: f32, z: f32) -> f32 {
    let vc = clamp(v, 0.0, 88.0);
    if (vc == raw && z > 0.0) {
        return 1.0 / z;
    }
    return 1.0 / sbrdf_sincos_deg(vc).y;
}


// The value of table `code` (1..6) stored from value index `at` of a component's values.
// f = (theta_h, theta_d, theta_i, theta_o) clamped, x clamped, s = (U of theta_i, U of theta_o).
fn sbrdf_fact_table(o: u32, enc: u32, at: u32, code: u32, f: vec4<f32>, x: f32,
    s: vec2<f32>) -> f32 {
    if (code == 6u) {
        let p = sbrdf_fact_locate(3u, f.z, s.x);
        let q = sbrdf_fact_locate(4u, x, 0.0);
        let j = bitcast<u32>(p.x);
        let i = bitcast<u32>(q.x);
        let a = p.y;
        let b = q.y;
        let t00 = sbrdf_value(o, at + 9u * j + i, enc, 1.0);
        let t01 = sbrdf_value(o, at + 9u * j + i + 1u, enc, 1.0);
        let t10 = sbrdf_value(o, at + 9u * (j + 1u) + i, enc, 1.0);
        let t11 = sbrdf_value(o, at + 9u * (j + 1u) + i + 1u, enc, 1.0);
        return (1.0 - a) * (1.0 - b) * t00 + (1.0 - a) * b * t01 + a * (1.0 - b) * t10
            + a * b * t11;
    }
    var ja = vec2<f32>(0.0);
    if (code == 1u) {
        ja = sbrdf_fact_locate(0u, f.x, 0.0);
    } else if (code == 2u) {
        ja = sbrdf_fact_locate(1u, f.y, 0.0);
    } else if (code == 3u) {
        ja = sbrdf_fact_locate(2u, f.z, s.x);
    } else if (code == 4u) {
        ja = sbrdf_fact_locate(2u, f.w, s.y);
    } else {
        ja = sbrdf_fact_locate(4u, x, 0.0);
    }
    let j = bitcast<u32>(ja.x);
    let t0 = sbrdf_value(o, at + j, enc, 1.0);
    let t1 = sbrdf_value(o, at + j + 1u, enc, 1.0);
    return (1.0 - ja.y) * t0 + ja.y * t1;
}


// Node count of a feature code's table.
fn sbrdf_fact_len(code: u32) -> u32 {
    switch (code) {
        case 1u: { return 23u; }
        case 2u: { return 10u; }
        case 3u, 4u: { return 12u; }
        case 5u: { return 9u; }
        default: { return 63u; }
    }
}


// n_c, the node count of a component's tables: the sum over its nf packed feature codes.
fn sbrdf_fact_nodes(codes: u32, nf: u32) -> u32 {
    var nodes = 0u;
    for (var k = 0u; k < 6u; k = k + 1u) {
        if (k < nf) {
            nodes = nodes + sbrdf_fact_len((codes >> (4u * k)) & 15u);
        }
    }
    return nodes;
}


// (j, a) of a finite wavelength among the layout's W wavelengths ("Factor model", Spectra):
// linear between wavelengths j and j + 1 at fraction a, held at the ends.
fn sbrdf_fact_bracket(base: u32, lambda: f32) -> vec2<f32> {
    let w = sbrdf_u(base + SBRDF_HDR_WAVES);
    let ow = base + sbrdf_u(base + SBRDF_HDR_OFF_WAVES);
    if (w > 1u && lambda > sbrdf_f(ow)) {
        if (lambda >= sbrdf_f(ow + w - 1u)) {
            return vec2<f32>(bitcast<f32>(w - 1u), 0.0);
        }
        return sbrdf_bracket(ow, w, lambda);
    }
    return vec2<f32>(0.0, 0.0);
}

// A spectrum of a component (W values from value `at`) at a wavelength placed by
// sbrdf_fact_bracket: linear between values j and j + 1 at fraction a.
fn sbrdf_fact_spectrum(o: u32, enc: u32, at: u32, j: u32, a: f32) -> f32 {
    var sp = sbrdf_value(o, at + j, enc, 1.0);
    if (a != 0.0) {
        sp = sp + a * (sbrdf_value(o, at + j + 1u, enc, 1.0) - sp);
    }
    return sp;
}

// The same at the first nl of four wavelengths (their j in jv, a in av), 0 in the other lanes.
fn sbrdf_fact_spectra4(o: u32, enc: u32, at: u32, jv: vec4<u32>, av: vec4<f32>, nl: u32) -> vec4<f32> {
    var v = vec4<f32>(0.0);
    v.x = sbrdf_fact_spectrum(o, enc, at, jv.x, av.x);
    if (nl > 1u) {
        v.y = sbrdf_fact_spectrum(o, enc, at, jv.y, av.y);
    }
    if (nl > 2u) {
        v.z = sbrdf_fact_spectrum(o, enc, at, jv.z, av.z);
    }
    if (nl > 3u) {
        v.w = sbrdf_fact_spectrum(o, enc, at, jv.w, av.w);
    }
    return v;
}

// exp(min(eta, 60)) at the first nl lanes, 0 in the others.
fn sbrdf_fact_exp4(eta: vec4<f32>, nl: u32) -> vec4<f32> {
    var v = vec4<f32>(0.0);
    v.x = exp(min(eta.x, 60.0));
    if (nl > 1u) {
        v.y = exp(min(eta.y, 60.0));
    }
    if (nl > 2u) {
        v.z = exp(min(eta.z, 60.0));
    }
    if (nl > 3u) {
        v.w = exp(min(eta.w, 60.0));
    }
    return v;
}

// The factor model's features at a query ("Factor model", Features): f = (theta_h, theta_d,
// theta_i, theta_o) clamped to the ranges of the model section at absolute word m, x clamped,
// and s = U (1/cos) of the clamped theta_i and theta_o.
struct SbrdfFeatures {
    f: vec4<f32>,
    s: vec2<f32>,
    x: f32,
}

// The features at the unit upper-hemisphere vectors ui, uo, in any common frame (every feature
// is invariant under a turn about z), without turning the frame: theta_h from the sum's
// horizontal length and height, theta_d as half the angle between wi and wo (the angle between
// wi and the half vector), x as wo's component along wi's azimuth.
fn sbrdf_fact_features(m: u32, ui: vec3<f32>, uo: vec3<f32>) -> SbrdfFeatures {
    let ri = length(ui.xy);
    let ro = length(uo.xy);
    let mv = ui + uo;
    let mh = length(mv.xy);
    let ti = sbrdf_atan2_deg(ri, ui.z);
    let to = sbrdf_atan2_deg(ro, uo.z);
    // The mirror direction (and m = 0, opposite on the horizon): the half vector is the pole.
    let pole = mh <= SBRDF_WARP_POLE_XY;
    let th = select(sbrdf_atan2_deg(mh, mv.z), 0.0, pole);
    let td = select(sbrdf_atan2_deg(length(cross(ui, uo)), 1.0 + dot(ui, uo)), ti, pole);
    let x = select(uo.x, (ui.x * uo.x + ui.y * uo.y) / ri, ri > 0.0);
    let rg = m + SBRDF_FACT_RANGES; // (min, max) of theta_h, theta_d, theta_i, theta_o, then x
    let lo = vec4<f32>(sbrdf_f(rg), sbrdf_f(rg + 2u), sbrdf_f(rg + 4u), sbrdf_f(rg + 6u));
    let hi = vec4<f32>(sbrdf_f(rg + 1u), sbrdf_f(rg + 3u), sbrdf_f(rg + 5u), sbrdf_f(rg + 7u));
    let f = clamp(vec4<f32>(th, td, ti, to), lo, hi);
    let s = vec2<f32>(sbrdf_fact_secant(f.z, ti, ui.z), sbrdf_fact_secant(f.w, to, uo.z));
    return SbrdfFeatures(f, s, clamp(x, sbrdf_f(rg + 8u), sbrdf_f(rg + 9u)));
}

// Where each of the first nl of four wavelengths falls among the layout's: column 0 j (as
// bits), column 1 a (sbrdf_fact_bracket); 0 in the other lanes.
fn sbrdf_fact_places(base: u32, lambda: vec4<f32>, nl: u32) -> mat2x4<f32> {
    var p = mat2x4<f32>();
    let p0 = sbrdf_fact_bracket(base, lambda.x);
    p[0].x = p0.x;
    p[1].x = p0.y;
    if (nl > 1u) {
        let p1 = sbrdf_fact_bracket(base, lambda.y);
        p[0].y = p1.x;
        p[1].y = p1.y;
    }
    if (nl > 2u) {
        let p2 = sbrdf_fact_bracket(base, lambda.z);
        p[0].z = p2.x;
        p[1].z = p2.y;
    }
    if (nl > 3u) {
        let p3 = sbrdf_fact_bracket(base, lambda.w);
        p[0].w = p3.x;
        p[1].w = p3.y;
    }
    return p;
}

// F at the first nl of the four (finite) wavelengths of the model section of kind 1 at absolute
// word m, at the unit upper-hemisphere vectors ui, uo; 0 in the other lanes.
fn sbrdf_fact4(base: u32, m: u32, ui: vec3<f32>, uo: vec3<f32>, lambda: vec4<f32>, nl: u32) -> vec4<f32> {
    let enc = sbrdf_u(m + SBRDF_FACT_ENCODING);
    let nc = min(sbrdf_u(m + SBRDF_FACT_COMPONENTS), 8u);
    let w = sbrdf_u(base + SBRDF_HDR_WAVES);
    let ft = sbrdf_fact_features(m, ui, uo);
    let places = sbrdf_fact_places(base, lambda, nl);
    let jv = bitcast<vec4<u32>>(places[0]);
    var total = vec4<f32>(0.0);
    for (var c = 0u; c < 8u; c = c + 1u) {
        if (c >= nc) {
            break;
        }
        let e = m + SBRDF_FACT_WORDS + SBRDF_FACT_C_WORDS * c;
        let rank = min(sbrdf_u(e + SBRDF_FACT_C_RANK), 8u);
        let nf = min(sbrdf_u(e + SBRDF_FACT_C_FEATURES), 6u);
        let codes = sbrdf_u(e + SBRDF_FACT_C_CODES);
        let o = base + sbrdf_u(e + SBRDF_FACT_C_OFF_VALUES);
        let nodes = sbrdf_fact_nodes(codes, nf);
        // eta_c = T_c0 + s_c(lambda) + sum_r>=1 w_cr(lambda) T_cr: rank r's spectrum (s_c or
        // w_cr) at value r (W + nodes), its tables from value r (W + nodes) + W.
        var eta = vec4<f32>(0.0);
        for (var r = 0u; r < 8u; r = r + 1u) {
            if (r >= rank) {
                break;
            }
            let at = r * (w + nodes);
            var t = 0.0;
            var tab = at + w;
            for (var k = 0u; k < 6u; k = k + 1u) {
                if (k >= nf) {
                    break;
                }
                let code = (codes >> (4u * k)) & 15u;
                t = t + sbrdf_fact_table(o, enc, tab, code, ft.f, ft.x, ft.s);
                tab = tab + sbrdf_fact_len(code);
            }
            let sp = sbrdf_fact_spectra4(o, enc, at, jv, places[1], nl);
            if (r == 0u) {
                eta = vec4<f32>(t) + sp;
            } else {
                eta = eta + sp * t;
            }
        }
        total = total + sbrdf_fact_exp4(eta, nl);
    }
    return total;
}

// ------------------------------------------------------------------ warped tables

// The model section of kind 2 (spec/GPU_LAYOUT.md, "Warped tables section"; spec/EVALUATION.md,
// "Warped tables"): a material measured on the RGL database's warped grids, which answers every
// query itself (its records are empty) and samples itself (its layout has no sampling section).
// Offsets inside the section are relative to its first word w. The arithmetic follows
// `src/decode/warped/query.rs`, in f32: the half vector's inverse VNDF warp blended between the
// two stored viewing directions around the query's, the packed tables bilinear at the warped
// point, times D/(4 sigma)/cos theta_i; sampling draws a warped point from the tables'
// spectrum-averaged values, then the VNDF warp forward. The four VNDF rows a cell reads (two
// rows of two stored incidences) are the lanes of vec4s, so that each row formula is written,
// and inlined, once.

const SBRDF_WARP_MARG_UNIT: f32 = 1.1920928955078125e-07; // 2^-(32 - SBRDF_WARP_POSITIVE_BITS)

// The absolute word of the layout's warped-tables section, 0 when it has none.
fn sbrdf_warp_section(base: u32) -> u32 {
    let m = sbrdf_u(base + SBRDF_HDR_OFF_MODEL);
    if (m == 0u || sbrdf_u(base + m + SBRDF_MODEL_KIND) != SBRDF_MODEL_WARPED) {
        return 0u;
    }
    return base + m;
}

// The absolute word of an entry of one of the section's arrays (header word `off`).
fn sbrdf_warp_at(w: u32, off: u32, entry: u32) -> u32 {
    return w + sbrdf_u(w + off) + entry;
}

// The two stored incidences around theta (radians) and the upper one's weight t; a layout of
// one stored incidence has a = b = 0.
struct SbrdfWarpSlices {
    a: u32,
    b: u32,
    t: f32,
}

fn sbrdf_warp_theta(w: u32, i: u32) -> f32 {
    return sbrdf_f(sbrdf_warp_at(w, SBRDF_WARP_OFF_INCIDENCES,
        SBRDF_WARP_INC_WORDS * i + SBRDF_WARP_INC_THETA));
}

fn sbrdf_warp_slices(w: u32, theta: f32) -> SbrdfWarpSlices {
    let n = sbrdf_u(w + SBRDF_WARP_N);
    if (n < 2u) {
        return SbrdfWarpSlices(0u, 0u, 0.0);
    }
    let th = clamp(theta, sbrdf_warp_theta(w, 0u), sbrdf_warp_theta(w, n - 1u));
    var i = 0u;
    for (; i + 2u < n; i = i + 1u) {
        if (sbrdf_warp_theta(w, i + 1u) > th) {
            break;
        }
    }
    let lo = sbrdf_warp_theta(w, i);
    let hi = sbrdf_warp_theta(w, i + 1u);
    return SbrdfWarpSlices(i, i + 1u, clamp((th - lo) / (hi - lo), 0.0, 1.0));
}

// a + (b - a) t, the CPU's `lerp` (WGSL's mix rounds differently).
fn sbrdf_warp_lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + (b - a) * t;
}

// The cell of x in [0, 1] on n nodes: (index as bits, position within it).
fn sbrdf_warp_cell(x: f32, n: u32) -> vec2<f32> {
    let f = clamp(x, 0.0, 1.0) * f32(n - 1u);
    let i = min(u32(f), n - 2u);
    return vec2<f32>(bitcast<f32>(i), f - f32(i));
}

// Lanes (row b of slice a, row b of slice b, row b + 1 of slice a, row b + 1 of slice b)
// blended between the slices: (row b, row b + 1).
fn sbrdf_warp_blend(sl: SbrdfWarpSlices, v: vec4<f32>) -> vec2<f32> {
    return vec2<f32>(v.x + (v.y - v.x) * sl.t, v.z + (v.w - v.z) * sl.t);
}

// A VNDF column (f, sin theta_m, cos theta_m, U, V).
struct SbrdfWarpCol {
    f: f32,
    s: f32,
    c: f32,
    u: f32,
    v: f32,
}

fn sbrdf_warp_col(w: u32, a: u32) -> SbrdfWarpCol {
    let o = sbrdf_warp_at(w, SBRDF_WARP_OFF_COLUMNS, SBRDF_WARP_COL_WORDS * a);
    return SbrdfWarpCol(sbrdf_f(o + SBRDF_WARP_COL_F), sbrdf_f(o + SBRDF_WARP_COL_SIN),
        sbrdf_f(o + SBRDF_WARP_COL_COS), sbrdf_f(o + SBRDF_WARP_COL_U),
        sbrdf_f(o + SBRDF_WARP_COL_V));
}

// The four VNDF rows of a cell (`vndf::Row`), lane-wise as sbrdf_warp_blend orders them:
// alpha = sin theta cos phi_row and cos theta, both times the incidence's 1/I (so that the
// densities and conditional integrals below come normalised), the run of positive columns,
// and the row's normalised total. (Four vec4s: what a GPU keeps in registers.)
struct SbrdfWarpRows {
    alpha: vec4<f32>,
    ct: vec4<f32>,
    positive: vec4<u32>,
    total: vec4<f32>,
}

fn sbrdf_warp_rows(w: u32, sl: SbrdfWarpSlices, b: u32) -> SbrdfWarpRows {
    let g = sbrdf_u(w + SBRDF_WARP_G);
    var r: SbrdfWarpRows;
    for (var j = 0u; j < 4u; j = j + 1u) {
        let i = select(sl.a, sl.b, (j & 1u) == 1u);
        let row = b + (j >> 1u);
        let inc = sbrdf_warp_at(w, SBRDF_WARP_OFF_INCIDENCES, SBRDF_WARP_INC_WORDS * i);
        let scale = sbrdf_f(inc + SBRDF_WARP_INC_VNDF_SCALE);
        let alpha = sbrdf_f(inc + SBRDF_WARP_INC_SIN)
            * sbrdf_f(sbrdf_warp_at(w, SBRDF_WARP_OFF_ROW_COSINES, row));
        let ct = sbrdf_f(inc + SBRDF_WARP_INC_COS);
        let positive = sbrdf_u(sbrdf_warp_at(w, SBRDF_WARP_OFF_VNDF_ROWS, i * g + row))
            & ((1u << SBRDF_WARP_POSITIVE_BITS) - 1u);
        // The total from the run's last column (`vndf::row_total`).
        var total = 0.0;
        if (positive > 0u) {
            let c = sbrdf_warp_col(w, positive - 1u);
            total = alpha * c.u + ct * c.v;
            if (positive < g) {
                total = total + 0.5 / f32(g - 1u) * (c.f * max(0.0, alpha * c.s + ct * c.c));
            }
        }
        r.alpha[j] = scale * alpha;
        r.ct[j] = scale * ct;
        r.positive[j] = positive;
        r.total[j] = scale * total;
    }
    return r;
}

// The four rows' densities at column a.
fn sbrdf_warp_density4(r: SbrdfWarpRows, a: u32, c: SbrdfWarpCol) -> vec4<f32> {
    let p = c.f * max(vec4<f32>(0.0), r.alpha * c.s + r.ct * c.c);
    return select(vec4<f32>(0.0), p, vec4<u32>(a) < r.positive);
}

// The four rows' conditional integrals at column a.
fn sbrdf_warp_cond4(r: SbrdfWarpRows, a: u32, c: SbrdfWarpCol) -> vec4<f32> {
    return select(r.total, r.alpha * c.u + r.ct * c.v, vec4<u32>(a) < r.positive);
}

// A VNDF row's marginal blended between the slices (the rows' bisection reads one row).
fn sbrdf_warp_vndf_marg(w: u32, sl: SbrdfWarpSlices, b: u32) -> f32 {
    let g = sbrdf_u(w + SBRDF_WARP_G);
    let ma = f32(sbrdf_u(sbrdf_warp_at(w, SBRDF_WARP_OFF_VNDF_ROWS, sl.a * g + b))
        >> SBRDF_WARP_POSITIVE_BITS) * SBRDF_WARP_MARG_UNIT;
    let mb = f32(sbrdf_u(sbrdf_warp_at(w, SBRDF_WARP_OFF_VNDF_ROWS, sl.b * g + b))
        >> SBRDF_WARP_POSITIVE_BITS) * SBRDF_WARP_MARG_UNIT;
    return ma + (mb - ma) * sl.t;
}

// The inverse VNDF warp of u (the half vector's parameter) and the blended VNDF density there:
// (sx, sy, density).
fn sbrdf_warp_invert(w: u32, sl: SbrdfWarpSlices, ux: f32, uy: f32) -> vec3<f32> {
    let g = sbrdf_u(w + SBRDF_WARP_G);
    let n1 = f32(g - 1u);
    let ca = sbrdf_warp_cell(ux, g);
    let cb = sbrdf_warp_cell(uy, g);
    let a = bitcast<u32>(ca.x);
    let tx = ca.y;
    let ty = cb.y;
    let b = bitcast<u32>(cb.x);
    let rows = sbrdf_warp_rows(w, sl, b);
    let col0 = sbrdf_warp_col(w, a);
    let d0 = sbrdf_warp_blend(sl, sbrdf_warp_density4(rows, a, col0));
    let d1 = sbrdf_warp_blend(sl, sbrdf_warp_density4(rows, a + 1u, sbrdf_warp_col(w, a + 1u)));
    let c0 = sbrdf_warp_lerp(d0.x, d0.y, ty);
    let c1 = sbrdf_warp_lerp(d1.x, d1.y, ty);
    let bc = sbrdf_warp_blend(sl, sbrdf_warp_cond4(rows, a, col0));
    let before = sbrdf_warp_lerp(bc.x, bc.y, ty);
    let within = tx * (c0 + 0.5 * (c1 - c0) * tx) / n1;
    let r = sbrdf_warp_blend(sl, rows.total);
    let total = sbrdf_warp_lerp(r.x, r.y, ty);
    var sx = 0.0;
    if (total > 0.0) {
        sx = (before + within) / total;
    }
    let sy = sbrdf_warp_vndf_marg(w, sl, b) + ty * (r.x + 0.5 * (r.y - r.x) * ty) / n1;
    return vec3<f32>(clamp(sx, 0.0, 1.0), clamp(sy, 0.0, 1.0), sbrdf_warp_lerp(c0, c1, tx));
}

// tau in [0, 1] with the integral over [0, tau] of sbrdf_warp_lerp(v0, v1, t) dt = a.
fn sbrdf_warp_segment(a_in: f32, v0: f32, v1: f32) -> f32 {
    let a = max(a_in, 0.0);
    let disc = max(v0 * v0 + 2.0 * a * (v1 - v0), 0.0);
    let den = v0 + sqrt(disc);
    if (den > 0.0) {
        return clamp(2.0 * a / den, 0.0, 1.0);
    }
    return 0.0;
}

// The forward VNDF warp: a uniform point (sx, sy) -> u. The row by bisection on the blended
// marginal, the column by bisection on the blended conditional integral.
fn sbrdf_warp_vndf_sample(w: u32, sl: SbrdfWarpSlices, sx_in: f32, sy_in: f32) -> vec2<f32> {
    let g = sbrdf_u(w + SBRDF_WARP_G);
    let n1 = f32(g - 1u);
    let sx = clamp(sx_in, 0.0, 1.0);
    let sy = clamp(sy_in, 0.0, 1.0);
    var lo = 0u;
    var hi = g - 1u;
    for (var it = 0u; it < 32u && lo + 1u < hi; it = it + 1u) {
        let mid = (lo + hi) >> 1u;
        if (sbrdf_warp_vndf_marg(w, sl, mid) < sy) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let b = min(hi - 1u, g - 2u);
    let rows = sbrdf_warp_rows(w, sl, b);
    let r = sbrdf_warp_blend(sl, rows.total);
    let ty = sbrdf_warp_segment((sy - sbrdf_warp_vndf_marg(w, sl, b)) * n1, r.x, r.y);
    let goal = sx * sbrdf_warp_lerp(r.x, r.y, ty);
    lo = 0u;
    hi = g - 1u;
    for (var it = 0u; it < 32u && lo + 1u < hi; it = it + 1u) {
        let mid = (lo + hi) >> 1u;
        let cm = sbrdf_warp_blend(sl, sbrdf_warp_cond4(rows, mid, sbrdf_warp_col(w, mid)));
        if (sbrdf_warp_lerp(cm.x, cm.y, ty) < goal) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = min(hi - 1u, g - 2u);
    let col0 = sbrdf_warp_col(w, a);
    let d0 = sbrdf_warp_blend(sl, sbrdf_warp_density4(rows, a, col0));
    let d1 = sbrdf_warp_blend(sl, sbrdf_warp_density4(rows, a + 1u, sbrdf_warp_col(w, a + 1u)));
    let ca = sbrdf_warp_blend(sl, sbrdf_warp_cond4(rows, a, col0));
    let tx = sbrdf_warp_segment((goal - sbrdf_warp_lerp(ca.x, ca.y, ty)) * n1, sbrdf_warp_lerp(d0.x, d0.y, ty),
        sbrdf_warp_lerp(d1.x, d1.y, ty));
    return vec2<f32>((f32(a) + tx) / n1, (f32(b) + ty) / n1);
}

// Code j of a packed table (bits per code, codes from absolute word o, least bit first).
fn sbrdf_warp_code(o: u32, bits: u32, j: u32) -> u32 {
    if (bits == 0u) {
        return 0u;
    }
    let bit = j * bits;
    let wd = o + (bit >> 5u);
    let sh = bit & 31u;
    var v = sbrdf_u(wd) >> sh;
    if (sh + bits > 32u) {
        v = v | (sbrdf_u(wd + 1u) << (32u - sh));
    }
    return v & ((1u << bits) - 1u);
}

// Table t = i K + k at nodes (n0, n0 + 1, n1, n1 + 1): lo + code step each.
fn sbrdf_warp_table4(w: u32, t: u32, n0: u32, n1: u32) -> vec4<f32> {
    let e = sbrdf_warp_at(w, SBRDF_WARP_OFF_TABLES, SBRDF_WARP_TAB_WORDS * t);
    let o = w + sbrdf_u(e + SBRDF_WARP_TAB_OFF_CODES);
    let bits = sbrdf_u(e + SBRDF_WARP_TAB_BITS);
    let codes = vec4<u32>(sbrdf_warp_code(o, bits, n0), sbrdf_warp_code(o, bits, n0 + 1u),
        sbrdf_warp_code(o, bits, n1), sbrdf_warp_code(o, bits, n1 + 1u));
    return vec4<f32>(sbrdf_f(e + SBRDF_WARP_TAB_LO)) + vec4<f32>(codes)
        * sbrdf_f(e + SBRDF_WARP_TAB_STEP);
}

// Bilinear in a cell from its corners (lower row's two, upper row's two), as the CPU's
// lerp(lerp(v00, v01, tx), lerp(v10, v11, tx), ty).
fn sbrdf_warp_bilerp(v: vec4<f32>, tx: f32, ty: f32) -> f32 {
    let lo = v.x + (v.y - v.x) * tx;
    let hi = v.z + (v.w - v.z) * tx;
    return lo + (hi - lo) * ty;
}

// The tables' frame for a direction d (the viewer's for evaluation, the given one for
// sampling): the turn about z that gives d azimuth 0, (cos, sin) in .xy, d's theta (radians)
// in .z.
fn sbrdf_warp_frame(d: vec3<f32>) -> vec3<f32> {
    let r = sqrt(d.x * d.x + d.y * d.y);
    var cs = vec2<f32>(1.0, 0.0);
    if (r > 0.0) {
        cs = vec2<f32>(d.x / r, d.y / r);
    }
    return vec3<f32>(cs, sbrdf_atan2_deg(r, d.z) * SBRDF_DEG);
}

fn sbrdf_warp_in(f: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(f.x * v.x + f.y * v.y, -f.y * v.x + f.x * v.y, v.z);
}

// The half-vector parameter u of unit m, and sin theta_m: (ux, uy, sin theta_m).
fn sbrdf_warp_half(m: vec3<f32>) -> vec3<f32> {
    let sin_m = sqrt(m.x * m.x + m.y * m.y);
    let ux = sqrt(sbrdf_atan2_deg(sin_m, m.z) / 90.0);
    var uy = (sbrdf_atan2_deg(m.y, m.x) + 180.0) / 360.0;
    if (uy >= 1.0) {
        uy = uy - 1.0;
    }
    return vec3<f32>(ux, uy, sin_m);
}

// Linear between M nodes at j/(M-1) (x clamped to [0, 1]), from absolute word o.
fn sbrdf_warp_nodes(o: u32, m: u32, x: f32) -> f32 {
    let c = sbrdf_warp_cell(x, m);
    let i = bitcast<u32>(c.x);
    let a = sbrdf_f(o + i);
    return a + (sbrdf_f(o + i + 1u) - a) * c.y;
}

// The half vector's distance from the pole under which it is the pole, and the least cosine of
// the light's direction the tables divide by (EVALUATION.md, "Warped tables", Value steps 1
// and 5; src/model/warped.rs POLE_HALF_XY, HORIZON_COS).
const SBRDF_WARP_POLE_XY: f32 = 1e-9;
const SBRDF_WARP_HORIZON_COS: f32 = 0.0009765625;

// What an evaluation at unit ui, uo (above the horizon) reads of the tables, into the query's
// record fields (a warped query blends no records): rec[0], rec[1] the slices, w[0] the upper
// one's weight; rec[2] the first node of the tables' cell (the upper row's is rec[2] + R), w[1],
// w[2] the position in the cell; w[3] = D(u_x) / (4 sigma) / max(cos theta_i, 2^-10) (0: none).
// The tables follow the viewer's direction uo: in the tables' frame the roles of the two
// directions are exchanged.
fn sbrdf_warp_query(w: u32, ui: vec3<f32>, uo: vec3<f32>, q: ptr<function, SbrdfQuery>) {
    (*q).w[3] = 0.0;
    let fr = sbrdf_warp_frame(uo);
    if (!(ui.z >= 0.0)) {
        return;
    }
    // h summed in the surface's frame, where a mirror pair's x and y cancel exactly, then turned.
    // Within SBRDF_WARP_POLE_XY of the pole (the mirror direction, or both directions opposite
    // on the horizon) it is the pole: u = (0, 1/2) (EVALUATION.md, "Warped tables", Value 1).
    let h = sbrdf_warp_in(fr, uo + ui);
    var u = vec3<f32>(0.0, 0.5, 0.0);
    if (sqrt(h.x * h.x + h.y * h.y) > SBRDF_WARP_POLE_XY) {
        u = sbrdf_warp_half(normalize(h));
    }
    let sl = sbrdf_warp_slices(w, fr.z);
    let s = sbrdf_warp_invert(w, sl, u.x, u.y);
    let m = sbrdf_u(w + SBRDF_WARP_M);
    let sigma = sbrdf_warp_nodes(sbrdf_warp_at(w, SBRDF_WARP_OFF_SIGMA, 0u), m,
        sqrt(max(fr.z, 0.0) / (0.5 * SBRDF_PI)));
    let d = sbrdf_warp_nodes(sbrdf_warp_at(w, SBRDF_WARP_OFF_NDF, 0u), m, u.x);
    let r = sbrdf_u(w + SBRDF_WARP_R);
    let cx = sbrdf_warp_cell(s.x, r);
    let cy = sbrdf_warp_cell(s.y, r);
    (*q).rec[0] = sl.a;
    (*q).rec[1] = sl.b;
    (*q).rec[2] = bitcast<u32>(cy.x) * r + bitcast<u32>(cx.x);
    (*q).w[0] = sl.t;
    (*q).w[1] = cx.y;
    (*q).w[2] = cy.y;
    (*q).w[3] = d / (4.0 * sigma) / max(ui.z, SBRDF_WARP_HORIZON_COS);
}

// Terms k0 .. k0 + 3 of the tables' spectral coefficients at the query (blended between the
// slices, bilinear in the cell, times f), 0 past K: the warped counterpart of sbrdf_coef4.
fn sbrdf_warp_coef4(w: u32, q: ptr<function, SbrdfQuery>, k0: u32) -> vec4<f32> {
    var c = vec4<f32>(0.0);
    let f = (*q).w[3];
    if (f == 0.0) {
        return c;
    }
    let nk = sbrdf_u(w + SBRDF_WARP_K);
    let n0 = (*q).rec[2];
    let n1 = n0 + sbrdf_u(w + SBRDF_WARP_R);
    for (var j = 0u; j < sbrdf_chunk(k0, nk); j = j + 1u) {
        // Slice a's and slice b's table of term k0 + j (one call site: 2 n calls).
        var v = vec2<f32>(0.0);
        for (var s = 0u; s < 2u; s = s + 1u) {
            let t = sbrdf_warp_table4(w, (*q).rec[s] * nk + k0 + j, n0, n1);
            v[s] = sbrdf_warp_bilerp(t, (*q).w[1], (*q).w[2]);
        }
        c[j] = (v.x + (v.y - v.x) * (*q).w[0]) * f;
    }
    return c;
}

// Importance sampling of warped tables ("Warped tables", Importance sampling): a share
// SBRDF_MIN_COSINE_WEIGHT of the cosine, the rest from each stored incidence's values' density
// (the spectrum-averaged packed values clamped at 0, plus the incidence's floor, over its total)
// through the VNDF warp.

// The values' density of stored incidence i at node j.
fn sbrdf_warp_values_at(w: u32, i: u32, j: u32) -> f32 {
    let nk = sbrdf_u(w + SBRDF_WARP_K);
    let means = sbrdf_warp_at(w, SBRDF_WARP_OFF_BASIS_MEANS, 0u);
    var v = 0.0;
    for (var k = 0u; k < nk; k = k + 1u) {
        let e = sbrdf_warp_at(w, SBRDF_WARP_OFF_TABLES, SBRDF_WARP_TAB_WORDS * (i * nk + k));
        let code = sbrdf_warp_code(w + sbrdf_u(e + SBRDF_WARP_TAB_OFF_CODES),
            sbrdf_u(e + SBRDF_WARP_TAB_BITS), j);
        let t = sbrdf_f(e + SBRDF_WARP_TAB_LO) + f32(code) * sbrdf_f(e + SBRDF_WARP_TAB_STEP);
        v = v + t * sbrdf_f(means + k);
    }
    let inc = sbrdf_warp_at(w, SBRDF_WARP_OFF_INCIDENCES, SBRDF_WARP_INC_WORDS * i);
    return sbrdf_f(inc + SBRDF_WARP_INC_VALUES_SCALE)
        * (max(v, 0.0) + sbrdf_f(inc + SBRDF_WARP_INC_VALUES_FLOOR));
}

// The values' density at nodes (n0, n0 + 1, n1, n1 + 1), blended between the slices.
fn sbrdf_warp_values4(w: u32, sl: SbrdfWarpSlices, n0: u32, n1: u32) -> vec4<f32> {
    var va = vec4<f32>(0.0);
    var vb = vec4<f32>(0.0);
    for (var j = 0u; j < 8u; j = j + 1u) {
        let corner = j >> 1u;
        let node = select(n0, n1, corner >= 2u) + (corner & 1u);
        let x = sbrdf_warp_values_at(w, select(sl.a, sl.b, (j & 1u) == 1u), node);
        if ((j & 1u) == 1u) {
            vb[corner] = x;
        } else {
            va[corner] = x;
        }
    }
    return va + (vb - va) * sl.t;
}

// Word `field` of values row (i, b).
fn sbrdf_warp_values_row(w: u32, i: u32, b: u32, field: u32) -> f32 {
    let r = sbrdf_u(w + SBRDF_WARP_R);
    return sbrdf_f(sbrdf_warp_at(w, SBRDF_WARP_OFF_VALUES_ROWS,
        SBRDF_WARP_VAL_WORDS * (i * r + b) + field));
}

// Word `field` of values rows b and b + 1, blended between the slices.
fn sbrdf_warp_values_rows(w: u32, sl: SbrdfWarpSlices, b: u32, field: u32) -> vec2<f32> {
    var v = vec4<f32>(0.0);
    for (var j = 0u; j < 4u; j = j + 1u) {
        v[j] = sbrdf_warp_values_row(w, select(sl.a, sl.b, (j & 1u) == 1u), b + (j >> 1u), field);
    }
    return sbrdf_warp_blend(sl, v);
}

// The forward warp of the values' density: a uniform point -> a warped point. The row by
// bisection on its stored marginal, the column from the last kept mark below the target,
// walking the row from there.
fn sbrdf_warp_values_sample(w: u32, sl: SbrdfWarpSlices, sx_in: f32, sy_in: f32) -> vec2<f32> {
    let r = sbrdf_u(w + SBRDF_WARP_R);
    let n1 = f32(r - 1u);
    let sx = clamp(sx_in, 0.0, 1.0);
    let sy = clamp(sy_in, 0.0, 1.0);
    var lo = 0u;
    var hi = r - 1u;
    for (var it = 0u; it < 32u && lo + 1u < hi; it = it + 1u) {
        let mid = (lo + hi) >> 1u;
        if (sbrdf_warp_values_rows(w, sl, mid, SBRDF_WARP_VAL_MARG).x < sy) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let b = min(hi - 1u, r - 2u);
    let tot = sbrdf_warp_values_rows(w, sl, b, SBRDF_WARP_VAL_TOTAL);
    let mb = sbrdf_warp_values_rows(w, sl, b, SBRDF_WARP_VAL_MARG).x;
    let ty = sbrdf_warp_segment((sy - mb) * n1, tot.x, tot.y);
    let goal = sx * sbrdf_warp_lerp(tot.x, tot.y, ty);
    var a = 0u;
    var before = 0.0;
    for (var j = 0u; j < SBRDF_WARP_MARKS; j = j + 1u) {
        let mk = sbrdf_warp_values_rows(w, sl, b, SBRDF_WARP_VAL_MARKS + j);
        let m = sbrdf_warp_lerp(mk.x, mk.y, ty);
        if (m >= goal) {
            break;
        }
        a = (j + 1u) * (r - 1u) / (SBRDF_WARP_MARKS + 1u);
        before = m;
    }
    // Walk the row: the density at columns a and a + 1 (rows b and b + 1 blended by ty).
    let half = 0.5 / n1;
    var c = vec2<f32>(0.0);
    for (var it = 0u; it < r; it = it + 1u) {
        let v = sbrdf_warp_values4(w, sl, b * r + a, b * r + r + a);
        c = vec2<f32>(sbrdf_warp_lerp(v.x, v.z, ty), sbrdf_warp_lerp(v.y, v.w, ty));
        if (a + 2u >= r) {
            break;
        }
        let next = before + half * (c.x + c.y);
        if (next >= goal) {
            break;
        }
        a = a + 1u;
        before = next;
    }
    let tx = sbrdf_warp_segment((goal - before) * n1, c.x, c.y);
    return vec2<f32>((f32(a) + tx) / n1, (f32(b) + ty) / n1);
}

// a + b = s + e exactly, as (s, e) (Knuth's two-sum: additions only, which no compiler fuses).
fn sbrdf_two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = a + b;
    let bb = s - a;
    return vec2<f32>(s, (a - (s - bb)) + (b - bb));
}

// |v|^2 - 1 to about 2^-35 where it is within 2^-10 of 0 (as it is for a renderer's unit vectors
// in f32): each component split by its bits into 12 significant bits and the rest, so that its
// square is three products that f32 holds exactly (whether or not a compiler fuses them into
// the sums), and the three large squares summed with two-sums.
fn sbrdf_norm2_minus_one(v: vec3<f32>) -> f32 {
    let hi = bitcast<vec3<f32>>(bitcast<vec3<u32>>(v) & vec3<u32>(0xfffff000u));
    let lo = v - hi;
    let sq = hi * hi;
    let a = sbrdf_two_sum(sq.x, sq.y);
    let b = sbrdf_two_sum(a.x, sq.z);
    // b.x lies in [0.5, 2] here, so this subtraction is exact.
    return (b.x - 1.0) + ((a.y + b.y) + (2.0 * dot(hi, lo) + dot(lo, lo)));
}

// How far |v|^2 may lie from 1 for sbrdf_norm2_minus_one's and sbrdf_inv_norm_minus_one's
// precision.
const SBRDF_NEAR_UNIT: f32 = 0.0009765625;

// 1/|v| - 1 from e = |v|^2 - 1 (|e| <= 2^-10: the series to e^2 leaves under 2^-31 of it).
fn sbrdf_inv_norm_minus_one(e: f32) -> f32 {
    return e * (-0.5 + 0.375 * e);
}

// sbrdf_pdf for warped tables at section w (wi, wo finite, non-zero, above the horizon: as the
// caller was given them, not yet made unit): the cosine's share plus the tables' share through
// the half vector of wi and wo and of wi and wo's mirror image below the surface (the draw
// reflects wi about the drawn half vector and takes |z|).
// Near the mirror direction both half vectors come from nearly opposite components whose sum
// is far smaller than either, so f32 must form them where the cancellation is exact (issue 38):
// h = wi/|wi| + wo'/|wo| as (wi + wo') (nearly opposite f32 components subtract exactly) plus
// the unit scalings' small corrections wi (1/|wi| - 1) + wo' (1/|wo| - 1), each |v|^2 - 1 taken
// to 2^-35 (normalising in f32 first rounds each component by up to 2^-25, 1e-3 of such a sum
// at a grazing light's mirror); then h turned into the tables' frame (an error relative to |h|,
// not to 1); and wo.m = |h|/2 for unit vectors, where an explicit dot with m nearly
// perpendicular to wo loses every digit. Inputs further than 2^-10 from unit length are made
// unit in f32 first.
fn sbrdf_warp_pdf(w: u32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let ui = sbrdf_upper(wi).xyz;
    let uo = sbrdf_upper(wo).xyz;
    if (uo.z <= 0.0) {
        return 0.0;
    }
    var vi = ui;
    var vo = uo;
    var ci = 0.0;
    var co = 0.0;
    let ei = sbrdf_norm2_minus_one(wi);
    let eo = sbrdf_norm2_minus_one(wo);
    if (abs(ei) <= SBRDF_NEAR_UNIT && abs(eo) <= SBRDF_NEAR_UNIT) {
        vi = wi;
        vo = wo;
        ci = sbrdf_inv_norm_minus_one(ei);
        co = sbrdf_inv_norm_minus_one(eo);
    }
    let fr = sbrdf_warp_frame(ui);
    let sl = sbrdf_warp_slices(w, fr.z);
    let r = sbrdf_u(w + SBRDF_WARP_R);
    var tables = 0.0;
    for (var j = 0u; j < 2u; j = j + 1u) {
        let vm = vec3<f32>(vo.x, vo.y, select(vo.z, -vo.z, j == 1u));
        let h = sbrdf_warp_in(fr, (vi + vm) + (vi * ci + vm * co));
        let len = length(h);
        if (!(len > 0.0) || h.z < 0.0) {
            continue;
        }
        let m = h / len;
        let u = sbrdf_warp_half(m);
        let jac = u.z * SBRDF_PI * u.x * 2.0 * SBRDF_PI;
        let d = 0.5 * len;
        if (!(jac > 0.0)) {
            continue;
        }
        let s = sbrdf_warp_invert(w, sl, u.x, u.y);
        let cx = sbrdf_warp_cell(s.x, r);
        let cy = sbrdf_warp_cell(s.y, r);
        let n0 = bitcast<u32>(cy.x) * r + bitcast<u32>(cx.x);
        let v = sbrdf_warp_values4(w, sl, n0, n0 + r);
        let density = sbrdf_warp_bilerp(v, cx.y, cy.y);
        tables = tables + density * s.z / jac / (4.0 * d);
    }
    return SBRDF_MIN_COSINE_WEIGHT * uo.z / SBRDF_PI + (1.0 - SBRDF_MIN_COSINE_WEIGHT) * tables;
}

// sbrdf_sample for warped tables at section w (unit ui above the horizon, u in [0, 1)^2):
// (wo, pdf), vec4(0) for none.
fn sbrdf_warp_sample(w: u32, wi: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    let ui = sbrdf_upper(wi).xyz;
    let fr = sbrdf_warp_frame(ui);
    let a = vec3<f32>(sqrt(ui.x * ui.x + ui.y * ui.y), 0.0, ui.z);
    let sl = sbrdf_warp_slices(w, fr.z);
    var local: vec3<f32>;
    if (u.x < SBRDF_MIN_COSINE_WEIGHT) {
        let u0 = u.x / SBRDF_MIN_COSINE_WEIGHT;
        let rad = sqrt(u0);
        let cs = sbrdf_sincos_turns(u.y);
        local = vec3<f32>(rad * cs.y, rad * cs.x, sqrt(max(1.0 - u0, 0.0)));
    } else {
        let u0 = min((u.x - SBRDF_MIN_COSINE_WEIGHT) / (1.0 - SBRDF_MIN_COSINE_WEIGHT), 1.0);
        let s = sbrdf_warp_values_sample(w, sl, u0, u.y);
        let uv = sbrdf_warp_vndf_sample(w, sl, s.x, s.y);
        // The half vector of u: theta_m = ux^2 pi/2, phi_m = 2 pi uy - pi (uy - 1/2 turns).
        let st = sbrdf_sincos_deg(uv.x * uv.x * 90.0);
        let sp = sbrdf_sincos_turns(uv.y - 0.5);
        let m = vec3<f32>(st.x * sp.y, st.x * sp.x, st.y);
        let d = 2.0 * (a.x * m.x + a.z * m.z);
        local = vec3<f32>(d * m.x - a.x, d * m.y, d * m.z - a.z);
    }
    local.z = abs(local.z);
    if (!(local.z > 0.0)) {
        return vec4<f32>(0.0);
    }
    // Back to the surface's frame (the inverse turn), and the density as sbrdf_pdf computes it.
    let wo = vec3<f32>(fr.x * local.x - fr.y * local.y, fr.y * local.x + fr.x * local.y, local.z);
    let back = sbrdf_upper(wo);
    if (back.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let pdf = sbrdf_warp_pdf(w, wi, wo);
    if (!(pdf > 0.0 && sbrdf_finite(pdf))) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(wo, pdf);
}

// ------------------------------------------------------------------ the model section

// The model section at absolute word m (header word 19 when not 0) at the first nl of four
// finite wavelengths, 0 in the other lanes: added to the records' series before the clamp.
// Dispatched on the section's kind: 1, the factor model (sbrdf_fact4). `q` is the query's
// incident side (the blend of the stored incidences), for a kind that needs it. A layout whose
// model kind this text does not know is one whose version it does not know, which the host
// refuses (the header's version, checked once); such a kind adds 0 here.
fn sbrdf_model4(base: u32, m: u32, q: ptr<function, SbrdfQuery>, ui: vec3<f32>, uo: vec3<f32>,
    lambda: vec4<f32>, nl: u32) -> vec4<f32> {
    let kind = sbrdf_u(m + SBRDF_MODEL_KIND);
    if (kind == SBRDF_MODEL_FACTOR) {
        return sbrdf_fact4(base, m, ui, uo, lambda, nl);
    }
    return vec4<f32>(0.0);
}

// ------------------------------------------------------------------ evaluation

// The coefficients c of the terms k0 .. k0 + 3 times their basis functions, summed, at the
// first nl of four wavelengths (0 in the other lanes).
fn sbrdf_series4(base: u32, c: vec4<f32>, k0: u32, tmax: u32, lambda: vec4<f32>, nl: u32) -> vec4<f32> {
    var v = vec4<f32>(0.0);
    v.x = dot(c, sbrdf_basis4(base, k0, tmax, lambda.x));
    if (nl > 1u) {
        v.y = dot(c, sbrdf_basis4(base, k0, tmax, lambda.y));
    }
    if (nl > 2u) {
        v.z = dot(c, sbrdf_basis4(base, k0, tmax, lambda.z));
    }
    if (nl > 3u) {
        v.w = dot(c, sbrdf_basis4(base, k0, tmax, lambda.w));
    }
    return v;
}

// rho at the first nl of four finite wavelengths ("Reconstruction", step 5: the records' series
// plus the model section's value, clamped at 0), 0 in the other lanes. ui, uo: the query's unit
// vectors; wo: uo in the records' frame. The coefficients are computed four terms at a time;
// the first four are kept in *c0 (computed when `have0` is false), so that a caller evaluating
// more wavelengths (sbrdf_eval_rgb) computes them once. (One call site of sbrdf_coef4 per entry
// point also keeps the inlined code small: drivers inline every function.)
fn sbrdf_rho4(base: u32, q: ptr<function, SbrdfQuery>, ui: vec3<f32>, uo: vec3<f32>, wo: vec3<f32>,
    lambda: vec4<f32>, nl: u32, c0: ptr<function, vec4<f32>>, have0: bool) -> vec4<f32> {
    let tmax = (*q).tmax;
    var v = vec4<f32>(0.0);
    for (var k0 = 0u; k0 < tmax; k0 = k0 + 4u) {
        var c = *c0;
        if (k0 > 0u || !have0) {
            if ((*q).warp != 0u) {
                c = sbrdf_warp_coef4((*q).warp, q, k0);
            } else {
                c = sbrdf_coef4(base, q, wo, k0);
            }
            if (k0 == 0u) {
                *c0 = c;
            }
        }
        v = v + sbrdf_series4(base, c, k0, tmax, lambda, nl);
    }
    let m = sbrdf_u(base + SBRDF_HDR_OFF_MODEL);
    if (m != 0u && (*q).warp == 0u) {
        v = v + sbrdf_model4(base, base + m, q, ui, uo, lambda, nl);
    }
    return max(v, vec4<f32>(0.0));
}

// rho at the first nl of four finite wavelengths (0 in the other lanes, and everywhere when a
// direction is refused: zero, not finite, or below the horizon).
fn sbrdf_eval_lanes(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda: vec4<f32>, nl: u32) -> vec4<f32> {
    let ui = sbrdf_upper(wi);
    let uo = sbrdf_upper(wo);
    if (ui.w == 0.0 || uo.w == 0.0) {
        return vec4<f32>(0.0);
    }
    var q: SbrdfQuery;
    sbrdf_query_pair(base, ui.xyz, uo.xyz, &q);
    var c0 = vec4<f32>(0.0);
    return sbrdf_rho4(base, &q, ui.xyz, uo.xyz, sbrdf_to_records(&q, uo.xyz), lambda, nl, &c0, false);
}

// rho(wi, wo, lambda) in 1/sr ("Reconstruction"), never negative.
fn sbrdf_eval(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: f32) -> f32 {
    if (!sbrdf_finite(lambda_nm)) {
        return 0.0;
    }
    return sbrdf_eval_lanes(base, wi, wo, vec4<f32>(lambda_nm), 1u).x;
}

// rho at four wavelengths (a hero-wavelength renderer's four, as pbrt-v4 samples them): what
// depends on the directions alone (blending, SH, lobes, a factor model's tables) is computed
// once; component i is sbrdf_eval(base, wi, wo, lambda_nm[i]), a non-finite one 0.
fn sbrdf_eval4(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: vec4<f32>) -> vec4<f32> {
    let ok = vec4<bool>(sbrdf_finite(lambda_nm.x), sbrdf_finite(lambda_nm.y),
        sbrdf_finite(lambda_nm.z), sbrdf_finite(lambda_nm.w));
    let v = sbrdf_eval_lanes(base, wi, wo, select(vec4<f32>(0.0), lambda_nm, ok), 4u);
    return select(vec4<f32>(0.0), v, ok);
}

// The colour weights W_i, i = 4g .. 4g + 3 the columns of sbrdf_rgb_weights4(g):
// W_i = M E(l_i) (xbar, ybar, zbar)(l_i) / sum_j E(l_j) ybar(l_j), at l_i = 380 + 5 i nm, with E the
// CIE D65 illuminant and M the IEC 61966-2-1 XYZ -> linear sRGB matrix: computed in f64 from
// src/decode/color/cie.rs and rounded to f32 (the Rust test `gpu::tests::rgb_weights_match_cie_tables`
// recomputes them and requires equality; tools/gen_wgsl_rgb_weights.py writes them). 81
// wavelengths: the last group's columns 1 to 3 are 0. A `switch` of constants rather than a
// `const` array: indexed at run time, an array would be copied into private memory.
// BEGIN GENERATED RGB WEIGHTS
fn sbrdf_rgb_weights4(g: u32) -> mat4x3<f32> {
    switch (g) {
        case 0u: { // 380 to 395 nm
            return mat4x3<f32>(
                vec3<f32>(2.736401984e-05, -2.328276423e-05, 1.628262398e-04),
                vec3<f32>(4.671593342e-05, -3.981535338e-05, 2.787752019e-04),
                vec3<f32>(9.227084956e-05, -7.896481111e-05, 5.534677184e-04),
                vec3<f32>(2.081311832e-04, -1.788624504e-04, 1.256573712e-03));
        }
        case 1u: { // 400 to 415 nm
            return mat4x3<f32>(
                vec3<f32>(4.672996583e-04, -4.035583115e-04, 2.836231375e-03),
                vec3<f32>(7.922822260e-04, -6.881969166e-04, 4.849435296e-03),
                vec3<f32>(1.546609681e-03, -1.354031148e-03, 9.583766572e-03),
                vec3<f32>(2.759892493e-03, -2.437515883e-03, 1.733913086e-02));
        }
        case 2u: { // 420 to 435 nm
            return mat4x3<f32>(
                vec3<f32>(4.749136046e-03, -4.239784554e-03, 3.046238422e-02),
                vec3<f32>(7.102948148e-03, -6.446093787e-03, 4.724521562e-02),
                vec3<f32>(8.666965179e-03, -8.031009696e-03, 6.062049791e-02),
                vec3<f32>(1.039745938e-02, -9.939746000e-03, 7.841189206e-02));
        }
        case 3u: { // 440 to 455 nm
            return mat4x3<f32>(
                vec3<f32>(1.102490071e-02, -1.100533362e-02, 9.235608578e-02),
                vec3<f32>(1.014692709e-02, -1.088432595e-02, 9.960128367e-02),
                vec3<f32>(8.166212589e-03, -1.001640875e-02, 1.043098345e-01),
                vec3<f32>(4.965676926e-03, -8.131371811e-03, 1.028559729e-01));
        }
        case 4u: { // 460 to 475 nm
            return mat4x3<f32>(
                vec3<f32>(9.962173644e-04, -5.570829380e-03, 9.857185930e-02),
                vec3<f32>(-3.401535563e-03, -2.270789351e-03, 8.884947747e-02),
                vec3<f32>(-8.086264133e-03, 1.892001717e-03, 7.355158031e-02),
                vec3<f32>(-1.267186739e-02, 6.375672761e-03, 5.930695683e-02));
        }
        case 5u: { // 480 to 495 nm
            return mat4x3<f32>(
                vec3<f32>(-1.695454493e-02, 1.107122749e-02, 4.586860165e-02),
                vec3<f32>(-2.018727921e-02, 1.525892224e-02, 3.296456113e-02),
                vec3<f32>(-2.306396887e-02, 1.948674209e-02, 2.322185598e-02),
                vec3<f32>(-2.715048566e-02, 2.505821921e-02, 1.659374498e-02));
        }
        case 6u: { // 500 to 515 nm
            return mat4x3<f32>(
                vec3<f32>(-3.188619763e-02, 3.168791905e-02, 1.148072910e-02),
                vec3<f32>(-3.720433265e-02, 3.958408162e-02, 7.266716566e-03),
                vec3<f32>(-4.192572087e-02, 4.800221324e-02, 3.321780590e-03),
                vec3<f32>(-4.508018121e-02, 5.619459227e-02, -2.205446217e-04));
        }
        case 7u: { // 520 to 535 nm
            return mat4x3<f32>(
                vec3<f32>(-4.588321596e-02, 6.315612793e-02, -2.905802568e-03),
                vec3<f32>(-4.487327859e-02, 6.957427412e-02, -4.785246216e-03),
                vec3<f32>(-4.126092792e-02, 7.430807501e-02, -6.219778676e-03),
                vec3<f32>(-3.460315242e-02, 7.519462705e-02, -7.150949910e-03));
        }
        case 8u: { // 540 to 555 nm
            return mat4x3<f32>(
                vec3<f32>(-2.645576373e-02, 7.454419136e-02, -7.755014580e-03),
                vec3<f32>(-1.715937443e-02, 7.352319360e-02, -8.175541647e-03),
                vec3<f32>(-6.358697079e-03, 7.122249156e-02, -8.348369971e-03),
                vec3<f32>(5.758139770e-03, 6.661267579e-02, -8.177512325e-03));
        }
        case 9u: { // 560 to 575 nm
            return mat4x3<f32>(
                vec3<f32>(1.869347319e-02, 6.106454879e-02, -7.842326537e-03),
                vec3<f32>(3.217719868e-02, 5.473833531e-02, -7.382581942e-03),
                vec3<f32>(4.581839591e-02, 4.774422199e-02, -6.816209294e-03),
                vec3<f32>(6.009481102e-02, 4.094711691e-02, -6.268387195e-03));
        }
        case 10u: { // 580 to 595 nm
            return mat4x3<f32>(
                vec3<f32>(7.392965257e-02, 3.372985125e-02, -5.651682150e-03),
                vec3<f32>(8.360785246e-02, 2.544838935e-02, -4.824145231e-03),
                vec3<f32>(9.070666879e-02, 1.786104217e-02, -4.032601137e-03),
                vec3<f32>(9.958435595e-02, 1.182419062e-02, -3.459956497e-03));
        }
        case 11u: { // 600 to 615 nm
            return mat4x3<f32>(
                vec3<f32>(1.052668318e-01, 6.579617504e-03, -2.926333109e-03),
                vec3<f32>(1.069405451e-01, 2.130769892e-03, -2.411489375e-03),
                vec3<f32>(1.049539819e-01, -1.181861269e-03, -1.967440592e-03),
                vec3<f32>(9.910125285e-02, -3.422832349e-03, -1.572193112e-03));
        }
        case 12u: { // 620 to 635 nm
            return mat4x3<f32>(
                vec3<f32>(9.059123695e-02, -4.696817603e-03, -1.241970807e-03),
                vec3<f32>(7.853749394e-02, -5.092732143e-03, -9.516475839e-04),
                vec3<f32>(6.598515064e-02, -4.939187318e-03, -7.182428380e-04),
                vec3<f32>(5.619686842e-02, -4.661577754e-03, -5.551548093e-04));
        }
        case 13u: { // 640 to 655 nm
            return mat4x3<f32>(
                vec3<f32>(4.682838172e-02, -4.186216742e-03, -4.249732592e-04),
                vec3<f32>(3.705943376e-02, -3.499369835e-03, -3.131919948e-04),
                vec3<f32>(2.855920233e-02, -2.800999442e-03, -2.285952505e-04),
                vec3<f32>(2.211217955e-02, -2.230354119e-03, -1.692601509e-04));
        }
        case 14u: { // 660 to 675 nm
            return mat4x3<f32>(
                vec3<f32>(1.672285981e-02, -1.721142093e-03, -1.236955577e-04),
                vec3<f32>(1.246425696e-02, -1.299640746e-03, -9.008890629e-05),
                vec3<f32>(9.111211635e-03, -9.598798351e-04, -6.461757584e-05),
                vec3<f32>(6.474243943e-03, -6.876727566e-04, -4.521357914e-05));
        }
        case 15u: { // 680 to 695 nm
            return mat4x3<f32>(
                vec3<f32>(4.646052606e-03, -4.973422620e-04, -3.196296893e-05),
                vec3<f32>(3.091558581e-03, -3.332476772e-04, -2.097925790e-05),
                vec3<f32>(2.010404831e-03, -2.175216214e-04, -1.354043889e-05),
                vec3<f32>(1.422151458e-03, -1.542119862e-04, -9.536042853e-06));
        }
        case 16u: { // 700 to 715 nm
            return mat4x3<f32>(
                vec3<f32>(1.033581677e-03, -1.121970417e-04, -6.915508948e-06),
                vec3<f32>(7.521391381e-04, -8.164596511e-05, -5.032428817e-06),
                vec3<f32>(5.470285541e-04, -5.938085451e-05, -3.660072480e-06),
                vec3<f32>(3.549552639e-04, -3.853099042e-05, -2.374942142e-06));
        }
        case 17u: { // 720 to 735 nm
            return mat4x3<f32>(
                vec3<f32>(2.269532852e-04, -2.463615783e-05, -1.518504178e-06),
                vec3<f32>(1.711882651e-04, -1.858277210e-05, -1.145390456e-06),
                vec3<f32>(1.278709242e-04, -1.388059445e-05, -8.555626323e-07),
                vec3<f32>(9.210098506e-05, -9.997714187e-06, -6.162314889e-07));
        }
        case 18u: { // 740 to 755 nm
            return mat4x3<f32>(
                vec3<f32>(6.584058428e-05, -7.147105862e-06, -4.405276570e-07),
                vec3<f32>(4.194105350e-05, -4.552771316e-06, -2.806201849e-07),
                vec3<f32>(2.685155232e-05, -2.914781135e-06, -1.796589544e-07),
                vec3<f32>(1.641277595e-05, -1.781634296e-06, -1.098149838e-07));
        }
        case 19u: { // 760 to 775 nm
            return mat4x3<f32>(
                vec3<f32>(9.799869076e-06, -1.063791615e-06, -6.556926735e-08),
                vec3<f32>(8.446046195e-06, -9.168316524e-07, -5.651110868e-08),
                vec3<f32>(7.052022738e-06, -7.655087870e-07, -4.718383906e-08),
                vec3<f32>(4.855772204e-06, -5.271020882e-07, -3.248912606e-08));
        }
        case 20u: { // 780 nm
            return mat4x3<f32>(
                vec3<f32>(3.343134722e-06, -3.629027958e-07, -2.236833119e-08),
                vec3<f32>(0.0),
                vec3<f32>(0.0),
                vec3<f32>(0.0));
        }
        default: {
            return mat4x3<f32>();
        }
    }
}
// END GENERATED RGB WEIGHTS

// Linear sRGB under D65 of rho(wi, wo, .) (Decoder::eval_linear_srgb with Illuminant::D65):
// the query and its first four coefficients once, then the series (plus F) at the 81
// wavelengths four at a time, clamped at 0 (a file of more than four terms computes its further
// coefficients for each group of four wavelengths).
fn sbrdf_eval_rgb(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let ui = sbrdf_upper(wi);
    let uo = sbrdf_upper(wo);
    if (ui.w == 0.0 || uo.w == 0.0) {
        return vec3<f32>(0.0);
    }
    var q: SbrdfQuery;
    sbrdf_query_pair(base, ui.xyz, uo.xyz, &q);
    let wr = sbrdf_to_records(&q, uo.xyz);
    var c0 = vec4<f32>(0.0);
    var rgb = vec3<f32>(0.0);
    for (var g = 0u; g < 21u; g = g + 1u) {
        let lambda = vec4<f32>(380.0 + 20.0 * f32(g)) + vec4<f32>(0.0, 5.0, 10.0, 15.0);
        let nl = select(4u, 1u, g == 20u);
        let rho = sbrdf_rho4(base, &q, ui.xyz, uo.xyz, wr, lambda, nl, &c0, g > 0u);
        rgb = rgb + sbrdf_rgb_weights4(g) * rho;
    }
    return rgb;
}

// ---- importance sampling (layout sampling section, header word 18) ----
//
// sbrdf_pdf(base, wi, wo) -> f32 and sbrdf_sample(base, wi, u) -> vec4<f32> (xyz the drawn
// direction, w its pdf): the mixture of `Decoder::sample` / `Decoder::pdf` (spec/EVALUATION.md,
// "Importance sampling"; spec/GPU_LAYOUT.md, "Sampling section") in f32. The records are blended
// as for evaluation (sbrdf_query); the mixture is the cosine plus one proposal per lobe (cosine
// power about the peak, von Mises-Fisher, GGX visible normals reflecting wi), weighted by the
// energies the layout stores, the cosine keeping at least SBRDF_MIN_COSINE_WEIGHT; a draw below
// the horizon is mirrored above it, and the pdf counts both images. u.x chooses the component
// exactly as the CPU does (its rescaled remainder then draws from it), so that the same u gives
// the same direction up to f32 rounding. A layout without a sampling section (word 18 = 0)
// samples the cosine: pdf = cos(theta_o) / pi. sbrdf_sample returns vec4(0) where the CPU
// returns None (wi zero, not finite or below the horizon, u not finite, a degenerate draw);
// sbrdf_pdf returns 0 where the CPU's pdf is 0 (either direction zero, not finite or below the
// horizon). The components are not stored: sbrdf_smp_walk goes through them in the CPU's order
// and computes what each pass needs (energies, densities, the chosen one).

const SBRDF_MIN_COSINE_WEIGHT: f32 = 0.1; // sampling/sample.rs MIN_COSINE_WEIGHT
const SBRDF_ONE_BELOW: f32 = 0.99999994; // the largest f32 below 1: u is clamped to [0, this]
const SBRDF_SHARED: u32 = 0xffffffffu; // a component's record index when the lobe is shared

// One proposal: kind 0 cosine, 1 cosine power (a = (p, n)), 2 von Mises-Fisher (a = (p, kappa),
// m = 1 - exp(-2 kappa)), 3 GGX visible normals (a = (ax, ay, axis.x, axis.y), m = k =
// G1(wi) / (4 cos theta_i)).
struct SbrdfShape {
    kind: u32,
    a: vec4<f32>,
    m: f32,
}

// exp(x) - 1, accurate relative to the result for small |x| (Taylor to x^10 below 1/2).
fn sbrdf_expm1(x: f32) -> f32 {
    if (abs(x) < 0.5) {
        return x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0
            + x * (1.0 / 720.0 + x * (1.0 / 5040.0 + x * (1.0 / 40320.0 + x * (1.0 / 362880.0
            + x * (1.0 / 3628800.0))))))))));
    }
    return exp(x) - 1.0;
}


// Absolute word of record r's sampling weights (background energy, then per lobe its weights).
fn sbrdf_smp_weights(base: u32, r: u32) -> u32 {
    let s = base + sbrdf_u(base + SBRDF_HDR_OFF_SAMPLING);
    return base + sbrdf_u(s + SBRDF_SMP_WORDS * r + SBRDF_SMP_OFF_WEIGHTS);
}

// Absolute word of lobe li's sampling weights (energy, ln width) in record r's.
fn sbrdf_smp_lobe(base: u32, r: u32, li: u32) -> u32 {
    return sbrdf_smp_weights(base, r) + SBRDF_SW_WORDS + SBRDF_SWL_WORDS * li;
}

// The GGX roughness whose distribution falls to half its peak where (1 + b s)^(-c) does
// (proposal.rs ggx_alpha): s = sin^2 theta_h (sin2) or 1 - cos theta_h.
fn sbrdf_ggx_alpha(sin2: bool, b: f32, c: f32) -> f32 {
    var hp = sbrdf_expm1(0.693147181 / c) / b;
    if (!(hp < 1.0)) {
        hp = 1.0; // also a NaN, as f64::min(NaN, 1) gives 1
    }
    var s2 = hp;
    if (!sin2) {
        s2 = hp * (2.0 - hp);
    }
    if (!(s2 > 0.0)) {
        return 1e-6;
    }
    let b_ggx = 0.414213562 / s2; // (sqrt 2 - 1) / s2
    return clamp(sqrt(1.0 / (1.0 + b_ggx)), 1e-6, 1.0);
}


// GGX visible normals of roughness (ax, ay) along the surface axis (cos psi, sin psi), for wi.
fn sbrdf_ggx_shape(ax: f32, ay: f32, axis: vec2<f32>, wi: vec3<f32>) -> SbrdfShape {
    let cz = max(wi.z, 0.0);
    let wu = wi.x * axis.x + wi.y * axis.y;
    let wv = wi.y * axis.x - wi.x * axis.y;
    let t = min(ax * ax * wu * wu + ay * ay * wv * wv, 1.0);
    return SbrdfShape(3u, vec4<f32>(ax, ay, axis.x, axis.y), 0.5 / (cz + sqrt(cz * cz + t)));
}


fn sbrdf_vmf_shape(p: vec3<f32>, ln_b: f32) -> SbrdfShape {
    let kappa = 2.0 * exp(-ln_b);
    return SbrdfShape(2u, vec4<f32>(p, kappa), -sbrdf_expm1(-2.0 * kappa));
}


// The shape of lobe li's component (records' frame), for blended record b's own lobe, or for
// the lobe every blended record shares (b = SBRDF_SHARED: blended as for evaluation); `kind`
// is the lobe's kind (1 to 5).
fn sbrdf_smp_shape(base: u32, q: ptr<function, SbrdfQuery>, li: u32, b: u32, kind: u32) -> SbrdfShape {
    let wi = (*q).wi;
    if (b != SBRDF_SHARED) {
        let r = (*q).rec[b];
        let e = sbrdf_rec(base, r);
        let par = base + sbrdf_u(sbrdf_lobe(base, e, li) + SBRDF_LOBE_OFF_PARAMETERS);
        if (kind == 1u) {
            return sbrdf_vmf_shape(sbrdf_rec_peak(e), sbrdf_f(sbrdf_smp_lobe(base, r, li) + SBRDF_SWL_LN_WIDTH));
        }
        if (kind == 4u) {
            return SbrdfShape(1u, vec4<f32>(sbrdf_rec_peak(e), sbrdf_f(par)), 0.0);
        }
        if (kind == 5u) {
            let c = sbrdf_f(par + 2u);
            let sc = sbrdf_sincos_deg(sbrdf_f(par + 5u));
            return sbrdf_ggx_shape(sbrdf_ggx_alpha(true, sbrdf_f(par), c),
                sbrdf_ggx_alpha(true, sbrdf_f(par + 1u), c), vec2<f32>(sc.y, sc.x), wi);
        }
        let alpha = sbrdf_ggx_alpha(kind == 3u, sbrdf_f(par), sbrdf_f(par + 1u));
        return sbrdf_ggx_shape(alpha, alpha, vec2<f32>(1.0, 0.0), wi);
    }
    if (kind == 1u) {
        var s = 0.0;
        var ws = 0.0;
        for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
            if (i < (*q).n) {
                s = s + (*q).w[i] * sbrdf_f(sbrdf_smp_lobe(base, (*q).rec[i], li) + SBRDF_SWL_LN_WIDTH);
                ws = ws + (*q).w[i];
            }
        }
        return sbrdf_vmf_shape(sbrdf_blended_peak(base, q), s / ws);
    }
    if (kind == 4u) {
        return SbrdfShape(1u, vec4<f32>(sbrdf_blended_peak(base, q), sbrdf_shared_geo(base, q, li, 0u)), 0.0);
    }
    if (kind == 5u) {
        let c = sbrdf_shared_geo(base, q, li, 2u);
        let sc = sbrdf_sincos_deg(sbrdf_shared_axis(base, q, li));
        return sbrdf_ggx_shape(sbrdf_ggx_alpha(true, sbrdf_shared_geo(base, q, li, 0u), c),
            sbrdf_ggx_alpha(true, sbrdf_shared_geo(base, q, li, 1u), c), vec2<f32>(sc.y, sc.x), wi);
    }
    let alpha = sbrdf_ggx_alpha(kind == 3u, sbrdf_shared_geo(base, q, li, 0u),
        sbrdf_shared_geo(base, q, li, 1u));
    return sbrdf_ggx_shape(alpha, alpha, vec2<f32>(1.0, 0.0), wi);
}

// The energy of lobe li's component: blended record b's own (its weight times its energy), or
// the shared lobe's (b = SBRDF_SHARED: the weighted sum over the blended records).
fn sbrdf_smp_energy(base: u32, q: ptr<function, SbrdfQuery>, li: u32, b: u32) -> f32 {
    if (b != SBRDF_SHARED) {
        return (*q).w[b] * sbrdf_f(sbrdf_smp_lobe(base, (*q).rec[b], li) + SBRDF_SWL_ENERGY);
    }
    var energy = 0.0;
    for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
        if (i < (*q).n) {
            energy = energy + (*q).w[i] * sbrdf_f(sbrdf_smp_lobe(base, (*q).rec[i], li) + SBRDF_SWL_ENERGY);
        }
    }
    return energy;
}

// The mixture's lobe components (sampling.rs Mixture::new), in its order: per lobe position,
// one component when the blended records share the lobe, else one per blended record that has
// it, each kept when its energy is > 0 and finite (at most 4 x 8 = 32 of them). One pass over
// them, starting from the sum t.y:
//   mode 0: t.y plus their energies, in .x;
//   mode 1: t.y plus, for each, energy x scale times its density at w and at w mirrored below
//           the horizon, in .x (w in the records' frame);
//   mode 2: the first whose cumulative probability (energy x scale, from t.y) exceeds t.x:
//           (li, b) as bits in .xy, the cumulative probability before it in .z and its own in
//           .w; when none does, the last one's, with .z the total (as the CPU's choice).
fn sbrdf_smp_walk(base: u32, q: ptr<function, SbrdfQuery>, mode: u32, scale: f32, t: vec2<f32>,
    w: vec3<f32>) -> vec4<f32> {
    let below = vec3<f32>(w.x, w.y, -w.z);
    var acc = t.y;
    var last = vec4<f32>(0.0);
    for (var li = 0u; li < SBRDF_MAX_LOBES; li = li + 1u) {
        if (li >= (*q).mmax) {
            break;
        }
        let shared_kind = sbrdf_shared_kind(base, q, li);
        // A shared lobe is one component (b = SBRDF_SHARED); else one per blended record.
        let nb = select((*q).n, 1u, shared_kind != 0u);
        for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
            if (i >= nb) {
                break;
            }
            var b = SBRDF_SHARED;
            var kind = shared_kind;
            if (shared_kind == 0u) {
                b = i;
                let e = sbrdf_rec(base, (*q).rec[i]);
                if (li >= sbrdf_u(e + SBRDF_REC_LOBES)) {
                    continue;
                }
                kind = sbrdf_u(sbrdf_lobe(base, e, li) + SBRDF_LOBE_KIND);
            }
            let energy = sbrdf_smp_energy(base, q, li, b);
            if (!(energy > 0.0 && sbrdf_finite(energy))) {
                continue;
            }
            if (mode == 0u) {
                acc = acc + energy;
                continue;
            }
            let p = energy * scale;
            if (mode == 1u) {
                let s = sbrdf_smp_shape(base, q, li, b, kind);
                acc = acc + p * (sbrdf_smp_density1(s, (*q).wi, w) + sbrdf_smp_density1(s, (*q).wi, below));
                continue;
            }
            last = vec4<f32>(bitcast<f32>(li), bitcast<f32>(b), acc, p);
            if (t.x < acc + p) {
                return last;
            }
            acc = acc + p;
        }
    }
    if (mode == 2u) {
        return vec4<f32>(last.xy, acc, last.w);
    }
    return vec4<f32>(acc, 0.0, 0.0, 0.0);
}

// The query's mixture (sampling.rs Mixture::normalise): (p0, scale), the cosine's probability
// (at least SBRDF_MIN_COSINE_WEIGHT) and the factor that turns a lobe component's energy into
// its probability; (1, 0) when the lobes' energies are not > 0 and finite (the cosine alone).
fn sbrdf_smp_mixture(base: u32, q: ptr<function, SbrdfQuery>) -> vec2<f32> {
    var cosine = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < (*q).n) {
            cosine = cosine + (*q).w[b] * sbrdf_f(sbrdf_smp_weights(base, (*q).rec[b]) + SBRDF_SW_BACKGROUND);
        }
    }
    if (!sbrdf_finite(cosine) || cosine < 0.0) {
        cosine = 0.0;
    }
    let lobes = sbrdf_smp_walk(base, q, 0u, 0.0, vec2<f32>(0.0), vec3<f32>(0.0)).x;
    if (!(lobes > 0.0 && sbrdf_finite(lobes))) {
        return vec2<f32>(1.0, 0.0);
    }
    let p0 = max(cosine / (cosine + lobes), SBRDF_MIN_COSINE_WEIGHT);
    return vec2<f32>(p0, (1.0 - p0) / lobes);
}

// The mixture's density over the upper hemisphere at w (records' frame): the cosine's, then each
// lobe component at w and at its mirror image below the horizon.
fn sbrdf_smp_density(base: u32, q: ptr<function, SbrdfQuery>, mix: vec2<f32>, w: vec3<f32>) -> f32 {
    let cosine = mix.x * max(w.z, 0.0) / SBRDF_PI;
    if (mix.y == 0.0) {
        return cosine;
    }
    return sbrdf_smp_walk(base, q, 1u, mix.y, vec2<f32>(0.0, cosine), w).x;
}

// A component's density over the sphere at the unit vector w (records' frame; wi the
// evaluation incidence there, which GGX's visible normals reflect).
fn sbrdf_smp_density1(sh: SbrdfShape, wi: vec3<f32>, w: vec3<f32>) -> f32 {
    let kind = sh.kind;
    let a = sh.a;
    if (kind == 0u) {
        return max(w.z, 0.0) / SBRDF_PI;
    }
    if (kind == 1u) {
        if (dot(w, a.xyz) <= 0.0) {
            return 0.0;
        }
        if (a.w == 0.0) {
            return 1.0 / (2.0 * SBRDF_PI);
        }
        return (a.w + 1.0) / (2.0 * SBRDF_PI) * sbrdf_cos_power(w, a.xyz, a.w);
    }
    if (kind == 2u) {
        // exp(kappa (cos - 1)) with 1 - cos = |w - p|^2 / 2, exact for small angles.
        let d = w - a.xyz;
        let x = min(0.5 * dot(d, d), 2.0);
        return a.w / (2.0 * SBRDF_PI * sh.m) * exp(-a.w * x);
    }
    let hs = wi + w;
    let len = length(hs);
    if (!(len > 0.0)) {
        return 0.0;
    }
    let h = hs / len;
    if (h.z <= 0.0 || dot(wi, h) <= 0.0) {
        return 0.0;
    }
    let hu = h.x * a.z + h.y * a.w;
    let hv = h.y * a.z - h.x * a.w;
    let t = hu * hu / (a.x * a.x) + hv * hv / (a.y * a.y) + h.z * h.z;
    return sh.m / (SBRDF_PI * a.x * a.y * t * t);
}


// The unit vector at angle (cos_a, sin_a) from the unit vector p, at azimuth 2 pi u about it
// (proposal.rs `around`, with the frame of Duff et al. 2017).
fn sbrdf_smp_around(p: vec3<f32>, cos_a: f32, sin_a: f32, u: f32) -> vec3<f32> {
    let sg = select(1.0, -1.0, (bitcast<u32>(p.z) & 0x80000000u) != 0u);
    let aa = -1.0 / (sg + p.z);
    let bb = p.x * p.y * aa;
    let t = vec3<f32>(1.0 + sg * p.x * p.x * aa, sg * bb, -sg * p.x);
    let b = vec3<f32>(bb, sg + p.y * p.y * aa, -p.y);
    let sc = sbrdf_sincos_turns(u);
    return (sin_a * sc.y) * t + (sin_a * sc.x) * b + cos_a * p;
}


// A direction over the sphere from a component (records' frame; wi as for
// sbrdf_smp_density1) and u in [0, 1)^2; .w = 0 when the draw is degenerate (the CPU's None).
fn sbrdf_smp_draw(sh: SbrdfShape, wi: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    let kind = sh.kind;
    let a = sh.a;
    if (kind == 0u) {
        let r = sqrt(u.x);
        let sc = sbrdf_sincos_turns(u.y);
        return vec4<f32>(r * sc.y, r * sc.x, sqrt(1.0 - u.x), 1.0);
    }
    if (kind == 1u) {
        // cos alpha = u^(1/(n+1)); sin alpha from -expm1(2 ln u / (n + 1)).
        if (u.x == 0.0) {
            return vec4<f32>(sbrdf_smp_around(a.xyz, 0.0, 1.0, u.y), 1.0);
        }
        let e = sbrdf_ln(u.x) / (a.w + 1.0);
        let sin_a = sqrt(max(-sbrdf_expm1(2.0 * e), 0.0));
        return vec4<f32>(sbrdf_smp_around(a.xyz, exp(e), sin_a, u.y), 1.0);
    }
    if (kind == 2u) {
        // 1 - cos alpha = -ln(1 - (1 - u) m) / kappa. The argument 1 - (1 - u) m is
        // u + (1 - u) exp(-2 kappa), which keeps u's relative precision where it is small.
        let kappa = a.w;
        let x = (1.0 - u.x) * sh.m;
        var t = 2.0;
        if (x < 0.5) {
            t = -sbrdf_log1p(-x) / kappa;
        } else {
            let arg = u.x + (1.0 - u.x) * exp(-2.0 * kappa);
            if (arg > 0.0) {
                t = -sbrdf_ln(arg) / kappa;
            }
        }
        t = clamp(t, 0.0, 2.0);
        return vec4<f32>(sbrdf_smp_around(a.xyz, 1.0 - t, sqrt(t * (2.0 - t)), u.y), 1.0);
    }
    // GGX visible normals (Heitz 2018), in the frame of the axes (u, v, z).
    let ax = a.x;
    let ay = a.y;
    let axis = a.zw;
    let iu = wi.x * axis.x + wi.y * axis.y;
    let iv = wi.y * axis.x - wi.x * axis.y;
    let vv = vec3<f32>(ax * iu, ay * iv, max(wi.z, 0.0));
    let vl = length(vv);
    if (!(vl > 0.0)) {
        return vec4<f32>(0.0);
    }
    let vh = vv / vl;
    let len2 = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if (len2 > 0.0) {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(len2);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let sc = sbrdf_sincos_turns(u.y);
    let p1 = r * sc.y;
    let sw = 0.5 * (1.0 + vh.z);
    // s = sqrt(1 - p1^2) and pz = sqrt(1 - p1^2 - p2^2) without their cancellations (near the
    // disk's edge, where the normal is nearly perpendicular to vh, 1 - p1^2 - p2^2 in f32 would
    // lose all but a few bits): 1 - p1^2 = (1 - u.x) + u.x sin^2; s -+ r sin from
    // (s - r sin)(s + r sin) = 1 - u.x, whichever side has no cancellation; 1 - sw = len2 / (2 (1 +
    // vh.z)); and pz^2 = (s - p2)(s + p2) = sw (s - r sin) ((2 - 2 sw) s + sw (s + r sin)).
    let one_u = 1.0 - u.x;
    let s = sqrt(one_u + u.x * sc.x * sc.x);
    var dm = s - r * sc.x; // s - r sin
    var dp = s + r * sc.x; // s + r sin
    if (sc.x > 0.0) {
        dm = one_u / dp;
    } else if (dm > 0.0) {
        dp = one_u / dm;
    }
    let two_minus = len2 / (1.0 + vh.z); // 2 - 2 sw = 1 - vh.z
    let p2 = 0.5 * two_minus * s + sw * r * sc.x;
    let pz = sqrt(max(sw * dm * (two_minus * s + sw * dp), 0.0));
    let nh = p1 * t1 + p2 * t2 + pz * vh;
    let hv = vec3<f32>(ax * nh.x, ay * nh.y, max(nh.z, 0.0));
    let hlen = length(hv);
    if (!(hlen > 0.0)) {
        return vec4<f32>(0.0);
    }
    let hl = hv / hlen;
    let h = vec3<f32>(hl.x * axis.x - hl.y * axis.y, hl.x * axis.y + hl.y * axis.x, hl.z);
    let d = dot(wi, h);
    if (d <= 0.0) {
        return vec4<f32>(0.0);
    }
    let o = 2.0 * d * h - wi;
    let ol = length(o);
    if (!(ol > 0.0)) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(o / ol, 1.0);
}


// The density (1/sr) with which sbrdf_sample draws wo for wi (Decoder::pdf).
fn sbrdf_pdf(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let ui = sbrdf_upper(wi);
    let uo = sbrdf_upper(wo);
    if (ui.w == 0.0 || uo.w == 0.0) {
        return 0.0;
    }
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_pdf(w, wi, wo);
    }
    if (sbrdf_u(base + SBRDF_HDR_OFF_SAMPLING) == 0u) {
        return uo.z / SBRDF_PI;
    }
    var q: SbrdfQuery;
    sbrdf_query(base, ui.xyz, &q);
    let mix = sbrdf_smp_mixture(base, &q);
    return sbrdf_smp_density(base, &q, mix, sbrdf_to_records(&q, uo.xyz));
}

// A direction drawn for wi from u in [0, 1)^2 (Decoder::sample): (wo, pdf), or vec4(0) where
// the CPU gives None.
fn sbrdf_sample(base: u32, wi: vec3<f32>, u_in: vec2<f32>) -> vec4<f32> {
    if (!(sbrdf_finite(u_in.x) && sbrdf_finite(u_in.y))) {
        return vec4<f32>(0.0);
    }
    let u = clamp(u_in, vec2<f32>(0.0), vec2<f32>(SBRDF_ONE_BELOW));
    let ui = sbrdf_upper(wi);
    if (ui.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_sample(w, wi, u);
    }
    if (sbrdf_u(base + SBRDF_HDR_OFF_SAMPLING) == 0u) {
        let r = sqrt(u.x);
        let sc = sbrdf_sincos_turns(u.y);
        let z = sqrt(1.0 - u.x);
        return vec4<f32>(r * sc.y, r * sc.x, z, z / SBRDF_PI);
    }
    var q: SbrdfQuery;
    sbrdf_query(base, ui.xyz, &q);
    let mix = sbrdf_smp_mixture(base, &q);
    // The component: the first whose cumulative probability exceeds u.x (the cosine's is p0).
    var d = vec4<f32>(0.0);
    if (u.x < mix.x) {
        let u0 = clamp(u.x / mix.x, 0.0, SBRDF_ONE_BELOW);
        d = sbrdf_smp_draw(SbrdfShape(0u, vec4<f32>(0.0), 0.0), q.wi, vec2<f32>(u0, u.y));
    } else {
        let c = sbrdf_smp_walk(base, &q, 2u, mix.y, vec2<f32>(u.x, mix.x), vec3<f32>(0.0));
        let li = bitcast<u32>(c.x);
        let b = bitcast<u32>(c.y);
        var kind = sbrdf_shared_kind(base, &q, li);
        if (b != SBRDF_SHARED) {
            kind = sbrdf_u(sbrdf_lobe(base, sbrdf_rec(base, q.rec[b]), li) + SBRDF_LOBE_KIND);
        }
        let u0 = clamp((u.x - c.z) / c.w, 0.0, SBRDF_ONE_BELOW);
        d = sbrdf_smp_draw(sbrdf_smp_shape(base, &q, li, b, kind), q.wi, vec2<f32>(u0, u.y));
    }
    if (d.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let wo = sbrdf_from_records(&q, vec3<f32>(d.x, d.y, abs(d.z)));
    // The density at the direction as returned, computed as sbrdf_pdf computes it.
    let back = sbrdf_upper(wo);
    if (back.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let pdf = sbrdf_smp_density(base, &q, mix, sbrdf_to_records(&q, back.xyz));
    if (!(pdf > 0.0 && sbrdf_finite(pdf))) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(wo, pdf);
}
