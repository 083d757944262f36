//! The README's code that a test can hold: its Rust example is `examples/readme.rs` (which
//! `cargo test` compiles) word for word, so the example a newcomer copies builds.

#[test]
fn the_readme_rust_example_is_the_compiled_example() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let start = readme
        .find("```rust\n")
        .expect("a Rust block in the README")
        + "```rust\n".len();
    let block = &readme[start..start + readme[start..].find("```").unwrap()];
    let example = std::fs::read_to_string(root.join("examples/readme.rs")).unwrap();
    let code = &example[example.find("\nfn main").expect("fn main in the example") + 1..];
    assert!(block.starts_with("fn main"), "{block}");
    assert_eq!(
        block, code,
        "README.md's Rust block and examples/readme.rs differ"
    );
}

#[test]
fn the_crate_documentation_opens_with_the_readme_rust_example() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let start = readme.find("```rust\n").unwrap() + "```rust\n".len();
    let block = &readme[start..start + readme[start..].find("```").unwrap()];
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap();
    let docs: String = lib
        .lines()
        .take_while(|l| l.starts_with("//!"))
        .map(|l| {
            format!(
                "{}\n",
                l.trim_start_matches("//!").strip_prefix(' ').unwrap_or("")
            )
        })
        .collect();
    let start = docs
        .find("```no_run\n")
        .expect("a code block in the crate docs")
        + 10;
    let code = &docs[start..start + docs[start..].find("```").unwrap()];
    assert_eq!(
        code, block,
        "src/lib.rs's example and README.md's Rust block differ"
    );
}
