//! Standard output and standard error of the command line. Every write is checked: a
//! failed write to standard output is an error (the run ends with exit status 1 and one
//! line on stderr), a failed write to standard error is ignored (there is nowhere left to
//! say so). Nothing a user supplies reaches a terminal raw: lines on stderr have their
//! control characters escaped ([`escape`]), text on stdout escapes the names it shows, and
//! JSON escapes what serde_json leaves raw ([`json`]).

use std::borrow::Cow;
use std::io::Write;

/// `s` with every character that could drive a terminal or forge a line escaped as Rust
/// escapes it (`\n`, `\t`, `\u{1b}`): control characters (C0, DEL, C1), as the readers'
/// echo of quoted input does, and the bidirectional-text overrides and isolates
/// (U+202A–U+202E, U+2066–U+2069), which reorder what follows on screen. Nothing is cut:
/// an ordinary name is returned as it is, byte for byte.
pub fn escape(s: &str) -> Cow<'_, str> {
    if !s.chars().any(needs_escape) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if needs_escape(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

fn needs_escape(c: char) -> bool {
    c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// JSON text with the characters serde_json leaves raw inside strings (DEL, C1 controls
/// and the bidirectional overrides; it escapes U+0000–U+001F itself) written as `\uXXXX`
/// escapes: the same JSON value, and nothing that drives a terminal. They can only occur
/// inside strings (JSON's own syntax is ASCII), so the text stays valid JSON.
pub fn json(text: &str) -> Cow<'_, str> {
    let raw = |c: char| c > '\u{1f}' && needs_escape(c);
    if !text.chars().any(raw) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if raw(c) {
            out.push_str(&format!("\\u{:04x}", c as u32));
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// A failed write to standard output: "standard output: CAUSE".
#[derive(Debug, thiserror::Error)]
#[error("standard output: {0}")]
pub struct StdoutError(pub std::io::Error);

impl StdoutError {
    /// The reader went away (`g1tess … | head`): the run ends quietly, as other tools do.
    pub fn is_broken_pipe(&self) -> bool {
        self.0.kind() == std::io::ErrorKind::BrokenPipe
    }
}

/// Writes `text` on standard output and flushes it, so that a failure is seen here and not
/// lost at exit.
pub fn stdout(text: &str) -> Result<(), StdoutError> {
    let mut w = std::io::stdout().lock();
    w.write_all(text.as_bytes())
        .and_then(|()| w.flush())
        .map_err(StdoutError)
}

/// Writes `line` and a newline on standard output ([`stdout`]).
pub fn stdout_line(line: &str) -> Result<(), StdoutError> {
    let mut w = std::io::stdout().lock();
    writeln!(w, "{line}")
        .and_then(|()| w.flush())
        .map_err(StdoutError)
}

/// Writes JSON `text` ([`json`]) and a newline on standard output ([`stdout`]).
pub fn stdout_json(text: &str) -> Result<(), StdoutError> {
    stdout_line(&json(text))
}

/// Writes `line`, its control characters escaped ([`escape`]), and a newline on standard
/// error; a failed write is ignored.
pub fn stderr_line(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{}", escape(line));
}

#[cfg(test)]
mod tests {
    use super::{escape, json};

    #[test]
    fn ordinary_text_is_unchanged() {
        // Names as users give them: spaces, accents, backslashes (Windows paths), quotes.
        for s in [
            "tests/data/bunny.obj",
            "C:\\meshes\\é ü.obj",
            "a 'b' \"c\"",
            "",
        ] {
            assert!(matches!(escape(s), std::borrow::Cow::Borrowed(_)), "{s}");
            assert_eq!(escape(s), s);
        }
        let pretty = "[\n  {\n    \"mesh\": \"sphere320\"\n  }\n]";
        assert_eq!(json(pretty), pretty);
    }

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(escape("bad\nname.obj"), "bad\\nname.obj");
        assert_eq!(escape("\u{1b}[31mred"), "\\u{1b}[31mred");
        assert_eq!(escape("\u{1b}]0;title\u{7}"), "\\u{1b}]0;title\\u{7}");
        assert_eq!(escape("a\u{9b}b\u{7f}"), "a\\u{9b}b\\u{7f}");
        assert_eq!(escape("x\u{202e}y"), "x\\u{202e}y");
    }

    #[test]
    fn json_stays_the_same_value() {
        let value = serde_json::json!({ "name": "a\u{9b}b\u{7f}\u{202e}c\u{1b}\n" });
        let text = serde_json::to_string(&value).unwrap();
        let safe = json(&text);
        assert!(!safe.chars().any(|c| c.is_control()), "{safe}");
        assert!(!safe.contains('\u{202e}'), "{safe}");
        let back: serde_json::Value = serde_json::from_str(&safe).unwrap();
        assert_eq!(back, value);
    }
}
