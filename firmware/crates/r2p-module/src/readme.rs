//! What the module READMEs' generated sections share (host builds only): each application
//! renders its topics, parameters and LEDs from its code between two marker lines, and a test
//! checks the committed README against it — or rewrites it when `R2P_BLESS` is set.

use std::format;
use std::string::String;

use r2p_management::message::Value;
use r2p_middleware::Class;

/// A parameter value for a table: its type's name and the value.
pub fn value_cell(v: Value) -> (&'static str, String) {
    match v {
        Value::Bool(b) => ("bool", format!("{b}")),
        Value::U32(x) => ("u32", format!("{x}")),
        Value::I32(x) => ("i32", format!("{x}")),
        Value::F32(x) => ("f32", format!("{x}")),
    }
}

/// Appends `s` and a line break to the section being written.
pub fn line(w: &mut String, s: &str) {
    w.push_str(s);
    w.push('\n');
}

/// A publisher's class for the topics table. `deadline_param` names the parameter an SRT
/// deadline comes from, if one does: the deadline is then given in ms, as that parameter
/// sets it; otherwise in µs.
pub fn class_cell(c: Class, deadline_param: Option<&str>) -> String {
    match (c, deadline_param) {
        (Class::NonRealTime, _) => "NRT".into(),
        (Class::AsyncRealTime { deadline_us }, Some(p)) => {
            format!("SRT, deadline {} ms (`{p}`)", deadline_us / 1000)
        }
        (Class::AsyncRealTime { deadline_us }, None) => format!("SRT, deadline {deadline_us} µs"),
        (Class::SyncRealTime { period_us }, _) => format!("HRT, period {period_us} µs"),
    }
}

/// `text` with the part from the line starting `begin` through the line `end` replaced by
/// `section` (which carries both marker lines); `None` if either marker is missing.
pub fn splice(text: &str, begin: &str, end: &str, section: &str) -> Option<String> {
    let a = text.find(begin)?;
    let b = text[a..].find(end)? + a + end.len();
    let rest = text[b..].strip_prefix('\n').unwrap_or(&text[b..]);
    Some(format!("{}{section}{rest}", &text[..a]))
}

/// Panics, naming the file and the command that fixes it, unless the README at `path` holds
/// `section` between its markers; with `R2P_BLESS` set in the environment it rewrites the
/// section instead. `bless` is the command to give (e.g. `cargo test -p r2p-app-psu readme`).
pub fn check_section(path: &str, begin: &str, end: &str, section: &str, bless: &str) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let want = splice(&text, begin, end, section).unwrap_or_else(|| {
        panic!("{path}: no generated section (marker lines {begin:?} … {end:?})")
    });
    if std::env::var_os("R2P_BLESS").is_some() {
        std::fs::write(path, &want).unwrap_or_else(|e| panic!("{path}: {e}"));
    } else {
        assert!(text == want, "{path}: the generated section is stale; run `R2P_BLESS=1 {bless}`");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splice_replaces_the_marked_lines_and_nothing_else() {
        let text = "x\n<!-- B -->\nold\n<!-- E -->\ny\n";
        assert_eq!(
            splice(text, "<!-- B", "<!-- E -->", "<!-- B -->\nnew\n<!-- E -->\n").unwrap(),
            "x\n<!-- B -->\nnew\n<!-- E -->\ny\n"
        );
        assert_eq!(splice("x\n<!-- B -->\n", "<!-- B", "<!-- E -->", ""), None);
        assert_eq!(splice("x\n<!-- E -->\n", "<!-- B", "<!-- E -->", ""), None);
    }

    #[test]
    fn classes_read_as_the_topics_table_shows_them() {
        assert_eq!(class_cell(Class::NonRealTime, Some("x_ms")), "NRT");
        let srt = Class::AsyncRealTime { deadline_us: 3_000 };
        assert_eq!(
            class_cell(srt, Some("obstacle_deadline_ms")),
            "SRT, deadline 3 ms (`obstacle_deadline_ms`)"
        );
        assert_eq!(class_cell(srt, None), "SRT, deadline 3000 µs");
        let hrt = Class::SyncRealTime { period_us: 10_000 };
        assert_eq!(class_cell(hrt, None), "HRT, period 10000 µs");
    }

    #[test]
    fn values_name_their_type() {
        assert_eq!(value_cell(Value::F32(0.5)), ("f32", "0.5".into()));
        assert_eq!(value_cell(Value::Bool(true)), ("bool", "true".into()));
        assert_eq!(value_cell(Value::I32(-3)), ("i32", "-3".into()));
        assert_eq!(value_cell(Value::U32(7)), ("u32", "7".into()));
    }
}
