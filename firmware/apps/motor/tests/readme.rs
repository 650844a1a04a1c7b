//! README.md's generated section (topics, parameters, faults, LEDs) is what the code says.
//! `R2P_BLESS=1 cargo test -p r2p-app-motor --test readme` rewrites it.

use r2p_app_motor::readme::{render, BEGIN, END};

#[test]
fn the_readme_section_matches_the_code() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let (Some(a), Some(b)) = (text.find(BEGIN), text.find(END)) else {
        panic!("{}: no generated section (lines {BEGIN:?} … {END:?})", path.display());
    };
    let start = a + BEGIN.len() + 1;
    let fresh = render();
    if std::env::var_os("R2P_BLESS").is_some_and(|v| v == "1") {
        let new = format!("{}{}{}", &text[..start], fresh, &text[b..]);
        std::fs::write(&path, new).unwrap();
        return;
    }
    assert!(
        text[start..b] == fresh,
        "{}: the generated section is stale: run `R2P_BLESS=1 cargo test -p r2p-app-motor --test readme` and commit README.md",
        path.display()
    );
}

#[test]
fn the_section_lists_every_parameter_and_topic() {
    let s = render();
    for p in r2p_app_motor::params::DEFAULTS {
        assert!(s.contains(&format!("`{}`", p.name)), "{}", p.name);
    }
    for t in ["setpoint", "clear_faults", "state", "fault"] {
        assert!(s.contains(&format!("`<name>/{t}`")), "{t}");
    }
    assert!(s.contains("| 10 | `current_limit` | 10 | 0.1 … 23 | A |"), "{s}");
}
