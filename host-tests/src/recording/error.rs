//! Typed errors of the recording reader, each located by file, 1-based line and column.
//!
//! Text taken from the file (a field, a header name) keeps its whole value in the error, but is
//! quoted in messages as a bounded excerpt ([`Excerpt`]): a 5,000-digit field or a 10,000-column
//! header does not flood the terminal, and the message still names file, line and column.

use std::fmt;
use std::path::PathBuf;

/// Characters of a file's text quoted whole in a message; longer text is cut to this many.
pub const EXCERPT_CHARS: usize = 40;

/// Header names listed in an [`RecordingErrorKind::UnknownColumnName`] message before the rest are
/// counted.
pub const LISTED_NAMES: usize = 20;

/// Text from the file as a message quotes it: whole up to [`EXCERPT_CHARS`] characters, else its
/// first [`EXCERPT_CHARS`] characters, `…` and the full length, e.g. ``123456…` (5000 characters)`.
///
/// Displays inside backticks. Cuts at a character boundary, never inside a UTF-8 sequence.
#[derive(Debug, Clone, Copy)]
pub struct Excerpt<'a>(pub &'a str);

impl fmt::Display for Excerpt<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.char_indices().nth(EXCERPT_CHARS) {
            None => write!(f, "`{}`", self.0),
            Some((cut, _)) => write!(
                f,
                "`{}…` ({} characters)",
                &self.0[..cut],
                self.0.chars().count()
            ),
        }
    }
}

/// A column of the recording, named where the file has a header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ColumnLocation {
    /// 0-based position of the column in the row.
    pub index: usize,
    /// Header name of the column; `None` for headerless files or columns beyond the header.
    pub name: Option<String>,
}

impl fmt::Display for ColumnLocation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.name {
            Some(name) => write!(f, "column {} {}", self.index, Excerpt(name)),
            None => write!(f, "column {}", self.index),
        }
    }
}

/// What went wrong while opening or reading a recording.
#[derive(Debug)]
pub enum RecordingErrorKind {
    /// The file could not be opened or read.
    Io(std::io::Error),
    /// The file has no non-blank line at all.
    EmptyFile,
    /// The file has a header row but no data row.
    HeaderOnly,
    /// A blank line is followed by more data (blank lines are only allowed at the end).
    BlankLine,
    /// A mapped field does not parse as a number.
    NonNumeric {
        /// The field text as found in the file.
        text: String,
    },
    /// A mapped field is NaN or infinite (after scaling).
    NonFinite {
        /// The field text as found in the file.
        text: String,
    },
    /// A mapped field is present but empty.
    MissingField,
    /// A row has a different number of fields than the header (or the first row).
    WrongFieldCount {
        /// Number of fields every row must have.
        expected: usize,
        /// Number of fields this row has (a trailing empty field is not counted).
        found: usize,
    },
    /// The time column does not strictly increase.
    TimeNotIncreasing {
        /// Time of the previous row, seconds.
        previous_s: f64,
        /// Time of this row, seconds.
        current_s: f64,
    },
    /// The time step to this row exceeds `gap_factor × Ts`.
    TimeGap {
        /// The step found, seconds.
        step_s: f64,
        /// The sampling period in force, seconds.
        ts_s: f64,
        /// The factor the step was compared against.
        gap_factor: f64,
    },
    /// A mapped column name is not in the header.
    UnknownColumnName {
        /// The name asked for.
        name: String,
        /// The names the header does have.
        available: Vec<String>,
    },
    /// A column is addressed by name but the file has no header row.
    ColumnNameWithoutHeader {
        /// The name asked for.
        name: String,
        /// Number of columns in the file (valid indices are `0..column_count`).
        column_count: usize,
    },
    /// A mapped column index is beyond the last column.
    ColumnIndexOutOfRange {
        /// The index asked for.
        index: usize,
        /// Number of columns in the file.
        column_count: usize,
    },
    /// No time column is mapped and no `ts_s` was given (or the time column has a single row).
    NoSamplingPeriod,
    /// The sampling period (given or found) is not a positive finite number.
    InvalidSamplingPeriod {
        /// The offending value, seconds.
        ts_s: f64,
    },
    /// The `ts_s` given disagrees with the period found in the time column.
    SamplingPeriodMismatch {
        /// Period found in the time column (median of the first steps), seconds.
        from_time_s: f64,
        /// Period given by the user, seconds.
        given_s: f64,
        /// Relative tolerance that was exceeded.
        relative_tolerance: f64,
    },
    /// A reader option is out of range (scale, quantum, gap factor, tolerance).
    InvalidOption {
        /// Which option and why.
        message: String,
    },
}

impl fmt::Display for RecordingErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use RecordingErrorKind as K;
        match self {
            K::Io(error) => write!(f, "I/O error: {error}"),
            K::EmptyFile => f.write_str("empty file (no header, no data)"),
            K::HeaderOnly => f.write_str("header row but no data rows"),
            K::BlankLine => {
                f.write_str("blank line inside the data (only trailing blank lines are allowed)")
            }
            K::NonNumeric { text } => write!(f, "non-numeric field {}", Excerpt(text)),
            K::NonFinite { text } => {
                write!(f, "non-finite value {} (NaN or infinite)", Excerpt(text))
            }
            K::MissingField => f.write_str("missing (empty) field"),
            K::WrongFieldCount { expected, found } => {
                write!(
                    f,
                    "wrong field count: expected {expected} fields, found {found}"
                )
            }
            K::TimeNotIncreasing {
                previous_s,
                current_s,
            } => write!(
                f,
                "time not strictly increasing: {current_s} s follows {previous_s} s"
            ),
            K::TimeGap {
                step_s,
                ts_s,
                gap_factor,
            } => write!(
                f,
                "time gap: step {step_s} s exceeds {gap_factor} × Ts = {} s (Ts = {ts_s} s)",
                gap_factor * ts_s
            ),
            K::UnknownColumnName { name, available } => {
                write!(f, "unknown column name {}; available: ", Excerpt(name))?;
                for (i, n) in available.iter().take(LISTED_NAMES).enumerate() {
                    let separator = if i == 0 { "" } else { ", " };
                    write!(f, "{separator}{}", Excerpt(n))?;
                }
                match available.len().saturating_sub(LISTED_NAMES) {
                    0 => Ok(()),
                    more => write!(f, " and {more} more"),
                }
            }
            K::ColumnNameWithoutHeader { name, column_count } => write!(
                f,
                "column {} addressed by name but the file has no header; use a 0-based index 0..{column_count}",
                Excerpt(name)
            ),
            K::ColumnIndexOutOfRange {
                index,
                column_count,
            } => write!(
                f,
                "column index {index} out of range: the file has {column_count} columns (0..{column_count})"
            ),
            K::NoSamplingPeriod => f.write_str(
                "no sampling period: map a time column with at least two rows or give ts_s",
            ),
            K::InvalidSamplingPeriod { ts_s } => {
                write!(
                    f,
                    "sampling period {ts_s} s is not a positive finite number"
                )
            }
            K::SamplingPeriodMismatch {
                from_time_s,
                given_s,
                relative_tolerance,
            } => write!(
                f,
                "ts_s = {given_s} s disagrees with the time column's period {from_time_s} s \
                 (relative tolerance {relative_tolerance})"
            ),
            K::InvalidOption { message } => write!(f, "invalid reader option: {message}"),
        }
    }
}

impl std::error::Error for RecordingErrorKind {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            RecordingErrorKind::Io(error) => Some(error),
            _ => None,
        }
    }
}

/// An error of the recording reader: the kind, the file and, where applicable, line and column.
///
/// Displays as `PATH: line L, column I `name`: message`.
#[derive(Debug)]
pub struct RecordingError {
    /// What went wrong.
    pub kind: RecordingErrorKind,
    /// The recording file.
    pub path: PathBuf,
    /// 1-based physical line number in the file, where applicable.
    pub line: Option<usize>,
    /// The column concerned, where applicable.
    pub column: Option<ColumnLocation>,
}

impl RecordingError {
    /// An error about the whole file (no line, no column).
    pub fn in_file(path: impl Into<PathBuf>, kind: RecordingErrorKind) -> RecordingError {
        RecordingError {
            kind,
            path: path.into(),
            line: None,
            column: None,
        }
    }

    /// The kind of error, for matching.
    #[must_use]
    pub fn kind(&self) -> &RecordingErrorKind {
        &self.kind
    }
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, ": line {line}")?;
        }
        if let Some(column) = &self.column {
            write!(f, ", {column}")?;
        }
        write!(f, ": {}", self.kind)
    }
}

impl std::error::Error for RecordingError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            RecordingErrorKind::Io(error) => Some(error),
            _ => None,
        }
    }
}
