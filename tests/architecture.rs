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
            continue; // generated tables (decode/color/cie.rs)
        }
        // decode/ is what a renderer's team reads first: its files stay shorter.
        let limit = if f.ends_with("main.rs") {
            300
        } else if f.starts_with(src.join("decode")) {
            600
        } else {
            900
        };
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

/// A module a file's code names by path, with the item named in it (if the path goes on), and
/// whether the naming is a re-export (`pub use`, `pub(crate) use`, `pub(super) use`).
#[derive(Debug, Clone, PartialEq)]
struct Named {
    module: Vec<String>,
    item: Option<String>,
    reexport: bool,
}

/// The text's lines with each `use` statement on one line (a group may run over several).
fn logical_lines(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut open: Option<String> = None;
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        if let Some(stmt) = open.as_mut() {
            stmt.push(' ');
            stmt.push_str(code.trim());
            if code.contains(';') {
                out.push(open.take().unwrap_or_default());
            }
            continue;
        }
        let t = code.trim_start();
        let starts_use = t.starts_with("use ") || is_reexport(code);
        if starts_use && !code.contains(';') {
            open = Some(code.to_string());
        } else {
            out.push(line.to_string());
        }
    }
    out.extend(open);
    out
}

/// Whether a line of code re-exports (`pub use …`, `pub(crate) use …`).
fn is_reexport(code: &str) -> bool {
    let t = code.trim_start();
    let Some(rest) = t.strip_prefix("pub") else {
        return false;
    };
    let rest = match rest.strip_prefix('(') {
        Some(r) => r.split_once(')').map_or("", |(_, after)| after),
        None => rest,
    };
    rest.trim_start().starts_with("use ")
}

/// The modules (among `known`) that a file's code names by path: `crate::a::b`, `super::b`,
/// `self::b`, a child module by its own name (`pub use context::…`, `formulas::frame(…)` in
/// `mod.rs` or any file with children), and each item of a `{…}` group after such a prefix;
/// the longest known prefix of each path, with the segment after it. Comments are skipped.
fn modules_named(text: &str, me: &[String], known: &[Vec<String>]) -> Vec<Named> {
    // `self` is the file's own module and `super` its parent, whether the file is `x.rs` or
    // `x/mod.rs` (module_of names both `x`).
    let resolve = |head: &str, rest: &[String]| -> Option<(Vec<String>, Option<String>)> {
        let mut path = match head {
            "crate" => Vec::new(),
            "super" => me[..me.len().saturating_sub(1)].to_vec(),
            _ => me.to_vec(), // self, or a child's name
        };
        let base = path.len();
        path.extend_from_slice(rest);
        (base.max(1)..=path.len())
            .rev()
            .find(|&k| known.contains(&path[..k].to_vec()))
            .map(|k| (path[..k].to_vec(), path.get(k).cloned()))
    };
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    // The file's child modules: a path may start with one's name.
    let children: Vec<String> = known
        .iter()
        .filter(|k| k.len() == me.len() + 1 && k.starts_with(me))
        .map(|k| k[me.len()].clone())
        .collect();
    let mut out = Vec::new();
    // Inline modules (`mod tests { … }`) the line is in, with the brace depth each opened at:
    // in them `super` is the file's own module.
    let mut inline: Vec<usize> = Vec::new();
    let mut depth = 0usize;
    for line in logical_lines(text) {
        let code = line.split("//").next().unwrap_or("");
        let t = code.trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or(t.strip_prefix("pub "))
            .unwrap_or(t);
        if t.starts_with("mod ") && t.trim_end().ends_with('{') {
            inline.push(depth);
        }
        depth += code.matches('{').count();
        depth = depth.saturating_sub(code.matches('}').count());
        while inline.last().is_some_and(|&d| depth <= d) && !t.starts_with("mod ") {
            inline.pop();
        }
        if !inline.is_empty() {
            // Inside an inline module: its paths name the file's own module or below, except
            // `crate::` paths, which mean what they say.
            if !code.contains("crate::") {
                continue;
            }
        }
        let reexport = is_reexport(code);
        let mut at = 0;
        while at < code.len() {
            let rest = &code[at..];
            let Some(i) = rest.find("::") else {
                break;
            };
            // The identifier before this `::`, and whether a path continues into it.
            let before = &rest[..i];
            let head: String = before
                .chars()
                .rev()
                .take_while(|&c| ident(c))
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect();
            let start = at + i - head.len();
            at += i + 2;
            if head.is_empty() || code[..start].ends_with("::") {
                continue;
            }
            let head = head.as_str();
            if !matches!(head, "crate" | "super" | "self") && !children.iter().any(|c| c == head) {
                continue;
            }
            let mut segs = Vec::new();
            if !matches!(head, "crate" | "super" | "self") {
                segs.push(head.to_string());
            }
            let mut r = &code[at..];
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
            let head = if matches!(head, "crate" | "super" | "self") {
                head
            } else {
                "self"
            };
            let mut found = |p: &[String]| {
                if let Some((module, item)) = resolve(head, p) {
                    out.push(Named {
                        module,
                        item,
                        reexport,
                    });
                }
            };
            if let Some(group) = r.strip_prefix('{') {
                // A group names its items (the prefix alone only as `self`).
                let group = group.split('}').next().unwrap_or("");
                for item in group.split(',') {
                    let item = item.trim();
                    let mut p = segs.clone();
                    for seg in item.split("::") {
                        let first: String = seg.trim().chars().take_while(|&c| ident(c)).collect();
                        if !first.is_empty() && first != "self" {
                            p.push(first);
                        }
                    }
                    found(&p);
                }
            } else {
                found(&segs);
            }
        }
    }
    out.retain(|m| m.module.as_slice() != me);
    out
}

/// What each module re-exports: (module, item name) → the module the item comes from, read
/// from its `pub use` lines (`pub use a::b::{C, D as E};`: C and E from a::b).
fn reexports(files: &[(Vec<String>, String)]) -> BTreeMap<(Vec<String>, String), Vec<String>> {
    let known: Vec<Vec<String>> = files.iter().map(|f| f.0.clone()).collect();
    let mut map = BTreeMap::new();
    for (me, text) in files {
        for line in logical_lines(text) {
            let code = line.split("//").next().unwrap_or("");
            if !is_reexport(code) {
                continue;
            }
            // The names the line makes: the last segment of each path, or its alias.
            let body = code
                .split("use ")
                .nth(1)
                .unwrap_or("")
                .trim_end_matches(';');
            let (prefix, items) = match body.split_once('{') {
                Some((p, g)) => (p, g.split('}').next().unwrap_or("").to_string()),
                None => match body.rsplit_once("::") {
                    Some((p, last)) => (p, last.to_string()),
                    None => continue,
                },
            };
            for item in items.split(',') {
                let item = item.trim();
                let (path, name) = match item.split_once(" as ") {
                    Some((p, alias)) => (p.trim(), alias.trim()),
                    None => (item, item.rsplit("::").next().unwrap_or(item)),
                };
                if name.is_empty() || name == "self" || name == "*" {
                    continue;
                }
                let full = format!("{}{}{path}", prefix.trim_end_matches("::"), "::");
                let named = modules_named(&format!("{full};"), me, &known);
                if let Some(n) = named.into_iter().last() {
                    map.insert((me.clone(), name.to_string()), n.module);
                }
            }
        }
    }
    map
}

/// The module edges of files (module path, text): each file to every module it names, an item
/// named through a re-export resolved to the module that defines it.
fn module_edges(files: &[(Vec<String>, String)]) -> Vec<(Vec<String>, Vec<String>)> {
    let known: Vec<Vec<String>> = files.iter().map(|f| f.0.clone()).collect();
    let re = reexports(files);
    let mut edges = Vec::new();
    for (me, text) in files {
        for n in modules_named(text, me, &known) {
            let mut to = n.module.clone();
            // Follow re-exports (a bounded number of hops: a re-export of a re-export).
            if let Some(item) = &n.item {
                for _ in 0..8 {
                    match re.get(&(to.clone(), item.clone())) {
                        Some(m) if *m != to => to = m.clone(),
                        _ => break,
                    }
                }
            }
            if &to != me {
                edges.push((me.clone(), to));
            }
        }
    }
    edges.sort();
    edges.dedup();
    edges
}

/// Strongly connected groups of more than one node (Tarjan), each sorted, as "a/b, a/c".
fn circles_of(nodes: &[Vec<String>], edges: &[(Vec<String>, Vec<String>)]) -> Vec<String> {
    let at = |m: &Vec<String>| nodes.iter().position(|k| k == m);
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
    for (a, b) in edges {
        if let (Some(a), Some(b)) = (at(a), at(b)) {
            if a != b {
                adj[a].push(b);
            }
        }
    }
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
    let n = nodes.len();
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
            visit(v, &adj, &mut s);
        }
    }
    let mut out: Vec<String> = s
        .groups
        .iter()
        .map(|g| {
            let mut names: Vec<String> = g.iter().map(|&i| nodes[i].join("/")).collect();
            names.sort();
            names.join(", ")
        })
        .collect();
    out.sort();
    out
}

/// The import circles among files of the same room: strongly connected groups of more than one
/// module, each sorted, as "a/b, a/c".
fn import_circles(files: &[(Vec<String>, String)]) -> Vec<String> {
    let nodes: Vec<Vec<String>> = files.iter().map(|f| f.0.clone()).collect();
    let edges: Vec<_> = module_edges(files)
        .into_iter()
        .filter(|(a, b)| a.first() == b.first()) // within the room
        .collect();
    circles_of(&nodes, &edges)
}

/// The import circles among folders: every module taken as its folder at each depth (the
/// modules of `decode/kernel/` as `decode/kernel`), edges between different folders of one
/// parent.
fn folder_circles(files: &[(Vec<String>, String)]) -> Vec<String> {
    let edges = module_edges(files);
    let depth = files.iter().map(|f| f.0.len()).max().unwrap_or(0);
    let mut out = Vec::new();
    for d in 1..depth {
        let cut = |m: &Vec<String>| m[..m.len().min(d + 1)].to_vec();
        // Only modules that are folders at this depth (they have modules below them) count as
        // one node; a file's own module stands for itself.
        let mut nodes: Vec<Vec<String>> = files.iter().map(|f| cut(&f.0)).collect();
        nodes.sort();
        nodes.dedup();
        let cut_edges: Vec<_> = edges
            .iter()
            .map(|(a, b)| (cut(a), cut(b)))
            .filter(|(a, b)| a != b && a.len() == b.len() && a[..a.len() - 1] == b[..b.len() - 1])
            .filter(|(a, b)| {
                let folder = |m: &Vec<String>| {
                    files
                        .iter()
                        .any(|f| f.0.len() > m.len() && f.0.starts_with(m))
                };
                folder(a) || folder(b)
            })
            .collect();
        out.extend(circles_of(&nodes, &cut_edges));
    }
    out.sort();
    out.dedup();
    out
}

fn source_modules() -> Vec<(Vec<String>, String)> {
    let src = src();
    let mut paths = Vec::new();
    rust_files(&src, &mut paths);
    paths.sort();
    paths
        .iter()
        .map(|p| (module_of(&src, p), std::fs::read_to_string(p).unwrap()))
        .collect()
}

#[test]
fn no_import_circle_between_files_of_a_room() {
    let circles = import_circles(&source_modules());
    assert!(
        circles.is_empty(),
        "import circles between files of one room (each file must use the others of its room \
         one way only; a `mod.rs` that uses a child is one of them):\n{}",
        circles.join("\n")
    );
}

#[test]
fn no_import_circle_between_folders() {
    let circles = folder_circles(&source_modules());
    assert!(
        circles.is_empty(),
        "import circles between folders (each folder must use its siblings one way only):\n{}",
        circles.join("\n")
    );
}

fn planted(files: &[(&str, &str)]) -> Vec<(Vec<String>, String)> {
    files
        .iter()
        .map(|(m, text)| {
            (
                m.split('/').map(String::from).collect::<Vec<_>>(),
                text.to_string(),
            )
        })
        .collect()
}

#[test]
fn the_circle_check_finds_a_planted_circle() {
    // a → b → c → a through the three spellings of a path, d outside the circle, and a use
    // in a comment that must not count.
    let files = planted(&[
        ("decode/a", "use super::b::Thing;\n// use super::d::X;"),
        ("decode/b", "use crate::decode::{c::More, d};"),
        ("decode/c", "fn f() { super::a::g() }"),
        ("decode/d", "use super::lattice::Q;"),
        ("encode/e", "use crate::decode::a::Thing;"),
    ]);
    assert_eq!(import_circles(&files), ["decode/a, decode/b, decode/c"]);
    // Broken at one edge, it is gone.
    let mut fixed = files.clone();
    fixed[2].1 = "fn f() {}".into();
    assert!(import_circles(&fixed).is_empty());
}

#[test]
fn the_circle_check_sees_a_child_named_without_a_prefix() {
    // A folder's mod.rs names its child by the child's own name (`pub use child::…`, a call
    // `child::f()`), the child uses its parent: a circle no `crate::` path shows.
    for parent in [
        "pub use context::Fitted;",
        "use formulas::{frame, Frame};",
        "fn g() { formulas::frame() }",
    ] {
        let files = planted(&[
            ("encode/fit", parent),
            ("encode/fit/context", "use super::Options;"),
            ("encode/fit/formulas", "use super::Options;"),
        ]);
        assert_eq!(
            import_circles(&files).len(),
            1,
            "{parent}: {:?}",
            import_circles(&files)
        );
    }
    // A child that uses only its siblings closes no circle.
    let files = planted(&[
        ("encode/fit", "pub use context::Fitted;"),
        ("encode/fit/context", "use super::options::Options;"),
        ("encode/fit/options", ""),
    ]);
    assert!(import_circles(&files).is_empty());
}

#[test]
fn the_circle_check_resolves_a_reexport_to_its_home() {
    // b re-exports c's Thing; a takes it through b; c uses a. Resolved to its home, a → c → a
    // is a circle; taken as a → b it was not.
    let files = planted(&[
        ("decode/a", "use super::b::Thing;"),
        ("decode/b", "pub use super::c::Thing;"),
        ("decode/c", "use super::a::Other;"),
    ]);
    assert_eq!(import_circles(&files), ["decode/a, decode/c"]);
    // So is an aliased re-export and a grouped one.
    let files = planted(&[
        ("decode/a", "use crate::decode::b::{Alias, More};"),
        (
            "decode/b",
            "pub(crate) use super::c::{Thing as Alias, More};",
        ),
        ("decode/c", "fn f() { super::a::g() }"),
    ]);
    assert_eq!(import_circles(&files), ["decode/a, decode/c"]);
}

#[test]
fn the_folder_check_finds_a_planted_circle() {
    // decode/x/p uses decode/y/q, decode/y/r uses decode/x: no two files take each other, but
    // the folders x and y do.
    let files = planted(&[
        ("decode/x", ""),
        ("decode/x/p", "use crate::decode::y::q::Q;"),
        ("decode/y", ""),
        ("decode/y/q", ""),
        ("decode/y/r", "use crate::decode::x::P;"),
    ]);
    assert!(import_circles(&files).is_empty());
    assert_eq!(folder_circles(&files), ["decode/x, decode/y"]);
}

/// The types a file defines (struct, enum, union, trait, type alias), by name.
fn types_defined(text: &str) -> Vec<String> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("").trim_start();
        let mut rest = code;
        if let Some(r) = rest.strip_prefix("pub") {
            rest = match r.strip_prefix('(') {
                Some(r) => r.split_once(')').map_or("", |(_, after)| after),
                None => r,
            }
            .trim_start();
        }
        for kw in ["struct ", "enum ", "union ", "trait ", "type "] {
            if let Some(r) = rest.strip_prefix(kw) {
                let name: String = r.chars().take_while(|&c| ident(c)).collect();
                if !name.is_empty() {
                    out.push(name);
                }
            }
        }
    }
    out
}

/// The types a file's `impl` blocks are for (`impl<T> Trait for Type<T>`: `Type`), with the
/// line of each.
fn types_implemented(text: &str) -> Vec<(usize, String)> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (n, line) in lines.iter().enumerate() {
        let code = line.split("//").next().unwrap_or("").trim_start();
        let code = code.strip_prefix("unsafe ").unwrap_or(code);
        let Some(rest) = code.strip_prefix("impl") else {
            continue;
        };
        if !(rest.starts_with('<') || rest.starts_with(' ')) {
            continue;
        }
        // The header up to its `{` (it may run over lines), generic parameters skipped.
        let mut header = rest.to_string();
        let mut more = n + 1;
        while !header.contains('{') && more < lines.len() {
            header.push(' ');
            header.push_str(lines[more]);
            more += 1;
        }
        let header = header.split('{').next().unwrap_or("");
        let mut depth = 0;
        let mut after_generics = String::new();
        for c in header.chars() {
            match c {
                '<' => depth += 1,
                '>' => depth -= 1,
                _ if depth == 0 => after_generics.push(c),
                _ => {}
            }
        }
        let after_generics = after_generics.split(" where ").next().unwrap_or("");
        let target = match after_generics.split_once(" for ") {
            Some((_, t)) => t,
            None => after_generics,
        };
        let target = target
            .trim()
            .trim_start_matches('&')
            .trim_start_matches("mut ");
        let target = target.rsplit("::").next().unwrap_or(target);
        let name: String = target.trim().chars().take_while(|&c| ident(c)).collect();
        if !name.is_empty() {
            out.push((n + 1, name));
        }
    }
    out
}

/// `impl` blocks of a type defined in another file (files: path, text): "path:line: impl
/// Type (defined in other)". A type defined in the file itself may be implemented there,
/// whatever else shares its name.
fn foreign_impls(files: &[(String, String)]) -> Vec<String> {
    let defined: Vec<(String, Vec<String>)> = files
        .iter()
        .map(|(p, t)| (p.clone(), types_defined(t)))
        .collect();
    let mut out = Vec::new();
    for ((path, text), (_, mine)) in files.iter().zip(&defined) {
        for (line, ty) in types_implemented(text) {
            if mine.contains(&ty) {
                continue;
            }
            let homes: Vec<&str> = defined
                .iter()
                .filter(|(_, d)| d.contains(&ty))
                .map(|(p, _)| p.as_str())
                .collect();
            if !homes.is_empty() {
                out.push(format!(
                    "{path}:{line}: impl {ty} (defined in {})",
                    homes.join(", ")
                ));
            }
        }
    }
    out
}

#[test]
fn every_type_is_implemented_in_its_own_file() {
    let src = src();
    let mut paths = Vec::new();
    rust_files(&src, &mut paths);
    paths.sort();
    let files: Vec<(String, String)> = paths
        .iter()
        .map(|p| {
            (
                p.strip_prefix(&src).unwrap().display().to_string(),
                std::fs::read_to_string(p).unwrap(),
            )
        })
        .collect();
    let found = foreign_impls(&files);
    assert!(
        found.is_empty(),
        "impl blocks outside their type's file (the import that shows the dependency is \
         missing; move the code, or make it a function taking the type):\n{}",
        found.join("\n")
    );
    // The scan must have seen the crate's types and impls.
    let impls: usize = files.iter().map(|f| types_implemented(&f.1).len()).sum();
    assert!(impls > 50, "only {impls} impl blocks found");
}

#[test]
fn the_impl_check_finds_a_planted_foreign_impl() {
    let file = |p: &str, t: &str| (p.to_string(), t.to_string());
    let files = vec![
        file(
            "decode/evaluator.rs",
            "pub(crate) struct Evaluator {}\nimpl Evaluator {}\npub trait Sink {}",
        ),
        file(
            "decode/general.rs",
            "use super::evaluator::Evaluator;\n// impl Evaluator {} in a comment\n\
             impl Evaluator {\n    fn more(&self) {}\n}",
        ),
        file(
            "decode/lanes.rs",
            "impl<const N: usize> crate::decode::Frame<N>\nwhere\n    N: Copy,\n{\n}",
        ),
        file("decode/frame.rs", "pub struct Frame<const N: usize>;"),
        file(
            "decode/sink.rs",
            "struct Own;\nimpl super::evaluator::Sink for Own {}",
        ),
        file("model/lanes.rs", "impl Real for f64 {}"),
    ];
    assert_eq!(
        foreign_impls(&files),
        [
            "decode/general.rs:3: impl Evaluator (defined in decode/evaluator.rs)",
            "decode/lanes.rs:1: impl Frame (defined in decode/frame.rs)",
        ]
    );
}

/// The entries of the code map's tree (`docs/guide/code-map.md`): each line whose first word
/// ends in `.rs` or `/` names a file or a folder, relative to the folders it is indented
/// under (`decode/` then `  records/` then `    general.rs`: `decode/records/general.rs`).
/// A word in a description names nothing.
fn code_map_entries(map: &str) -> Vec<String> {
    let start = map.find("```text\n").expect("the code map's tree") + 8;
    let end = start + map[start..].find("```").expect("the tree's end");
    let mut folders: Vec<(usize, String)> = Vec::new();
    let mut out = Vec::new();
    for line in map[start..end].lines() {
        let indent = line.len() - line.trim_start().len();
        let head = line.split_whitespace().next().unwrap_or("");
        if !(head.ends_with(".rs") || head.ends_with('/')) || head.contains("::") {
            continue;
        }
        while folders.last().is_some_and(|(i, _)| *i >= indent) {
            folders.pop();
        }
        let path: String = folders.iter().map(|(_, f)| f.as_str()).collect::<String>() + head;
        if head.ends_with('/') {
            folders.push((indent, head.to_string()));
        }
        out.push(path);
    }
    out
}

/// The code-map problems of a tree against the files under `src` (paths relative to it): a
/// file not named by an entry of its own (a folder's `mod.rs` by the folder's entry), and an
/// entry that names nothing.
fn code_map_problems(map: &str, files: &[String]) -> Vec<String> {
    let entries = code_map_entries(map);
    let mut problems = Vec::new();
    for f in files {
        let entry = match f.strip_suffix("mod.rs") {
            Some(folder) if !folder.is_empty() => folder.to_string(),
            _ => f.clone(),
        };
        if !entries.contains(&entry) {
            problems.push(format!("src/{f} is not in the code map"));
        }
    }
    for e in &entries {
        let exists = if e.ends_with('/') {
            files.iter().any(|f| f.starts_with(e.as_str()))
        } else {
            files.contains(e)
        };
        if !exists {
            problems.push(format!("the code map names src/{e}, which does not exist"));
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
    let problems = code_map_problems(&map, &files);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(code_map_entries(&map).len() > 100, "the tree was not read");
}

#[test]
fn the_code_map_check_finds_planted_mistakes() {
    let map = "intro\n```text\nlib.rs   the surface\ndecode/  the decoder\n  decoder.rs  \
               the facade, beside batch.rs\n  records/    the records\n    general.rs  the \
               general path\n  batch.rs    many pairs\n```\n";
    let files: Vec<String> = [
        "lib.rs",
        "decode/mod.rs",
        "decode/decoder.rs",
        "decode/batch.rs",
        "decode/records/mod.rs",
        "decode/records/general.rs",
    ]
    .map(String::from)
    .to_vec();
    assert!(
        code_map_problems(map, &files).is_empty(),
        "{:?}",
        code_map_problems(map, &files)
    );
    // A file left out (named only in a description does not count) and one not there.
    let mut more = files.clone();
    more.push("decode/records/planted.rs".into());
    assert_eq!(
        code_map_problems(map, &more),
        ["src/decode/records/planted.rs is not in the code map"]
    );
    let without = map.replace("  batch.rs    many pairs\n", "");
    assert_eq!(
        code_map_problems(&without, &files),
        ["src/decode/batch.rs is not in the code map"]
    );
    let stale = map.replace("general.rs", "summed.rs");
    assert_eq!(
        code_map_problems(&stale, &files),
        [
            "src/decode/records/general.rs is not in the code map",
            "the code map names src/decode/records/summed.rs, which does not exist",
        ]
    );
}
