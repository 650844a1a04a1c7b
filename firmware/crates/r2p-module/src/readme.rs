//! What the module READMEs' generated sections share (host builds only): each application
//! renders its topics, parameters and LEDs from its code between two marker lines, and a test
//! checks the committed README against it — or rewrites it when `R2P_BLESS` is set.

use std::format;
use std::string::String;

use core::fmt::Write;

use r2p_management::message::Value;
use r2p_middleware::Class;
use r2p_node::Param;

use crate::ParamDoc;

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

/// A README's generated section: its first and last lines (the markers) and the command that
/// rewrites it.
#[derive(Clone, Copy, Debug)]
pub struct Section {
    /// The first line: names the generator and the command.
    pub begin: &'static str,
    /// The last line.
    pub end: &'static str,
    /// The command that rewrites the section (e.g. `cargo test -p r2p-app-psu readme`), with
    /// `R2P_BLESS=1` set.
    pub bless: &'static str,
}

impl Section {
    /// The section: the first line, a blank line, what `body` writes, a blank line, the last.
    pub fn render(&self, body: impl FnOnce(&mut String)) -> String {
        let mut w = String::new();
        line(&mut w, self.begin);
        line(&mut w, "");
        body(&mut w);
        line(&mut w, "");
        line(&mut w, self.end);
        w
    }

    /// `text` with this section replaced by `section`; `None` without both markers.
    pub fn splice(&self, text: &str, section: &str) -> Option<String> {
        splice(text, self.begin, self.end, section)
    }

    /// [`check_section`] of the README at `path` against `section`.
    pub fn check(&self, path: &str, section: &str) {
        check_section(path, self.begin, self.end, section, self.bless);
    }
}

/// The heading and header of a topics table whose rows [`topic_row`] writes; `title` is e.g.
/// "Topics (instance 0)".
pub fn topics_header(w: &mut String, title: &str) {
    let _ = write!(w, "### {title}\n\n| topic | type | | class | what |\n|---|---|---|---|---|\n");
}

/// A row of the topics table: the topic's name, its type, what the module does with it
/// ("publishes", "subscribes"), its class (see [`class_cell`]) and what it carries.
pub fn topic_row(w: &mut String, name: &str, ty: &str, dir: &str, class: &str, what: &str) {
    let _ = writeln!(w, "| `{name}` | `{ty}` | {dir} | {class} | {what} |");
}

/// The parameters section: one row per parameter of `defaults` with its documentation from
/// `docs` (same order): index, name, type, default, range (`false, true` for a flag), unit,
/// meaning and whether it takes effect at boot only.
pub fn params_table(w: &mut String, defaults: &[Param], docs: &[ParamDoc]) {
    assert_eq!(defaults.len(), docs.len(), "DOCS must document every parameter of DEFAULTS");
    line(w, "### Parameters");
    line(w, "");
    line(w, "| # | name | type | default | range | unit | meaning |");
    line(w, "|---|---|---|---|---|---|---|");
    for (i, (p, d)) in defaults.iter().zip(docs).enumerate() {
        let (ty, def) = value_cell(p.value);
        let range = if ty == "bool" {
            String::from("false, true")
        } else {
            format!("{} … {}", value_cell(p.min).1, value_cell(p.max).1)
        };
        let boot = if d.at_boot { " (at boot)" } else { "" };
        let _ = writeln!(
            w,
            "| {i} | `{}` | {ty} | {def} | {range} | {} | {}{boot} |",
            p.name, d.unit, d.doc
        );
    }
}

/// The LEDs section: its heading and header, the status LED's row (the same on every module)
/// and then `rows`, the module's own (`| bus | … |`, `| fault | … |`).
pub fn leds_table(w: &mut String, rows: &[&str]) {
    line(w, "### LEDs");
    line(w, "");
    line(w, "| LED | pattern | meaning |");
    line(w, "|---|---|---|");
    line(w, "| status | slow blink (1 Hz) / fast blink (5 Hz) | running / booting |");
    for row in rows {
        line(w, row);
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

    #[test]
    fn the_parameters_table_has_a_row_per_parameter_with_its_documentation() {
        use crate::param_doc::{boot, doc};
        let defaults = [Param::u32("instance", 0, 0, 3), Param::bool("power", true)];
        let docs = [boot("", "module name"), doc("", "switch")];
        let mut w = String::new();
        params_table(&mut w, &defaults, &docs);
        assert!(w.starts_with("### Parameters\n\n| # | name | type |"), "{w}");
        assert!(
            w.contains("| 0 | `instance` | u32 | 0 | 0 … 3 |  | module name (at boot) |\n"),
            "{w}"
        );
        assert!(w.contains("| 1 | `power` | bool | true | false, true |  | switch |\n"), "{w}");
    }

    #[test]
    #[should_panic(expected = "DOCS must document every parameter")]
    fn an_undocumented_parameter_is_refused() {
        params_table(&mut String::new(), &[Param::bool("power", true)], &[]);
    }

    #[test]
    fn the_topics_and_leds_tables_share_their_headers_and_the_status_row() {
        let mut w = String::new();
        topics_header(&mut w, "Topics");
        topic_row(&mut w, "a/b", "Ty", "publishes", "NRT", "what");
        assert_eq!(
            w,
            "### Topics\n\n| topic | type | | class | what |\n|---|---|---|---|---|\n\
             | `a/b` | `Ty` | publishes | NRT | what |\n"
        );
        let mut w = String::new();
        leds_table(&mut w, &["| fault | on | x |"]);
        assert!(w.ends_with("| status | slow blink (1 Hz) / fast blink (5 Hz) | running / booting |\n| fault | on | x |\n"));
    }

    #[test]
    fn a_section_is_framed_by_its_markers_and_replaces_only_itself() {
        let section = Section { begin: "<!-- B x -->", end: "<!-- E -->", bless: "cmd" };
        let s = section.render(|w| line(w, "body"));
        assert_eq!(s, "<!-- B x -->\n\nbody\n\n<!-- E -->\n");
        let text = "top\n<!-- B x -->\nold\n<!-- E -->\nbottom\n";
        assert_eq!(section.splice(text, &s).unwrap(), std::format!("top\n{s}bottom\n"));
        assert_eq!(section.splice("top\n", &s), None);
    }
}
