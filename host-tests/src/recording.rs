//! Streaming reader for measured recordings (CSV or whitespace-separated text).
//!
//! [`RecordingReader`] reads a file line by line (it never holds the file in memory) and yields
//! one [`Sample`] `{ t_s, u, y, r }` per data row. A [`ColumnMapping`] says which column plays
//! which role, by header name or 0-based index; its CLI syntax is parsed by [`str::parse`]:
//! `u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s` or `u=0,y=2`.
//!
//! Accepted layouts: a comma- (or `;`-) separated file with a header row, a whitespace-separated
//! file with or without header, a UTF-8 byte-order mark at the start of the file (as spreadsheet
//! programs write it; dropped), quoted header names, one trailing empty field per row (as in
//! Silverbox's `0.0057756,0.0093978,`), blank lines at the very end. Only mapped columns are
//! parsed as numbers, but every row must have the header's field count.
//!
//! The sampling period Ts is the median of the first steps of the time column, or the `ts_s`
//! the user gives when no time column is mapped (time is then synthesised as `index × Ts`). With
//! both, they must agree within [`ReaderOptions::ts_relative_tolerance`] and the given `ts_s` is
//! used. Every row is validated; nothing is skipped. Errors ([`RecordingError`]) name the file,
//! the 1-based line and the column, and quote the file's text as a bounded [`Excerpt`]. Errors
//! in the first [`LOOKAHEAD_ROWS`] rows, which are read ahead to find Ts, are still reported by
//! the iterator, in file order. Jitter statistics ([`RecordingSummary`]) are available once the
//! iterator is exhausted, or from [`read_all`].
//!
//! Roles, scales and the output quantum are metadata of the reader ([`RecordingMeta`]); the
//! reader multiplies by the scales but never rounds to the quantum.
//!
//! # EMPS (header, time column, encoder quantum)
//! ```
//! use sledid_host::recording::{ColumnMapping, ReaderOptions, RecordingReader};
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/emps/DATA_EMPS.csv");
//! let mapping: ColumnMapping = "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s".parse()?;
//! let options = ReaderOptions { output_quantum: Some(5e-8), ..ReaderOptions::new(mapping) };
//! let mut reader = RecordingReader::open(path, &options)?;
//! assert!((reader.meta().ts_s - 1e-3).abs() < 1e-7);
//! let first = reader.next().expect("one row")?;
//! assert_eq!((first.t_s, first.u, first.y), (0.0, 2.538628089, 7.45e-06));
//! assert_eq!(first.r, Some(0.00010782208));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # DaISy CD-player arm (header, no time column, Ts undocumented)
//! ```
//! use sledid_host::recording::{ReaderOptions, RecordingReader};
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/daisy/cd_player_arm.csv");
//! // Ts is not documented: ts_s = 1 makes t_s the sample index.
//! let options = ReaderOptions { ts_s: Some(1.0), ..ReaderOptions::new("u=u1_force,y=y1_tracking".parse()?) };
//! let mut reader = RecordingReader::open(path, &options)?;
//! let second = reader.nth(1).expect("two rows")?;
//! assert_eq!((second.t_s, second.u, second.y, second.r), (1.0, 0.0526, 0.0525, None));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Silverbox (quoted header, trailing comma, no time column, fs = 610.35 Hz)
//! ```
//! use sledid_host::recording::{ReaderOptions, RecordingReader};
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/silverbox/SNLS80mV.csv");
//! let options = ReaderOptions { ts_s: Some(1.0 / 610.35), ..ReaderOptions::new("u=V1,y=V2".parse()?) };
//! let reader = RecordingReader::open(path, &options)?;
//! assert_eq!(reader.meta().column_names.as_deref(), Some(&["V1".to_owned(), "V2".to_owned()][..]));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod error;
mod mapping;
mod options;
mod text;
mod timing;

use std::collections::VecDeque;
use std::fs::File;
use std::io::BufReader;
use std::ops::Range;
use std::path::Path;

pub use error::{
    ColumnLocation, EXCERPT_CHARS, Excerpt, LISTED_NAMES, RecordingError, RecordingErrorKind,
};
pub use mapping::{ColumnMapping, ColumnRef, MappingError, ResolvedColumns, Role};
pub use options::{ReaderOptions, RecordingMeta, RoleScales};
pub use text::{Delimiter, HeaderMode};
pub use timing::{RecordingSummary, StepStatistics};

use text::{LineSource, looks_numeric, split_fields};
use timing::{TimingTracker, median_positive_step};

/// Number of data rows read ahead when a reader is opened, to find Ts from the time column.
pub const LOOKAHEAD_ROWS: usize = 33;

/// One data row, scaled into the reader's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, seconds: the (scaled) time column, or `row index × Ts` when there is none.
    pub t_s: f64,
    /// Plant input.
    pub u: f64,
    /// Plant output.
    pub y: f64,
    /// Reference, if a reference column is mapped.
    pub r: Option<f64>,
}

/// A data row's mapped values, scaled, before time validation.
#[derive(Debug, Clone, Copy)]
struct ParsedRow {
    time: Option<f64>,
    input: f64,
    output: f64,
    reference: Option<f64>,
}

/// Splits and parses one data row (`text`, at 1-based `line`) according to `meta`.
fn parse_row(
    meta: &RecordingMeta,
    text: &str,
    line: usize,
    spans: &mut Vec<Range<usize>>,
) -> Result<ParsedRow, RecordingError> {
    split_fields(text, meta.delimiter, spans);
    if spans.len() != meta.column_count {
        let kind = RecordingErrorKind::WrongFieldCount {
            expected: meta.column_count,
            found: spans.len(),
        };
        return Err(meta.error_at(kind, line, Some(spans.len().min(meta.column_count))));
    }
    let field = |index: usize, scale: f64| {
        let field_text = &text[spans[index].clone()];
        let kind = match field_text.parse::<f64>() {
            _ if field_text.is_empty() => RecordingErrorKind::MissingField,
            Ok(value) if (value * scale).is_finite() => return Ok(value * scale),
            Ok(_) => RecordingErrorKind::NonFinite {
                text: field_text.to_owned(),
            },
            Err(_) => RecordingErrorKind::NonNumeric {
                text: field_text.to_owned(),
            },
        };
        Err(meta.error_at(kind, line, Some(index)))
    };
    let (columns, scales) = (&meta.columns, &meta.scales);
    Ok(ParsedRow {
        time: columns
            .time
            .map(|index| field(index, scales.time))
            .transpose()?,
        input: field(columns.input, scales.input)?,
        output: field(columns.output, scales.output)?,
        reference: columns
            .reference
            .map(|index| field(index, scales.reference))
            .transpose()?,
    })
}

/// Streaming reader of one recording: an iterator of `Result<Sample, RecordingError>`.
///
/// The iterator stops after the first error (it is fused). After it returns `None`,
/// [`RecordingReader::summary`] holds the jitter statistics.
#[derive(Debug)]
pub struct RecordingReader {
    meta: RecordingMeta,
    lines: LineSource<BufReader<File>>,
    spans: Vec<Range<usize>>,
    lookahead: VecDeque<Result<(usize, ParsedRow), RecordingError>>,
    timing: TimingTracker,
    summary: Option<RecordingSummary>,
    failed: bool,
}

impl RecordingReader {
    /// Opens `path`, reads the header and the first [`LOOKAHEAD_ROWS`] rows, resolves the
    /// mapping and settles the sampling period.
    ///
    /// # Errors
    /// File-level problems: I/O, empty file, header only, unknown column, invalid option,
    /// missing or mismatching sampling period (or, when a missing period is due to it, the
    /// first row error).
    pub fn open(
        path: impl AsRef<Path>,
        options: &ReaderOptions,
    ) -> Result<RecordingReader, RecordingError> {
        let path = path.as_ref().to_path_buf();
        let in_file = |kind| RecordingError::in_file(&path, kind);
        let at_line = |(line, kind)| RecordingError {
            line: Some(line),
            ..in_file(kind)
        };
        options.validate().map_err(in_file)?;
        let file = File::open(&path).map_err(|error| in_file(RecordingErrorKind::Io(error)))?;
        let mut lines = LineSource::new(BufReader::new(file));
        let first_line = lines
            .next_line()
            .map_err(at_line)?
            .ok_or_else(|| in_file(RecordingErrorKind::EmptyFile))?;

        let delimiter = options
            .delimiter
            .unwrap_or_else(|| Delimiter::detect(lines.text()));
        let mut spans = Vec::new();
        split_fields(lines.text(), delimiter, &mut spans);
        let has_header = match options.header {
            HeaderMode::Auto => !looks_numeric(lines.text(), &spans),
            HeaderMode::Present => true,
            HeaderMode::Absent => false,
        };
        let column_names: Option<Vec<String>> = has_header.then(|| {
            spans
                .iter()
                .map(|span| lines.text()[span.clone()].to_owned())
                .collect()
        });
        let columns = (options.mapping)
            .resolve(column_names.as_deref(), spans.len())
            .map_err(|kind| at_line((first_line, kind)))?;
        let first_data_line = if has_header {
            lines
                .next_line()
                .map_err(at_line)?
                .ok_or_else(|| in_file(RecordingErrorKind::HeaderOnly))?
        } else {
            first_line
        };

        let meta = RecordingMeta {
            path: path.clone(),
            delimiter,
            column_names,
            column_count: spans.len(),
            mapping: options.mapping.clone(),
            columns,
            ts_s: f64::NAN,
            ts_from_time_column_s: None,
            scales: options.scales,
            output_quantum: options.output_quantum,
            row_count: 0,
        };
        let mut reader = RecordingReader {
            meta,
            lines,
            spans,
            lookahead: VecDeque::new(),
            timing: TimingTracker::new(f64::NAN, options.gap_factor),
            summary: None,
            failed: false,
        };
        reader.fill_lookahead(first_data_line);
        reader.meta.ts_s = reader.settle_sampling_period(options)?;
        reader.timing = TimingTracker::new(reader.meta.ts_s, options.gap_factor);
        Ok(reader)
    }

    /// Parses up to [`LOOKAHEAD_ROWS`] rows, the first at `first_line`; stops after an error.
    fn fill_lookahead(&mut self, first_line: usize) {
        let mut next_line = Some(first_line);
        while let Some(line) = next_line {
            let row = parse_row(&self.meta, self.lines.text(), line, &mut self.spans);
            let stop = row.is_err();
            self.lookahead.push_back(row.map(|row| (line, row)));
            if stop || self.lookahead.len() == LOOKAHEAD_ROWS {
                break;
            }
            next_line = self.lines.next_line().unwrap_or_else(|(line, kind)| {
                self.lookahead
                    .push_back(Err(self.meta.error_at(kind, line, None)));
                None
            });
        }
    }

    /// Finds Ts from the read-ahead rows' time column and/or `options.ts_s` (see module doc).
    fn settle_sampling_period(&mut self, options: &ReaderOptions) -> Result<f64, RecordingError> {
        let time_column = self.meta.columns.time;
        let leading_rows = self.lookahead.iter().map_while(|row| row.as_ref().ok());
        let times: Vec<f64> = leading_rows
            .clone()
            .filter_map(|(_, row)| row.time)
            .collect();
        let from_time = median_positive_step(&times);
        self.meta.ts_from_time_column_s = from_time;
        match (from_time, options.ts_s) {
            (Some(found), Some(given))
                if (found - given).abs() > options.ts_relative_tolerance * given =>
            {
                let kind = RecordingErrorKind::SamplingPeriodMismatch {
                    from_time_s: found,
                    given_s: given,
                    relative_tolerance: options.ts_relative_tolerance,
                };
                let column = time_column.map(|index| self.meta.column_location(index));
                Err(RecordingError {
                    column,
                    ..RecordingError::in_file(&self.meta.path, kind)
                })
            }
            (_, Some(given)) => Ok(given),
            (Some(found), None) => Ok(found),
            (None, None) if time_column.is_some() => {
                // No positive step: report the row error that prevented one, if any.
                let mut probe = TimingTracker::new(f64::INFINITY, 2.0);
                for (line, row) in leading_rows {
                    probe
                        .observe(row.time.unwrap_or_default())
                        .map_err(|kind| self.meta.error_at(kind, *line, time_column))?;
                }
                match self.lookahead.pop_back() {
                    Some(Err(error)) => Err(error),
                    _ => Err(RecordingError::in_file(
                        &self.meta.path,
                        RecordingErrorKind::NoSamplingPeriod,
                    )),
                }
            }
            (None, None) => Err(RecordingError::in_file(
                &self.meta.path,
                RecordingErrorKind::NoSamplingPeriod,
            )),
        }
    }

    /// What is known about the recording (row count grows while reading).
    #[must_use]
    pub fn meta(&self) -> &RecordingMeta {
        &self.meta
    }

    /// Timing summary; `Some` only once the iterator has returned `None` without an error.
    #[must_use]
    pub fn summary(&self) -> Option<&RecordingSummary> {
        self.summary.as_ref()
    }

    /// Reads, parses and time-checks the next row; `Ok(None)` at the end of the file.
    fn next_sample(&mut self) -> Result<Option<Sample>, RecordingError> {
        let (line, row) = match self.lookahead.pop_front() {
            Some(entry) => entry?,
            None => {
                let next = self
                    .lines
                    .next_line()
                    .map_err(|(line, kind)| self.meta.error_at(kind, line, None))?;
                match next {
                    Some(line) => (
                        line,
                        parse_row(&self.meta, self.lines.text(), line, &mut self.spans)?,
                    ),
                    None => return Ok(None),
                }
            }
        };
        let t_s = row
            .time
            .unwrap_or(self.meta.row_count as f64 * self.meta.ts_s);
        self.timing
            .observe(t_s)
            .map_err(|kind| self.meta.error_at(kind, line, self.meta.columns.time))?;
        self.meta.row_count += 1;
        Ok(Some(Sample {
            t_s,
            u: row.input,
            y: row.output,
            r: row.reference,
        }))
    }
}

impl Iterator for RecordingReader {
    type Item = Result<Sample, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.summary.is_some() {
            return None;
        }
        match self.next_sample() {
            Ok(Some(sample)) => Some(Ok(sample)),
            Ok(None) => {
                self.summary = Some(self.timing.summary(self.meta.row_count));
                None
            }
            Err(error) => {
                self.failed = true;
                Some(Err(error))
            }
        }
    }
}

/// A whole recording in memory, as returned by [`read_all`].
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Metadata, with the final row count.
    pub meta: RecordingMeta,
    /// Every sample, in file order.
    pub samples: Vec<Sample>,
    /// Timing summary of the whole file.
    pub summary: RecordingSummary,
}

/// Reads the whole recording at `path` into memory.
///
/// # Errors
/// The first error of [`RecordingReader::open`] or of any row.
pub fn read_all(
    path: impl AsRef<Path>,
    options: &ReaderOptions,
) -> Result<Recording, RecordingError> {
    let mut reader = RecordingReader::open(path, options)?;
    let samples = reader.by_ref().collect::<Result<Vec<_>, _>>()?;
    let summary = reader.timing.summary(reader.meta.row_count);
    Ok(Recording {
        meta: reader.meta,
        samples,
        summary,
    })
}
