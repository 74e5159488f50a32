//! Shared helpers of the line-oriented text readers: reading a file with its path in
//! every error, and typed access to whitespace-separated fields by name.

use crate::error::{limits, Error, Result};
use std::path::{Path, PathBuf};

/// Reads a whole text file, naming it in the error; bytes that are not UTF-8 (a
/// binary or compressed file given as a log) are an [`Error::NotText`] naming the
/// line and byte offset of the first one.
pub(crate) fn read_text(path: &Path) -> Result<String> {
    let text = pgm_core::fsutil::read_utf8(path).map_err(|e| Error::io(path, e))?;
    text.map_err(|e| Error::NotText {
        path: path.to_path_buf(),
        line: e.line,
        offset: e.offset,
        byte: e.byte,
    })
}

/// The fields of one line, with the file and line number for error messages.
pub(crate) struct Fields<'a> {
    pub path: &'a Path,
    pub line: usize,
    pub tokens: Vec<&'a str>,
}

impl<'a> Fields<'a> {
    pub fn new(path: &'a Path, line: usize, text: &'a str) -> Self {
        Self {
            path,
            line,
            tokens: text.split_whitespace().collect(),
        }
    }

    fn path_buf(&self) -> PathBuf {
        self.path.to_path_buf()
    }

    /// The raw token at `index`, or a [`Error::MissingField`] naming `field`.
    pub fn raw(&self, index: usize, field: &str, expected: usize) -> Result<&'a str> {
        self.tokens
            .get(index)
            .copied()
            .ok_or_else(|| Error::MissingField {
                path: self.path_buf(),
                line: self.line,
                field: field.to_string(),
                found: self.tokens.len(),
                expected: expected.max(index + 1),
            })
    }

    pub fn error(&self, field: &str, value: &str, problem: impl Into<String>) -> Error {
        Error::Field {
            path: self.path_buf(),
            line: self.line,
            field: field.to_string(),
            value: value.to_string(),
            problem: problem.into(),
        }
    }

    /// A finite number.
    pub fn finite(&self, index: usize, field: &str, expected: usize) -> Result<f64> {
        let raw = self.raw(index, field, expected)?;
        let v: f64 = raw
            .parse()
            .map_err(|_| self.error(field, raw, "not a number"))?;
        if !v.is_finite() {
            return Err(self.error(field, raw, "not a finite number"));
        }
        Ok(v)
    }

    /// A finite number of magnitude at most `limit`; `what` names the quantity in the
    /// error (for example "a position (m)").
    pub fn bounded(
        &self,
        index: usize,
        field: &str,
        expected: usize,
        limit: f64,
        what: &str,
    ) -> Result<f64> {
        let v = self.finite(index, field, expected)?;
        if v.abs() > limit {
            let raw = self.tokens[index];
            return Err(self.error(
                field,
                raw,
                format!("{what} of magnitude above {limit:e} means nothing here"),
            ));
        }
        Ok(v)
    }

    /// A position coordinate (m), within [`limits::MAX_POSITION`].
    pub fn position(&self, index: usize, field: &str, expected: usize) -> Result<f64> {
        self.bounded(
            index,
            field,
            expected,
            limits::MAX_POSITION,
            "a position (m)",
        )
    }

    /// A heading (rad), within [`limits::MAX_HEADING`].
    pub fn heading(&self, index: usize, field: &str, expected: usize) -> Result<f64> {
        self.bounded(
            index,
            field,
            expected,
            limits::MAX_HEADING,
            "a heading (rad)",
        )
    }

    /// A time stamp (s), within [`limits::MAX_TIMESTAMP`].
    pub fn timestamp(&self, index: usize, field: &str, expected: usize) -> Result<f64> {
        self.bounded(
            index,
            field,
            expected,
            limits::MAX_TIMESTAMP,
            "a time stamp (s)",
        )
    }

    /// A count of entries that follow on the line after index `index` (a number of
    /// beams, remissions, …), followed by `after` more fields: a count larger than
    /// the rest of the line is an error here, so no size larger than the line itself
    /// is ever trusted, added to or allocated (a count that is only a few fields off
    /// is left to [`Fields::expect_len`], which names the first missing field).
    pub fn count_on_line(
        &self,
        index: usize,
        field: &str,
        expected: usize,
        after: usize,
    ) -> Result<usize> {
        let n = self.count(index, field, expected)?;
        let room = self.tokens.len().saturating_sub(index + 1);
        if n > room {
            return Err(self.error(
                field,
                self.tokens[index],
                format!(
                    "declares {n} entries, but only {room} fields follow on the line (and \
                     {after} more must follow the entries)"
                ),
            ));
        }
        Ok(n)
    }

    /// The field parsed as a `T`; one that does not parse is an error saying
    /// `problem`.
    pub fn parsed<T: std::str::FromStr>(
        &self,
        index: usize,
        field: &str,
        expected: usize,
        problem: &str,
    ) -> Result<T> {
        let raw = self.raw(index, field, expected)?;
        raw.parse().map_err(|_| self.error(field, raw, problem))
    }

    /// Any number that parses, `nan` and `inf` included.
    pub fn number(&self, index: usize, field: &str, expected: usize) -> Result<f64> {
        self.parsed(index, field, expected, "not a number")
    }

    /// An angle (rad), finite and within two full turns.
    pub fn angle(&self, index: usize, field: &str, expected: usize) -> Result<f64> {
        self.bounded(
            index,
            field,
            expected,
            2.0 * limits::MAX_SPAN,
            "an angle (rad)",
        )
    }

    /// The ranges at `indices` (named `range[k]`, `k` from 0) and their validity per
    /// [`crate::beams::stored_beam`] within `[range_min, range_max]`: REP 117's special
    /// values are beams without a return; a finite negative range or one above
    /// [`limits::MAX_RANGE`] is an error (`no_return` says how to write none).
    pub fn ranges(
        &self,
        indices: std::ops::Range<usize>,
        expected: usize,
        [range_min, range_max]: [f64; 2],
        no_return: &str,
    ) -> Result<(Vec<f64>, Vec<bool>)> {
        let mut ranges = Vec::with_capacity(indices.len());
        let mut valid = Vec::with_capacity(indices.len());
        for (k, index) in indices.enumerate() {
            let name = format!("range[{k}]");
            let r = self.number(index, &name, expected)?;
            if r < 0.0 && !crate::beams::is_special_range(r) {
                return Err(self.error(&name, self.tokens[index], "negative range"));
            }
            if r.is_finite() && r > limits::MAX_RANGE {
                return Err(self.error(
                    &name,
                    self.tokens[index],
                    format!(
                        "a range above {:e} m means nothing here ({no_return})",
                        limits::MAX_RANGE
                    ),
                ));
            }
            let (range, ok) = crate::beams::stored_beam(r, range_min, range_max);
            ranges.push(range);
            valid.push(ok);
        }
        Ok((ranges, valid))
    }

    /// A non-negative integer.
    pub fn count(&self, index: usize, field: &str, expected: usize) -> Result<usize> {
        self.parsed(index, field, expected, "not a non-negative integer")
    }

    /// Fails unless the line has exactly `expected` fields; `name_of` names the field
    /// at an index (for the first missing field).
    pub fn expect_len(
        &self,
        expected: usize,
        context: &str,
        name_of: impl Fn(usize) -> String,
    ) -> Result<()> {
        if self.tokens.len() > expected {
            return Err(Error::ExtraFields {
                path: self.path_buf(),
                line: self.line,
                found: self.tokens.len(),
                expected,
                context: context.to_string(),
            });
        }
        if self.tokens.len() < expected {
            return Err(Error::MissingField {
                path: self.path_buf(),
                line: self.line,
                field: name_of(self.tokens.len()),
                found: self.tokens.len(),
                expected,
            });
        }
        Ok(())
    }
}
