//! The folders of `src/` are the architecture (README, "Code map"): dependencies point one way,
//! down the list below, so that a renderer's build (`model`, `format`, `decode`) never reaches
//! the encoder or the program. This test reads the sources and fails on any reference that
//! points up, and on files grown past the size a reader can hold in mind.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Rooms from the bottom up; a room may use the rooms before it and itself.
const ROOMS: [&str; 7] = ["model", "format", "decode", "encode", "io", "report", "cli"];

/// Files anyone may use, or that are the crate's surface.
const SHARED: [&str; 2] = ["error", "lib"];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The room a file under `src/` belongs to (`main.rs` is the program, as `cli/` is).
fn room_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel
        .components()
        .next()
        .unwrap()
        .as_os_str()
        .to_string_lossy();
    match first.trim_end_matches(".rs") {
        "main" => "cli".to_string(),
        other => other.to_string(),
    }
}

/// Every room named after `crate::` or `sbrdf::` in the file's code (comments skipped).
fn rooms_used(text: &str) -> Vec<(usize, String)> {
    let mut used = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        for prefix in ["crate::", "sbrdf::"] {
            let mut rest = code;
            while let Some(i) = rest.find(prefix) {
                rest = &rest[i + prefix.len()..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if ROOMS.contains(&name.as_str()) {
                    used.push((n + 1, name));
                }
            }
        }
    }
    used
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn dependencies_point_down_the_rooms() {
    let src = src();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let rank = |r: &str| ROOMS.iter().position(|x| *x == r);
    let mut edges: BTreeMap<(String, String), usize> = BTreeMap::new();
    let mut wrong = Vec::new();
    for f in &files {
        let from = room_of(&src, f);
        if SHARED.contains(&from.as_str()) {
            continue;
        }
        let from_rank = rank(&from)
            .unwrap_or_else(|| panic!("{}: a file outside every room; add it to one", f.display()));
        for (line, to) in rooms_used(&std::fs::read_to_string(f).unwrap()) {
            *edges.entry((from.clone(), to.clone())).or_default() += 1;
            if rank(&to).unwrap() > from_rank {
                wrong.push(format!("{}:{line}: {from} uses {to}", f.display()));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "references pointing up:\n{}",
        wrong.join("\n")
    );
    // The test must have seen the layering it guards: the decoder uses the model and the
    // format, the encoder the decoder, the program every room.
    for (a, b) in [
        ("decode", "model"),
        ("decode", "format"),
        ("encode", "model"),
        ("cli", "io"),
    ] {
        assert!(
            edges.contains_key(&(a.to_string(), b.to_string())),
            "no use of {b} from {a} found: is the scan reading the sources?"
        );
    }
}

#[test]
fn the_decoder_only_build_compiles_three_rooms() {
    // lib.rs compiles model, format and decode unconditionally and everything else behind a
    // feature: a renderer with `default-features = false` gets nothing above `decode`.
    let lib = std::fs::read_to_string(src().join("lib.rs")).unwrap();
    let mut gated = false;
    let mut always = Vec::new();
    for line in lib.lines() {
        let t = line.trim();
        if t.starts_with("#[cfg(") {
            gated = true;
            continue;
        }
        if let Some(m) = t.strip_prefix("pub mod ").or(t.strip_prefix("mod ")) {
            let m = m.trim_end_matches(';').to_string();
            if !gated {
                always.push(m);
            }
        }
        gated = false;
    }
    always.sort();
    assert_eq!(always, ["decode", "error", "format", "model"]);
}

#[test]
fn no_source_file_is_too_long_to_read() {
    let src = src();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    assert!(files.len() > 30, "only {} source files found", files.len());
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        if text.contains("Do not edit by hand") {
            continue; // generated tables (decode/cie.rs)
        }
        let limit = if f.ends_with("main.rs") { 300 } else { 900 };
        let n = text.lines().count();
        assert!(n <= limit, "{}: {n} lines (at most {limit})", f.display());
    }
}
