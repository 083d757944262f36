//! The folders of `src/` are the architecture (`docs/guide/code-map.md`): dependencies point one way,
//! down the list below, so that a renderer's build (`model`, `format`, `decode`) never reaches
//! the encoder or the program. This test reads the sources and fails on any reference that
//! points up, and on files grown past the size a reader can hold in mind.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Rooms from the bottom up; a room may use the rooms before it and itself.
/// `gpu` (the WGSL text) sits on `decode`: it evaluates what `Decoder::gpu_layout` writes.
/// `preview` (the preview sphere without an evaluator, feature `preview`) on `model`.
const ROOMS: [&str; 9] = [
    "model", "format", "decode", "gpu", "preview", "encode", "io", "report", "cli",
];

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
    // lib.rs compiles model, format and decode (and gpu, the WGSL text that evaluates the
    // decoder's device layout) unconditionally and everything else behind a feature: a
    // renderer with `default-features = false` gets nothing above `decode` but that text.
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
    assert_eq!(always, ["decode", "error", "format", "gpu", "model"]);
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

/// A file's module path under `src/` (`decode/kernel/mod.rs` → `decode::kernel`).
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts
        .last()
        .is_some_and(|p| p == "mod" || p == "lib" || p == "main")
    {
        parts.pop();
    }
    parts
}

/// The modules (among `known`) that a file's code names by path: `crate::a::b`, `super::b`,
/// `self::b`, and each item of a `{…}` group after such a prefix; the longest known prefix of
/// each path. Comments are skipped.
fn modules_named(text: &str, me: &[String], known: &[Vec<String>]) -> Vec<Vec<String>> {
    // `self` is the file's own module and `super` its parent, whether the file is `x.rs` or
    // `x/mod.rs` (module_of names both `x`).
    let resolve = |head: &str, rest: &[String]| -> Option<Vec<String>> {
        let mut path = match head {
            "crate" => Vec::new(),
            "self" => me.to_vec(),
            _ => me[..me.len().saturating_sub(1)].to_vec(), // super
        };
        path.extend_from_slice(rest);
        (1..=path.len())
            .rev()
            .map(|k| path[..k].to_vec())
            .find(|p| known.contains(p))
    };
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        for head in ["crate", "super", "self"] {
            let mut rest = code;
            while let Some(i) = rest.find(&format!("{head}::")) {
                let before = rest[..i].chars().last();
                rest = &rest[i + head.len() + 2..];
                if before.is_some_and(ident) {
                    continue;
                }
                let mut segs = Vec::new();
                let mut r = rest;
                loop {
                    let name: String = r.chars().take_while(|&c| ident(c)).collect();
                    if name.is_empty() {
                        break;
                    }
                    r = &r[name.len()..];
                    segs.push(name);
                    match r.strip_prefix("::") {
                        Some(t) => r = t,
                        None => break,
                    }
                }
                if let Some(group) = r.strip_prefix('{') {
                    let group = group.split('}').next().unwrap_or("");
                    for item in group.split(',') {
                        let first: String = item.trim().chars().take_while(|&c| ident(c)).collect();
                        let mut p = segs.clone();
                        p.push(first);
                        out.extend(resolve(head, &p));
                    }
                }
                out.extend(resolve(head, &segs));
            }
        }
    }
    out.retain(|m| m.as_slice() != me);
    out
}

/// The import circles among files of the same room: strongly connected groups of more than one
/// module (Tarjan), each sorted, as "a/b, a/c".
fn import_circles(files: &[(Vec<String>, String)]) -> Vec<String> {
    let known: Vec<Vec<String>> = files.iter().map(|f| f.0.clone()).collect();
    let edges: Vec<Vec<usize>> = files
        .iter()
        .map(|(me, text)| {
            let mut e: Vec<usize> = modules_named(text, me, &known)
                .iter()
                .filter(|m| m.first() == me.first()) // within the room
                .filter_map(|m| known.iter().position(|k| k == m))
                .collect();
            e.sort();
            e.dedup();
            e
        })
        .collect();
    struct State {
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        stack: Vec<usize>,
        on: Vec<bool>,
        next: usize,
        groups: Vec<Vec<usize>>,
    }
    fn visit(v: usize, edges: &[Vec<usize>], s: &mut State) {
        s.index[v] = Some(s.next);
        s.low[v] = s.next;
        s.next += 1;
        s.stack.push(v);
        s.on[v] = true;
        for &w in &edges[v] {
            match s.index[w] {
                None => {
                    visit(w, edges, s);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(i) if s.on[w] => s.low[v] = s.low[v].min(i),
                _ => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut group = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on[w] = false;
                group.push(w);
                if w == v {
                    break;
                }
            }
            if group.len() > 1 {
                s.groups.push(group);
            }
        }
    }
    let n = files.len();
    let mut s = State {
        index: vec![None; n],
        low: vec![0; n],
        stack: Vec::new(),
        on: vec![false; n],
        next: 0,
        groups: Vec::new(),
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(v, &edges, &mut s);
        }
    }
    let mut out: Vec<String> = s
        .groups
        .iter()
        .map(|g| {
            let mut names: Vec<String> = g.iter().map(|&i| known[i].join("/")).collect();
            names.sort();
            names.join(", ")
        })
        .collect();
    out.sort();
    out
}

/// Circles allowed between files of a room: none (the last, the evaluator, its one-wavelength
/// kernel and the θ-line path taking each other, went with issue 24: the kernel now reads the
/// resident arrays and hands back the queries it does not take).
const KNOWN_CIRCLES: [&str; 0] = [];

#[test]
fn no_import_circle_between_files_of_a_room() {
    let src = src();
    let mut paths = Vec::new();
    rust_files(&src, &mut paths);
    paths.sort();
    let files: Vec<(Vec<String>, String)> = paths
        .iter()
        .map(|p| (module_of(&src, p), std::fs::read_to_string(p).unwrap()))
        .collect();
    let circles = import_circles(&files);
    assert_eq!(
        circles, KNOWN_CIRCLES,
        "import circles between files of one room (each file must use the others of its room \
         one way only)"
    );
}

#[test]
fn the_circle_check_finds_a_planted_circle() {
    let file = |m: &str, text: &str| {
        (
            m.split('/').map(String::from).collect::<Vec<_>>(),
            text.to_string(),
        )
    };
    // a → b → c → a through the three spellings of a path, d outside the circle, and a use
    // in a comment that must not count.
    let files = vec![
        file("decode/a", "use super::b::Thing;\n// use super::d::X;"),
        file("decode/b", "use crate::decode::{c::More, d};"),
        file("decode/c", "fn f() { super::a::g() }"),
        file("decode/d", "use super::lattice::Q;"),
        file("encode/e", "use crate::decode::a::Thing;"),
    ];
    assert_eq!(import_circles(&files), ["decode/a, decode/b, decode/c"]);
    // Broken at one edge, it is gone.
    let mut fixed = files.clone();
    fixed[2].1 = "fn f() {}".into();
    assert!(import_circles(&fixed).is_empty());
}

/// The code map's tree (`docs/guide/code-map.md`), split into its sections: (the name at the
/// start of a line, `decode/` or `lib.rs`, and the section's text).
fn code_map_sections(map: &str) -> Vec<(String, String)> {
    let start = map.find("```text\n").expect("the code map's tree") + 8;
    let end = start + map[start..].find("```").expect("the tree's end");
    let mut out: Vec<(String, String)> = Vec::new();
    for line in map[start..end].lines() {
        let head = line.split_whitespace().next().unwrap_or("");
        if !line.starts_with(' ') && (head.ends_with('/') || head.ends_with(".rs")) {
            out.push((head.to_string(), String::new()));
        }
        if let Some(last) = out.last_mut() {
            last.1.push_str(line);
            last.1.push('\n');
        }
    }
    out
}

/// The `name.rs` words of a text (with any folder prefix).
fn rs_words(text: &str) -> Vec<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '/' || c == '.'))
        .map(|w| w.trim_end_matches('.'))
        .filter(|w| w.ends_with(".rs") && w.len() > 3)
        .map(str::to_string)
        .collect()
}

/// The code-map problems of a tree against the files under `src` (paths relative to it).
fn code_map_problems(map: &str, files: &[String], root: &Path) -> Vec<String> {
    let sections = code_map_sections(map);
    let mut problems = Vec::new();
    let under = |dir: &str| -> Vec<&String> {
        files
            .iter()
            .filter(|f| dir.is_empty() || f.starts_with(dir))
            .collect()
    };
    for f in files {
        let top = f.split('/').next().unwrap();
        let named = if !f.contains('/') {
            sections.iter().any(|(h, _)| h == f)
        } else {
            let folder = format!("{top}/");
            let base = f.rsplit('/').next().unwrap();
            sections.iter().any(|(h, text)| {
                h == &folder
                    && if base == "mod.rs" {
                        // a folder's mod.rs: the folder (or a nested folder) is named
                        let parent = f.trim_end_matches("mod.rs").trim_end_matches('/');
                        let leaf = parent.rsplit('/').next().unwrap();
                        parent == top || text.contains(&format!("{leaf}/"))
                    } else {
                        rs_words(text).iter().any(|w| w == base)
                    }
            })
        };
        if !named {
            problems.push(format!("src/{f} is not in the code map"));
        }
    }
    for (head, text) in &sections {
        let dir = if head.ends_with('/') {
            head.as_str()
        } else {
            ""
        };
        for w in rs_words(text) {
            let exists = if w.contains('/') {
                root.join("src").join(&w).exists() || root.join(&w).exists()
            } else {
                under(dir)
                    .iter()
                    .any(|f| f.rsplit('/').next() == Some(w.as_str()))
            };
            if !exists {
                problems.push(format!(
                    "the code map names {w} under {head}, which does not exist"
                ));
            }
        }
    }
    problems
}

#[test]
fn the_code_map_names_every_file_and_only_files_that_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths = Vec::new();
    rust_files(&src(), &mut paths);
    let files: Vec<String> = paths
        .iter()
        .map(|p| {
            p.strip_prefix(src())
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/")
        })
        .collect();
    let map = std::fs::read_to_string(root.join("docs/guide/code-map.md")).unwrap();
    let problems = code_map_problems(&map, &files, root);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // The check fails on a file left out and on a file that is not there.
    let mut more = files.clone();
    more.push("decode/planted.rs".into());
    let p = code_map_problems(&map, &more, root);
    assert!(
        p.iter().any(|m| m.contains("src/decode/planted.rs is not")),
        "{p:?}"
    );
    let stale = map.replace("  sums.rs ", "  summed.rs ");
    let p = code_map_problems(&stale, &files, root);
    assert!(p.iter().any(|m| m.contains("names summed.rs")), "{p:?}");
    assert!(
        p.iter().any(|m| m.contains("src/decode/sums.rs is not")),
        "{p:?}"
    );
}
