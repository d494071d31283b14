//! Tests of the streaming recording reader: mapping syntax, every malformed-input error (kind,
//! line and column), the accepted layouts and the three bundled real recordings.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use sledid_host::recording::{
    ColumnMapping, ColumnRef, Delimiter, EXCERPT_CHARS, Excerpt, HeaderMode, MappingError,
    ReaderOptions, Recording, RecordingError, RecordingErrorKind, RecordingReader, Role,
    RoleScales, read_all,
};

const EMPS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/emps/DATA_EMPS.csv"
);
const DAISY: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/daisy/cd_player_arm.csv"
);
const SILVERBOX: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/silverbox/SNLS80mV.csv"
);
const SILVERBOX_TS_S: f64 = 1.0 / 610.35;

/// Writes `contents` to a fresh file in the system temp dir and returns its path.
fn fixture(name: &str, contents: &str) -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let unique = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("sledid-recording-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create temp dir");
    let path = dir.join(format!("{unique}-{name}"));
    std::fs::write(&path, contents).expect("write fixture");
    path
}

fn mapping(spec: &str) -> ColumnMapping {
    spec.parse().expect("valid mapping")
}

fn options(spec: &str) -> ReaderOptions {
    ReaderOptions::new(mapping(spec))
}

fn options_ts(spec: &str, ts_s: f64) -> ReaderOptions {
    ReaderOptions {
        ts_s: Some(ts_s),
        ..options(spec)
    }
}

/// Reads `contents` to the end and returns the error it must produce.
fn read_error(name: &str, contents: &str, options: &ReaderOptions) -> RecordingError {
    let path = fixture(name, contents);
    match read_all(&path, options) {
        Ok(recording) => panic!(
            "{name}: expected an error, read {} samples",
            recording.samples.len()
        ),
        Err(error) => {
            assert_eq!(error.path, path, "error names the file");
            assert!(
                error.to_string().contains(&path.display().to_string()),
                "{error}"
            );
            error
        }
    }
}

/// Asserts the error is at `line` (1-based) and the display text names `line` and `column`.
fn assert_located(error: &RecordingError, line: usize, column: &str) {
    let message = error.to_string();
    assert_eq!(error.line, Some(line), "{message}");
    assert!(message.contains(&format!(": line {line}, ")), "{message}");
    assert!(
        message.contains(column),
        "expected `{column}` in: {message}"
    );
}

fn read_ok(name: &str, contents: &str, options: &ReaderOptions) -> Recording {
    let path = fixture(name, contents);
    read_all(&path, options).unwrap_or_else(|error| panic!("{name}: {error}"))
}

fn assert_close(actual: f64, expected: f64, tolerance: f64) {
    assert!(
        (actual - expected).abs() <= tolerance,
        "{actual} != {expected} ± {tolerance}"
    );
}

// ---------------------------------------------------------------- mapping syntax

#[test]
fn mapping_parses_names_for_every_role() {
    let parsed = mapping("u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s");
    let expected = ColumnMapping::new(
        ColumnRef::Name("vir_ctrl_V".into()),
        ColumnRef::Name("qm_meas_pos_m".into()),
    )
    .with_time(ColumnRef::Name("t_s".into()))
    .with_reference(ColumnRef::Name("qg_ref_pos_m".into()));
    assert_eq!(parsed, expected);
    assert_eq!(
        parsed.to_string(),
        "t=t_s,u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m"
    );
}

#[test]
fn mapping_parses_indices_and_leaves_optional_roles_empty() {
    let parsed = mapping(" u = 0 , y=2 ");
    assert_eq!(parsed.input, ColumnRef::Index(0));
    assert_eq!(parsed.output, ColumnRef::Index(2));
    assert_eq!(parsed.time, None);
    assert_eq!(parsed.column(Role::Reference), None);
}

#[test]
fn mapping_rejects_unknown_role() {
    let error = "u=0,y=1,x=2".parse::<ColumnMapping>().unwrap_err();
    assert_eq!(error, MappingError::UnknownRole { role: "x".into() });
    assert!(error.to_string().contains("unknown role `x`"), "{error}");
}

#[test]
fn mapping_rejects_duplicate_role() {
    let error = "u=0,y=1,u=2".parse::<ColumnMapping>().unwrap_err();
    assert_eq!(error, MappingError::DuplicateRole { role: Role::Input });
    assert!(
        error.to_string().contains("`u` is mapped more than once"),
        "{error}"
    );
}

#[test]
fn mapping_requires_input_and_output() {
    assert_eq!(
        "y=1,t=0".parse::<ColumnMapping>().unwrap_err(),
        MappingError::MissingRole { role: Role::Input }
    );
    let error = "u=1".parse::<ColumnMapping>().unwrap_err();
    assert_eq!(error, MappingError::MissingRole { role: Role::Output });
    assert!(error.to_string().contains("required role `y`"), "{error}");
    assert_eq!(
        "".parse::<ColumnMapping>().unwrap_err(),
        MappingError::MissingRole { role: Role::Input }
    );
}

#[test]
fn mapping_rejects_malformed_pairs() {
    for spec in ["u0,y=1", "u=,y=1", "u=0,y"] {
        let error = spec.parse::<ColumnMapping>().unwrap_err();
        assert!(
            matches!(error, MappingError::MalformedPair { .. }),
            "{spec}: {error:?}"
        );
    }
}

// ---------------------------------------------------------------- column resolution

#[test]
fn unknown_column_name_lists_available_names() {
    let error = read_error("unknown.csv", "t,u,y\n0,1,2\n", &options("u=u,y=pos"));
    match error.kind() {
        RecordingErrorKind::UnknownColumnName { name, available } => {
            assert_eq!(name, "pos");
            assert_eq!(available, &["t", "u", "y"]);
        }
        other => panic!("wrong kind {other:?}"),
    }
    assert!(
        error.to_string().contains("available: `t`, `u`, `y`"),
        "{error}"
    );
}

#[test]
fn column_name_without_header_is_an_error() {
    let error = read_error(
        "noheader.csv",
        "0,1,2\n1,2,3\n",
        &options_ts("u=u,y=2", 1.0),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::ColumnNameWithoutHeader { name, column_count: 3 } if name == "u"),
        "{error:?}"
    );
}

#[test]
fn column_index_out_of_range_is_an_error() {
    let error = read_error("range.csv", "a,b\n1,2\n", &options_ts("u=0,y=2", 1.0));
    assert!(
        matches!(
            error.kind(),
            RecordingErrorKind::ColumnIndexOutOfRange {
                index: 2,
                column_count: 2
            }
        ),
        "{error:?}"
    );
}

// ---------------------------------------------------------------- malformed rows

#[test]
fn non_numeric_field_names_line_and_column() {
    let error = read_error(
        "nonnum.csv",
        "t,u,y,r\n0,1,2,3\n0.1,1,abc,3\n",
        &options("t=t,u=u,y=y,r=r"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonNumeric { text } if text == "abc"),
        "{error:?}"
    );
    assert_located(&error, 3, "column 2 `y`");
}

#[test]
fn nan_field_is_non_finite() {
    let error = read_error(
        "nan.csv",
        "t,u,y\n0,1,2\n0.1,NaN,2\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonFinite { text } if text == "NaN"),
        "{error:?}"
    );
    assert_located(&error, 3, "column 1 `u`");
}

#[test]
fn infinite_field_is_non_finite() {
    let error = read_error(
        "inf.csv",
        "t,u,y\n0,1,2\n0.1,1,2\n0.2,1,-inf\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonFinite { text } if text == "-inf"),
        "{error:?}"
    );
    assert_located(&error, 4, "column 2 `y`");
}

#[test]
fn overflow_after_scaling_is_non_finite() {
    let opts = ReaderOptions {
        scales: RoleScales {
            output: 1e300,
            ..RoleScales::default()
        },
        ..options("t=t,u=u,y=y")
    };
    let error = read_error("scaled-inf.csv", "t,u,y\n0,1,1e10\n", &opts);
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonFinite { .. }),
        "{error:?}"
    );
    assert_located(&error, 2, "column 2 `y`");
}

#[test]
fn empty_field_is_missing() {
    let error = read_error(
        "emptyfield.csv",
        "t,u,y,r\n0,1,2,3\n0.1,,2,3\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::MissingField),
        "{error:?}"
    );
    assert_located(&error, 3, "column 1 `u`");
}

#[test]
fn short_row_is_wrong_field_count_at_first_missing_column() {
    let error = read_error(
        "short.csv",
        "t,u,y,r\n0,1,2,3\n0.1,1,2\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(
            error.kind(),
            RecordingErrorKind::WrongFieldCount {
                expected: 4,
                found: 3
            }
        ),
        "{error:?}"
    );
    assert_located(&error, 3, "column 3 `r`");
}

#[test]
fn long_row_is_wrong_field_count_at_first_extra_column() {
    let error = read_error(
        "long.csv",
        "t,u,y\n0,1,2\n0.1,1,2\n0.2,1,2,9\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(
            error.kind(),
            RecordingErrorKind::WrongFieldCount {
                expected: 3,
                found: 4
            }
        ),
        "{error:?}"
    );
    assert_located(&error, 4, "column 3");
}

#[test]
fn trailing_comma_does_not_hide_a_missing_last_value() {
    // `1,` in a two-column file: the empty last field is the trailing comma, so one field is missing.
    let error = read_error(
        "trailing-missing.csv",
        "\"a\",\"b\",\n1,2,\n1,\n",
        &options_ts("u=a,y=b", 1.0),
    );
    assert!(
        matches!(
            error.kind(),
            RecordingErrorKind::WrongFieldCount {
                expected: 2,
                found: 1
            }
        ),
        "{error:?}"
    );
    assert_located(&error, 3, "column 1 `b`");
}

#[test]
fn time_equal_to_previous_is_not_increasing() {
    let error = read_error(
        "equal.csv",
        "t,u,y\n0,1,2\n0.1,1,2\n0.1,1,2\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::TimeNotIncreasing { previous_s, current_s } if *previous_s == 0.1 && *current_s == 0.1),
        "{error:?}"
    );
    assert_located(&error, 4, "column 0 `t`");
}

#[test]
fn time_going_back_is_not_increasing() {
    let error = read_error(
        "back.csv",
        "u,t,y\n1,0,2\n1,0.1,2\n1,0.2,2\n1,0.15,2\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::TimeNotIncreasing { .. }),
        "{error:?}"
    );
    assert_located(&error, 5, "column 1 `t`");
}

#[test]
fn non_increasing_time_from_the_start_is_reported_at_its_row() {
    // No positive step at all, so Ts cannot be found; the row error explains why.
    let error = read_error(
        "flat.csv",
        "t,u,y\n5,1,2\n5,1,2\n4,1,2\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::TimeNotIncreasing { .. }),
        "{error:?}"
    );
    assert_located(&error, 3, "column 0 `t`");
}

#[test]
fn time_gap_names_line_and_column() {
    let error = read_error(
        "gap.csv",
        "t,u,y\n0,1,2\n0.01,1,2\n0.02,1,2\n0.04,1,2\n",
        &options("t=t,u=u,y=y"),
    );
    match error.kind() {
        RecordingErrorKind::TimeGap {
            step_s,
            ts_s,
            gap_factor,
        } => {
            assert_close(*step_s, 0.02, 1e-12);
            assert_close(*ts_s, 0.01, 1e-12);
            assert_eq!(*gap_factor, 1.5);
        }
        other => panic!("wrong kind {other:?}"),
    }
    assert_located(&error, 5, "column 0 `t`");
}

#[test]
fn gap_factor_is_configurable() {
    let contents = "t,u,y\n0,1,2\n0.01,1,2\n0.02,1,2\n0.038,1,2\n";
    let strict = read_error("gap-strict.csv", contents, &options("t=t,u=u,y=y"));
    assert!(
        matches!(strict.kind(), RecordingErrorKind::TimeGap { .. }),
        "{strict:?}"
    );
    let relaxed = ReaderOptions {
        gap_factor: 2.0,
        ..options("t=t,u=u,y=y")
    };
    assert_eq!(
        read_ok("gap-relaxed.csv", contents, &relaxed).samples.len(),
        4
    );
}

#[test]
fn error_far_beyond_the_lookahead_is_found_while_streaming() {
    let mut contents = String::from("t,u,y\n");
    for k in 0..200 {
        let y = if k == 150 {
            "oops".to_owned()
        } else {
            format!("{k}")
        };
        contents.push_str(&format!("{},{},{y}\n", k as f64 * 0.001, k));
    }
    let path = fixture("late.csv", &contents);
    let mut reader = RecordingReader::open(&path, &options("t=t,u=u,y=y")).expect("opens");
    let good: Vec<_> = reader
        .by_ref()
        .take(150)
        .collect::<Result<_, _>>()
        .expect("first 150 rows are fine");
    assert_eq!(good[149].y, 149.0);
    let error = reader.next().expect("an item").unwrap_err();
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonNumeric { .. }),
        "{error:?}"
    );
    assert_located(&error, 152, "column 2 `y`");
    assert!(
        reader.next().is_none(),
        "the iterator is fused after an error"
    );
    assert!(reader.summary().is_none(), "no summary after an error");
}

#[test]
fn error_inside_the_lookahead_comes_after_the_good_rows() {
    let path = fixture("early.csv", "t,u,y\n0,1,2\n0.1,1,2\n0.2,x,2\n");
    let mut reader = RecordingReader::open(&path, &options("t=t,u=u,y=y")).expect("opens");
    assert_eq!(reader.next().expect("row").expect("ok").t_s, 0.0);
    assert_eq!(reader.next().expect("row").expect("ok").t_s, 0.1);
    let error = reader.next().expect("row").unwrap_err();
    assert_located(&error, 4, "column 1 `u`");
    assert_eq!(reader.meta().row_count, 2);
}

#[test]
fn empty_file_is_an_error() {
    for (name, contents) in [("empty.csv", ""), ("blank.csv", "\n  \n\t\n")] {
        let error = read_error(name, contents, &options_ts("u=0,y=1", 1.0));
        assert!(
            matches!(error.kind(), RecordingErrorKind::EmptyFile),
            "{error:?}"
        );
        assert!(error.to_string().contains("empty file"), "{error}");
    }
}

#[test]
fn header_only_is_an_error() {
    let error = read_error("headeronly.csv", "t,u,y\n\n", &options("t=t,u=u,y=y"));
    assert!(
        matches!(error.kind(), RecordingErrorKind::HeaderOnly),
        "{error:?}"
    );
    assert!(error.to_string().contains("no data rows"), "{error}");
}

#[test]
fn blank_line_inside_data_is_an_error_but_trailing_blanks_are_not() {
    let error = read_error(
        "blankmid.csv",
        "t,u,y\n0,1,2\n\n0.1,1,2\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::BlankLine),
        "{error:?}"
    );
    assert_eq!(error.line, Some(3));
    assert!(
        error.to_string().contains(": line 3: blank line"),
        "{error}"
    );
    let trailing = read_ok(
        "blankend.csv",
        "t,u,y\n0,1,2\n0.1,1,2\n\n\n",
        &options("t=t,u=u,y=y"),
    );
    assert_eq!(trailing.samples.len(), 2);
}

// ---------------------------------------------------------------- sampling period and options

#[test]
fn missing_sampling_period_is_an_error() {
    let error = read_error("nots.csv", "u,y\n1,2\n3,4\n", &options("u=u,y=y"));
    assert!(
        matches!(error.kind(), RecordingErrorKind::NoSamplingPeriod),
        "{error:?}"
    );
    let single = read_error("single.csv", "t,u,y\n0,1,2\n", &options("t=t,u=u,y=y"));
    assert!(
        matches!(single.kind(), RecordingErrorKind::NoSamplingPeriod),
        "{single:?}"
    );
}

#[test]
fn single_row_with_given_period_has_no_step_statistics() {
    let recording = read_ok(
        "single-ts.csv",
        "t,u,y\n0.5,1,2\n",
        &options_ts("t=t,u=u,y=y", 0.01),
    );
    assert_eq!(recording.samples.len(), 1);
    assert_eq!(recording.samples[0].t_s, 0.5);
    assert_eq!(recording.summary.steps, None);
}

#[test]
fn given_period_must_agree_with_time_column() {
    let contents = "t,u,y\n0,1,2\n0.01,1,2\n0.02,1,2\n";
    let error = read_error("mismatch.csv", contents, &options_ts("t=t,u=u,y=y", 0.02));
    match error.kind() {
        RecordingErrorKind::SamplingPeriodMismatch {
            from_time_s,
            given_s,
            relative_tolerance,
        } => {
            assert_close(*from_time_s, 0.01, 1e-12);
            assert_eq!(*given_s, 0.02);
            assert_eq!(*relative_tolerance, 1e-3);
        }
        other => panic!("wrong kind {other:?}"),
    }
    assert!(error.to_string().contains("column 0 `t`"), "{error}");
    let agreeing = read_ok(
        "agree.csv",
        contents,
        &options_ts("t=t,u=u,y=y", 0.010_000_1),
    );
    assert_eq!(agreeing.meta.ts_s, 0.010_000_1, "the given period is used");
    assert_close(
        agreeing.meta.ts_from_time_column_s.expect("found"),
        0.01,
        1e-12,
    );
}

#[test]
fn invalid_options_are_rejected() {
    let contents = "t,u,y\n0,1,2\n0.01,1,2\n";
    let bad_ts = read_error("badts.csv", contents, &options_ts("u=u,y=y", -1.0));
    assert!(
        matches!(bad_ts.kind(), RecordingErrorKind::InvalidSamplingPeriod { ts_s } if *ts_s == -1.0)
    );
    let cases = [
        ReaderOptions {
            gap_factor: 1.0,
            ..options("t=t,u=u,y=y")
        },
        ReaderOptions {
            output_quantum: Some(0.0),
            ..options("t=t,u=u,y=y")
        },
        ReaderOptions {
            scales: RoleScales {
                input: f64::NAN,
                ..RoleScales::default()
            },
            ..options("t=t,u=u,y=y")
        },
        ReaderOptions {
            ts_relative_tolerance: -0.1,
            ..options("t=t,u=u,y=y")
        },
    ];
    for opts in &cases {
        let error = read_error("badopt.csv", contents, opts);
        assert!(
            matches!(error.kind(), RecordingErrorKind::InvalidOption { .. }),
            "{error:?}"
        );
    }
}

#[test]
fn missing_file_is_an_io_error() {
    let path = std::env::temp_dir().join("sledid-recording-tests-does-not-exist.csv");
    let error = read_all(&path, &options_ts("u=0,y=1", 1.0)).unwrap_err();
    assert!(
        matches!(error.kind(), RecordingErrorKind::Io(_)),
        "{error:?}"
    );
    assert!(std::error::Error::source(&error).is_some());
}

// ---------------------------------------------------------------- accepted layouts

#[test]
fn scales_are_applied_and_quantum_is_only_metadata() {
    let opts = ReaderOptions {
        scales: RoleScales {
            time: 1e-3,
            input: 2.0,
            output: 1e-6,
            reference: -1.0,
        },
        output_quantum: Some(5e-8),
        ..options("t=t_ms,u=u,y=y_um,r=r")
    };
    let recording = read_ok(
        "scaled.csv",
        "t_ms,u,y_um,r\n0,1,0.123,4\n1,2,0.2,5\n2,3,0.3,6\n",
        &opts,
    );
    let first = recording.samples[0];
    assert_eq!((first.t_s, first.u, first.r), (0.0, 2.0, Some(-4.0)));
    assert_close(first.y, 0.123e-6, 1e-20);
    assert!(
        (first.y / 5e-8 - (first.y / 5e-8).round()).abs() > 0.1,
        "the reader does not round to the quantum"
    );
    assert_eq!(recording.meta.output_quantum, Some(5e-8));
    assert_close(recording.meta.ts_s, 1e-3, 1e-15);
    assert_close(recording.samples[2].t_s, 2e-3, 1e-15);
}

#[test]
fn jitter_statistics_are_computed_while_streaming() {
    let contents = "t,u,y\n0,1,2\n0.01,1,2\n0.021,1,2\n0.030,1,2\n0.040,1,2\n";
    let path = fixture("jitter.csv", contents);
    let mut reader = RecordingReader::open(&path, &options("t=t,u=u,y=y")).expect("opens");
    assert!(reader.summary().is_none(), "no summary before the end");
    assert_eq!(reader.by_ref().count(), 5);
    let summary = *reader.summary().expect("summary after the end");
    assert_eq!(summary.rows, 5);
    assert_close(summary.ts_s, 0.01, 1e-12);
    let steps = summary.steps.expect("steps");
    assert_eq!(steps.count, 4);
    assert_close(steps.min_step_s, 0.009, 1e-12);
    assert_close(steps.max_step_s, 0.011, 1e-12);
    assert_close(steps.mean_step_s, 0.01, 1e-12);
    assert_close(steps.max_abs_jitter_s, 0.001, 1e-12);
    assert_eq!(reader.meta().row_count, 5);
}

#[test]
fn whitespace_separated_file_with_header() {
    let contents = "  time\tinput   output\n0.0\t1.5   -2\n0.5  2.5\t-3  \n1.0 3.5 -4\n";
    let recording = read_ok(
        "ws-header.txt",
        contents,
        &options("t=time,u=input,y=output"),
    );
    assert_eq!(recording.meta.delimiter, Delimiter::Whitespace);
    assert_eq!(
        recording.meta.column_names.as_deref(),
        Some(&["time".to_owned(), "input".into(), "output".into()][..])
    );
    assert_eq!(recording.samples.len(), 3);
    assert_eq!(recording.samples[1].u, 2.5);
    assert_eq!(recording.samples[2].y, -4.0);
    assert_close(recording.summary.ts_s, 0.5, 1e-12);
}

#[test]
fn whitespace_separated_file_without_header_by_index() {
    let contents = "1.0 10 100 7\n2.0 20 200 8\n3.0 30 300 9\n";
    let recording = read_ok(
        "ws-noheader.txt",
        contents,
        &options_ts("u=1,y=2,r=3", 0.25),
    );
    assert_eq!(recording.meta.column_names, None);
    assert_eq!(recording.meta.column_count, 4);
    let last = recording.samples[2];
    assert_eq!(
        (last.t_s, last.u, last.y, last.r),
        (0.5, 30.0, 300.0, Some(9.0))
    );
    let steps = recording.summary.steps.expect("steps");
    assert_eq!(steps.max_abs_jitter_s, 0.0);
}

#[test]
fn headerless_comma_file_by_index_with_time_column() {
    let recording = read_ok(
        "csv-noheader.csv",
        "0,5,6\n0.002,7,8\n0.004,9,10\n",
        &options("t=0,u=2,y=1"),
    );
    assert_eq!(recording.samples.len(), 3);
    assert_eq!((recording.samples[0].u, recording.samples[0].y), (6.0, 5.0));
    assert_close(recording.meta.ts_s, 0.002, 1e-12);
    let error = read_error(
        "csv-noheader-bad.csv",
        "0,5,6\n0.002,7,x\n",
        &options("t=0,u=2,y=1"),
    );
    assert_located(&error, 2, "column 2");
    assert!(
        !error.to_string().contains("column 2 `"),
        "no header, so no column name: {error}"
    );
}

#[test]
fn forced_header_mode_and_semicolons_and_crlf() {
    // A numeric-looking header is only a header when told so.
    let contents = "10;20\r\n0.1;0.2\r\n0.3;0.4\r\n";
    let forced = ReaderOptions {
        header: HeaderMode::Present,
        ..options_ts("u=0,y=1", 1.0)
    };
    let recording = read_ok("semi.csv", contents, &forced);
    assert_eq!(recording.meta.delimiter, Delimiter::Semicolon);
    assert_eq!(recording.samples.len(), 2);
    assert_eq!((recording.samples[1].u, recording.samples[1].y), (0.3, 0.4));
    assert_eq!(
        recording.meta.column_names.as_deref(),
        Some(&["10".to_owned(), "20".to_owned()][..])
    );
    let auto = read_ok("semi-auto.csv", contents, &options_ts("u=0,y=1", 1.0));
    assert_eq!(auto.samples.len(), 3);
}

#[test]
fn unmapped_columns_are_not_parsed() {
    let recording = read_ok(
        "labels.csv",
        "u,label,y\n1,start,2\n3,end,4\n",
        &options_ts("u=u,y=y", 1.0),
    );
    assert_eq!(recording.samples.len(), 2);
}

#[test]
fn quoted_header_with_trailing_commas() {
    let contents = "\"V1\",\"V2\",\n0.1,0.2,\n0.3,0.4,\n\n";
    let recording = read_ok(
        "silverbox-like.csv",
        contents,
        &options_ts("u=V1,y=V2", 0.5),
    );
    assert_eq!(recording.meta.column_count, 2);
    assert_eq!(recording.samples.len(), 2);
    assert_eq!(
        recording.samples[1],
        sledid_host::recording::Sample {
            t_s: 0.5,
            u: 0.3,
            y: 0.4,
            r: None
        }
    );
}

// ---------------------------------------------------------------- byte-order mark

/// A CSV saved "UTF-8 with BOM" (spreadsheet programs): the header's first name is `t`, not
/// `\u{feff}t`. Catches a reader that keeps the BOM in the first field (issue 12: "unknown column
/// name `t`; available: `\u{feff}t`").
#[test]
fn byte_order_mark_before_a_csv_header_is_dropped() {
    let recording = read_ok(
        "bom.csv",
        "\u{feff}t;u;y\r\n0;1;2\r\n0.5;3;4\r\n",
        &options("t=t,u=u,y=y"),
    );
    assert_eq!(
        recording.meta.column_names.as_deref(),
        Some(&["t".to_owned(), "u".into(), "y".into()][..])
    );
    assert_eq!(recording.samples.len(), 2);
    assert_eq!(
        (recording.samples[1].t_s, recording.samples[1].u),
        (0.5, 3.0)
    );
}

/// A headerless whitespace file with a BOM: the BOM is not whitespace, so a reader that kept it
/// would glue it to the first number (then take the first row for a header, or refuse it).
#[test]
fn byte_order_mark_before_headerless_whitespace_data_is_dropped() {
    let recording = read_ok(
        "bom.txt",
        "\u{feff}0.0 1 2\n0.5 3 4\n",
        &options("t=0,u=1,y=2"),
    );
    assert_eq!(recording.meta.column_names, None);
    assert_eq!(recording.samples.len(), 2);
    assert_eq!(
        (recording.samples[0].t_s, recording.samples[0].u),
        (0.0, 1.0)
    );
}

/// Only the file's first character may be a BOM: one inside the data is a non-numeric field, not
/// something to strip silently (catches a reader that deletes U+FEFF everywhere).
#[test]
fn byte_order_mark_inside_the_data_is_an_error() {
    let error = read_error(
        "bom-inside.csv",
        "t,u,y\n0,1,2\n0.5,\u{feff}3,4\n",
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonNumeric { text } if text == "\u{feff}3"),
        "{error:?}"
    );
    assert_located(&error, 3, "column 1 `u`");
}

// ---------------------------------------------------------------- long text in messages

/// A 5,000-digit field (it parses, to infinity): the error keeps the whole text but its message
/// quotes the first 40 characters and the length, and still names file, line and column. Catches
/// a message that quotes the field whole (issue 12).
#[test]
fn a_long_field_is_quoted_as_a_bounded_excerpt() {
    let digits = "9".repeat(5_000);
    let error = read_error(
        "long-field.csv",
        &format!("t,u,y\n0,1,2\n0.5,{digits},4\n"),
        &options("t=t,u=u,y=y"),
    );
    assert!(
        matches!(error.kind(), RecordingErrorKind::NonFinite { text } if *text == digits),
        "the error keeps the whole field"
    );
    assert_located(&error, 3, "column 1 `u`");
    let message = error.to_string();
    let path_len = error.path.display().to_string().len();
    println!("{message}");
    assert!(
        message.contains(&format!(
            "`{}…` (5000 characters)",
            &digits[..EXCERPT_CHARS]
        )),
        "{message}"
    );
    assert!(message.len() < path_len + 200, "{} bytes", message.len());
}

/// The excerpt counts characters and cuts between them: a field of 3,000 two-byte characters
/// (catches slicing inside a UTF-8 sequence, which panics); exactly 40 characters are quoted whole,
/// 41 are cut (catches an off-by-one at the limit).
#[test]
fn excerpts_cut_between_characters_at_the_limit() {
    let accents = "é".repeat(3_000);
    let error = read_error(
        "long-utf8.csv",
        &format!("u,y\n{accents},1\n"),
        &options_ts("u=u,y=y", 1.0),
    );
    let message = error.to_string();
    assert!(
        message.contains(&format!(
            "`{}…` (3000 characters)",
            "é".repeat(EXCERPT_CHARS)
        )),
        "{message}"
    );
    assert_located(&error, 2, "column 0 `u`");
    for (n, cut) in [(EXCERPT_CHARS, false), (EXCERPT_CHARS + 1, true)] {
        let text = "x".repeat(n);
        let quoted = Excerpt(&text).to_string();
        assert_eq!(quoted.contains('…'), cut, "{n} characters: {quoted}");
        assert!(quoted.starts_with(&format!("`{}", "x".repeat(EXCERPT_CHARS))));
    }
}

/// A header of 100 columns whose first name has 5,000 characters: an unknown-column message lists
/// the first 20 names, each as an excerpt, and counts the rest; a data error in that column quotes
/// its name as an excerpt too. Catches a message that grows with the header.
#[test]
fn long_header_names_and_many_columns_are_quoted_bounded() {
    let long_name = "n".repeat(5_000);
    let names: Vec<String> = std::iter::once(long_name.clone())
        .chain((1..100).map(|i| format!("c{i}")))
        .collect();
    let header = names.join(",");
    let row = vec!["1"; 100].join(",");
    let error = read_error(
        "wide.csv",
        &format!("{header}\n{row}\n"),
        &options_ts("u=c1,y=pos", 1.0),
    );
    let message = error.to_string();
    println!("{message}");
    assert!(
        matches!(error.kind(), RecordingErrorKind::UnknownColumnName { available, .. } if available.len() == 100)
    );
    assert!(
        message.contains("(5000 characters), `c1`, `c2`"),
        "{message}"
    );
    assert!(message.contains(", `c19` and 80 more"), "{message}");
    assert!(!message.contains("`c20`"), "{message}");
    assert!(message.len() < error.path.display().to_string().len() + 400);

    let bad_row = format!("x{}", vec![",1"; 99].concat());
    let error = read_error(
        "wide-bad.csv",
        &format!("{header}\n{bad_row}\n"),
        &ReaderOptions {
            ts_s: Some(1.0),
            ..ReaderOptions::new(ColumnMapping::new(
                ColumnRef::Name(long_name),
                ColumnRef::Name("c1".into()),
            ))
        },
    );
    let message = error.to_string();
    assert_located(
        &error,
        2,
        &format!(
            "column 0 `{}…` (5000 characters)",
            "n".repeat(EXCERPT_CHARS)
        ),
    );
    assert!(
        message.len() < error.path.display().to_string().len() + 200,
        "{message}"
    );
}

// ---------------------------------------------------------------- real recordings

#[test]
fn emps_end_to_end() {
    let opts = ReaderOptions {
        output_quantum: Some(5e-8),
        ..options("u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s")
    };
    let recording = read_all(EMPS, &opts).expect("EMPS reads");
    assert_eq!(recording.samples.len(), 24_841);
    assert_eq!(recording.meta.row_count, 24_841);
    assert_eq!(recording.summary.rows, 24_841);
    assert_eq!(recording.meta.columns.time, Some(0));
    assert_eq!(recording.meta.columns.input, 3);
    assert_close(recording.meta.ts_s, 1e-3, 1e-7);
    let first = recording.samples[0];
    assert_eq!(
        first,
        sledid_host::recording::Sample {
            t_s: 0.0,
            u: 2.538628089,
            y: 7.45e-06,
            r: Some(0.00010782208)
        }
    );
    let last = recording.samples[24_840];
    assert_eq!(
        last,
        sledid_host::recording::Sample {
            t_s: 24.84,
            u: -0.9527324302,
            y: 0.00361505,
            r: Some(0.003327322)
        }
    );
    let steps = recording.summary.steps.expect("steps");
    assert_close(steps.mean_step_s, 1e-3, 1e-9);
    assert!(
        steps.min_step_s > 0.99e-3 && steps.max_step_s < 1.01e-3,
        "{steps:?}"
    );
    assert!(steps.max_abs_jitter_s < 1e-7, "{steps:?}");
    // Every position lies on the encoder grid; the reader did not have to round.
    let quantum = recording.meta.output_quantum.expect("quantum");
    assert!(
        recording
            .samples
            .iter()
            .all(|s| ((s.y / quantum) - (s.y / quantum).round()).abs() < 1e-6)
    );
    // Giving Ts = 1 ms agrees with the time column; 1.1 ms does not.
    let given = read_all(
        EMPS,
        &ReaderOptions {
            ts_s: Some(1e-3),
            ..opts.clone()
        },
    )
    .expect("agrees");
    assert_eq!(given.summary.ts_s, 1e-3);
    let wrong = RecordingReader::open(
        EMPS,
        &ReaderOptions {
            ts_s: Some(1.1e-3),
            ..opts
        },
    )
    .unwrap_err();
    assert!(
        matches!(
            wrong.kind(),
            RecordingErrorKind::SamplingPeriodMismatch { .. }
        ),
        "{wrong:?}"
    );
}

#[test]
fn daisy_end_to_end_by_name_and_by_index() {
    let recording =
        read_all(DAISY, &options_ts("u=u1_force,y=y1_tracking", 1.0)).expect("DaISy reads");
    assert_eq!(recording.samples.len(), 2_048);
    let (first, last) = (recording.samples[0], recording.samples[2_047]);
    assert_eq!(
        (first.t_s, first.u, first.y, first.r),
        (0.0, 0.0531, 0.0495, None)
    );
    assert_eq!((last.t_s, last.u, last.y), (2047.0, 0.1441, -0.2375));
    let by_index = read_all(DAISY, &options_ts("u=1,y=3", 1.0)).expect("DaISy by index");
    assert_eq!(by_index.meta.column_count, 4);
    assert_eq!(
        (by_index.samples[0].u, by_index.samples[0].y),
        (-0.0313, 0.0342)
    );
    assert_eq!(
        (by_index.samples[2_047].u, by_index.samples[2_047].y),
        (-0.4938, 0.1892)
    );
}

#[test]
fn silverbox_end_to_end() {
    let recording =
        read_all(SILVERBOX, &options_ts("u=V1,y=V2", SILVERBOX_TS_S)).expect("Silverbox reads");
    assert_eq!(recording.samples.len(), 131_072);
    assert_eq!(recording.meta.delimiter, Delimiter::Comma);
    assert_eq!(
        recording.meta.column_names.as_deref(),
        Some(&["V1".to_owned(), "V2".to_owned()][..])
    );
    assert_eq!(recording.meta.ts_from_time_column_s, None);
    let (first, last) = (recording.samples[0], recording.samples[131_071]);
    assert_eq!((first.t_s, first.u, first.y), (0.0, 0.0057756, 0.0093978));
    assert_eq!((last.u, last.y), (0.0096732, -0.0072247));
    assert_close(last.t_s, 131_071.0 / 610.35, 1e-9);
    let steps = recording.summary.steps.expect("steps");
    assert_close(steps.mean_step_s, SILVERBOX_TS_S, 1e-12);
    assert!(steps.max_abs_jitter_s < 1e-9, "{steps:?}");
}
