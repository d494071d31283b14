//! Reader options (mapping, sampling period, scales, quantum) and the metadata of an open recording.

use std::path::PathBuf;

use super::error::{ColumnLocation, RecordingError, RecordingErrorKind};
use super::mapping::{ColumnMapping, ResolvedColumns};
use super::text::{Delimiter, HeaderMode};

/// Multiplicative scale factor applied to each role's raw value (1 = unchanged).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoleScales {
    /// Factor turning the time column into seconds (e.g. 1e-3 for milliseconds).
    pub time: f64,
    /// Factor applied to the input column.
    pub input: f64,
    /// Factor applied to the output column.
    pub output: f64,
    /// Factor applied to the reference column.
    pub reference: f64,
}

impl Default for RoleScales {
    fn default() -> Self {
        RoleScales {
            time: 1.0,
            input: 1.0,
            output: 1.0,
            reference: 1.0,
        }
    }
}

/// How to read a recording. Build with [`ReaderOptions::new`] and struct-update syntax.
#[derive(Debug, Clone, PartialEq)]
pub struct ReaderOptions {
    /// Which column plays which role.
    pub mapping: ColumnMapping,
    /// Sampling period, seconds; required when no time column is mapped.
    pub ts_s: Option<f64>,
    /// Allowed relative difference between `ts_s` and the time column's period (default 1e-3).
    pub ts_relative_tolerance: f64,
    /// A time step above `gap_factor × Ts` is a gap (default 1.5; must be > 1).
    pub gap_factor: f64,
    /// Per-role scale factors (default all 1).
    pub scales: RoleScales,
    /// Quantum of the output after scaling (e.g. 5e-8 m); kept as metadata, never applied.
    pub output_quantum: Option<f64>,
    /// Field delimiter; `None` detects it from the first line.
    pub delimiter: Option<Delimiter>,
    /// Whether the first line is a header.
    pub header: HeaderMode,
}

impl ReaderOptions {
    /// Options with the given mapping and all defaults.
    #[must_use]
    pub fn new(mapping: ColumnMapping) -> ReaderOptions {
        ReaderOptions {
            mapping,
            ts_s: None,
            ts_relative_tolerance: 1e-3,
            gap_factor: 1.5,
            scales: RoleScales::default(),
            output_quantum: None,
            delimiter: None,
            header: HeaderMode::Auto,
        }
    }

    /// Checks every numeric option for range and finiteness.
    pub(super) fn validate(&self) -> Result<(), RecordingErrorKind> {
        let invalid = |message: String| Err(RecordingErrorKind::InvalidOption { message });
        let RoleScales {
            time,
            input,
            output,
            reference,
        } = self.scales;
        for (role, scale) in [("t", time), ("u", input), ("y", output), ("r", reference)] {
            if !scale.is_finite() || scale == 0.0 {
                return invalid(format!(
                    "scale for {role} is {scale}; it must be finite and non-zero"
                ));
            }
        }
        if let Some(quantum) = self.output_quantum.filter(|q| !(q.is_finite() && *q > 0.0)) {
            return invalid(format!(
                "output quantum {quantum} must be positive and finite"
            ));
        }
        if !(self.gap_factor.is_finite() && self.gap_factor > 1.0) {
            return invalid(format!(
                "gap factor {} must be finite and > 1",
                self.gap_factor
            ));
        }
        let tolerance = self.ts_relative_tolerance;
        if !(tolerance.is_finite() && tolerance >= 0.0) {
            return invalid(format!(
                "ts relative tolerance {tolerance} must be finite and >= 0"
            ));
        }
        match self.ts_s {
            Some(ts_s) if !(ts_s.is_finite() && ts_s > 0.0) => {
                Err(RecordingErrorKind::InvalidSamplingPeriod { ts_s })
            }
            _ => Ok(()),
        }
    }
}

/// What is known about an open recording.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingMeta {
    /// The file being read.
    pub path: PathBuf,
    /// The delimiter in use (given or detected).
    pub delimiter: Delimiter,
    /// Header names (unquoted, trimmed); `None` when the file has no header.
    pub column_names: Option<Vec<String>>,
    /// Number of fields every row has (a trailing empty field not counted).
    pub column_count: usize,
    /// The mapping as given.
    pub mapping: ColumnMapping,
    /// The mapping resolved to column indices.
    pub columns: ResolvedColumns,
    /// The sampling period in force, seconds.
    pub ts_s: f64,
    /// The period found in the time column (median of the first steps), if one is mapped.
    pub ts_from_time_column_s: Option<f64>,
    /// The per-role scale factors applied.
    pub scales: RoleScales,
    /// The output quantum after scaling, if given (not applied by the reader).
    pub output_quantum: Option<f64>,
    /// Data rows yielded so far; the file's total once the reader is exhausted.
    pub row_count: usize,
}

impl RecordingMeta {
    /// Column `index`, named from the header where there is one.
    pub(super) fn column_location(&self, index: usize) -> ColumnLocation {
        let name = self
            .column_names
            .as_ref()
            .and_then(|names| names.get(index).cloned());
        ColumnLocation { index, name }
    }

    /// An error located at `line` and, if given, at column `index`.
    pub(super) fn error_at(
        &self,
        kind: RecordingErrorKind,
        line: usize,
        index: Option<usize>,
    ) -> RecordingError {
        let column = index.map(|index| self.column_location(index));
        RecordingError {
            kind,
            path: self.path.clone(),
            line: Some(line),
            column,
        }
    }
}
