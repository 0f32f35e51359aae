//! Positions in a scene file (file:line:column) and one-line errors that name the field.

use anyhow::anyhow;
use std::ops::Range;

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
        anyhow!("{}: {field}: {msg}", self.pos(span.start))
    }
}
