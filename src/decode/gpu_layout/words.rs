//! The word offsets of the flat device layout (`spec/GPU_LAYOUT.md`), defined once.
//!
//! Every table of the layout (the header, a record table entry, a lobe table entry, the
//! sampling section, the model section) is a module here whose constants are the word offsets
//! the writers (`mod.rs`, `sampling.rs`, `factor.rs`, `warped.rs` here) use, and whose `SECTION`
//! lists them for the two generated or checked copies:
//!
//! * the shader's named constants, the block of `shaders/sbrdf.wgsl` between
//!   `// BEGIN GENERATED LAYOUT WORDS` and `// END GENERATED LAYOUT WORDS`, which
//!   [`wgsl_block`] writes (the test `gpu::tests::layout_words_match_the_rust_table` fails when
//!   the shader's block differs, and says how to regenerate it);
//! * the tables of `spec/GPU_LAYOUT.md`, whose rows (word, type, and the words of each field's
//!   description in [`Field::spec`]) the test `words::tests::spec_tables_match` compares
//!   with these.
//!
//! A new table (a model section of another kind, say) is one more `section!` here, its rows in
//! the spec, and `SECTIONS` extended; the shader's block is then regenerated.

/// One field of a table: a word, or a run of words, of one entry.
#[cfg_attr(not(test), allow(dead_code))]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Field {
    /// The constant's name (the WGSL constant is the section's prefix and this).
    pub name: &'static str,
    /// Its first word within the entry.
    pub word: usize,
    /// Its last word (a run of f32 words, such as the factor model's ranges), else `word`.
    pub last: usize,
    /// `u32` or `f32`.
    pub ty: &'static str,
    /// Words the spec's row for this field says (its description column must contain them).
    pub spec: &'static str,
}

/// One table of the layout, and where the spec describes it.
#[cfg_attr(not(test), allow(dead_code))]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Section {
    /// What the table is, for the shader's block.
    pub title: &'static str,
    /// The WGSL constants' prefix.
    pub prefix: &'static str,
    /// What the shader's block says the offsets are relative to.
    pub relative_to: &'static str,
    /// The heading of `spec/GPU_LAYOUT.md` after which the table's rows are.
    pub heading: &'static str,
    /// Which table after that heading (0: the first).
    pub table: usize,
    /// Where the entries start in that table's word numbering (the factor model's components
    /// start at word 14 of the model section), and the words from one entry to the next when
    /// the table describes a repeated entry (0: the entry is described once, as the header).
    pub at: usize,
    pub stride: usize,
    /// Words in one entry.
    pub words: usize,
    pub fields: &'static [Field],
}

macro_rules! section {
    (
        $(#[doc = $doc:literal])*
        mod $module:ident {
            $title:literal, prefix $prefix:literal, relative to $relative:literal,
            spec $heading:literal table $table:literal at $at:literal stride $stride:literal,
            words $words:literal;
            $( $name:ident = $word:literal $(..= $last:literal)? : $ty:ident, $spec:literal; )*
        }
    ) => {
        $(#[doc = $doc])*
        #[allow(dead_code)] // the shader uses every field; the writers not all
        pub(crate) mod $module {
            $(
                #[doc = $spec]
                pub(crate) const $name: usize = $word;
            )*
            /// Words in one entry.
            pub(crate) const WORDS: usize = $words;
            /// The table, for the shader's constants and the spec's check.
            pub(crate) const SECTION: super::Section = super::Section {
                title: $title,
                prefix: $prefix,
                relative_to: $relative,
                heading: $heading,
                table: $table,
                at: $at,
                stride: $stride,
                words: $words,
                fields: &[$(super::Field {
                    name: stringify!($name),
                    word: $word,
                    last: section!(@last $word $(, $last)?),
                    ty: stringify!($ty),
                    spec: $spec,
                },)*],
            };
        }
    };
    (@last $w:literal) => { $w };
    (@last $w:literal, $l:literal) => { $l };
}

section! {
    /// The header: words relative to the material's base.
    mod header {
        "Header", prefix "SBRDF_HDR_", relative to "base",
        spec "## Header (20 words)" table 0 at 0 stride 0,
        words 20;
        MAGIC = 0: u32, "magic";
        VERSION = 1: u32, "layout version";
        TOTAL = 2: u32, "total_words";
        INCIDENCE = 3: u32, "incidence layout";
        BASIS = 4: u32, "spectral basis";
        TERMS = 5: u32, "K, the basis's number of terms";
        SH_LEVEL = 6: u32, "sh_level";
        WAVES = 7: u32, "W, the number of wavelengths";
        RECORDS = 8: u32, "N, the number of records";
        THETAS = 9: u32, "T, the number of distinct stored θi";
        PHIS = 10: u32, "P, the number of distinct stored φi";
        LAMBDA_MIN = 11: f32, "λmin (nm)";
        LAMBDA_MAX = 12: f32, "λmax (nm)";
        OFF_WAVES = 13: u32, "offset of the wavelengths";
        OFF_BASIS_TABLE = 14: u32, "offset of the basis table";
        OFF_THETAS = 15: u32, "offset of the stored θi";
        OFF_PHIS = 16: u32, "offset of the stored φi";
        OFF_RECORDS = 17: u32, "offset of the record table";
        OFF_SAMPLING = 18: u32, "offset of the sampling section";
        OFF_MODEL = 19: u32, "offset of the model section";
    }
}

section! {
    /// A record table entry: words relative to the entry (header word 17 + 12 r).
    mod record {
        "Record table entry", prefix "SBRDF_REC_", relative to "a record table entry",
        spec "## Record table entry (12 words)" table 0 at 0 stride 0,
        words 12;
        THETA_I = 0: f32, "θi (degrees)";
        PHI_I = 1: f32, "φi";
        THETA_P = 2: f32, "θp, the peak's polar angle";
        PHI_P = 3: f32, "φp";
        LEVEL = 4: u32, "the record's SH level L";
        TERMS = 5: u32, "terms";
        LOBES = 6: u32, "lobe count M";
        ENCODING = 7: u32, "value encoding";
        SCALE = 8: f32, "scale";
        OFF_SH = 9: u32, "offset of the SH coefficients";
        OFF_LOBES = 10: u32, "offset of the lobe table";
        RESERVED = 11: u32, "0 (reserved)";
    }
}

section! {
    /// A lobe table entry: words relative to the entry (the record's lobe table + 3 l).
    mod lobe {
        "Lobe table entry", prefix "SBRDF_LOBE_", relative to "a lobe table entry",
        spec "### Lobe table entry (3 words)" table 0 at 0 stride 0,
        words 3;
        KIND = 0: u32, "kind";
        OFF_AMPLITUDES = 1: u32, "offset of its amplitudes";
        OFF_PARAMETERS = 2: u32, "offset of its parameters";
    }
}

section! {
    /// The sampling section's record index: word S + r is the offset of record r's weights.
    mod sampling {
        "Sampling section, its record index", prefix "SBRDF_SMP_", relative to "the sampling section (header word 18) + r",
        spec "## Sampling section" table 0 at 0 stride 1,
        words 1;
        OFF_WEIGHTS = 0: u32, "offset of record r's weights";
    }
}

section! {
    /// A record's sampling weights: the background's energy, then `lobe_weights` per lobe.
    mod weights {
        "Sampling section, a record's weights", prefix "SBRDF_SW_", relative to "a record's weights",
        spec "## Sampling section" table 1 at 0 stride 0,
        words 1;
        BACKGROUND = 0: f32, "E_bg";
    }
}

section! {
    /// Lobe l's sampling weights: words relative to a record's weights + 1 + 2 l.
    mod lobe_weights {
        "Sampling section, a lobe's weights in its record's", prefix "SBRDF_SWL_", relative to "a record's weights + 1 + 2 l",
        spec "## Sampling section" table 1 at 1 stride 2,
        words 2;
        ENERGY = 0: f32, "E_l";
        LN_WIDTH = 1: f32, "ln b_l";
    }
}

section! {
    /// The model section's first word, common to every kind.
    mod model {
        "Model section, every kind", prefix "SBRDF_MODEL_", relative to "the model section (header word 19)",
        spec "## Model section" table 0 at 0 stride 0,
        words 1;
        KIND = 0: u32, "kind";
    }
}

section! {
    /// The model section of kind 1, the factor model: its fixed words.
    mod factor {
        "Model section of kind 1, the factor model", prefix "SBRDF_FACT_", relative to "the model section of kind 1",
        spec "## Model section" table 0 at 0 stride 0,
        words 14;
        ENCODING = 1: u32, "value encoding of the model's values";
        COMPONENTS = 2: u32, "C, the number of components";
        RESERVED = 3: u32, "0 (reserved)";
        RANGES = 4..=13: f32, "the ranges";
    }
}

section! {
    /// A factor model's component entry: words relative to the model section + 14 + 4 c.
    mod component {
        "Factor model, a component's entry", prefix "SBRDF_FACT_C_", relative to "the model section of kind 1 + 14 + 4 c",
        spec "## Model section" table 0 at 14 stride 4,
        words 4;
        RANK = 0: u32, "rank R_c";
        FEATURES = 1: u32, "feature count F_c";
        CODES = 2: u32, "feature codes";
        OFF_VALUES = 3: u32, "offset of its values";
    }
}

section! {
    /// The model section of kind 2, warped tables: its header. Offsets in it are relative to
    /// its first word W (the section is also the CPU decoder's compact form, built alone).
    mod warped {
        "Model section of kind 2, warped tables", prefix "SBRDF_WARP_", relative to "the model section of kind 2",
        spec "## Warped tables section" table 0 at 0 stride 0,
        words 16;
        KIND = 0: u32, "kind: 2 warped tables";
        N = 1: u32, "N, stored incidences";
        K = 2: u32, "K, spectral terms";
        R = 3: u32, "R, table side";
        G = 4: u32, "G, VNDF grid side";
        M = 5: u32, "M, NDF nodes";
        OFF_INCIDENCES = 6: u32, "offset of the incidences";
        OFF_NDF = 7: u32, "offset of the NDF";
        OFF_SIGMA = 8: u32, "offset of σ";
        OFF_COLUMNS = 9: u32, "offset of the columns";
        OFF_ROW_COSINES = 10: u32, "offset of the rows' cosines";
        OFF_VNDF_ROWS = 11: u32, "offset of the VNDF rows";
        OFF_TABLES = 12: u32, "offset of the table entries";
        OFF_VALUES_ROWS = 13: u32, "offset of the values rows";
        OFF_BASIS_MEANS = 14: u32, "offset of the basis means";
        RESERVED = 15: u32, "0 (reserved)";
    }
}

section! {
    /// A stored incidence of warped tables: words relative to its entry (W + word 6 + 6 i).
    mod warped_incidence {
        "Warped tables, a stored incidence", prefix "SBRDF_WARP_INC_", relative to "an incidence entry",
        spec "## Warped tables section" table 1 at 0 stride 0,
        words 6;
        THETA = 0: f32, "θ_i (radians)";
        SIN = 1: f32, "sin θ_i";
        COS = 2: f32, "cos θ_i";
        VNDF_SCALE = 3: f32, "1/I_i";
        VALUES_SCALE = 4: f32, "the values' density: 1 over its total";
        VALUES_FLOOR = 5: f32, "the values' floor";
    }
}

section! {
    /// A column of the VNDF grid: words relative to its entry (W + word 9 + 5 a).
    mod warped_column {
        "Warped tables, a VNDF column", prefix "SBRDF_WARP_COL_", relative to "a column entry",
        spec "## Warped tables section" table 2 at 0 stride 0,
        words 5;
        F = 0: f32, "f_a";
        SIN = 1: f32, "sin θm_a";
        COS = 2: f32, "cos θm_a";
        U = 3: f32, "U[a]";
        V = 4: f32, "V[a]";
    }
}

section! {
    /// A table's entry: words relative to it (W + word 12 + 4 (i K + k)).
    mod warped_table {
        "Warped tables, a table's entry", prefix "SBRDF_WARP_TAB_", relative to "a table entry",
        spec "## Warped tables section" table 3 at 0 stride 0,
        words 4;
        OFF_CODES = 0: u32, "offset of its codes";
        BITS = 1: u32, "bits per code";
        LO = 2: f32, "least value";
        STEP = 3: f32, "step";
    }
}

section! {
    /// A row of a stored incidence's values' density: words relative to it (W + word 13 +
    /// 5 (i R + b)).
    mod warped_values {
        "Warped tables, a values row", prefix "SBRDF_WARP_VAL_", relative to "a values row",
        spec "## Warped tables section" table 4 at 0 stride 0,
        words 5;
        TOTAL = 0: f32, "the row's total";
        MARG = 1: f32, "its marginal";
        MARKS = 2..=4: f32, "conditional integrals at columns";
    }
}

/// Every table, in the order of the spec and of the shader's block.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) const SECTIONS: [Section; 14] = [
    header::SECTION,
    record::SECTION,
    lobe::SECTION,
    sampling::SECTION,
    weights::SECTION,
    lobe_weights::SECTION,
    model::SECTION,
    factor::SECTION,
    component::SECTION,
    warped::SECTION,
    warped_incidence::SECTION,
    warped_column::SECTION,
    warped_table::SECTION,
    warped_values::SECTION,
];

/// The codes the layout's words hold (`spec/GPU_LAYOUT.md`), also given to the shader by name.
pub(crate) mod codes {
    /// `SBGL` read as a little-endian u32: header word 0 of every layout.
    pub(crate) const MAGIC: u32 = u32::from_le_bytes(*b"SBGL");
    /// Incidence layouts (header word 3).
    pub(crate) const INCIDENCE_ISOTROPIC: u32 = 0;
    pub(crate) const INCIDENCE_LATTICE: u32 = 1;
    pub(crate) const INCIDENCE_SCATTERED: u32 = 2;
    /// Value encodings (record word 7, factor model word 1).
    pub(crate) const ENCODING_F32: u32 = 1;
    pub(crate) const ENCODING_F16_PAIRS: u32 = 2;
    /// Model section kinds (model word 0).
    pub(crate) const MODEL_FACTOR: u32 = 1;
    pub(crate) const MODEL_WARPED: u32 = 2;
    /// A warped VNDF row's word: its positive run in the low bits, its marginal above in
    /// units of 2^-(32 − bits).
    pub(crate) const WARP_POSITIVE_BITS: u32 = 9;
    /// Conditional integrals kept per warped values row.
    pub(crate) const WARP_MARKS: u32 = 3;
}

/// The codes' WGSL names and values, in the block's order.
#[cfg_attr(not(test), allow(dead_code))]
const CODES: [(&str, u32, &str); 10] = [
    (
        "SBRDF_INCIDENCE_ISOTROPIC",
        codes::INCIDENCE_ISOTROPIC,
        "header word 3",
    ),
    (
        "SBRDF_INCIDENCE_LATTICE",
        codes::INCIDENCE_LATTICE,
        "header word 3",
    ),
    (
        "SBRDF_INCIDENCE_SCATTERED",
        codes::INCIDENCE_SCATTERED,
        "header word 3",
    ),
    (
        "SBRDF_ENCODING_F32",
        codes::ENCODING_F32,
        "one f32 per word",
    ),
    (
        "SBRDF_ENCODING_F16_PAIRS",
        codes::ENCODING_F16_PAIRS,
        "two f16 per word",
    ),
    (
        "SBRDF_MODEL_FACTOR",
        codes::MODEL_FACTOR,
        "model kind 1: the factor model",
    ),
    (
        "SBRDF_MODEL_WARPED",
        codes::MODEL_WARPED,
        "model kind 2: warped tables",
    ),
    (
        "SBRDF_WARP_POSITIVE_BITS",
        codes::WARP_POSITIVE_BITS,
        "a VNDF row's positive run below, its marginal above",
    ),
    (
        "SBRDF_WARP_MARKS",
        codes::WARP_MARKS,
        "conditional integrals kept per values row",
    ),
    (
        "SBRDF_LAYOUT_MAGIC",
        codes::MAGIC,
        "header word 0: the bytes SBGL",
    ),
];

/// The shader's block of constants (without its marker lines): one `const NAME: u32 = Nu;` per
/// field and per table's size, then the codes. What `shaders/sbrdf.wgsl` must hold between its
/// `// BEGIN GENERATED LAYOUT WORDS` and `// END GENERATED LAYOUT WORDS` lines.
#[cfg_attr(not(test), allow(dead_code))] // read by the tests of this file and of gpu.rs
pub(crate) fn wgsl_block() -> String {
    let mut s = String::from(
        "// Generated from src/decode/gpu_layout/words.rs, the one definition of spec/GPU_LAYOUT.md's word\n\
         // offsets; do not edit (the test gpu::tests::layout_words_match_the_rust_table says how to\n\
         // regenerate). Offsets are in words, relative to what each table's comment says.\n",
    );
    for sec in SECTIONS {
        s += &format!(
            "// {} ({} words), relative to {}\n",
            sec.title, sec.words, sec.relative_to
        );
        for f in sec.fields {
            let ty = if f.last != f.word {
                format!("{} {} words, to {}", f.last - f.word + 1, f.ty, f.last)
            } else {
                f.ty.to_string()
            };
            s += &format!(
                "const {}{}: u32 = {}u; // {ty}: {}\n",
                sec.prefix, f.name, f.word, f.spec
            );
        }
        s += &format!("const {}WORDS: u32 = {}u;\n", sec.prefix, sec.words);
    }
    s += "// Codes the words hold\n";
    for (name, value, what) in CODES {
        let v = if value > 255 {
            format!("{value:#x}")
        } else {
            value.to_string()
        };
        s += &format!("const {name}: u32 = {v}u; // {what}\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spec's text.
    const SPEC: &str = include_str!("../../../spec/GPU_LAYOUT.md");

    /// One row of a spec table: (first word, words per repeated entry, last word, type,
    /// description), parsed from its word column ("7", "M + 14 + 4c", "1 + 2l", "S + r, r = …",
    /// "M + 4 … M + 13").
    type Row = (usize, usize, usize, String, String);

    fn parse_word(col: &str) -> (usize, usize, usize) {
        let col = col.split(',').next().unwrap();
        let mut ends = col.split('…').map(|side| {
            let (mut offset, mut stride) = (0usize, 0usize);
            for term in side.split('+').map(str::trim) {
                let digits: String = term.chars().take_while(char::is_ascii_digit).collect();
                let rest = &term[digits.len()..];
                match (digits.is_empty(), rest.is_empty()) {
                    (false, true) => offset += digits.parse::<usize>().unwrap(),
                    (false, false) => stride += digits.parse::<usize>().unwrap(),
                    // A section's letter (S, M) is its start; a lone index letter is stride 1.
                    (true, false) if rest.chars().all(|c| c.is_ascii_lowercase()) => stride += 1,
                    (true, false) => {}
                    (true, true) => panic!("word column {col:?}: empty term"),
                }
            }
            (offset, stride)
        });
        let (first, stride) = ends.next().unwrap();
        let last = ends.next().map_or(first, |(l, _)| l);
        (first, stride, last)
    }

    /// The rows of the `n`-th table after `heading`.
    fn spec_table(heading: &str, n: usize) -> Vec<Row> {
        let at = SPEC
            .lines()
            .position(|l| l.trim() == heading)
            .unwrap_or_else(|| panic!("spec/GPU_LAYOUT.md has no heading {heading:?}"));
        let lines: Vec<&str> = SPEC.lines().skip(at + 1).collect();
        let mut tables: Vec<Vec<Row>> = Vec::new();
        let mut inside = false;
        for l in &lines {
            if l.starts_with("## ") || l.starts_with("### ") {
                break; // the next section
            }
            if !l.starts_with('|') {
                inside = false;
                continue;
            }
            let cols: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            if !inside {
                inside = true;
                tables.push(Vec::new());
                continue; // the column names
            }
            if cols[0].starts_with("---") {
                continue;
            }
            let (first, stride, last) = parse_word(cols[0]);
            tables
                .last_mut()
                .unwrap()
                .push((first, stride, last, cols[1].into(), cols[2].into()));
        }
        tables
            .into_iter()
            .nth(n)
            .unwrap_or_else(|| panic!("spec/GPU_LAYOUT.md, {heading:?}: no table {n}"))
    }

    /// Every table of the spec holds exactly the Rust table's fields: the same words in the
    /// same order, the same types, and a description that says what the field's `spec` says.
    #[test]
    fn spec_tables_match() {
        let mut tables: Vec<(&str, usize)> =
            SECTIONS.iter().map(|s| (s.heading, s.table)).collect();
        tables.dedup();
        assert_eq!(tables.len(), 11, "tables: {tables:?}");
        for (heading, n) in tables {
            let want: Vec<(usize, usize, usize, &str, &str)> = SECTIONS
                .iter()
                .filter(|s| s.heading == heading && s.table == n)
                .flat_map(|s| {
                    s.fields
                        .iter()
                        .map(move |f| (s.at + f.word, s.stride, s.at + f.last, f.ty, f.spec))
                })
                .collect();
            let got = spec_table(heading, n);
            assert_eq!(
                got.len(),
                want.len(),
                "spec/GPU_LAYOUT.md {heading:?} table {n}: {} rows, the Rust table (src/decode/gpu_layout/words.rs) {}",
                got.len(),
                want.len()
            );
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(
                    (g.0, g.1, g.2, g.3.as_str()),
                    (w.0, w.1, w.2, w.3),
                    "spec/GPU_LAYOUT.md {heading:?}: the row {:?} differs from src/decode/gpu_layout/words.rs's {:?}",
                    g,
                    w
                );
                assert!(
                    g.4.contains(w.4),
                    "spec/GPU_LAYOUT.md {heading:?}: the row for word {} says {:?}, not {:?}",
                    g.0,
                    g.4,
                    w.4
                );
            }
        }
    }

    /// Each section's fields are within its entry, in increasing order, without overlap.
    #[test]
    fn fields_fit_their_entries() {
        for s in SECTIONS {
            let mut next = 0;
            for f in s.fields {
                assert!(f.word >= next && f.last >= f.word, "{}{}", s.prefix, f.name);
                next = f.last + 1;
            }
            assert!(next <= s.words, "{}: {} words", s.prefix, s.words);
        }
        // The header holds every word it declares; the factor model's components follow its
        // fixed words (the shader finds them at SBRDF_FACT_WORDS).
        assert_eq!(header::OFF_MODEL + 1, header::WORDS);
        assert_eq!(component::SECTION.at, factor::WORDS);
        assert_eq!(component::SECTION.stride, component::WORDS);
        assert_eq!(lobe_weights::SECTION.at, weights::WORDS);
        assert_eq!(lobe_weights::SECTION.stride, lobe_weights::WORDS);
        assert_eq!(warped::RESERVED + 1, warped::WORDS);
        assert_eq!(
            warped_values::MARKS + codes::WARP_MARKS as usize,
            warped_values::WORDS
        );
    }

    #[test]
    fn word_columns_parse() {
        assert_eq!(parse_word("7"), (7, 0, 7));
        assert_eq!(parse_word("M + 14 + 4c"), (14, 4, 14));
        assert_eq!(parse_word("1 + 2l"), (1, 2, 1));
        assert_eq!(parse_word("S + r, r = 0..N−1"), (0, 1, 0));
        assert_eq!(parse_word("M + 4 … M + 13"), (4, 0, 13));
        assert_eq!(parse_word("M"), (0, 0, 0));
    }
}
