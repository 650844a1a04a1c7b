//! Copies every ```rust block of docs/middleware.md into `$OUT_DIR/snippetN.rs` (N from 0, in
//! document order), each as one block expression, and writes how many there are
//! (`$OUT_DIR/count.rs`) so that the crate can insist on a context for each.

use std::path::PathBuf;

const DOC: &str = "docs/middleware.md";

fn main() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap()).join("../../..");
    let path = root.join(DOC);
    println!("cargo:rerun-if-changed={}", path.display());
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{DOC}: {e}"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap());
    let mut n = 0;
    let mut lines = text.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        if line.trim_end() != "```rust" {
            continue;
        }
        let mut body = format!("// {DOC}:{}\n{{\n", i + 2);
        let mut closed = false;
        for (_, l) in lines.by_ref() {
            if l.trim_end() == "```" {
                closed = true;
                break;
            }
            body.push_str(l);
            body.push('\n');
        }
        assert!(closed, "{DOC}:{}: a ```rust block that is never closed", i + 1);
        body.push_str("}\n");
        std::fs::write(out.join(format!("snippet{n}.rs")), body).unwrap();
        n += 1;
    }
    std::fs::write(out.join("count.rs"), format!("{n}\n")).unwrap();
}
