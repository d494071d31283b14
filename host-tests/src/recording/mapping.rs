//! Column mapping: which column of a recording plays which signal role.
//!
//! The CLI syntax is a comma-separated list of `role=column` pairs, e.g.
//! `u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s` or `u=0,y=2`. A column written as a
//! non-negative integer is a 0-based index, anything else is a header name.

use std::fmt;
use std::str::FromStr;

use super::error::RecordingErrorKind;

/// The signal role a column plays in the identification problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    /// `t`: sample time, seconds (after scaling).
    Time,
    /// `u`: plant input (e.g. controller output voltage).
    Input,
    /// `y`: plant output (e.g. measured position).
    Output,
    /// `r`: reference (set-point) of the control loop.
    Reference,
}

impl Role {
    /// All roles, in the order `t, u, y, r`.
    pub const ALL: [Role; 4] = [Role::Time, Role::Input, Role::Output, Role::Reference];

    /// The one-letter key used in the CLI syntax (`t`, `u`, `y`, `r`).
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Role::Time => "t",
            Role::Input => "u",
            Role::Output => "y",
            Role::Reference => "r",
        }
    }

    /// Parses a one-letter role key; `None` for anything else.
    #[must_use]
    pub fn from_key(key: &str) -> Option<Role> {
        Role::ALL.into_iter().find(|role| role.key() == key)
    }
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.key())
    }
}

/// How a column is addressed: by header name or by 0-based index.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum ColumnRef {
    /// Column addressed by its (unquoted, trimmed) header name.
    Name(String),
    /// Column addressed by its 0-based position in the row.
    Index(usize),
}

impl ColumnRef {
    /// Parses `text`: a non-negative integer is an index, anything else a name.
    #[must_use]
    pub fn parse(text: &str) -> ColumnRef {
        match text.parse::<usize>() {
            Ok(index) => ColumnRef::Index(index),
            Err(_) => ColumnRef::Name(text.to_owned()),
        }
    }
}

impl fmt::Display for ColumnRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ColumnRef::Name(name) => f.write_str(name),
            ColumnRef::Index(index) => write!(f, "{index}"),
        }
    }
}

/// Typed column mapping: `u` and `y` are required, `t` and `r` optional.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ColumnMapping {
    /// Column holding the sample time (`t`), if the recording has one.
    pub time: Option<ColumnRef>,
    /// Column holding the plant input (`u`).
    pub input: ColumnRef,
    /// Column holding the plant output (`y`).
    pub output: ColumnRef,
    /// Column holding the reference (`r`), if the recording has one.
    pub reference: Option<ColumnRef>,
}

impl ColumnMapping {
    /// Mapping with only the required input and output columns.
    #[must_use]
    pub fn new(input: ColumnRef, output: ColumnRef) -> ColumnMapping {
        ColumnMapping {
            time: None,
            input,
            output,
            reference: None,
        }
    }

    /// Returns `self` with the time column set.
    #[must_use]
    pub fn with_time(mut self, time: ColumnRef) -> ColumnMapping {
        self.time = Some(time);
        self
    }

    /// Returns `self` with the reference column set.
    #[must_use]
    pub fn with_reference(mut self, reference: ColumnRef) -> ColumnMapping {
        self.reference = Some(reference);
        self
    }

    /// The column mapped to `role`, if any.
    #[must_use]
    pub fn column(&self, role: Role) -> Option<&ColumnRef> {
        match role {
            Role::Time => self.time.as_ref(),
            Role::Input => Some(&self.input),
            Role::Output => Some(&self.output),
            Role::Reference => self.reference.as_ref(),
        }
    }
}

/// A [`ColumnMapping`] resolved against a file: the 0-based column index of each role.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ResolvedColumns {
    /// Index of the time column, if mapped.
    pub time: Option<usize>,
    /// Index of the input column.
    pub input: usize,
    /// Index of the output column.
    pub output: usize,
    /// Index of the reference column, if mapped.
    pub reference: Option<usize>,
}

impl ColumnMapping {
    /// Resolves every role to a column index, given the header `names` (`None` when the file
    /// has no header) and the number of columns per row.
    ///
    /// # Errors
    /// [`RecordingErrorKind::UnknownColumnName`] (listing the header's names),
    /// [`RecordingErrorKind::ColumnNameWithoutHeader`] or
    /// [`RecordingErrorKind::ColumnIndexOutOfRange`].
    pub fn resolve(
        &self,
        names: Option<&[String]>,
        column_count: usize,
    ) -> Result<ResolvedColumns, RecordingErrorKind> {
        let index_of = |column: &ColumnRef| match (column, names) {
            (ColumnRef::Index(index), _) if *index < column_count => Ok(*index),
            (ColumnRef::Index(index), _) => Err(RecordingErrorKind::ColumnIndexOutOfRange {
                index: *index,
                column_count,
            }),
            (ColumnRef::Name(name), Some(names)) => names
                .iter()
                .position(|candidate| candidate == name)
                .ok_or_else(|| RecordingErrorKind::UnknownColumnName {
                    name: name.clone(),
                    available: names.to_vec(),
                }),
            (ColumnRef::Name(name), None) => Err(RecordingErrorKind::ColumnNameWithoutHeader {
                name: name.clone(),
                column_count,
            }),
        };
        Ok(ResolvedColumns {
            time: self.time.as_ref().map(index_of).transpose()?,
            input: index_of(&self.input)?,
            output: index_of(&self.output)?,
            reference: self.reference.as_ref().map(index_of).transpose()?,
        })
    }
}

impl fmt::Display for ColumnMapping {
    /// Formats back into the CLI syntax, e.g. `t=t_s,u=vir_ctrl_V,y=qm_meas_pos_m`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut separator = "";
        for role in Role::ALL {
            if let Some(column) = self.column(role) {
                write!(f, "{separator}{role}={column}")?;
                separator = ",";
            }
        }
        Ok(())
    }
}

/// Why a mapping specification such as `u=0,y=2` could not be parsed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MappingError {
    /// A comma-separated item is not of the form `role=column` (or its column is empty).
    MalformedPair {
        /// The offending item, as written.
        pair: String,
    },
    /// The role key is not one of `t`, `u`, `y`, `r`.
    UnknownRole {
        /// The unknown key, as written.
        role: String,
    },
    /// The same role appears twice.
    DuplicateRole {
        /// The repeated role.
        role: Role,
    },
    /// A required role (`u` or `y`) is absent.
    MissingRole {
        /// The absent role.
        role: Role,
    },
}

impl fmt::Display for MappingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MappingError::MalformedPair { pair } => {
                write!(
                    f,
                    "column mapping item `{pair}` is not of the form role=column"
                )
            }
            MappingError::UnknownRole { role } => {
                write!(
                    f,
                    "unknown role `{role}` in column mapping (expected t, u, y or r)"
                )
            }
            MappingError::DuplicateRole { role } => {
                write!(f, "role `{role}` is mapped more than once")
            }
            MappingError::MissingRole { role } => {
                write!(
                    f,
                    "required role `{role}` is not mapped (u and y are required)"
                )
            }
        }
    }
}

impl std::error::Error for MappingError {}

impl FromStr for ColumnMapping {
    type Err = MappingError;

    /// Parses `u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s` or `u=0,y=2`.
    fn from_str(spec: &str) -> Result<ColumnMapping, MappingError> {
        let mut columns: [Option<ColumnRef>; 4] = Default::default();
        for pair in spec
            .split(',')
            .map(str::trim)
            .filter(|pair| !pair.is_empty())
        {
            let malformed = || MappingError::MalformedPair {
                pair: pair.to_owned(),
            };
            let (key, column) = pair.split_once('=').ok_or_else(malformed)?;
            let (key, column) = (key.trim(), column.trim());
            if column.is_empty() {
                return Err(malformed());
            }
            let role = Role::from_key(key).ok_or_else(|| MappingError::UnknownRole {
                role: key.to_owned(),
            })?;
            // `columns` is indexed in declaration order: t, u, y, r (as `Role::ALL`).
            let slot = &mut columns[role as usize];
            if slot.is_some() {
                return Err(MappingError::DuplicateRole { role });
            }
            *slot = Some(ColumnRef::parse(column));
        }
        let [time, input, output, reference] = columns;
        Ok(ColumnMapping {
            time,
            input: input.ok_or(MappingError::MissingRole { role: Role::Input })?,
            output: output.ok_or(MappingError::MissingRole { role: Role::Output })?,
            reference,
        })
    }
}
