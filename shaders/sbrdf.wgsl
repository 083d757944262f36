// sbrdf.wgsl: evaluation of an sbrdf material from its flat device layout
// (spec/GPU_LAYOUT.md, layout versions 1 to 4) in WGSL, all in f32.
//
// HOW TO USE. Paste (or concatenate) this text after the host shader's own declarations. It
// declares NO binding itself: it reads the layout words from a storage array named
// `sbrdf_words` that the host must declare, for example
//
//     @group(0) @binding(0) var<storage, read> sbrdf_words: array<u32>;
//
// filled with the words `Decoder::gpu_layout()` returns (several materials may be concatenated;
// a material is addressed by the word offset `base` where its layout starts). Every identifier
// this module declares starts with `sbrdf_` / `SBRDF_`.
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
// MODEL SECTIONS. A layout without a sampling section (version 1) samples the cosine. A factor
// model (FACT) is the model section of kind 1 (version 3, header word 19; 0 in versions 1 and 2):
// its F is added to the records' series. Warped tables (WARP, the RGL measurements) are the
// model section of kind 2 (version 4): they answer every query and sample themselves (the
// "warped tables" block at the end).
// No check of the header's magic or version is made per query: the host checks them once.
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
// other covered golden file meets (worst 0.44 of it).

const SBRDF_MAX_TERMS: u32 = 256u; // K <= 256 (spec/FORMAT.md)
const SBRDF_MAX_SH: u32 = 441u; // (20 + 1)^2: SH level <= 20
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
    if (enc == 1u) {
        return sbrdf_f(o + i);
    }
    let pair = unpack2x16float(sbrdf_words[o + (i >> 1u)]);
    return select(pair.x, pair.y, (i & 1u) == 1u) * scale;
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

// Real SH Y_0..Y_{(level+1)^2-1} at the unit vector w ("Spherical harmonics", Cartesian form),
// into y. The associated Legendre part is carried already normalised (the recurrence of
// K_l^m Q_l^m): the unnormalised Q_l^m and the factorial ratio of K_l^m overflow f32 from
// level 17 on ((2m-1)!! and (l+m)! up to 40!), and their product would lose precision.
fn sbrdf_sh_eval(level: u32, w: vec3<f32>, y: ptr<function, array<f32, 441>>) {
    let x = w.x;
    let yy = w.y;
    let z = w.z;
    var c = 1.0; // C_m
    var s = 0.0; // S_m
    var pmm = 0.28209479177387814; // K_0^0 Q_0^0 = sqrt(1 / (4 pi))
    for (var m = 0u; m <= level; m = m + 1u) {
        if (m > 0u) {
            let c2 = x * c - yy * s;
            s = yy * c + x * s;
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
                p = sqrt(2.0 * fm + 3.0) * z * pmm;
            } else if (l > m + 1u) {
                let a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
                let b = sqrt(((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0));
                p = a * (z * p1 - b * p2);
            }
            if (l > m) {
                p2 = p1;
                p1 = p;
            }
            let centre = l * (l + 1u);
            if (m == 0u) {
                (*y)[centre] = p;
            } else {
                (*y)[centre + m] = 1.41421356237 * p * c;
                (*y)[centre - m] = 1.41421356237 * p * s;
            }
        }
    }
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

// ------------------------------------------------------------------ the query

struct SbrdfBlend {
    n: u32, // records blended (1..4), in increasing record index
    rec: array<u32, 4>,
    w: array<f32, 4>,
    theta: f32, // the evaluation incidence (theta*, phi*), degrees
    phi: f32,
    wi: vec3<f32>, // its direction, in the records' frame
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

fn sbrdf_blend_add(bl: ptr<function, SbrdfBlend>, rec: u32, w: f32) {
    for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
        if (i >= (*bl).n) {
            break;
        }
        if ((*bl).rec[i] == rec) {
            (*bl).w[i] = (*bl).w[i] + w;
            return;
        }
    }
    let n = (*bl).n;
    (*bl).rec[n] = rec;
    (*bl).w[n] = w;
    (*bl).n = n + 1u;
}

// Step 4: the cells merged by record, sorted by record index, weights 0 dropped.
fn sbrdf_blend_finish(bl: ptr<function, SbrdfBlend>) {
    var out: SbrdfBlend = *bl;
    out.n = 0u;
    for (var it = 0u; it < SBRDF_MAX_BLEND; it = it + 1u) {
        // selection: the smallest record index not yet taken with a positive weight
        var best = 0xffffffffu;
        var bw = 0.0;
        for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
            if (i < (*bl).n && (*bl).w[i] > 0.0 && (*bl).rec[i] < best
                && (out.n == 0u || (*bl).rec[i] > out.rec[out.n - 1u])) {
                best = (*bl).rec[i];
                bw = (*bl).w[i];
            }
        }
        if (best == 0xffffffffu) {
            break;
        }
        out.rec[out.n] = best;
        out.w[out.n] = bw;
        out.n = out.n + 1u;
    }
    *bl = out;
}

// The record table entry of record r.
fn sbrdf_rec(base: u32, r: u32) -> u32 {
    return base + sbrdf_u(base + 17u) + 12u * r;
}

// The peak direction of record entry e.
fn sbrdf_rec_peak(e: u32) -> vec3<f32> {
    return sbrdf_dir(sbrdf_f(e + 2u), sbrdf_f(e + 3u));
}

// "Blended peak direction" of a lobe shared by the blended records (kinds 1 and 4).
fn sbrdf_blended_peak(base: u32, bl: SbrdfBlend, isotropic: bool) -> vec3<f32> {
    if (isotropic) {
        var v = vec3<f32>(0.0);
        for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
            if (i < bl.n) {
                v = v + bl.w[i] * sbrdf_rec_peak(sbrdf_rec(base, bl.rec[i]));
            }
        }
        let n = length(v);
        if (n != 0.0 && sbrdf_finite(n)) {
            return v / n;
        }
    }
    var dt = 0.0;
    var dp = 0.0;
    for (var i = 0u; i < SBRDF_MAX_BLEND; i = i + 1u) {
        if (i < bl.n) {
            let e = sbrdf_rec(base, bl.rec[i]);
            let ti = sbrdf_f(e);
            let pi = sbrdf_f(e + 1u);
            let tp = sbrdf_f(e + 2u);
            let pp = sbrdf_f(e + 3u);
            dt = dt + bl.w[i] * (tp - ti);
            if (tp != 0.0) {
                var off = (pp - (pi + 180.0)) % 360.0;
                if (off > 180.0) {
                    off = off - 360.0;
                } else if (off <= -180.0) {
                    off = off + 360.0;
                }
                dp = dp + bl.w[i] * off;
            }
        }
    }
    return sbrdf_dir(bl.theta + dt, sbrdf_wrap360(bl.phi + 180.0) + dp);
}

// The blended spectral coefficients at (wi, wo): ("Reconstruction", steps 1 to 4 and the
// lobes), into coef[0..tmax); returns tmax, 0 when rho is 0 (step 1 and 2's refusals).
fn sbrdf_coefficients(base: u32, wi_in: vec3<f32>, wo_in: vec3<f32>,
    coef: ptr<function, array<f32, 256>>) -> u32 {
    let ui4 = sbrdf_upper(wi_in);
    let uo4 = sbrdf_upper(wo_in);
    if (ui4.w == 0.0 || uo4.w == 0.0) {
        return 0u;
    }
    let ui = ui4.xyz;
    var wo = uo4.xyz;
    let inc_layout = sbrdf_u(base + 3u);
    let isotropic = inc_layout == 0u;
    let n_rec = sbrdf_u(base + 8u);
    let n_theta = sbrdf_u(base + 9u);
    let n_phi = sbrdf_u(base + 10u);
    let off_th = base + sbrdf_u(base + 15u);
    let off_ph = base + sbrdf_u(base + 16u);

    // theta of the query from its horizontal length and height (atan2, so that it keeps its
    // precision near the normal, where acos(z) does not).
    let r = sqrt(ui.x * ui.x + ui.y * ui.y);
    let theta_q = sbrdf_atan2_deg(r, ui.z);
    var wq = ui;
    var phi_q = 0.0;
    if (isotropic) {
        // Step 3: turn the query so that wi has azimuth 0, with the azimuth's cosine and sine
        // taken from the vector (no trigonometry).
        var c = 1.0;
        var s = 0.0;
        if (r > 0.0) {
            c = ui.x / r;
            s = ui.y / r;
        }
        wq = vec3<f32>(r, 0.0, ui.z);
        wo = vec3<f32>(c * wo.x + s * wo.y, -s * wo.x + c * wo.y, wo.z);
    } else if (r > 0.0) {
        phi_q = sbrdf_wrap360(sbrdf_atan2_deg(ui.y, ui.x));
    }

    // Step 4: the records to blend and the evaluation incidence.
    var bl: SbrdfBlend;
    bl.n = 0u;
    if (inc_layout == 2u) {
        // Scattered: the nearest stored incidence (largest cosine, the lowest index on ties).
        var best = 0u;
        var best_cos = -2.0;
        for (var i = 0u; i < n_rec; i = i + 1u) {
            let e = sbrdf_rec(base, i);
            let cs = dot(sbrdf_dir(sbrdf_f(e), sbrdf_f(e + 1u)), ui);
            if (cs > best_cos) {
                best_cos = cs;
                best = i;
            }
        }
        let e = sbrdf_rec(base, best);
        bl.n = 1u;
        bl.rec[0] = best;
        bl.w[0] = 1.0;
        bl.theta = sbrdf_f(e);
        bl.phi = sbrdf_f(e + 1u);
        bl.wi = sbrdf_dir(bl.theta, bl.phi);
    } else {
        let th0 = sbrdf_f(off_th);
        let th1 = sbrdf_f(off_th + n_theta - 1u);
        bl.theta = clamp(theta_q, th0, th1);
        let bt = sbrdf_bracket(off_th, n_theta, theta_q);
        let i = bitcast<u32>(bt.x);
        let t = bt.y;
        let i2 = min(i + 1u, n_theta - 1u);
        if (isotropic) {
            sbrdf_blend_add(&bl, i, 1.0 - t);
            sbrdf_blend_add(&bl, i2, t);
            bl.phi = 0.0;
            // theta unclamped: the evaluation direction is the query's own vector (more
            // precise than rebuilding it from an f32 angle).
            bl.wi = select(sbrdf_dir(bl.theta, 0.0), wq, bl.theta == theta_q);
        } else {
            var j = 0u;
            var j2 = 0u;
            var u = 0.0;
            let p = phi_q;
            if (n_phi > 1u) {
                let p0 = sbrdf_f(off_ph);
                let p1 = sbrdf_f(off_ph + n_phi - 1u);
                if (p < p0 || p >= p1) {
                    j = n_phi - 1u;
                    j2 = 0u;
                    u = sbrdf_wrap360(p - p1) / (p0 + 360.0 - p1);
                } else {
                    let bp = sbrdf_bracket(off_ph, n_phi, p);
                    j = bitcast<u32>(bp.x);
                    u = bp.y;
                    j2 = j + 1u;
                }
            }
            sbrdf_blend_add(&bl, i * n_phi + j, (1.0 - t) * (1.0 - u));
            sbrdf_blend_add(&bl, i * n_phi + j2, (1.0 - t) * u);
            sbrdf_blend_add(&bl, i2 * n_phi + j, t * (1.0 - u));
            sbrdf_blend_add(&bl, i2 * n_phi + j2, t * u);
            if (n_phi == 1u) {
                bl.phi = sbrdf_f(off_ph); // a single stored azimuth is clamped to, like theta
                bl.wi = sbrdf_dir(bl.theta, bl.phi);
            } else {
                bl.phi = phi_q;
                bl.wi = select(sbrdf_dir(bl.theta, bl.phi), ui, bl.theta == theta_q);
            }
        }
        sbrdf_blend_finish(&bl);
    }
    let wis = bl.wi;

    // The blended records' largest term count, SH level and lobe count.
    var tmax = 1u;
    var lmax = 0u;
    var mmax = 0u;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < bl.n) {
            let e = sbrdf_rec(base, bl.rec[b]);
            lmax = max(lmax, sbrdf_u(e + 4u));
            tmax = max(tmax, sbrdf_u(e + 5u));
            mmax = max(mmax, sbrdf_u(e + 6u));
        }
    }
    tmax = min(tmax, SBRDF_MAX_TERMS);
    lmax = min(lmax, 20u);
    mmax = min(mmax, SBRDF_MAX_LOBES);
    for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
        if (k >= tmax) {
            break;
        }
        (*coef)[k] = 0.0;
    }

    // The SH background: Y once at the largest level (a lower level's Y are its prefix).
    var y: array<f32, 441>;
    sbrdf_sh_eval(lmax, wo, &y);
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b >= bl.n) {
            break;
        }
        let e = sbrdf_rec(base, bl.rec[b]);
        let level = sbrdf_u(e + 4u);
        let terms = sbrdf_u(e + 5u);
        let enc = sbrdf_u(e + 7u);
        let scale = sbrdf_f(e + 8u);
        let o = base + sbrdf_u(e + 9u);
        let pr = (level + 1u) * (level + 1u);
        for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
            if (k >= terms) {
                break;
            }
            var acc = 0.0;
            for (var j = 0u; j < SBRDF_MAX_SH; j = j + 1u) {
                if (j >= pr) {
                    break;
                }
                acc = acc + sbrdf_value(o, k * pr + j, enc, scale) * y[j];
            }
            (*coef)[k] = (*coef)[k] + bl.w[b] * acc;
        }
    }

    // The lobes, by position ("Lobes by position").
    for (var li = 0u; li < SBRDF_MAX_LOBES; li = li + 1u) {
        if (li >= mmax) {
            break;
        }
        // Shared: more than one record blended, each with a lobe at li, all of one kind.
        var shared_kind = 0u;
        if (bl.n > 1u) {
            shared_kind = 0xffffffffu;
            for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
                if (b < bl.n) {
                    let e = sbrdf_rec(base, bl.rec[b]);
                    var kind = 0u;
                    if (li < sbrdf_u(e + 6u)) {
                        kind = sbrdf_u(base + sbrdf_u(e + 10u) + 3u * li);
                    }
                    if (kind == 0u || (shared_kind != 0xffffffffu && kind != shared_kind)) {
                        shared_kind = 0u;
                        break;
                    }
                    shared_kind = kind;
                }
            }
        }
        if (shared_kind != 0u) {
            sbrdf_add_shared_lobe(base, bl, isotropic, shared_kind, li, tmax, wis, wo, coef);
        } else {
            for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
                if (b >= bl.n) {
                    break;
                }
                let e = sbrdf_rec(base, bl.rec[b]);
                if (li < sbrdf_u(e + 6u)) {
                    sbrdf_add_lobe(base, e, li, bl.w[b], wis, wo, coef);
                }
            }
        }
    }
    return tmax;
}

// One record's lobe li, times the blending weight wgt, added to coef.
fn sbrdf_add_lobe(base: u32, e: u32, li: u32, wgt: f32, wis: vec3<f32>, w: vec3<f32>,
    coef: ptr<function, array<f32, 256>>) {
    let terms = sbrdf_u(e + 5u);
    let enc = sbrdf_u(e + 7u);
    let scale = sbrdf_f(e + 8u);
    let lt = base + sbrdf_u(e + 10u) + 3u * li;
    let kind = sbrdf_u(lt);
    let amp = base + sbrdf_u(lt + 1u);
    let par = base + sbrdf_u(lt + 2u);
    if (kind == 1u || kind == 4u) {
        let peak = sbrdf_rec_peak(e);
        if (kind == 1u) {
            let a = sbrdf_angle(w, peak);
            let a2 = a * a;
            for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
                if (k >= terms) {
                    break;
                }
                let g = exp(-a2 / sbrdf_f(par + k));
                (*coef)[k] = (*coef)[k] + wgt * sbrdf_value(amp, k, enc, scale) * g;
            }
        } else {
            let f = sbrdf_cos_power(w, peak, sbrdf_f(par));
            for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
                if (k >= terms) {
                    break;
                }
                (*coef)[k] = (*coef)[k] + wgt * sbrdf_value(amp, k, enc, scale) * f;
            }
        }
        return;
    }
    var q = vec3<f32>(0.0);
    if (kind == 5u) {
        q = vec3<f32>(sbrdf_f(par + 3u), sbrdf_f(par + 4u), sbrdf_f(par + 5u));
    }
    let p = vec3<f32>(sbrdf_f(par), sbrdf_f(par + 1u), sbrdf_f(par + 2u));
    let v = sbrdf_microfacet(kind, p, q, wis, w);
    for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
        if (k >= terms) {
            break;
        }
        let s = v.x * sbrdf_value(amp, k, enc, scale)
            + v.y * sbrdf_value(amp, terms + k, enc, scale)
            + v.z * sbrdf_value(amp, 2u * terms + k, enc, scale)
            + v.w * sbrdf_value(amp, 3u * terms + k, enc, scale);
        (*coef)[k] = (*coef)[k] + wgt * s;
    }
}

// Sum over the blended records of weight times amplitude (variant j, term k) of lobe li:
// the blended amplitude ("Lobes by position"); a record with fewer terms adds 0.
fn sbrdf_shared_amp(base: u32, bl: SbrdfBlend, li: u32, j: u32, k: u32) -> f32 {
    var a = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < bl.n) {
            let e = sbrdf_rec(base, bl.rec[b]);
            let terms = sbrdf_u(e + 5u);
            if (k < terms) {
                let lt = base + sbrdf_u(e + 10u) + 3u * li;
                let amp = base + sbrdf_u(lt + 1u);
                a = a + bl.w[b] * sbrdf_value(amp, j * terms + k, sbrdf_u(e + 7u), sbrdf_f(e + 8u));
            }
        }
    }
    return a;
}

// Parameter i of lobe li of blended record b.
fn sbrdf_shared_par(base: u32, bl: SbrdfBlend, b: u32, li: u32, i: u32) -> f32 {
    let e = sbrdf_rec(base, bl.rec[b]);
    let lt = base + sbrdf_u(e + 10u) + 3u * li;
    return sbrdf_f(base + sbrdf_u(lt + 2u) + i);
}

// Weighted geometric mean of parameter i over the blended records: exp(sum w log x).
fn sbrdf_shared_geo(base: u32, bl: SbrdfBlend, li: u32, i: u32) -> f32 {
    var s = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < bl.n) {
            s = s + bl.w[b] * sbrdf_ln(sbrdf_shared_par(base, bl, b, li, i));
        }
    }
    return exp(s);
}

// Weighted arithmetic mean of parameter i over the blended records.
fn sbrdf_shared_lin(base: u32, bl: SbrdfBlend, li: u32, i: u32) -> f32 {
    var s = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < bl.n) {
            s = s + bl.w[b] * sbrdf_shared_par(base, bl, b, li, i);
        }
    }
    return s;
}

// A lobe present, of one kind, in every blended record ("Lobes by position"): amplitudes
// blended linearly, shape parameters as the spec says, evaluated once.
fn sbrdf_add_shared_lobe(base: u32, bl: SbrdfBlend, isotropic: bool, kind: u32, li: u32,
    tmax: u32, wis: vec3<f32>, w: vec3<f32>, coef: ptr<function, array<f32, 256>>) {
    if (kind == 1u || kind == 4u) {
        let peak = sbrdf_blended_peak(base, bl, isotropic);
        if (kind == 1u) {
            let a = sbrdf_angle(w, peak);
            let a2 = a * a;
            for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
                if (k >= tmax) {
                    break;
                }
                // The width of term k: the geometric mean over the records that have term k,
                // their weights renormalised.
                var s = 0.0;
                var ws = 0.0;
                for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
                    if (b < bl.n && k < sbrdf_u(sbrdf_rec(base, bl.rec[b]) + 5u)) {
                        s = s + bl.w[b] * sbrdf_ln(sbrdf_shared_par(base, bl, b, li, k));
                        ws = ws + bl.w[b];
                    }
                }
                let width = exp(s / ws);
                (*coef)[k] = (*coef)[k] + sbrdf_shared_amp(base, bl, li, 0u, k) * exp(-a2 / width);
            }
        } else {
            let f = sbrdf_cos_power(w, peak, sbrdf_shared_geo(base, bl, li, 0u));
            for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
                if (k >= tmax) {
                    break;
                }
                (*coef)[k] = (*coef)[k] + sbrdf_shared_amp(base, bl, li, 0u, k) * f;
            }
        }
        return;
    }
    var p = vec3<f32>(0.0);
    var q = vec3<f32>(0.0);
    if (kind == 5u) {
        p = vec3<f32>(sbrdf_shared_geo(base, bl, li, 0u), sbrdf_shared_geo(base, bl, li, 1u),
            sbrdf_shared_geo(base, bl, li, 2u));
        // psi blended as an axis: the doubled angles' weighted mean, halved back to [0, 180);
        // the first record's psi when that mean vanishes.
        var x = 0.0;
        var yv = 0.0;
        var tw = 0.0;
        for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
            if (b < bl.n) {
                let cs = sbrdf_sincos_deg(2.0 * sbrdf_shared_par(base, bl, b, li, 5u));
                x = x + bl.w[b] * cs.y;
                yv = yv + bl.w[b] * cs.x;
                tw = tw + abs(bl.w[b]);
            }
        }
        var psi = sbrdf_shared_par(base, bl, 0u, li, 5u);
        if (sqrt(x * x + yv * yv) > 1e-9 * tw) {
            psi = 0.5 * sbrdf_atan2_deg(yv, x);
            if (psi < 0.0) {
                psi = psi + 180.0;
            }
            if (psi >= 180.0) {
                psi = 0.0;
            }
        }
        q = vec3<f32>(sbrdf_shared_lin(base, bl, li, 3u), sbrdf_shared_lin(base, bl, li, 4u), psi);
    } else {
        p = vec3<f32>(sbrdf_shared_geo(base, bl, li, 0u), sbrdf_shared_geo(base, bl, li, 1u),
            sbrdf_shared_lin(base, bl, li, 2u));
    }
    let v = sbrdf_microfacet(kind, p, q, wis, w);
    for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
        if (k >= tmax) {
            break;
        }
        let s = v.x * sbrdf_shared_amp(base, bl, li, 0u, k) + v.y * sbrdf_shared_amp(base, bl, li, 1u, k)
            + v.z * sbrdf_shared_amp(base, bl, li, 2u, k) + v.w * sbrdf_shared_amp(base, bl, li, 3u, k);
        (*coef)[k] = (*coef)[k] + s;
    }
}

// ------------------------------------------------------------------ the spectrum

// k u mod 1 for an integer k < 2^12 and u in [0, 1], accurate to the rounding of u itself:
// u is split into a head of 12 bits (k times it is exact in f32, so its fraction is exact)
// and a tail (whose product rounds at 2^-24 of a value below 2^-12 k). A plain fract(k u)
// would lose log2(k) bits, and the Fourier basis goes up to k = 128 (K <= 256).
fn sbrdf_frac_mul(k: f32, u: f32) -> f32 {
    let head = floor(u * 4096.0) / 4096.0;
    let tail = u - head;
    return fract(fract(k * head) + k * tail);
}

// sum_k coef[k] B_k(lambda) ("Spectral basis"), before the clamp at 0.
fn sbrdf_series(base: u32, coef: ptr<function, array<f32, 256>>, tmax: u32, lambda: f32) -> f32 {
    let basis = sbrdf_u(base + 4u);
    var v = 0.0;
    if (basis == 3u) {
        // Tabulated: linear between the wavelengths, held at the ends.
        let nw = sbrdf_u(base + 7u);
        let ow = base + sbrdf_u(base + 13u);
        let tab = base + sbrdf_u(base + 14u);
        var i = 0u;
        var f = 0.0;
        if (nw > 1u && lambda > sbrdf_f(ow)) {
            let bw = sbrdf_bracket(ow, nw, lambda);
            i = bitcast<u32>(bw.x);
            f = bw.y;
        }
        for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
            if (k >= tmax) {
                break;
            }
            var bk = sbrdf_f(tab + k * nw + i);
            if (f != 0.0) {
                bk = bk + f * (sbrdf_f(tab + k * nw + i + 1u) - bk);
            }
            v = v + (*coef)[k] * bk;
        }
        return v;
    }
    let lo = sbrdf_f(base + 11u);
    let hi = sbrdf_f(base + 12u);
    let lc = clamp(lambda, lo, hi);
    var u = 0.0; // (lambda - lo) / (hi - lo) in [0, 1]
    if (hi > lo) {
        u = clamp((lc - lo) / (hi - lo), 0.0, 1.0);
    }
    if (basis == 1u) {
        // Fourier: 1/2, cos(2 pi j u), sin(2 pi j u), ... with the phase j u reduced in turns.
        v = 0.5 * (*coef)[0];
        for (var k = 1u; k < SBRDF_MAX_TERMS; k = k + 1u) {
            if (k >= tmax) {
                break;
            }
            let j = f32((k + 1u) / 2u);
            let cs = sbrdf_sincos_turns(sbrdf_frac_mul(j, u));
            v = v + (*coef)[k] * select(cs.x, cs.y, (k & 1u) == 1u);
        }
        return v;
    }
    // Cosine: cos(pi k u) = cos(2 pi (k u / 2)); k u / 2 in turns, reduced exactly.
    for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
        if (k >= tmax) {
            break;
        }
        let cs = sbrdf_sincos_turns(sbrdf_frac_mul(f32(k), 0.5 * u));
        v = v + (*coef)[k] * cs.y;
    }
    return v;
}

// ------------------------------------------------------------------ the factor model

// The model section of kind 1 (spec/GPU_LAYOUT.md, "Model section"; spec/EVALUATION.md, "Factor
// model"): F(wi, wo, lambda) = sum_c exp(min(eta_c, 60)), added to the records' series before
// the clamp at 0. The angular terms T_cr depend on the directions only and are computed once per
// query (sbrdf_fact_terms); the spectra are interpolated per wavelength (sbrdf_fact_value).

// The fixed nodes of each feature code, and U at the 1/cos axes' nodes (1/cos of the node,
// computed in f64 and rounded to f32).
const SBRDF_FACT_NODES_H = array<f32, 23>(0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0,
    6.5, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0, 75.0, 90.0);
const SBRDF_FACT_NODES_POLAR = array<f32, 12>(0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0,
    75.0, 80.0, 85.0, 88.0);
const SBRDF_FACT_U_POLAR = array<f32, 12>(1.0, 1.015426636, 1.064177752, 1.154700518,
    1.305407286, 1.555723786, 2.0, 2.923804283, 3.863703251, 5.758770466, 11.47371292,
    28.6537075);
const SBRDF_FACT_NODES_COARSE = array<f32, 7>(0.0, 20.0, 40.0, 60.0, 70.0, 80.0, 88.0);
const SBRDF_FACT_U_COARSE = array<f32, 7>(1.0, 1.064177752, 1.305407286, 2.0, 2.923804283,
    5.758770466, 28.6537075);

// (j, a) of v on an axis ("Tables": the largest j with n_j <= v, at most m - 2; a linear in U,
// clamped to [0, 1]): axis 0 theta_h, 1 theta_d (every 10 degrees), 2 theta_i / theta_o
// (in 1/cos, u = 1/cos of v), 3 the coarse theta_i axis of code 6 (likewise), 4 x (every 0.25).
// v is already clamped to the stored range, which lies within the nodes.
fn sbrdf_fact_locate(axis: u32, v: f32, u: f32) -> vec2<f32> {
    var j = 0u;
    var a = 0.0;
    if (axis == 0u) {
        for (var i = 1u; i < 22u; i = i + 1u) {
            if (SBRDF_FACT_NODES_H[i] <= v) {
                j = i;
            }
        }
        a = (v - SBRDF_FACT_NODES_H[j]) / (SBRDF_FACT_NODES_H[j + 1u] - SBRDF_FACT_NODES_H[j]);
    } else if (axis == 1u) {
        j = min(u32(max(floor(v / 10.0), 0.0)), 8u);
        a = (v - 10.0 * f32(j)) / 10.0;
    } else if (axis == 2u) {
        for (var i = 1u; i < 11u; i = i + 1u) {
            if (SBRDF_FACT_NODES_POLAR[i] <= v) {
                j = i;
            }
        }
        a = (u - SBRDF_FACT_U_POLAR[j]) / (SBRDF_FACT_U_POLAR[j + 1u] - SBRDF_FACT_U_POLAR[j]);
    } else if (axis == 3u) {
        for (var i = 1u; i < 6u; i = i + 1u) {
            if (SBRDF_FACT_NODES_COARSE[i] <= v) {
                j = i;
            }
        }
        a = (u - SBRDF_FACT_U_COARSE[j]) / (SBRDF_FACT_U_COARSE[j + 1u] - SBRDF_FACT_U_COARSE[j]);
    } else {
        j = min(u32(max(floor((v + 1.0) * 4.0), 0.0)), 7u);
        a = (v - (-1.0 + 0.25 * f32(j))) * 4.0;
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

// The angular terms T_cr of the model section at absolute word m, at the unit upper-hemisphere
// vectors ui, uo (any common frame: every feature is invariant under a turn about z), into t in
// component order, rank-major.
fn sbrdf_fact_terms(base: u32, m: u32, ui: vec3<f32>, uo: vec3<f32>,
    t: ptr<function, array<f32, 64>>) {
    let enc = sbrdf_u(m + 1u);
    let nc = min(sbrdf_u(m + 2u), 8u);
    let w = sbrdf_u(base + 7u);
    // Features ("Factor model", Features), without turning the frame: theta_h from the sum's
    // horizontal length and height, theta_d as half the angle between wi and wo (the angle
    // between wi and the half vector), x as wo's component along wi's azimuth.
    let ri = length(ui.xy);
    let ro = length(uo.xy);
    let mv = ui + uo;
    let mh = length(mv.xy);
    var th = 90.0;
    var td = 90.0;
    if (mh > 0.0 || mv.z > 0.0) {
        th = sbrdf_atan2_deg(mh, mv.z);
        td = sbrdf_atan2_deg(length(cross(ui, uo)), 1.0 + dot(ui, uo));
    }
    let ti = sbrdf_atan2_deg(ri, ui.z);
    let to = sbrdf_atan2_deg(ro, uo.z);
    var x = uo.x;
    if (ri > 0.0) {
        x = (ui.x * uo.x + ui.y * uo.y) / ri;
    }
    let raw = vec4<f32>(th, td, ti, to);
    let lo = vec4<f32>(sbrdf_f(m + 4u), sbrdf_f(m + 6u), sbrdf_f(m + 8u), sbrdf_f(m + 10u));
    let hi = vec4<f32>(sbrdf_f(m + 5u), sbrdf_f(m + 7u), sbrdf_f(m + 9u), sbrdf_f(m + 11u));
    let f = clamp(raw, lo, hi);
    let xc = clamp(x, sbrdf_f(m + 12u), sbrdf_f(m + 13u));
    let s = vec2<f32>(sbrdf_fact_secant(f.z, ti, ui.z), sbrdf_fact_secant(f.w, to, uo.z));
    var n = 0u;
    for (var c = 0u; c < 8u; c = c + 1u) {
        if (c >= nc) {
            break;
        }
        let e = m + 14u + 4u * c;
        let rank = min(sbrdf_u(e), 8u);
        let nf = min(sbrdf_u(e + 1u), 6u);
        let codes = sbrdf_u(e + 2u);
        let o = base + sbrdf_u(e + 3u);
        let nodes = sbrdf_fact_nodes(codes, nf);
        for (var r = 0u; r < 8u; r = r + 1u) {
            if (r >= rank) {
                break;
            }
            // Rank r's tables start at value r (W + nodes) + W (GPU_LAYOUT.md, "Model section").
            var at = r * (w + nodes) + w;
            var acc = 0.0;
            for (var k = 0u; k < 6u; k = k + 1u) {
                if (k >= nf) {
                    break;
                }
                let code = (codes >> (4u * k)) & 15u;
                acc = acc + sbrdf_fact_table(o, enc, at, code, f, xc, s);
                at = at + sbrdf_fact_len(code);
            }
            (*t)[n] = acc;
            n = n + 1u;
        }
    }
}

// F at wavelength lambda (finite) from the terms of sbrdf_fact_terms ("Factor model", Spectra).
fn sbrdf_fact_value(base: u32, m: u32, t: ptr<function, array<f32, 64>>, lambda: f32) -> f32 {
    let enc = sbrdf_u(m + 1u);
    let nc = min(sbrdf_u(m + 2u), 8u);
    let w = sbrdf_u(base + 7u);
    let ow = base + sbrdf_u(base + 13u);
    var j = 0u;
    var a = 0.0;
    if (w > 1u && lambda > sbrdf_f(ow)) {
        if (lambda >= sbrdf_f(ow + w - 1u)) {
            j = w - 1u;
        } else {
            let bw = sbrdf_bracket(ow, w, lambda);
            j = bitcast<u32>(bw.x);
            a = bw.y;
        }
    }
    var total = 0.0;
    var n = 0u;
    for (var c = 0u; c < 8u; c = c + 1u) {
        if (c >= nc) {
            break;
        }
        let e = m + 14u + 4u * c;
        let rank = min(sbrdf_u(e), 8u);
        let nf = min(sbrdf_u(e + 1u), 6u);
        let codes = sbrdf_u(e + 2u);
        let o = base + sbrdf_u(e + 3u);
        let nodes = sbrdf_fact_nodes(codes, nf);
        var eta = (*t)[n];
        for (var r = 0u; r < 8u; r = r + 1u) {
            if (r >= rank) {
                break;
            }
            // s_c at value 0, w_cr (r >= 1) at value r (W + nodes).
            let at = r * (w + nodes);
            var sp = sbrdf_value(o, at + j, enc, 1.0);
            if (a != 0.0) {
                sp = sp + a * (sbrdf_value(o, at + j + 1u, enc, 1.0) - sp);
            }
            if (r == 0u) {
                eta = eta + sp;
            } else {
                eta = eta + sp * (*t)[n + r];
            }
        }
        n = n + rank;
        total = total + exp(min(eta, 60.0));
    }
    return total;
}

// The model section's angular terms for the query, when the layout has one (header word 19;
// returns its absolute word, 0 when none). The directions are those sbrdf_coefficients accepted.
fn sbrdf_model_terms(base: u32, wi: vec3<f32>, wo: vec3<f32>,
    t: ptr<function, array<f32, 64>>) -> u32 {
    let m = sbrdf_u(base + 19u);
    if (m == 0u) {
        return 0u;
    }
    sbrdf_fact_terms(base, base + m, sbrdf_upper(wi).xyz, sbrdf_upper(wo).xyz, t);
    return base + m;
}

// rho at one finite wavelength from the blended coefficients and the model's terms (m = 0:
// none): the series plus F, clamped at 0 ("Reconstruction", step 5).
fn sbrdf_rho(base: u32, coef: ptr<function, array<f32, 256>>, tmax: u32, m: u32,
    t: ptr<function, array<f32, 64>>, lambda: f32) -> f32 {
    var v = sbrdf_series(base, coef, tmax, lambda);
    if (m != 0u) {
        v = v + sbrdf_fact_value(base, m, t, lambda);
    }
    return max(0.0, v);
}

// rho(wi, wo, lambda) in 1/sr ("Reconstruction"), never negative.
fn sbrdf_eval(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: f32) -> f32 {
    if (!sbrdf_finite(lambda_nm)) {
        return 0.0;
    }
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_eval4(base, w, wi, wo, vec4<f32>(lambda_nm)).x;
    }
    var coef: array<f32, 256>;
    let tmax = sbrdf_coefficients(base, wi, wo, &coef);
    if (tmax == 0u) {
        return 0.0;
    }
    var t: array<f32, 64>;
    let m = sbrdf_model_terms(base, wi, wo, &t);
    return sbrdf_rho(base, &coef, tmax, m, &t, lambda_nm);
}

// rho at four wavelengths (a hero-wavelength renderer's four, as pbrt-v4 samples them): what
// depends on the directions alone (blending, SH, lobes, a factor model's tables) is computed
// once; component i is sbrdf_eval(base, wi, wo, lambda_nm[i]), a non-finite one 0.
fn sbrdf_eval4(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: vec4<f32>) -> vec4<f32> {
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_eval4(base, w, wi, wo, lambda_nm);
    }
    var coef: array<f32, 256>;
    let tmax = sbrdf_coefficients(base, wi, wo, &coef);
    if (tmax == 0u) {
        return vec4<f32>(0.0);
    }
    var t: array<f32, 64>;
    let m = sbrdf_model_terms(base, wi, wo, &t);
    var out = vec4<f32>(0.0);
    for (var i = 0u; i < 4u; i = i + 1u) {
        let l = lambda_nm[i];
        if (sbrdf_finite(l)) {
            out[i] = sbrdf_rho(base, &coef, tmax, m, &t, l);
        }
    }
    return out;
}

// SBRDF_RGB_WEIGHTS[i] = M E(l_i) (xbar, ybar, zbar)(l_i) / sum_j E(l_j) ybar(l_j), at
// l_i = 380 + 5 i nm, with E the CIE D65 illuminant and M the IEC 61966-2-1 XYZ -> linear sRGB
// matrix: computed in f64 from src/decode/cie.rs and rounded to f32 (the Rust test
// `gpu::tests::rgb_weights_match_cie_tables` recomputes them and requires equality).
// BEGIN GENERATED RGB WEIGHTS
const SBRDF_RGB_WEIGHTS = array<vec3<f32>, 81>(
    vec3<f32>(2.736401984e-05, -2.328276423e-05, 1.628262398e-04),
    vec3<f32>(4.671593342e-05, -3.981535338e-05, 2.787752019e-04),
    vec3<f32>(9.227084956e-05, -7.896481111e-05, 5.534677184e-04),
    vec3<f32>(2.081311832e-04, -1.788624504e-04, 1.256573712e-03),
    vec3<f32>(4.672996583e-04, -4.035583115e-04, 2.836231375e-03),
    vec3<f32>(7.922822260e-04, -6.881969166e-04, 4.849435296e-03),
    vec3<f32>(1.546609681e-03, -1.354031148e-03, 9.583766572e-03),
    vec3<f32>(2.759892493e-03, -2.437515883e-03, 1.733913086e-02),
    vec3<f32>(4.749136046e-03, -4.239784554e-03, 3.046238422e-02),
    vec3<f32>(7.102948148e-03, -6.446093787e-03, 4.724521562e-02),
    vec3<f32>(8.666965179e-03, -8.031009696e-03, 6.062049791e-02),
    vec3<f32>(1.039745938e-02, -9.939746000e-03, 7.841189206e-02),
    vec3<f32>(1.102490071e-02, -1.100533362e-02, 9.235608578e-02),
    vec3<f32>(1.014692709e-02, -1.088432595e-02, 9.960128367e-02),
    vec3<f32>(8.166212589e-03, -1.001640875e-02, 1.043098345e-01),
    vec3<f32>(4.965676926e-03, -8.131371811e-03, 1.028559729e-01),
    vec3<f32>(9.962173644e-04, -5.570829380e-03, 9.857185930e-02),
    vec3<f32>(-3.401535563e-03, -2.270789351e-03, 8.884947747e-02),
    vec3<f32>(-8.086264133e-03, 1.892001717e-03, 7.355158031e-02),
    vec3<f32>(-1.267186739e-02, 6.375672761e-03, 5.930695683e-02),
    vec3<f32>(-1.695454493e-02, 1.107122749e-02, 4.586860165e-02),
    vec3<f32>(-2.018727921e-02, 1.525892224e-02, 3.296456113e-02),
    vec3<f32>(-2.306396887e-02, 1.948674209e-02, 2.322185598e-02),
    vec3<f32>(-2.715048566e-02, 2.505821921e-02, 1.659374498e-02),
    vec3<f32>(-3.188619763e-02, 3.168791905e-02, 1.148072910e-02),
    vec3<f32>(-3.720433265e-02, 3.958408162e-02, 7.266716566e-03),
    vec3<f32>(-4.192572087e-02, 4.800221324e-02, 3.321780590e-03),
    vec3<f32>(-4.508018121e-02, 5.619459227e-02, -2.205446217e-04),
    vec3<f32>(-4.588321596e-02, 6.315612793e-02, -2.905802568e-03),
    vec3<f32>(-4.487327859e-02, 6.957427412e-02, -4.785246216e-03),
    vec3<f32>(-4.126092792e-02, 7.430807501e-02, -6.219778676e-03),
    vec3<f32>(-3.460315242e-02, 7.519462705e-02, -7.150949910e-03),
    vec3<f32>(-2.645576373e-02, 7.454419136e-02, -7.755014580e-03),
    vec3<f32>(-1.715937443e-02, 7.352319360e-02, -8.175541647e-03),
    vec3<f32>(-6.358697079e-03, 7.122249156e-02, -8.348369971e-03),
    vec3<f32>(5.758139770e-03, 6.661267579e-02, -8.177512325e-03),
    vec3<f32>(1.869347319e-02, 6.106454879e-02, -7.842326537e-03),
    vec3<f32>(3.217719868e-02, 5.473833531e-02, -7.382581942e-03),
    vec3<f32>(4.581839591e-02, 4.774422199e-02, -6.816209294e-03),
    vec3<f32>(6.009481102e-02, 4.094711691e-02, -6.268387195e-03),
    vec3<f32>(7.392965257e-02, 3.372985125e-02, -5.651682150e-03),
    vec3<f32>(8.360785246e-02, 2.544838935e-02, -4.824145231e-03),
    vec3<f32>(9.070666879e-02, 1.786104217e-02, -4.032601137e-03),
    vec3<f32>(9.958435595e-02, 1.182419062e-02, -3.459956497e-03),
    vec3<f32>(1.052668318e-01, 6.579617504e-03, -2.926333109e-03),
    vec3<f32>(1.069405451e-01, 2.130769892e-03, -2.411489375e-03),
    vec3<f32>(1.049539819e-01, -1.181861269e-03, -1.967440592e-03),
    vec3<f32>(9.910125285e-02, -3.422832349e-03, -1.572193112e-03),
    vec3<f32>(9.059123695e-02, -4.696817603e-03, -1.241970807e-03),
    vec3<f32>(7.853749394e-02, -5.092732143e-03, -9.516475839e-04),
    vec3<f32>(6.598515064e-02, -4.939187318e-03, -7.182428380e-04),
    vec3<f32>(5.619686842e-02, -4.661577754e-03, -5.551548093e-04),
    vec3<f32>(4.682838172e-02, -4.186216742e-03, -4.249732592e-04),
    vec3<f32>(3.705943376e-02, -3.499369835e-03, -3.131919948e-04),
    vec3<f32>(2.855920233e-02, -2.800999442e-03, -2.285952505e-04),
    vec3<f32>(2.211217955e-02, -2.230354119e-03, -1.692601509e-04),
    vec3<f32>(1.672285981e-02, -1.721142093e-03, -1.236955577e-04),
    vec3<f32>(1.246425696e-02, -1.299640746e-03, -9.008890629e-05),
    vec3<f32>(9.111211635e-03, -9.598798351e-04, -6.461757584e-05),
    vec3<f32>(6.474243943e-03, -6.876727566e-04, -4.521357914e-05),
    vec3<f32>(4.646052606e-03, -4.973422620e-04, -3.196296893e-05),
    vec3<f32>(3.091558581e-03, -3.332476772e-04, -2.097925790e-05),
    vec3<f32>(2.010404831e-03, -2.175216214e-04, -1.354043889e-05),
    vec3<f32>(1.422151458e-03, -1.542119862e-04, -9.536042853e-06),
    vec3<f32>(1.033581677e-03, -1.121970417e-04, -6.915508948e-06),
    vec3<f32>(7.521391381e-04, -8.164596511e-05, -5.032428817e-06),
    vec3<f32>(5.470285541e-04, -5.938085451e-05, -3.660072480e-06),
    vec3<f32>(3.549552639e-04, -3.853099042e-05, -2.374942142e-06),
    vec3<f32>(2.269532852e-04, -2.463615783e-05, -1.518504178e-06),
    vec3<f32>(1.711882651e-04, -1.858277210e-05, -1.145390456e-06),
    vec3<f32>(1.278709242e-04, -1.388059445e-05, -8.555626323e-07),
    vec3<f32>(9.210098506e-05, -9.997714187e-06, -6.162314889e-07),
    vec3<f32>(6.584058428e-05, -7.147105862e-06, -4.405276570e-07),
    vec3<f32>(4.194105350e-05, -4.552771316e-06, -2.806201849e-07),
    vec3<f32>(2.685155232e-05, -2.914781135e-06, -1.796589544e-07),
    vec3<f32>(1.641277595e-05, -1.781634296e-06, -1.098149838e-07),
    vec3<f32>(9.799869076e-06, -1.063791615e-06, -6.556926735e-08),
    vec3<f32>(8.446046195e-06, -9.168316524e-07, -5.651110868e-08),
    vec3<f32>(7.052022738e-06, -7.655087870e-07, -4.718383906e-08),
    vec3<f32>(4.855772204e-06, -5.271020882e-07, -3.248912606e-08),
    vec3<f32>(3.343134722e-06, -3.629027958e-07, -2.236833119e-08),
);
// END GENERATED RGB WEIGHTS

// Linear sRGB under D65 of rho(wi, wo, .) (Decoder::eval_linear_srgb with Illuminant::D65):
// the coefficients (and a factor model's angular terms) once, then the series (plus F) at each
// of the 81 wavelengths, clamped at 0.
fn sbrdf_eval_rgb(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_eval_rgb(base, w, wi, wo);
    }
    var coef: array<f32, 256>;
    let tmax = sbrdf_coefficients(base, wi, wo, &coef);
    if (tmax == 0u) {
        return vec3<f32>(0.0);
    }
    var t: array<f32, 64>;
    let m = sbrdf_model_terms(base, wi, wo, &t);
    var rgb = vec3<f32>(0.0);
    for (var i = 0u; i < 81u; i = i + 1u) {
        let lambda = 380.0 + 5.0 * f32(i);
        let s = sbrdf_rho(base, &coef, tmax, m, &t, lambda);
        rgb = rgb + s * SBRDF_RGB_WEIGHTS[i];
    }
    return rgb;
}

// ---- importance sampling (layout sampling section, header word 18) ----
//
// sbrdf_pdf(base, wi, wo) -> f32 and sbrdf_sample(base, wi, u) -> vec4<f32> (xyz the drawn
// direction, w its pdf): the mixture of `Decoder::sample` / `Decoder::pdf` (spec/EVALUATION.md,
// "Importance sampling"; spec/GPU_LAYOUT.md, "Sampling section") in f32. The records are blended
// as for evaluation; the mixture is the cosine plus one proposal per lobe (cosine power about the
// peak, von Mises-Fisher, GGX visible normals reflecting wi), weighted by the energies the layout
// stores, the cosine keeping at least SBRDF_MIN_COSINE_WEIGHT; a draw below the horizon is
// mirrored above it, and the pdf counts both images. u.x chooses the component exactly as the CPU
// does (its rescaled remainder then draws from it), so that the same u gives the same direction
// up to f32 rounding. A layout without a sampling section (word 18 = 0) samples the cosine:
// pdf = cos(theta_o) / pi. sbrdf_sample returns vec4(0) where the CPU returns None (wi zero, not
// finite or below the horizon, u not finite, a degenerate draw); sbrdf_pdf returns 0 where the
// CPU's pdf is 0 (either direction zero, not finite or below the horizon).
//
// The block repeats the query's blending of sbrdf_coefficients (sbrdf_smp_query) rather than
// calling into it, so that it needs no change there.

const SBRDF_MAX_COMPONENTS: u32 = 33u; // the cosine + 4 blended records x 8 lobes
const SBRDF_MIN_COSINE_WEIGHT: f32 = 0.1; // draw.rs MIN_COSINE_WEIGHT
const SBRDF_ONE_BELOW: f32 = 0.99999994; // the largest f32 below 1: u is clamped to [0, this]

// The query in the records' frame: the blend, and the rotation (cos, sin) into that frame
// (isotropic files; (1, 0) otherwise).
struct SbrdfQuery {
    bl: SbrdfBlend,
    rot: vec2<f32>,
    isotropic: bool,
}

// One proposal: kind 0 cosine, 1 cosine power (a = (p, n)), 2 von Mises-Fisher (a = (p, kappa),
// m = 1 - exp(-2 kappa)), 3 GGX visible normals (a = (ax, ay, axis.x, axis.y), m = k =
// G1(wi) / (4 cos theta_i)).
struct SbrdfShape {
    kind: u32,
    a: vec4<f32>,
    m: f32,
}

struct SbrdfMix {
    n: u32,
    kind: array<u32, 33>,
    a: array<vec4<f32>, 33>,
    m: array<f32, 33>,
    w: array<f32, 33>,
    wi: vec3<f32>,
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

// The query's blend and frame, as sbrdf_coefficients makes them (step 3 and 4), for the unit
// incident vector ui (z >= 0).
fn sbrdf_smp_query(base: u32, ui: vec3<f32>) -> SbrdfQuery {
    var q: SbrdfQuery;
    let inc_layout = sbrdf_u(base + 3u);
    q.isotropic = inc_layout == 0u;
    q.rot = vec2<f32>(1.0, 0.0);
    let n_rec = sbrdf_u(base + 8u);
    let n_theta = sbrdf_u(base + 9u);
    let n_phi = sbrdf_u(base + 10u);
    let off_th = base + sbrdf_u(base + 15u);
    let off_ph = base + sbrdf_u(base + 16u);
    let r = sqrt(ui.x * ui.x + ui.y * ui.y);
    let theta_q = sbrdf_atan2_deg(r, ui.z);
    var wq = ui;
    var phi_q = 0.0;
    if (q.isotropic) {
        if (r > 0.0) {
            q.rot = vec2<f32>(ui.x / r, ui.y / r);
        }
        wq = vec3<f32>(r, 0.0, ui.z);
    } else if (r > 0.0) {
        phi_q = sbrdf_wrap360(sbrdf_atan2_deg(ui.y, ui.x));
    }
    var bl: SbrdfBlend;
    bl.n = 0u;
    if (inc_layout == 2u) {
        var best = 0u;
        var best_cos = -2.0;
        for (var i = 0u; i < n_rec; i = i + 1u) {
            let e = sbrdf_rec(base, i);
            let cs = dot(sbrdf_dir(sbrdf_f(e), sbrdf_f(e + 1u)), ui);
            if (cs > best_cos) {
                best_cos = cs;
                best = i;
            }
        }
        let e = sbrdf_rec(base, best);
        bl.n = 1u;
        bl.rec[0] = best;
        bl.w[0] = 1.0;
        bl.theta = sbrdf_f(e);
        bl.phi = sbrdf_f(e + 1u);
        bl.wi = sbrdf_dir(bl.theta, bl.phi);
    } else {
        let th0 = sbrdf_f(off_th);
        let th1 = sbrdf_f(off_th + n_theta - 1u);
        bl.theta = clamp(theta_q, th0, th1);
        let bt = sbrdf_bracket(off_th, n_theta, theta_q);
        let i = bitcast<u32>(bt.x);
        let t = bt.y;
        let i2 = min(i + 1u, n_theta - 1u);
        if (q.isotropic) {
            sbrdf_smp_blend_add(&bl, i, 1.0 - t);
            sbrdf_smp_blend_add(&bl, i2, t);
            bl.phi = 0.0;
            bl.wi = select(sbrdf_dir(bl.theta, 0.0), wq, bl.theta == theta_q);
        } else {
            var j = 0u;
            var j2 = 0u;
            var u = 0.0;
            let p = phi_q;
            if (n_phi > 1u) {
                let p0 = sbrdf_f(off_ph);
                let p1 = sbrdf_f(off_ph + n_phi - 1u);
                if (p < p0 || p >= p1) {
                    j = n_phi - 1u;
                    j2 = 0u;
                    u = sbrdf_wrap360(p - p1) / (p0 + 360.0 - p1);
                } else {
                    let bp = sbrdf_bracket(off_ph, n_phi, p);
                    j = bitcast<u32>(bp.x);
                    u = bp.y;
                    j2 = j + 1u;
                }
            }
            sbrdf_smp_blend_add(&bl, i * n_phi + j, (1.0 - t) * (1.0 - u));
            sbrdf_smp_blend_add(&bl, i * n_phi + j2, (1.0 - t) * u);
            sbrdf_smp_blend_add(&bl, i2 * n_phi + j, t * (1.0 - u));
            sbrdf_smp_blend_add(&bl, i2 * n_phi + j2, t * u);
            if (bl.n == 0u) {
                sbrdf_blend_add(&bl, i * n_phi + j, 1.0); // as the CPU (no weight > 0)
            }
            if (n_phi == 1u) {
                bl.phi = sbrdf_f(off_ph);
                bl.wi = sbrdf_dir(bl.theta, bl.phi);
            } else {
                bl.phi = phi_q;
                bl.wi = select(sbrdf_dir(bl.theta, bl.phi), ui, bl.theta == theta_q);
            }
        }
    }
    q.bl = bl;
    return q;
}

// Record rec with weight w added to the query's blend as the CPU's Blend::push adds it: a weight
// <= 0 is dropped, a record already there gets the weight added, records stay in the order they
// were first added (not sorted: the mixture's components follow this order, and u.x picks among
// them in it).
fn sbrdf_smp_blend_add(bl: ptr<function, SbrdfBlend>, rec: u32, w: f32) {
    if (!(w > 0.0)) {
        return;
    }
    sbrdf_blend_add(bl, rec, w);
}

// A local-frame vector in the records' frame, and back.
fn sbrdf_smp_in(q: SbrdfQuery, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(q.rot.x * v.x + q.rot.y * v.y, -q.rot.y * v.x + q.rot.x * v.y, v.z);
}

fn sbrdf_smp_out(q: SbrdfQuery, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(q.rot.x * v.x - q.rot.y * v.y, q.rot.y * v.x + q.rot.x * v.y, v.z);
}

// Absolute word of record r's weights: background energy, then (energy, ln width) per lobe.
fn sbrdf_smp_weights(base: u32, r: u32) -> u32 {
    return base + sbrdf_u(base + sbrdf_u(base + 18u) + r);
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

// The axis angle psi of lobe li blended over the records (as sbrdf_add_shared_lobe blends it).
fn sbrdf_smp_axis(base: u32, bl: SbrdfBlend, li: u32) -> f32 {
    var x = 0.0;
    var yv = 0.0;
    var tw = 0.0;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < bl.n) {
            let cs = sbrdf_sincos_deg(2.0 * sbrdf_shared_par(base, bl, b, li, 5u));
            x = x + bl.w[b] * cs.y;
            yv = yv + bl.w[b] * cs.x;
            tw = tw + abs(bl.w[b]);
        }
    }
    var psi = sbrdf_shared_par(base, bl, 0u, li, 5u);
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

// Lobe li of blended record b alone (its own peak and parameters).
fn sbrdf_smp_own_shape(base: u32, bl: SbrdfBlend, b: u32, li: u32, wi: vec3<f32>) -> SbrdfShape {
    let e = sbrdf_rec(base, bl.rec[b]);
    let lt = base + sbrdf_u(e + 10u) + 3u * li;
    let kind = sbrdf_u(lt);
    let par = base + sbrdf_u(lt + 2u);
    if (kind == 1u) {
        return sbrdf_vmf_shape(sbrdf_rec_peak(e), sbrdf_f(sbrdf_smp_weights(base, bl.rec[b]) + 2u + 2u * li));
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

// Lobe li shared by every blended record (bl.n > 1), its shape blended as for evaluation.
fn sbrdf_smp_shared_shape(base: u32, bl: SbrdfBlend, isotropic: bool, kind: u32, li: u32,
    wi: vec3<f32>) -> SbrdfShape {
    if (kind == 1u) {
        var s = 0.0;
        var ws = 0.0;
        for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
            if (b < bl.n) {
                s = s + bl.w[b] * sbrdf_f(sbrdf_smp_weights(base, bl.rec[b]) + 2u + 2u * li);
                ws = ws + bl.w[b];
            }
        }
        return sbrdf_vmf_shape(sbrdf_blended_peak(base, bl, isotropic), s / ws);
    }
    if (kind == 4u) {
        return SbrdfShape(1u, vec4<f32>(sbrdf_blended_peak(base, bl, isotropic),
            sbrdf_shared_geo(base, bl, li, 0u)), 0.0);
    }
    if (kind == 5u) {
        let c = sbrdf_shared_geo(base, bl, li, 2u);
        let sc = sbrdf_sincos_deg(sbrdf_smp_axis(base, bl, li));
        return sbrdf_ggx_shape(sbrdf_ggx_alpha(true, sbrdf_shared_geo(base, bl, li, 0u), c),
            sbrdf_ggx_alpha(true, sbrdf_shared_geo(base, bl, li, 1u), c), vec2<f32>(sc.y, sc.x), wi);
    }
    let alpha = sbrdf_ggx_alpha(kind == 3u, sbrdf_shared_geo(base, bl, li, 0u),
        sbrdf_shared_geo(base, bl, li, 1u));
    return sbrdf_ggx_shape(alpha, alpha, vec2<f32>(1.0, 0.0), wi);
}

fn sbrdf_mix_push(mx: ptr<function, SbrdfMix>, s: SbrdfShape, energy: f32) {
    if (energy > 0.0 && sbrdf_finite(energy) && (*mx).n < SBRDF_MAX_COMPONENTS) {
        let n = (*mx).n;
        (*mx).kind[n] = s.kind;
        (*mx).a[n] = s.a;
        (*mx).m[n] = s.m;
        (*mx).w[n] = energy;
        (*mx).n = n + 1u;
    }
}

// The query's mixture (sampling.rs Mixture::new and normalise): component 0 the cosine, then
// per lobe position one shared component, or one per blended record that has the lobe.
fn sbrdf_smp_mix(base: u32, q: SbrdfQuery) -> SbrdfMix {
    let bl = q.bl;
    var mx: SbrdfMix;
    mx.n = 1u;
    mx.kind[0] = 0u;
    mx.wi = bl.wi;
    var cosine = 0.0;
    var mmax = 0u;
    for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
        if (b < bl.n) {
            cosine = cosine + bl.w[b] * sbrdf_f(sbrdf_smp_weights(base, bl.rec[b]));
            mmax = max(mmax, sbrdf_u(sbrdf_rec(base, bl.rec[b]) + 6u));
        }
    }
    mmax = min(mmax, SBRDF_MAX_LOBES);
    for (var li = 0u; li < SBRDF_MAX_LOBES; li = li + 1u) {
        if (li >= mmax) {
            break;
        }
        // Shared when every blended record (more than one) has a lobe of one kind at li; one
        // record alone gives the same component either way.
        var shared_kind = 0u;
        if (bl.n > 1u) {
            shared_kind = 0xffffffffu;
            for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
                if (b < bl.n) {
                    let e = sbrdf_rec(base, bl.rec[b]);
                    var kind = 0u;
                    if (li < sbrdf_u(e + 6u)) {
                        kind = sbrdf_u(base + sbrdf_u(e + 10u) + 3u * li);
                    }
                    if (kind == 0u || (shared_kind != 0xffffffffu && kind != shared_kind)) {
                        shared_kind = 0u;
                        break;
                    }
                    shared_kind = kind;
                }
            }
        }
        if (shared_kind != 0u) {
            var energy = 0.0;
            for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
                if (b < bl.n) {
                    energy = energy + bl.w[b] * sbrdf_f(sbrdf_smp_weights(base, bl.rec[b]) + 1u + 2u * li);
                }
            }
            sbrdf_mix_push(&mx, sbrdf_smp_shared_shape(base, bl, q.isotropic, shared_kind, li, bl.wi), energy);
        } else {
            for (var b = 0u; b < SBRDF_MAX_BLEND; b = b + 1u) {
                if (b < bl.n && li < sbrdf_u(sbrdf_rec(base, bl.rec[b]) + 6u)) {
                    let energy = bl.w[b] * sbrdf_f(sbrdf_smp_weights(base, bl.rec[b]) + 1u + 2u * li);
                    sbrdf_mix_push(&mx, sbrdf_smp_own_shape(base, bl, b, li, bl.wi), energy);
                }
            }
        }
    }
    // Energies to probabilities, the cosine's at least SBRDF_MIN_COSINE_WEIGHT.
    if (!sbrdf_finite(cosine) || cosine < 0.0) {
        cosine = 0.0;
    }
    var lobes = 0.0;
    for (var i = 1u; i < SBRDF_MAX_COMPONENTS; i = i + 1u) {
        if (i < mx.n) {
            lobes = lobes + mx.w[i];
        }
    }
    if (!(lobes > 0.0 && sbrdf_finite(lobes))) {
        mx.n = 1u;
        mx.w[0] = 1.0;
        return mx;
    }
    let p_cos = max(cosine / (cosine + lobes), SBRDF_MIN_COSINE_WEIGHT);
    mx.w[0] = p_cos;
    let scale = (1.0 - p_cos) / lobes;
    for (var i = 1u; i < SBRDF_MAX_COMPONENTS; i = i + 1u) {
        if (i < mx.n) {
            mx.w[i] = mx.w[i] * scale;
        }
    }
    return mx;
}

// Component i's density over the sphere at the unit vector w (records' frame).
fn sbrdf_smp_density1(mx: SbrdfMix, i: u32, w: vec3<f32>) -> f32 {
    let kind = mx.kind[i];
    let a = mx.a[i];
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
        return a.w / (2.0 * SBRDF_PI * mx.m[i]) * exp(-a.w * x);
    }
    let hs = mx.wi + w;
    let len = length(hs);
    if (!(len > 0.0)) {
        return 0.0;
    }
    let h = hs / len;
    if (h.z <= 0.0 || dot(mx.wi, h) <= 0.0) {
        return 0.0;
    }
    let hu = h.x * a.z + h.y * a.w;
    let hv = h.y * a.z - h.x * a.w;
    let t = hu * hu / (a.x * a.x) + hv * hv / (a.y * a.y) + h.z * h.z;
    return mx.m[i] / (SBRDF_PI * a.x * a.y * t * t);
}

// The mixture's density over the upper hemisphere at w (records' frame): each lobe component at
// w and at its mirror image below the horizon.
fn sbrdf_smp_density(mx: SbrdfMix, w: vec3<f32>) -> f32 {
    let below = vec3<f32>(w.x, w.y, -w.z);
    var sum = mx.w[0] * max(w.z, 0.0) / SBRDF_PI;
    for (var i = 1u; i < SBRDF_MAX_COMPONENTS; i = i + 1u) {
        if (i >= mx.n) {
            break;
        }
        sum = sum + mx.w[i] * (sbrdf_smp_density1(mx, i, w) + sbrdf_smp_density1(mx, i, below));
    }
    return sum;
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

// A direction over the sphere from component i (records' frame) and u in [0, 1)^2; .w = 0 when
// the draw is degenerate (the CPU's None).
fn sbrdf_smp_draw(mx: SbrdfMix, i: u32, u: vec2<f32>) -> vec4<f32> {
    let kind = mx.kind[i];
    let a = mx.a[i];
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
        let x = (1.0 - u.x) * mx.m[i];
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
    let wi = mx.wi;
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
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_pdf(w, wi, wo);
    }
    let ui = sbrdf_upper(wi);
    let uo = sbrdf_upper(wo);
    if (ui.w == 0.0 || uo.w == 0.0) {
        return 0.0;
    }
    if (sbrdf_u(base + 18u) == 0u) {
        return uo.z / SBRDF_PI;
    }
    let q = sbrdf_smp_query(base, ui.xyz);
    let mx = sbrdf_smp_mix(base, q);
    return sbrdf_smp_density(mx, sbrdf_smp_in(q, uo.xyz));
}

// A direction drawn for wi from u in [0, 1)^2 (Decoder::sample): (wo, pdf), or vec4(0) where
// the CPU gives None.
fn sbrdf_sample(base: u32, wi: vec3<f32>, u_in: vec2<f32>) -> vec4<f32> {
    if (!(sbrdf_finite(u_in.x) && sbrdf_finite(u_in.y))) {
        return vec4<f32>(0.0);
    }
    let u = clamp(u_in, vec2<f32>(0.0), vec2<f32>(SBRDF_ONE_BELOW));
    let w = sbrdf_warp_section(base);
    if (w != 0u) {
        return sbrdf_warp_sample(w, wi, u);
    }
    let ui = sbrdf_upper(wi);
    if (ui.w == 0.0) {
        return vec4<f32>(0.0);
    }
    if (sbrdf_u(base + 18u) == 0u) {
        let r = sqrt(u.x);
        let sc = sbrdf_sincos_turns(u.y);
        let z = sqrt(1.0 - u.x);
        return vec4<f32>(r * sc.y, r * sc.x, z, z / SBRDF_PI);
    }
    let q = sbrdf_smp_query(base, ui.xyz);
    let mx = sbrdf_smp_mix(base, q);
    // The component: the first whose cumulative weight exceeds u.x (the last otherwise).
    var i = mx.n - 1u;
    var lo = 0.0;
    for (var k = 0u; k < SBRDF_MAX_COMPONENTS; k = k + 1u) {
        if (k >= mx.n) {
            break;
        }
        if (u.x < lo + mx.w[k]) {
            i = k;
            break;
        }
        lo = lo + mx.w[k];
    }
    let u0 = clamp((u.x - lo) / mx.w[i], 0.0, SBRDF_ONE_BELOW);
    let d = sbrdf_smp_draw(mx, i, vec2<f32>(u0, u.y));
    if (d.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let wo = sbrdf_smp_out(q, vec3<f32>(d.x, d.y, abs(d.z)));
    // The density at the direction as returned, computed as sbrdf_pdf computes it.
    let back = sbrdf_upper(wo);
    if (back.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let pdf = sbrdf_smp_density(mx, sbrdf_smp_in(q, back.xyz));
    if (!(pdf > 0.0 && sbrdf_finite(pdf))) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(wo, pdf);
}

// ------------------------------------------------------------------ warped tables
//
// The model section of kind 2 (spec/GPU_LAYOUT.md, "Warped tables section"; spec/EVALUATION.md,
// "Warped tables"): a material measured on the RGL database's warped grids, which answers every
// query itself and samples itself. Offsets inside the section are relative to its first word.
// The functions follow `src/decode/warped/query.rs` line for line, in f32: the half vector's
// inverse VNDF warp blended between the two stored viewing directions around the query's, the
// packed tables bilinear at the warped point, D/(4 sigma)/cos theta_i; sampling draws a warped
// point from the tables' spectrum-averaged values, then the VNDF warp forward.

const SBRDF_WARP_KIND: u32 = 2u;
const SBRDF_WARP_POSITIVE_BITS: u32 = 9u; // a VNDF row's word: positive run below, marginal above
const SBRDF_WARP_MARG_UNIT: f32 = 1.1920928955078125e-07; // 2^-23
const SBRDF_WARP_MARKS: u32 = 3u; // conditional integrals kept per values row

// The absolute word of the layout's warped-tables section, 0 when it has none.
fn sbrdf_warp_section(base: u32) -> u32 {
    let m = sbrdf_u(base + 19u);
    if (m == 0u || sbrdf_u(base + m) != SBRDF_WARP_KIND) {
        return 0u;
    }
    return base + m;
}

struct SbrdfWarpCol {
    f: f32,
    s: f32,
    c: f32,
    u: f32,
    v: f32,
}

fn sbrdf_warp_col(w: u32, a: u32) -> SbrdfWarpCol {
    let o = w + sbrdf_u(w + 9u) + 5u * a;
    return SbrdfWarpCol(sbrdf_f(o), sbrdf_f(o + 1u), sbrdf_f(o + 2u), sbrdf_f(o + 3u),
        sbrdf_f(o + 4u));
}

// A row of one stored incidence's VNDF (`vndf::Row`): alpha = sin theta cos phi_b, cos theta,
// its run of positive columns, the incidence's normalisation and the row's normalised total.
struct SbrdfWarpRow {
    alpha: f32,
    ct: f32,
    positive: u32,
    scale: f32,
    total: f32,
}

fn sbrdf_warp_row(w: u32, i: u32, b: u32) -> SbrdfWarpRow {
    let inc = w + sbrdf_u(w + 6u) + 6u * i;
    let g = sbrdf_u(w + 4u);
    let st = sbrdf_f(inc + 1u);
    let ct = sbrdf_f(inc + 2u);
    let scale = sbrdf_f(inc + 3u);
    let alpha = st * sbrdf_f(w + sbrdf_u(w + 10u) + b);
    let positive = sbrdf_u(w + sbrdf_u(w + 11u) + i * g + b)
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
    return SbrdfWarpRow(alpha, ct, positive, scale, scale * total);
}

fn sbrdf_warp_row_density(r: SbrdfWarpRow, a: u32, c: SbrdfWarpCol) -> f32 {
    if (a < r.positive) {
        return r.scale * (c.f * max(0.0, r.alpha * c.s + r.ct * c.c));
    }
    return 0.0;
}

fn sbrdf_warp_row_cond(r: SbrdfWarpRow, a: u32, c: SbrdfWarpCol) -> f32 {
    if (a < r.positive) {
        return r.scale * (r.alpha * c.u + r.ct * c.v);
    }
    return r.total;
}

// The two stored incidences around theta (radians) and the upper one's weight.
struct SbrdfWarpSlices {
    a: u32,
    b: u32,
    t: f32,
}

fn sbrdf_warp_theta(w: u32, i: u32) -> f32 {
    return sbrdf_f(w + sbrdf_u(w + 6u) + 6u * i);
}

fn sbrdf_warp_slices(w: u32, theta: f32) -> SbrdfWarpSlices {
    let n = sbrdf_u(w + 1u);
    if (n == 1u) {
        return SbrdfWarpSlices(0u, 0u, 0.0);
    }
    let th = clamp(theta, sbrdf_warp_theta(w, 0u), sbrdf_warp_theta(w, n - 1u));
    var i = 0u;
    var hi = sbrdf_warp_theta(w, 1u);
    for (var it = 0u; it < n; it = it + 1u) {
        if (i + 2u >= n || hi > th) {
            break;
        }
        i = i + 1u;
        hi = sbrdf_warp_theta(w, i + 1u);
    }
    let lo = sbrdf_warp_theta(w, i);
    return SbrdfWarpSlices(i, i + 1u, clamp((th - lo) / (hi - lo), 0.0, 1.0));
}

fn sbrdf_warp_mix(sl: SbrdfWarpSlices, x: f32, y: f32) -> f32 {
    return x + (y - x) * sl.t;
}

// The cell of x in [0, 1] on n nodes: (index as bits, position within it).
fn sbrdf_warp_cell(x: f32, n: u32) -> vec2<f32> {
    let f = clamp(x, 0.0, 1.0) * f32(n - 1u);
    let i = min(u32(f), n - 2u);
    return vec2<f32>(bitcast<f32>(i), f - f32(i));
}

// The four VNDF rows a cell reads: rows b (lo) and b + 1 (hi) of slices a (0) and b (1).
struct SbrdfWarpCellRows {
    lo0: SbrdfWarpRow,
    lo1: SbrdfWarpRow,
    hi0: SbrdfWarpRow,
    hi1: SbrdfWarpRow,
}

fn sbrdf_warp_cell_rows(w: u32, sl: SbrdfWarpSlices, b: u32) -> SbrdfWarpCellRows {
    return SbrdfWarpCellRows(sbrdf_warp_row(w, sl.a, b), sbrdf_warp_row(w, sl.b, b),
        sbrdf_warp_row(w, sl.a, b + 1u), sbrdf_warp_row(w, sl.b, b + 1u));
}

// Blended densities at column a of the lower and upper row.
fn sbrdf_warp_densities(rows: SbrdfWarpCellRows, sl: SbrdfWarpSlices, a: u32,
    c: SbrdfWarpCol) -> vec2<f32> {
    return vec2<f32>(
        sbrdf_warp_mix(sl, sbrdf_warp_row_density(rows.lo0, a, c),
            sbrdf_warp_row_density(rows.lo1, a, c)),
        sbrdf_warp_mix(sl, sbrdf_warp_row_density(rows.hi0, a, c),
            sbrdf_warp_row_density(rows.hi1, a, c)));
}

// Blended conditional integrals at column a of the lower and upper row.
fn sbrdf_warp_conds(rows: SbrdfWarpCellRows, sl: SbrdfWarpSlices, a: u32,
    c: SbrdfWarpCol) -> vec2<f32> {
    return vec2<f32>(
        sbrdf_warp_mix(sl, sbrdf_warp_row_cond(rows.lo0, a, c), sbrdf_warp_row_cond(rows.lo1, a, c)),
        sbrdf_warp_mix(sl, sbrdf_warp_row_cond(rows.hi0, a, c), sbrdf_warp_row_cond(rows.hi1, a, c)));
}

fn sbrdf_warp_totals(rows: SbrdfWarpCellRows, sl: SbrdfWarpSlices) -> vec2<f32> {
    return vec2<f32>(sbrdf_warp_mix(sl, rows.lo0.total, rows.lo1.total),
        sbrdf_warp_mix(sl, rows.hi0.total, rows.hi1.total));
}

fn sbrdf_warp_vndf_marg(w: u32, sl: SbrdfWarpSlices, b: u32) -> f32 {
    let g = sbrdf_u(w + 4u);
    let o = w + sbrdf_u(w + 11u);
    let ma = f32(sbrdf_u(o + sl.a * g + b) >> SBRDF_WARP_POSITIVE_BITS) * SBRDF_WARP_MARG_UNIT;
    let mb = f32(sbrdf_u(o + sl.b * g + b) >> SBRDF_WARP_POSITIVE_BITS) * SBRDF_WARP_MARG_UNIT;
    return sbrdf_warp_mix(sl, ma, mb);
}

// The inverse VNDF warp of u (half-vector parameter) and the blended VNDF density there:
// (sx, sy, density).
fn sbrdf_warp_invert(w: u32, sl: SbrdfWarpSlices, ux: f32, uy: f32) -> vec3<f32> {
    let g = sbrdf_u(w + 4u);
    let n1 = f32(g - 1u);
    let ca = sbrdf_warp_cell(ux, g);
    let cb = sbrdf_warp_cell(uy, g);
    let a = bitcast<u32>(ca.x);
    let b = bitcast<u32>(cb.x);
    let tx = ca.y;
    let ty = cb.y;
    let rows = sbrdf_warp_cell_rows(w, sl, b);
    let col0 = sbrdf_warp_col(w, a);
    let col1 = sbrdf_warp_col(w, a + 1u);
    let d0 = sbrdf_warp_densities(rows, sl, a, col0);
    let d1 = sbrdf_warp_densities(rows, sl, a + 1u, col1);
    let c0 = mix(d0.x, d0.y, ty);
    let c1 = mix(d1.x, d1.y, ty);
    let bc = sbrdf_warp_conds(rows, sl, a, col0);
    let before = mix(bc.x, bc.y, ty);
    let within = tx * (c0 + 0.5 * (c1 - c0) * tx) / n1;
    let r = sbrdf_warp_totals(rows, sl);
    let total = mix(r.x, r.y, ty);
    var sx = 0.0;
    if (total > 0.0) {
        sx = (before + within) / total;
    }
    let sy = sbrdf_warp_vndf_marg(w, sl, b) + ty * (r.x + 0.5 * (r.y - r.x) * ty) / n1;
    return vec3<f32>(clamp(sx, 0.0, 1.0), clamp(sy, 0.0, 1.0), mix(c0, c1, tx));
}

// tau in [0, 1] with the integral over [0, tau] of mix(v0, v1, t) dt = a.
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
    let g = sbrdf_u(w + 4u);
    let n1 = f32(g - 1u);
    let sx = clamp(sx_in, 0.0, 1.0);
    let sy = clamp(sy_in, 0.0, 1.0);
    var lo = 0u;
    var hi = g - 1u;
    for (var it = 0u; it < 32u; it = it + 1u) {
        if (lo + 1u >= hi) {
            break;
        }
        let mid = (lo + hi) >> 1u;
        if (sbrdf_warp_vndf_marg(w, sl, mid) < sy) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let b = min(hi - 1u, g - 2u);
    let rows = sbrdf_warp_cell_rows(w, sl, b);
    let r = sbrdf_warp_totals(rows, sl);
    let ty = sbrdf_warp_segment((sy - sbrdf_warp_vndf_marg(w, sl, b)) * n1, r.x, r.y);
    let goal = sx * mix(r.x, r.y, ty);
    lo = 0u;
    hi = g - 1u;
    for (var it = 0u; it < 32u; it = it + 1u) {
        if (lo + 1u >= hi) {
            break;
        }
        let mid = (lo + hi) >> 1u;
        let cm = sbrdf_warp_conds(rows, sl, mid, sbrdf_warp_col(w, mid));
        if (mix(cm.x, cm.y, ty) < goal) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = min(hi - 1u, g - 2u);
    let col0 = sbrdf_warp_col(w, a);
    let d0 = sbrdf_warp_densities(rows, sl, a, col0);
    let d1 = sbrdf_warp_densities(rows, sl, a + 1u, sbrdf_warp_col(w, a + 1u));
    let ca = sbrdf_warp_conds(rows, sl, a, col0);
    let tx = sbrdf_warp_segment((goal - mix(ca.x, ca.y, ty)) * n1, mix(d0.x, d0.y, ty),
        mix(d1.x, d1.y, ty));
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
    var v = sbrdf_words[wd] >> sh;
    if (sh + bits > 32u) {
        v = v | (sbrdf_words[wd + 1u] << (32u - sh));
    }
    return v & ((1u << bits) - 1u);
}

// Table t = i K + k at node j: lo + code step.
fn sbrdf_warp_table(w: u32, t: u32, j: u32) -> f32 {
    let e = w + sbrdf_u(w + 12u) + 4u * t;
    return sbrdf_f(e + 2u) + f32(sbrdf_warp_code(w + sbrdf_u(e), sbrdf_u(e + 1u), j))
        * sbrdf_f(e + 3u);
}

// A table bilinear in the cell whose lower row starts at node n00 (upper at n10).
fn sbrdf_warp_table_bilerp(w: u32, t: u32, n00: u32, n10: u32, tx: f32, ty: f32) -> f32 {
    let e = w + sbrdf_u(w + 12u) + 4u * t;
    let o = w + sbrdf_u(e);
    let bits = sbrdf_u(e + 1u);
    let lo = sbrdf_f(e + 2u);
    let step = sbrdf_f(e + 3u);
    let v00 = lo + f32(sbrdf_warp_code(o, bits, n00)) * step;
    let v01 = lo + f32(sbrdf_warp_code(o, bits, n00 + 1u)) * step;
    let v10 = lo + f32(sbrdf_warp_code(o, bits, n10)) * step;
    let v11 = lo + f32(sbrdf_warp_code(o, bits, n10 + 1u)) * step;
    return mix(mix(v00, v01, tx), mix(v10, v11, tx), ty);
}

// The tables' frame for a query: turned about z so that the tables' own direction d (the
// viewer's for evaluation, the given one for sampling) has azimuth 0. (cos, sin) of the turn
// in .xy, d's theta (radians) in .z.
fn sbrdf_warp_frame(d: vec3<f32>) -> vec3<f32> {
    let r = sqrt(d.x * d.x + d.y * d.y);
    var c = 1.0;
    var s = 0.0;
    if (r > 0.0) {
        c = d.x / r;
        s = d.y / r;
    }
    return vec3<f32>(c, s, sbrdf_atan2_deg(r, d.z) * SBRDF_DEG);
}

fn sbrdf_warp_in(f: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(f.x * v.x + f.y * v.y, -f.y * v.x + f.x * v.y, v.z);
}

fn sbrdf_warp_out(f: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(f.x * v.x - f.y * v.y, f.y * v.x + f.x * v.y, v.z);
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

// f32 lerp of M nodes at j/(M-1), at x in [0, 1] (clamped), from absolute word o.
fn sbrdf_warp_nodes(o: u32, m: u32, x: f32) -> f32 {
    let f = clamp(x, 0.0, 1.0) * f32(m - 1u);
    let i = min(u32(f), m - 2u);
    let a = sbrdf_f(o + i);
    return a + (sbrdf_f(o + i + 1u) - a) * (f - f32(i));
}

// What a query reads of the tables: the slices, the tables' cell and the factor
// D(u_x) / (4 sigma) / cos theta_i (f = 0: rho is 0).
struct SbrdfWarpQuery {
    sl: SbrdfWarpSlices,
    n00: u32,
    n10: u32,
    tx: f32,
    ty: f32,
    f: f32,
}

fn sbrdf_warp_query(w: u32, wi: vec3<f32>, wo: vec3<f32>) -> SbrdfWarpQuery {
    var q: SbrdfWarpQuery;
    q.f = 0.0;
    let ui = sbrdf_upper(wi);
    let uo = sbrdf_upper(wo);
    if (ui.w == 0.0 || uo.w == 0.0) {
        return q;
    }
    // The tables follow the viewer's direction (the query's wo): the roles are exchanged.
    let fr = sbrdf_warp_frame(uo.xyz);
    let a = vec3<f32>(sqrt(uo.x * uo.x + uo.y * uo.y), 0.0, uo.z);
    let b = sbrdf_warp_in(fr, ui.xyz);
    if (b.z <= 0.0) {
        return q;
    }
    let h = a + b;
    let len = length(h);
    if (!(len > 0.0)) {
        return q;
    }
    let u = sbrdf_warp_half(h / len);
    q.sl = sbrdf_warp_slices(w, fr.z);
    let s = sbrdf_warp_invert(w, q.sl, u.x, u.y);
    let m = sbrdf_u(w + 5u);
    let sigma = sbrdf_warp_nodes(w + sbrdf_u(w + 8u), m, sqrt(max(fr.z, 0.0) / (0.5 * SBRDF_PI)));
    let d = sbrdf_warp_nodes(w + sbrdf_u(w + 7u), m, u.x);
    q.f = d / (4.0 * sigma) / b.z;
    let r = sbrdf_u(w + 3u);
    let cx = sbrdf_warp_cell(s.x, r);
    let cy = sbrdf_warp_cell(s.y, r);
    q.n00 = bitcast<u32>(cy.x) * r + bitcast<u32>(cx.x);
    q.n10 = q.n00 + r;
    q.tx = cx.y;
    q.ty = cy.y;
    return q;
}

// Term k's blended table value times the query's factor.
fn sbrdf_warp_term(w: u32, q: SbrdfWarpQuery, k: u32) -> f32 {
    let nk = sbrdf_u(w + 2u);
    let va = sbrdf_warp_table_bilerp(w, q.sl.a * nk + k, q.n00, q.n10, q.tx, q.ty);
    let vb = sbrdf_warp_table_bilerp(w, q.sl.b * nk + k, q.n00, q.n10, q.tx, q.ty);
    return (va + (vb - va) * q.sl.t) * q.f;
}

// B_k(lambda) ("Spectral basis") at a finite wavelength.
fn sbrdf_warp_basis(base: u32, k: u32, l: f32) -> f32 {
    let basis = sbrdf_u(base + 4u);
    if (basis == 3u) {
        let nw = sbrdf_u(base + 7u);
        let ow = base + sbrdf_u(base + 13u);
        let tab = base + sbrdf_u(base + 14u) + k * nw;
        var j = 0u;
        var f = 0.0;
        if (nw > 1u && l > sbrdf_f(ow)) {
            let bw = sbrdf_bracket(ow, nw, l);
            j = bitcast<u32>(bw.x);
            f = bw.y;
        }
        var bk = sbrdf_f(tab + j);
        if (f != 0.0) {
            bk = bk + f * (sbrdf_f(tab + j + 1u) - bk);
        }
        return bk;
    }
    let lo = sbrdf_f(base + 11u);
    let hi = sbrdf_f(base + 12u);
    var u = 0.0;
    if (hi > lo) {
        u = clamp((clamp(l, lo, hi) - lo) / (hi - lo), 0.0, 1.0);
    }
    if (basis == 1u) {
        if (k == 0u) {
            return 0.5;
        }
        let cs = sbrdf_sincos_turns(sbrdf_frac_mul(f32((k + 1u) / 2u), u));
        return select(cs.x, cs.y, (k & 1u) == 1u);
    }
    return sbrdf_sincos_turns(sbrdf_frac_mul(f32(k), 0.5 * u)).y;
}

// rho at four wavelengths (each clamped at 0; a non-finite one 0).
fn sbrdf_warp_eval4(base: u32, w: u32, wi: vec3<f32>, wo: vec3<f32>, l: vec4<f32>) -> vec4<f32> {
    let q = sbrdf_warp_query(w, wi, wo);
    if (q.f == 0.0) {
        return vec4<f32>(0.0);
    }
    var ok = vec4<bool>(false);
    var lf = vec4<f32>(0.0);
    for (var i = 0u; i < 4u; i = i + 1u) {
        ok[i] = sbrdf_finite(l[i]);
        lf[i] = select(0.0, l[i], ok[i]);
    }
    var v = vec4<f32>(0.0);
    let nk = sbrdf_u(w + 2u);
    for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
        if (k >= nk) {
            break;
        }
        let b = vec4<f32>(sbrdf_warp_basis(base, k, lf.x), sbrdf_warp_basis(base, k, lf.y),
            sbrdf_warp_basis(base, k, lf.z), sbrdf_warp_basis(base, k, lf.w));
        v = v + sbrdf_warp_term(w, q, k) * b;
    }
    return select(vec4<f32>(0.0), max(v, vec4<f32>(0.0)), ok);
}

// Terms kept per query by sbrdf_warp_eval_rgb (files with more read the rest again per
// wavelength; the RGL measurements have 2 or 3).
const SBRDF_WARP_RGB_TERMS: u32 = 8u;

fn sbrdf_warp_eval_rgb(base: u32, w: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let q = sbrdf_warp_query(w, wi, wo);
    if (q.f == 0.0) {
        return vec3<f32>(0.0);
    }
    let nk = sbrdf_u(w + 2u);
    var v: array<f32, 8>;
    for (var k = 0u; k < SBRDF_WARP_RGB_TERMS; k = k + 1u) {
        if (k >= nk) {
            break;
        }
        v[k] = sbrdf_warp_term(w, q, k);
    }
    var rgb = vec3<f32>(0.0);
    for (var i = 0u; i < 81u; i = i + 1u) {
        let lambda = 380.0 + 5.0 * f32(i);
        var s = 0.0;
        for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
            if (k >= nk) {
                break;
            }
            var t = 0.0;
            if (k < SBRDF_WARP_RGB_TERMS) {
                t = v[k];
            } else {
                t = sbrdf_warp_term(w, q, k);
            }
            s = s + t * sbrdf_warp_basis(base, k, lambda);
        }
        rgb = rgb + max(s, 0.0) * SBRDF_RGB_WEIGHTS[i];
    }
    return rgb;
}

// The values' density of stored incidence i at node j (normalised): the spectrum-averaged table
// values clamped at 0, plus the incidence's floor.
fn sbrdf_warp_values_at(w: u32, i: u32, j: u32) -> f32 {
    let nk = sbrdf_u(w + 2u);
    let means = w + sbrdf_u(w + 14u);
    var v = 0.0;
    for (var k = 0u; k < SBRDF_MAX_TERMS; k = k + 1u) {
        if (k >= nk) {
            break;
        }
        v = v + sbrdf_warp_table(w, i * nk + k, j) * sbrdf_f(means + k);
    }
    let inc = w + sbrdf_u(w + 6u) + 6u * i;
    return sbrdf_f(inc + 4u) * (max(v, 0.0) + sbrdf_f(inc + 5u));
}

fn sbrdf_warp_values_density(w: u32, sl: SbrdfWarpSlices, x: f32, y: f32) -> f32 {
    let r = sbrdf_u(w + 3u);
    let cx = sbrdf_warp_cell(x, r);
    let cy = sbrdf_warp_cell(y, r);
    let n00 = bitcast<u32>(cy.x) * r + bitcast<u32>(cx.x);
    let n10 = n00 + r;
    let v00 = sbrdf_warp_mix(sl, sbrdf_warp_values_at(w, sl.a, n00), sbrdf_warp_values_at(w, sl.b, n00));
    let v01 = sbrdf_warp_mix(sl, sbrdf_warp_values_at(w, sl.a, n00 + 1u),
        sbrdf_warp_values_at(w, sl.b, n00 + 1u));
    let v10 = sbrdf_warp_mix(sl, sbrdf_warp_values_at(w, sl.a, n10), sbrdf_warp_values_at(w, sl.b, n10));
    let v11 = sbrdf_warp_mix(sl, sbrdf_warp_values_at(w, sl.a, n10 + 1u),
        sbrdf_warp_values_at(w, sl.b, n10 + 1u));
    return mix(mix(v00, v01, cx.y), mix(v10, v11, cx.y), cy.y);
}

// Word j of values row (i, b): 0 total, 1 marginal, 2.. the marks' conditional integrals.
fn sbrdf_warp_values_row(w: u32, i: u32, b: u32, j: u32) -> f32 {
    let r = sbrdf_u(w + 3u);
    return sbrdf_f(w + sbrdf_u(w + 13u) + (2u + SBRDF_WARP_MARKS) * (i * r + b) + j);
}

// The blended values' density at column a of rows b and b + 1, blended by ty.
fn sbrdf_warp_values_col(w: u32, sl: SbrdfWarpSlices, b: u32, a: u32, ty: f32) -> f32 {
    let r = sbrdf_u(w + 3u);
    let lo = b * r + a;
    let hi = lo + r;
    return mix(sbrdf_warp_mix(sl, sbrdf_warp_values_at(w, sl.a, lo), sbrdf_warp_values_at(w, sl.b, lo)),
        sbrdf_warp_mix(sl, sbrdf_warp_values_at(w, sl.a, hi), sbrdf_warp_values_at(w, sl.b, hi)), ty);
}

// The forward warp of the values' density: a uniform point -> a warped point (the row by its
// stored marginal, the column from the last kept mark below the target, walking the row).
fn sbrdf_warp_values_sample(w: u32, sl: SbrdfWarpSlices, sx_in: f32, sy_in: f32) -> vec2<f32> {
    let r = sbrdf_u(w + 3u);
    let n1 = f32(r - 1u);
    let sx = clamp(sx_in, 0.0, 1.0);
    let sy = clamp(sy_in, 0.0, 1.0);
    var lo = 0u;
    var hi = r - 1u;
    for (var it = 0u; it < 32u; it = it + 1u) {
        if (lo + 1u >= hi) {
            break;
        }
        let mid = (lo + hi) >> 1u;
        let m = sbrdf_warp_mix(sl, sbrdf_warp_values_row(w, sl.a, mid, 1u),
            sbrdf_warp_values_row(w, sl.b, mid, 1u));
        if (m < sy) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let b = min(hi - 1u, r - 2u);
    let mb = sbrdf_warp_mix(sl, sbrdf_warp_values_row(w, sl.a, b, 1u),
        sbrdf_warp_values_row(w, sl.b, b, 1u));
    let r0 = sbrdf_warp_mix(sl, sbrdf_warp_values_row(w, sl.a, b, 0u),
        sbrdf_warp_values_row(w, sl.b, b, 0u));
    let r1 = sbrdf_warp_mix(sl, sbrdf_warp_values_row(w, sl.a, b + 1u, 0u),
        sbrdf_warp_values_row(w, sl.b, b + 1u, 0u));
    let ty = sbrdf_warp_segment((sy - mb) * n1, r0, r1);
    let goal = sx * mix(r0, r1, ty);
    var a = 0u;
    var before = 0.0;
    for (var j = 0u; j < SBRDF_WARP_MARKS; j = j + 1u) {
        let m = mix(sbrdf_warp_mix(sl, sbrdf_warp_values_row(w, sl.a, b, 2u + j),
            sbrdf_warp_values_row(w, sl.b, b, 2u + j)),
            sbrdf_warp_mix(sl, sbrdf_warp_values_row(w, sl.a, b + 1u, 2u + j),
            sbrdf_warp_values_row(w, sl.b, b + 1u, 2u + j)), ty);
        if (m >= goal) {
            break;
        }
        a = (j + 1u) * (r - 1u) / (SBRDF_WARP_MARKS + 1u);
        before = m;
    }
    let half = 0.5 / n1;
    var c0 = sbrdf_warp_values_col(w, sl, b, a, ty);
    var c1 = sbrdf_warp_values_col(w, sl, b, a + 1u, ty);
    for (var it = 0u; it < r; it = it + 1u) {
        if (a + 2u >= r) {
            break;
        }
        let next = before + half * (c0 + c1);
        if (next >= goal) {
            break;
        }
        a = a + 1u;
        before = next;
        c0 = c1;
        c1 = sbrdf_warp_values_col(w, sl, b, a + 1u, ty);
    }
    let tx = sbrdf_warp_segment((goal - before) * n1, c0, c1);
    return vec2<f32>((f32(a) + tx) / n1, (f32(b) + ty) / n1);
}

// The density over wo (the tables' frame) of reflecting wi about a half vector drawn from the
// blended warps (0 where m is below the horizon or faces away from wo).
fn sbrdf_warp_reflected(w: u32, sl: SbrdfWarpSlices, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let h = wi + wo;
    let len = length(h);
    if (!(len > 0.0) || h.z < 0.0) {
        return 0.0;
    }
    let m = h / len;
    let u = sbrdf_warp_half(m);
    let jac = u.z * SBRDF_PI * u.x * 2.0 * SBRDF_PI;
    let d = dot(wo, m);
    if (!(jac > 0.0 && d > 0.0)) {
        return 0.0;
    }
    let s = sbrdf_warp_invert(w, sl, u.x, u.y);
    return sbrdf_warp_values_density(w, sl, s.x, s.y) * s.z / jac / (4.0 * d);
}

// The density with which sbrdf_warp_sample draws unit wo for unit wi (both above the horizon):
// the cosine share plus the tables' share at wo and at its mirror image.
fn sbrdf_warp_pdf_unit(w: u32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let fr = sbrdf_warp_frame(wi);
    let a = vec3<f32>(sqrt(wi.x * wi.x + wi.y * wi.y), 0.0, wi.z);
    let b = sbrdf_warp_in(fr, wo);
    if (b.z <= 0.0) {
        return 0.0;
    }
    let sl = sbrdf_warp_slices(w, fr.z);
    let tables = sbrdf_warp_reflected(w, sl, a, b)
        + sbrdf_warp_reflected(w, sl, a, vec3<f32>(b.x, b.y, -b.z));
    return SBRDF_MIN_COSINE_WEIGHT * b.z / SBRDF_PI + (1.0 - SBRDF_MIN_COSINE_WEIGHT) * tables;
}

fn sbrdf_warp_pdf(w: u32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let ui = sbrdf_upper(wi);
    let uo = sbrdf_upper(wo);
    if (ui.w == 0.0 || uo.w == 0.0) {
        return 0.0;
    }
    return sbrdf_warp_pdf_unit(w, ui.xyz, uo.xyz);
}

// A direction drawn for wi from u (already clamped to [0, 1)^2): (wo, pdf), vec4(0) for none.
fn sbrdf_warp_sample(w: u32, wi: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    let ui = sbrdf_upper(wi);
    if (ui.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let fr = sbrdf_warp_frame(ui.xyz);
    let a = vec3<f32>(sqrt(ui.x * ui.x + ui.y * ui.y), 0.0, ui.z);
    var local: vec3<f32>;
    if (u.x < SBRDF_MIN_COSINE_WEIGHT) {
        let u0 = u.x / SBRDF_MIN_COSINE_WEIGHT;
        let rad = sqrt(u0);
        let cs = sbrdf_sincos_turns(u.y);
        local = vec3<f32>(rad * cs.y, rad * cs.x, sqrt(max(1.0 - u0, 0.0)));
    } else {
        let u0 = min((u.x - SBRDF_MIN_COSINE_WEIGHT) / (1.0 - SBRDF_MIN_COSINE_WEIGHT), 1.0);
        let sl = sbrdf_warp_slices(w, fr.z);
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
    let wo = sbrdf_warp_out(fr, local);
    let back = sbrdf_upper(wo);
    if (back.w == 0.0) {
        return vec4<f32>(0.0);
    }
    let pdf = sbrdf_warp_pdf_unit(w, ui.xyz, back.xyz);
    if (!(pdf > 0.0 && sbrdf_finite(pdf))) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(wo, pdf);
}
