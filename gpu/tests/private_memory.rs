//! Private memory per invocation, measured from naga's IR: what each entry point of the tests'
//! module (`sbrdf_eval`, `sbrdf_eval4`, `sbrdf_eval_rgb`, `sbrdf_pdf`, `sbrdf_sample` behind
//! `eval_spectral`, `eval_four`, `eval_rgb`, `pdf_at`, `sample_dir`) may keep in function-scope
//! memory, which a GPU holds in registers when it can and in slow local memory when it cannot
//! (an array indexed at run time, above all).
//!
//! Per function: the sizes of its local variables (`var`, from naga's `Layouter`), plus every
//! composite value that naga's SPIR-V writer must spill into a temporary variable because it is
//! indexed at run time (an array or matrix that is not behind a pointer: a `const` array, or an
//! array field of a struct passed by value), once per spilled expression as the writer does.
//! Per entry point: its own function's figure plus that of every function it reaches through
//! calls, each counted once. WGSL has no recursion, so no call path holds a function's frame
//! twice: the sum bounds the frames live at any one time. It is an upper bound: compilers keep
//! scalars and small vectors in registers and reuse a finished function's space.
//!
//! The bound this test holds: `BOUND` bytes for every entry point, whatever the material (the
//! shader streams the spherical harmonics, the spectral basis and the factor model's terms
//! instead of storing them, so no variable depends on the file).

mod common;
mod sampling;
use common::*;
use naga::proc::Layouter;
use naga::valid::{Capabilities, FunctionInfo, ValidationFlags, Validator};
use naga::{Block, Expression, Function, Handle, Module, Statement, TypeInner};
use std::collections::{BTreeMap, BTreeSet};

/// Bytes of private memory each entry point may use (issue 38: at most 256 for the default
/// files; the figure is the same for every file).
const BOUND: u32 = 256;

/// One function's own figure: local variables and spilled composites, and the largest of them.
#[derive(Debug, Default, Clone)]
struct Own {
    locals: u32,
    spills: u32,
    /// The part of `locals` in variables that hold an array (indexed at run time, these are
    /// what a GPU cannot keep in registers).
    arrays: u32,
    /// (bytes, what) of each variable or spill, for the report.
    items: Vec<(u32, String)>,
}

/// Every function a block calls, directly.
fn calls(block: &Block, out: &mut BTreeSet<Handle<Function>>) {
    for s in block.iter() {
        match s {
            Statement::Call { function, .. } => {
                out.insert(*function);
            }
            Statement::Block(b) => calls(b, out),
            Statement::If { accept, reject, .. } => {
                calls(accept, out);
                calls(reject, out);
            }
            Statement::Switch { cases, .. } => cases.iter().for_each(|c| calls(&c.body, out)),
            Statement::Loop {
                body, continuing, ..
            } => {
                calls(body, out);
                calls(continuing, out);
            }
            _ => {}
        }
    }
}

/// Whether a type is or contains an array.
fn holds_array(module: &Module, ty: Handle<naga::Type>) -> bool {
    match &module.types[ty].inner {
        TypeInner::Array { .. } => true,
        TypeInner::Struct { members, .. } => members.iter().any(|m| holds_array(module, m.ty)),
        _ => false,
    }
}

/// A function's local variables and spills (see the module's comment).
fn own(module: &Module, layouter: &Layouter, f: &Function, info: &FunctionInfo) -> Own {
    let mut o = Own::default();
    for (_, v) in f.local_variables.iter() {
        let size = layouter[v.ty].size;
        o.locals += size;
        if holds_array(module, v.ty) {
            o.arrays += size;
        }
        let name = v.name.clone().unwrap_or_else(|| "?".into());
        o.items.push((size, format!("var {name}")));
    }
    // naga's SPIR-V writer spills the base of an `Access` (a run-time index) when the base is
    // an array or matrix value rather than a pointer: one temporary per base expression.
    let mut spilled = BTreeSet::new();
    for (_, e) in f.expressions.iter() {
        if let Expression::Access { base, index } = *e {
            let constant = matches!(
                f.expressions[index],
                Expression::Literal(_) | Expression::Constant(_) | Expression::ZeroValue(_)
            );
            let inner = info[base].ty.inner_with(&module.types);
            if !constant
                && matches!(inner, TypeInner::Array { .. } | TypeInner::Matrix { .. })
                && spilled.insert(base)
            {
                let size = inner.size(module.to_ctx());
                o.spills += size;
                o.items
                    .push((size, format!("spill of {:?}", f.expressions[base])));
            }
        }
    }
    o
}

/// What one entry point may hold.
struct Measured {
    entry: String,
    /// The deepest call path: the entry's frame plus, at each call, the largest of its callees'
    /// (a function's frame lives only while it runs).
    deepest: u32,
    /// Every function it reaches, each once (as if all were inlined with nothing reused).
    all: u32,
    /// The functions along the deepest path.
    path: Vec<String>,
    /// Every reachable function's name and figure.
    parts: Vec<(String, Own)>,
}

/// The deepest path from `h` (its bytes and functions), memoised.
fn deepest(
    h: Handle<Function>,
    owns: &BTreeMap<Handle<Function>, Own>,
    callees: &BTreeMap<Handle<Function>, BTreeSet<Handle<Function>>>,
    memo: &mut BTreeMap<Handle<Function>, (u32, Vec<Handle<Function>>)>,
) -> (u32, Vec<Handle<Function>>) {
    if let Some(r) = memo.get(&h) {
        return r.clone();
    }
    let mut best = (0, Vec::new());
    for &g in &callees[&h] {
        let r = deepest(g, owns, callees, memo);
        if r.0 > best.0 {
            best = r;
        }
    }
    let o = &owns[&h];
    best.0 += o.locals + o.spills;
    best.1.insert(0, h);
    memo.insert(h, best.clone());
    best
}

/// Per entry point of the module, what it may hold.
fn measure(src: &str) -> Vec<Measured> {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("WGSL parse error:\n{}", e.emit_to_string(src)));
    let info = Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("validation error:\n{}", e.emit_to_string(src)));
    let mut layouter = Layouter::default();
    layouter
        .update(module.to_ctx())
        .expect("layout of the types");
    let mut owns = BTreeMap::new();
    let mut callees = BTreeMap::new();
    for (h, f) in module.functions.iter() {
        owns.insert(h, own(&module, &layouter, f, &info[h]));
        let mut c = BTreeSet::new();
        calls(&f.body, &mut c);
        callees.insert(h, c);
    }
    let name = |h: Handle<Function>| module.functions[h].name.clone().unwrap_or_default();
    let mut memo = BTreeMap::new();
    module
        .entry_points
        .iter()
        .enumerate()
        .map(|(i, ep)| {
            let mine = own(&module, &layouter, &ep.function, info.get_entry_point(i));
            let mut direct = BTreeSet::new();
            calls(&ep.function.body, &mut direct);
            let mut reach = BTreeSet::new();
            let mut todo: Vec<_> = direct.iter().copied().collect();
            while let Some(h) = todo.pop() {
                if reach.insert(h) {
                    todo.extend(callees[&h].iter().copied());
                }
            }
            let mut path = (0, Vec::new());
            for &g in &direct {
                let r = deepest(g, &owns, &callees, &mut memo);
                if r.0 > path.0 {
                    path = r;
                }
            }
            let own_bytes = mine.locals + mine.spills;
            let mut parts = vec![(ep.name.clone(), mine)];
            parts.extend(reach.iter().map(|&h| (name(h), owns[&h].clone())));
            Measured {
                entry: ep.name.clone(),
                deepest: own_bytes + path.0,
                all: parts.iter().map(|(_, o)| o.locals + o.spills).sum(),
                path: std::iter::once(ep.name.clone())
                    .chain(path.1.into_iter().map(name))
                    .collect(),
                parts,
            }
        })
        .collect()
}

/// The measure itself: a known array, a spilled `const` array and a call are counted.
#[test]
fn the_measure_counts_locals_spills_and_callees() {
    let src = r#"
const T = array<f32, 8>(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0);
@group(0) @binding(0) var<storage, read_write> out: array<f32>;
fn helper(i: u32) -> f32 {
    var a: array<f32, 16>;
    a[i] = 1.0;
    return a[i] + T[i];
}
@compute @workgroup_size(1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    var v: vec4<f32>;
    v.x = helper(id.x);
    out[id.x] = v.x + T[id.y];
}
"#;
    let m = measure(src);
    assert_eq!(m.len(), 1);
    // main: v (16) + spill of T (32); helper: a (64) + i's spill of T (32).
    assert_eq!(m[0].deepest, 16 + 32 + 64 + 32, "{:#?}", m[0].parts);
    assert_eq!(m[0].path, ["main", "helper"]);
}

/// Two callees of one function: the deepest path takes the larger, the sum both.
#[test]
fn the_deepest_path_takes_the_larger_callee() {
    let src = r#"
@group(0) @binding(0) var<storage, read_write> out: array<f32>;
fn small(i: u32) -> f32 {
    var a: array<f32, 4>;
    a[i] = 1.0;
    return a[i];
}
fn large(i: u32) -> f32 {
    var a: array<f32, 32>;
    a[i] = 2.0;
    return a[i];
}
@compute @workgroup_size(1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    out[id.x] = small(id.x) + large(id.y);
}
"#;
    let m = measure(src);
    assert_eq!((m[0].deepest, m[0].all), (128, 128 + 16));
    assert_eq!(m[0].path, ["main", "large"]);
}

#[test]
fn private_memory_per_invocation_is_bounded() {
    let src = format!(
        "{}\n{}",
        full_module(&shader_source()),
        sampling::SAMPLING_ENTRY_POINTS
    );
    let measured = measure(&src);
    let mut over = Vec::new();
    for m in &measured {
        println!(
            "{}: {} bytes of private memory per invocation along the deepest call path (every \
             reachable function at once: {} bytes); arrays and spills: {} bytes",
            m.entry,
            m.deepest,
            m.all,
            m.parts
                .iter()
                .map(|(_, o)| o.spills + o.arrays)
                .sum::<u32>()
        );
        println!("    path: {}", m.path.join(" > "));
        let mut items: Vec<(u32, String, String)> = m
            .parts
            .iter()
            .flat_map(|(f, o)| o.items.iter().map(move |(b, w)| (*b, f.clone(), w.clone())))
            .collect();
        items.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        for (b, f, w) in items.iter().take(4) {
            println!("    {b:5} B  {f}: {w}");
        }
        if m.deepest > BOUND {
            over.push(format!("{}: {} B", m.entry, m.deepest));
        }
    }
    let names: Vec<&str> = measured.iter().map(|m| m.entry.as_str()).collect();
    assert_eq!(
        names,
        [
            "eval_spectral",
            "eval_four",
            "eval_rgb",
            "pdf_at",
            "sample_dir"
        ]
    );
    assert!(over.is_empty(), "over {BOUND} bytes: {over:?}");
}
