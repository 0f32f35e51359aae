//! Positions in a scene file (file:line:column) and one-line errors that name the field.
//!
//! Every string of the user's that an error repeats goes through [`quote`] (or [`short`]): control
//! characters are escaped (a `"x\ny"` stays on the error's one line) and long strings are cut, so
//! that a 100,000-character typo does not fill the terminal.

use anyhow::anyhow;
use std::ops::Range;

/// Characters of a user string kept in an error message.
const QUOTE_CHARS: usize = 60;
/// Characters of an error message kept after the position and field.
const MESSAGE_CHARS: usize = 1000;

/// `s` escaped (newlines, tabs and other control characters as `\n`, `\t`, `\u{..}`) and cut to
/// [`QUOTE_CHARS`] characters, with the count of the characters left out.
pub(crate) fn short(s: &str) -> String {
    let total = s.chars().count();
    let mut out = String::new();
    for c in s.chars().take(QUOTE_CHARS) {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    if total > QUOTE_CHARS {
        out.push_str(&format!("… ({total} characters)"));
    }
    out
}

/// A user string as an error quotes it: [`short`] between backticks.
pub(crate) fn quote(s: &str) -> String {
    format!("`{}`", short(s))
}

/// A list of user strings as an error quotes it: the first few, each [`quote`]d.
pub(crate) fn quote_list<S: AsRef<str>>(names: &[S]) -> String {
    const SHOWN: usize = 12;
    let mut parts: Vec<String> = names.iter().take(SHOWN).map(|n| quote(n.as_ref())).collect();
    if names.len() > SHOWN {
        parts.push(format!("… {} in all", names.len()));
    }
    format!("[{}]", parts.join(", "))
}

/// A message on one line, at most [`MESSAGE_CHARS`] characters: the last guard for text that did
/// not go through [`quote`] (messages of the TOML parser and of the file readers).
pub(crate) fn one_line(msg: &str) -> String {
    let mut out = String::new();
    for (n, c) in msg.chars().enumerate() {
        if n == MESSAGE_CHARS {
            out.push('…');
            break;
        }
        match c {
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => out.extend(c.escape_default()),
            c => out.push(c),
        }
    }
    out
}

pub(crate) struct Cx<'a> {
    pub(crate) file: &'a str,
    pub(crate) text: &'a str,
}

impl Cx<'_> {
    pub(crate) fn pos(&self, offset: usize) -> String {
        let before = &self.text[..offset.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
        format!("{}:{line}:{col}", self.file)
    }
    pub(crate) fn err(&self, span: &Range<usize>, field: &str, msg: impl std::fmt::Display) -> anyhow::Error {
        anyhow!("{}: {}: {}", self.pos(span.start), one_line(field), one_line(&msg.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_strings_stay_on_one_short_line() {
        assert_eq!(quote("x\ny"), "`x\\ny`");
        let long = "a".repeat(100_000);
        let q = quote(&long);
        assert!(q.chars().count() < 100, "{q}");
        assert!(q.contains("100000 characters"));
        assert_eq!(one_line("a\nb\tc"), "a b\\tc");
        assert!(one_line(&long).chars().count() <= MESSAGE_CHARS + 1);
    }
}
