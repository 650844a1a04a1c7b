//! Whether a Zenoh key expression (possibly with wildcards) matches a key without any: what a
//! subscriber's key expression, declared by the router, says about a key this client publishes.
//!
//! Zenoh's key expressions (zenoh-keyexpr's documentation, "Key Expressions" in the Zenoh
//! specification): chunks separated by `/`; `*` is exactly one chunk, `**` zero or more chunks,
//! `$*` inside a chunk any run of characters (possibly none) within that chunk. A chunk that
//! starts with `@` is verbatim: only the same chunk matches it, never a wildcard (so `**` does
//! not reach `@ros2_lv/…`). The published key here is concrete (the gateway's topic keys have no
//! wildcards), so "intersects" is "matches": a pattern with a wildcard the key cannot satisfy is
//! no match. Written from the specification's rules, checked by the tests below.

/// Whether `pattern` matches the concrete key `key`.
pub fn matches(pattern: &str, key: &str) -> bool {
    chunks_match(pattern.as_bytes(), key.as_bytes())
}

/// The first chunk and the rest (after its `/`), or `None` at the end.
fn split(s: &[u8]) -> (&[u8], Option<&[u8]>) {
    match s.iter().position(|&c| c == b'/') {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    }
}

fn verbatim(chunk: &[u8]) -> bool {
    chunk.first() == Some(&b'@')
}

/// Pattern chunks against key chunks; `**` tries every number of key chunks it may take (none
/// verbatim). Recursion depth is bounded by the number of `**` chunks in the pattern.
fn chunks_match(pattern: &[u8], key: &[u8]) -> bool {
    let (p, p_rest) = split(pattern);
    if p == b"**" {
        let Some(p_rest) = p_rest else {
            // `**` at the end takes all that is left, if none of it is verbatim.
            return !key.split(|&c| c == b'/').any(verbatim);
        };
        // Take no chunk, then one more at a time.
        let mut k = key;
        loop {
            if chunks_match(p_rest, k) {
                return true;
            }
            let (c, k_rest) = split(k);
            match k_rest {
                Some(rest) if !verbatim(c) => k = rest,
                _ => return false,
            }
        }
    }
    let (k, k_rest) = split(key);
    if !chunk_matches(p, k) {
        return false;
    }
    match (p_rest, k_rest) {
        (None, None) => true,
        (Some(p_rest), Some(k_rest)) => chunks_match(p_rest, k_rest),
        // The key is over: only a trailing `**` may still match (none of it).
        (Some(p_rest), None) => p_rest == b"**",
        (None, Some(_)) => false,
    }
}

/// One pattern chunk against one key chunk.
fn chunk_matches(p: &[u8], k: &[u8]) -> bool {
    if p == k {
        return true;
    }
    if verbatim(p) || verbatim(k) {
        return false;
    }
    p == b"*" || sub_matches(p, k)
}

/// `$*` within a chunk: any run of characters (a glob on bytes).
fn sub_matches(p: &[u8], k: &[u8]) -> bool {
    match p.strip_prefix(b"$*") {
        Some(rest) => (0..=k.len()).any(|i| sub_matches(rest, &k[i..])),
        None => match (p.first(), k.first()) {
            (Some(a), Some(b)) if a == b => sub_matches(&p[1..], &k[1..]),
            (None, None) => true,
            _ => false,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::matches;

    const ODOM: &str = "0/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc9";

    #[test]
    fn a_key_matches_itself_and_no_other() {
        assert!(matches(ODOM, ODOM));
        assert!(!matches("0/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc8", ODOM));
        assert!(!matches("0/odom", ODOM), "a prefix is another key");
        assert!(!matches(ODOM, "0/odom"));
        assert!(!matches("0/odom/x/y/z", ODOM));
    }

    #[test]
    fn a_star_is_one_chunk() {
        assert!(matches("0/*/nav_msgs::msg::dds_::Odometry_/*", ODOM));
        assert!(matches("*/odom/*/*", ODOM));
        assert!(!matches("0/*", ODOM), "one chunk, not three");
        assert!(!matches("0/odom/*/*/*", ODOM));
        assert!(!matches("*", "a/b"));
        assert!(matches("*", "a"));
    }

    #[test]
    fn a_double_star_is_any_number_of_chunks_even_none() {
        for p in ["**", "0/**", "0/odom/**", "**/RIHS01_3cc9", "0/**/RIHS01_3cc9", "**/odom/**"] {
            assert!(matches(p, ODOM), "{p}");
        }
        assert!(matches(&std::format!("{ODOM}/**"), ODOM), "none");
        assert!(matches(&std::format!("**/{ODOM}"), ODOM), "none, in front");
        assert!(matches("0/**/**/RIHS01_3cc9", ODOM));
        assert!(!matches("1/**", ODOM));
        assert!(!matches("**/battery_state/**", ODOM));
        assert!(!matches("0/**/odom", ODOM), "odom is not the last chunk");
    }

    #[test]
    fn a_dollar_star_is_any_run_within_one_chunk() {
        assert!(matches("0/od$*/$*::Odometry_/RIHS01_$*", ODOM));
        assert!(matches("0/$*odom$*/*/*", ODOM), "an empty run on both sides");
        assert!(matches("0/$*/*/*", ODOM));
        assert!(!matches("0/od$*x/*/*", ODOM), "no run ends the chunk in x");
        assert!(!matches("0/$*/*", ODOM), "it stays within its chunk");
    }

    #[test]
    fn verbatim_chunks_take_no_wildcard() {
        let token = "@ros2_lv/0/abc/MP";
        assert!(!matches("**", token));
        assert!(!matches("*/0/**", token));
        assert!(matches("@ros2_lv/**", token));
        assert!(!matches("a/**", "a/@b/c"), "** does not cross @b");
        assert!(!matches("a/**/c", "a/@b/c"));
        assert!(matches("a/@b/**", "a/@b/c"));
        assert!(!matches("a/$*", "a/@b"));
        assert!(!matches("a/@$*", "a/@b"), "a verbatim pattern chunk is itself");
    }

    #[test]
    fn odd_input_is_no_match_and_no_panic() {
        for (p, k) in
            [("", ""), ("", "a"), ("a", ""), ("/", "/"), ("a//b", "a//b"), ("$*", ""), ("$", "$")]
        {
            let _ = matches(p, k);
        }
        assert!(matches("", ""));
        assert!(!matches("a", ""));
    }
}
