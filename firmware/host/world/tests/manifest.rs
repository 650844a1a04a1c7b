//! The emulator's kind table agrees with the module manifest (modules.toml, the one list of
//! modules): every module's `emulator` is a kind here, every kind models some module, and a
//! kind's board file is its module's.

use std::collections::BTreeSet;
use std::path::PathBuf;

use r2p_world::BoardKind;

fn manifest() -> Vec<toml::Table> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let text = std::fs::read_to_string(root.join("modules.toml")).expect("modules.toml");
    let t: toml::Table = toml::from_str(&text).expect("modules.toml parses");
    t["module"].as_array().unwrap().iter().map(|m| m.as_table().unwrap().clone()).collect()
}

#[test]
fn every_emulator_model_of_the_manifest_is_a_kind_and_every_kind_is_used() {
    let modules = manifest();
    let named: BTreeSet<&str> =
        modules.iter().filter_map(|m| m.get("emulator").and_then(|e| e.as_str())).collect();
    let kinds: BTreeSet<&str> = BoardKind::ALL.iter().map(|k| k.name()).collect();
    for e in &named {
        assert!(
            BoardKind::from_name(e).is_some(),
            "modules.toml names emulator model `{e}`, which firmware/host/world's BoardKind lacks"
        );
    }
    assert_eq!(named, kinds, "every BoardKind models a module of modules.toml");
}

#[test]
fn a_kinds_board_file_is_its_modules() {
    for m in manifest() {
        let name = m["name"].as_str().unwrap();
        let Some(kind) = BoardKind::from_name(name) else { continue };
        let want = m.get("board_file").and_then(|f| f.as_str());
        let have = kind.board_file().map(|f| format!("firmware/boards/{f}"));
        assert_eq!(have.as_deref(), want, "{name}");
    }
}
