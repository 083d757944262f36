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
