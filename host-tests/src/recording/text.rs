//! Line-level text handling: reading numbered lines, splitting them into fields.

use std::io::BufRead;
use std::ops::Range;

use super::error::RecordingErrorKind;

/// How fields are separated within a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delimiter {
    /// `,` — one trailing empty field per line (Silverbox's `a,b,`) is dropped, not a column.
    Comma,
    /// `;` — same trailing-field rule as [`Delimiter::Comma`].
    Semicolon,
    /// Any run of whitespace (spaces, tabs); leading and trailing whitespace is ignored.
    Whitespace,
}

impl Delimiter {
    /// Guesses the delimiter from a line: `,` if present, else `;` if present, else whitespace.
    #[must_use]
    pub fn detect(line: &str) -> Delimiter {
        if line.contains(',') {
            Delimiter::Comma
        } else if line.contains(';') {
            Delimiter::Semicolon
        } else {
            Delimiter::Whitespace
        }
    }
}

/// Whether the first non-blank line is a header row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HeaderMode {
    /// Header if any non-empty field of the first line is not a number.
    #[default]
    Auto,
    /// The first line is a header.
    Present,
    /// There is no header; columns can only be addressed by index.
    Absent,
}

/// U+FEFF, which spreadsheet programs write at the start of a UTF-8 file ("UTF-8 with BOM").
const BYTE_ORDER_MARK: char = '\u{feff}';

/// Reads physical lines, numbering them from 1, drops a byte-order mark at the start of the file and
/// enforces "blank lines only at the end".
#[derive(Debug)]
pub(crate) struct LineSource<R> {
    reader: R,
    buffer: String,
    line_number: usize,
}

impl<R: BufRead> LineSource<R> {
    /// Wraps a buffered reader positioned at the start of the file.
    pub(crate) fn new(reader: R) -> Self {
        LineSource {
            reader,
            buffer: String::new(),
            line_number: 0,
        }
    }

    /// Advances to the next non-blank line and returns its 1-based number, or `None` at the end.
    ///
    /// A blank line followed by a non-blank one is an error located at the blank line.
    pub(crate) fn next_line(&mut self) -> Result<Option<usize>, (usize, RecordingErrorKind)> {
        let mut first_blank = None;
        loop {
            self.buffer.clear();
            let bytes = self
                .reader
                .read_line(&mut self.buffer)
                .map_err(|error| (self.line_number + 1, RecordingErrorKind::Io(error)))?;
            if bytes == 0 {
                return Ok(None);
            }
            self.line_number += 1;
            if self.line_number == 1 && self.buffer.starts_with(BYTE_ORDER_MARK) {
                self.buffer.drain(..BYTE_ORDER_MARK.len_utf8());
            }
            if !self.text().trim().is_empty() {
                return match first_blank {
                    Some(blank) => Err((blank, RecordingErrorKind::BlankLine)),
                    None => Ok(Some(self.line_number)),
                };
            }
            first_blank.get_or_insert(self.line_number);
        }
    }

    /// The current line without its line terminator.
    pub(crate) fn text(&self) -> &str {
        self.buffer.trim_end_matches(['\n', '\r'])
    }
}

/// Splits `line` into field byte ranges (trimmed, surrounding double quotes removed) into `spans`.
pub(crate) fn split_fields(line: &str, delimiter: Delimiter, spans: &mut Vec<Range<usize>>) {
    spans.clear();
    let base = line.as_ptr() as usize;
    let mut push = |piece: &str| {
        let mut field = piece.trim();
        if field.len() >= 2 && field.starts_with('"') && field.ends_with('"') {
            field = &field[1..field.len() - 1];
        }
        let start = field.as_ptr() as usize - base;
        spans.push(start..start + field.len());
    };
    match delimiter {
        Delimiter::Comma => line.split(',').for_each(&mut push),
        Delimiter::Semicolon => line.split(';').for_each(&mut push),
        Delimiter::Whitespace => line.split_whitespace().for_each(&mut push),
    }
    if delimiter != Delimiter::Whitespace
        && spans.len() > 1
        && spans.last().is_some_and(Range::is_empty)
    {
        spans.pop();
    }
}

/// True if every non-empty field of the line parses as a number (so it is data, not a header).
pub(crate) fn looks_numeric(line: &str, spans: &[Range<usize>]) -> bool {
    spans
        .iter()
        .map(|span| &line[span.clone()])
        .all(|field| field.is_empty() || field.parse::<f64>().is_ok())
}
