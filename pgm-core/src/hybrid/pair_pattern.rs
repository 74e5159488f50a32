//! Sparsity patterns of pairwise tables, "one default value plus listed exceptions":
//! [`PairPattern`].

use crate::error::Result;
use crate::param::InvalidParameter;
use std::ops::Range;

/// The listed entries of a pairwise table between a position with
/// [`rows`](PairPattern::rows) states and the next with
/// [`columns`](PairPattern::columns) states, with row and column indices for the
/// max-messages. Build it once and share it (`Arc<PairPattern>`) between the edges
/// that have the same pattern.
///
/// Many chain models have pairwise tables that are constant except on a few entries:
/// the association chain of CRF-Matching over the full state space (every point may
/// match any of the `M` reference points or be an outlier) has one weight
/// (`sequence.far`) for every pair of reference points that are not close in beam order, and its own
/// features only on a band `|b − a − 1| ≤ band` and on the outlier row and column,
/// about `(2·band + 3)·M` of the `(M + 1)²` entries. A pattern lists those entries
/// once; [`FlatChain::with_patterns`](super::FlatChain::with_patterns) then
/// stores such a table as its listed values plus one default value and computes each
/// max-message in `O(s_i + s_{i+1} + nnz + d log d)` instead of `O(s_i · s_{i+1})`,
/// `d` the longest column (row) that is not full, plus one (see
/// [`FlatChain`](super::FlatChain)).
///
/// The listed entries are numbered in row-major order: *pattern position* `p` is the
/// `p`-th listed entry `(a, b)` when the entries are sorted by row, then column. A
/// table over a pattern with `nnz` ([`PairPattern::len`]) listed entries has `nnz + 1`
/// values: the listed entries in pattern order, then the default
/// ([`PairPattern::default_entry`] `== nnz`), which every unlisted entry takes.
///
/// Building costs O(rows + columns + nnz) time and memory (plus the
/// O(rows · columns) calls of [`PairPattern::from_fn`]).
///
/// ```
/// use pgm_core::hybrid::PairPattern;
///
/// // A 3 × 4 table listing the diagonal and the last column.
/// let pattern = PairPattern::from_fn(3, 4, |a, b| a == b || b == 3);
/// assert_eq!(pattern.len(), 6);
/// let entries: Vec<_> = pattern.entries().collect();
/// assert_eq!(entries, [(0, 0), (0, 3), (1, 1), (1, 3), (2, 2), (2, 3)]);
/// assert_eq!(pattern.position(1, 3), Some(3));
/// assert_eq!(pattern.position(1, 2), None);
/// assert_eq!(pattern.default_entry(), 6);
/// // Row 1 holds pattern positions 2 and 3, in columns 1 and 3.
/// assert_eq!(pattern.row_positions(1), 2..4);
/// assert_eq!(pattern.row_columns(1), &[1, 3]);
/// // Column 3 lists rows 0, 1, 2 at positions 1, 3, 5.
/// assert_eq!(pattern.column_rows(3), &[0, 1, 2]);
/// assert_eq!(pattern.column_positions(3), &[1, 3, 5]);
///
/// // A table over the pattern: the listed values in pattern order, then the default.
/// let table = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, -1.0];
/// let mut dense = [0.0; 12];
/// pattern.expand(&table, 1, &mut dense);
/// assert_eq!(dense, [1.0, -1.0, -1.0, 2.0, -1.0, 3.0, -1.0, 4.0, -1.0, -1.0, 5.0, 6.0]);
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PairPattern {
    rows: usize,
    columns: usize,
    /// Pattern positions of row `a`: `row_start[a]..row_start[a + 1]` (`rows + 1`
    /// entries).
    row_start: Vec<usize>,
    /// The column of each listed entry, in pattern order.
    column: Vec<usize>,
    /// Column `b`'s entries are `column_start[b]..column_start[b + 1]` of
    /// `column_rows` and `column_positions` (`columns + 1` entries).
    column_start: Vec<usize>,
    /// The rows of the listed entries, column by column, ascending within a column.
    column_rows: Vec<usize>,
    /// The pattern positions of the listed entries, column by column.
    column_positions: Vec<usize>,
    /// The longest column that is not full, plus one (0 when every column is full):
    /// how deep a forward message may have to look into the states sorted by score
    /// to find one its column does not list.
    column_depth: usize,
    /// The same for rows (backward messages).
    row_depth: usize,
    /// Row `a`'s listed entries as runs of consecutive columns: runs
    /// `run_start[a]..run_start[a + 1]` of `runs` (`rows + 1` entries).
    run_start: Vec<usize>,
    /// (first column, first pattern position, length) of each run, row by row.
    runs: Vec<(usize, usize, usize)>,
}

impl PairPattern {
    /// The pattern of a `rows × columns` table listing `entries`, which must be in
    /// strictly increasing row-major order (row, then column; no repeats), so that
    /// `entries[p]` is pattern position `p`. O(rows + columns + nnz).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`](crate::Error::InvalidParameter) naming the first
    /// entry that is out of range or out of order.
    pub fn new(rows: usize, columns: usize, entries: &[(usize, usize)]) -> Result<Self> {
        for (p, &(a, b)) in entries.iter().enumerate() {
            if a >= rows || b >= columns {
                return Err(InvalidParameter::new(
                    "pair pattern",
                    format!("entry {p} is ({a}, {b}) in a {rows} x {columns} table"),
                    "entries inside the table",
                )
                .into());
            }
            if p > 0 && entries[p - 1] >= (a, b) {
                return Err(InvalidParameter::new(
                    "pair pattern",
                    format!("entry {p} is ({a}, {b}) after {:?}", entries[p - 1]),
                    "entries in strictly increasing row-major order (row, then column)",
                )
                .into());
            }
        }
        Ok(Self::from_sorted(rows, columns, entries))
    }

    /// The pattern of a `rows × columns` table listing every `(a, b)` with
    /// `listed(a, b)`, visited in row-major order. O(rows · columns) calls: meant to
    /// be built once and shared.
    pub fn from_fn(
        rows: usize,
        columns: usize,
        mut listed: impl FnMut(usize, usize) -> bool,
    ) -> Self {
        let mut entries = Vec::new();
        for a in 0..rows {
            for b in 0..columns {
                if listed(a, b) {
                    entries.push((a, b));
                }
            }
        }
        Self::from_sorted(rows, columns, &entries)
    }

    /// Builds the indices from entries already checked to be sorted and in range.
    fn from_sorted(rows: usize, columns: usize, entries: &[(usize, usize)]) -> Self {
        let nnz = entries.len();
        let mut row_start = vec![0; rows + 1];
        let mut column_start = vec![0; columns + 1];
        for &(a, b) in entries {
            row_start[a + 1] += 1;
            column_start[b + 1] += 1;
        }
        for a in 0..rows {
            row_start[a + 1] += row_start[a];
        }
        for b in 0..columns {
            column_start[b + 1] += column_start[b];
        }
        let mut fill = column_start.clone();
        let mut column_rows = vec![0; nnz];
        let mut column_positions = vec![0; nnz];
        // Row-major order visits each column's rows in increasing order.
        for (p, &(a, b)) in entries.iter().enumerate() {
            column_rows[fill[b]] = a;
            column_positions[fill[b]] = p;
            fill[b] += 1;
        }
        let depth = |start: &[usize], full: usize| {
            start
                .windows(2)
                .map(|w| w[1] - w[0])
                .filter(|&k| k < full)
                .map(|k| k + 1)
                .max()
                .unwrap_or(0)
        };
        // Consecutive columns of one row are consecutive pattern positions.
        let mut run_start = Vec::with_capacity(rows + 1);
        let mut runs: Vec<(usize, usize, usize)> = Vec::new();
        for a in 0..rows {
            let first_run = runs.len();
            run_start.push(first_run);
            let row = row_start[a]..row_start[a + 1];
            for (p, &(_, b)) in row.clone().zip(&entries[row]) {
                match runs[first_run..].last_mut() {
                    Some((first, _, length)) if *first + *length == b => *length += 1,
                    _ => runs.push((b, p, 1)),
                }
            }
        }
        run_start.push(runs.len());
        Self {
            rows,
            columns,
            run_start,
            runs,
            column_depth: depth(&column_start, rows),
            row_depth: depth(&row_start, columns),
            row_start,
            column: entries.iter().map(|&(_, b)| b).collect(),
            column_start,
            column_rows,
            column_positions,
        }
    }

    /// One more than the number of entries of the longest column that is not full
    /// (0 when every column is full): a state with none of its column's entries listed
    /// is among this many states of largest score.
    pub(crate) fn column_depth(&self) -> usize {
        self.column_depth
    }

    /// [`PairPattern::column_depth`] for rows.
    pub(crate) fn row_depth(&self) -> usize {
        self.row_depth
    }

    /// Row `a`'s listed entries as runs of consecutive columns: (first column, first
    /// pattern position, length), in column order (a banded pattern has one or two
    /// runs per row, which the messages process as contiguous slices).
    pub(crate) fn row_runs(&self, a: usize) -> &[(usize, usize, usize)] {
        &self.runs[self.run_start[a]..self.run_start[a + 1]]
    }

    /// Number of states of the first position (rows of the table).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of states of the second position (columns of the table).
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// Number of listed entries (`nnz`).
    pub fn len(&self) -> usize {
        self.column.len()
    }

    /// True when no entry is listed (every entry takes the default).
    pub fn is_empty(&self) -> bool {
        self.column.is_empty()
    }

    /// The index of the default value in a table over the pattern: [`PairPattern::len`].
    pub fn default_entry(&self) -> usize {
        self.len()
    }

    /// Number of values of a table over the pattern: [`PairPattern::len`] `+ 1`.
    pub fn table_len(&self) -> usize {
        self.len() + 1
    }

    /// The listed entries `(a, b)` in pattern order (row-major).
    pub fn entries(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.rows).flat_map(move |a| self.row_columns(a).iter().map(move |&b| (a, b)))
    }

    /// The entry `(a, b)` at pattern position `p`. O(log rows).
    ///
    /// # Panics
    /// If `p >= len()`.
    pub fn entry(&self, p: usize) -> (usize, usize) {
        assert!(p < self.len(), "pattern position {p} of {}", self.len());
        let a = self.row_start.partition_point(|&s| s <= p) - 1;
        (a, self.column[p])
    }

    /// The pattern position of entry `(a, b)`, or `None` when it is not listed (or
    /// out of range). O(log of the row's length).
    pub fn position(&self, a: usize, b: usize) -> Option<usize> {
        if a >= self.rows {
            return None;
        }
        let range = self.row_positions(a);
        self.column[range.clone()]
            .binary_search(&b)
            .ok()
            .map(|k| range.start + k)
    }

    /// The pattern positions of row `a`'s listed entries (consecutive).
    ///
    /// # Panics
    /// If `a >= rows()`.
    pub fn row_positions(&self, a: usize) -> Range<usize> {
        self.row_start[a]..self.row_start[a + 1]
    }

    /// The columns of row `a`'s listed entries, increasing; the `k`-th is at pattern
    /// position `row_positions(a).start + k`.
    ///
    /// # Panics
    /// If `a >= rows()`.
    pub fn row_columns(&self, a: usize) -> &[usize] {
        &self.column[self.row_positions(a)]
    }

    /// The rows of column `b`'s listed entries, increasing.
    ///
    /// # Panics
    /// If `b >= columns()`.
    pub fn column_rows(&self, b: usize) -> &[usize] {
        &self.column_rows[self.column_start[b]..self.column_start[b + 1]]
    }

    /// The pattern positions of column `b`'s listed entries, in the order of
    /// [`PairPattern::column_rows`].
    ///
    /// # Panics
    /// If `b >= columns()`.
    pub fn column_positions(&self, b: usize) -> &[usize] {
        &self.column_positions[self.column_start[b]..self.column_start[b + 1]]
    }

    /// Expands a table over the pattern into the dense row-major table. Each entry is
    /// a row of `width` values (1 for log-potentials; the number of weights for the
    /// feature vectors a [`FeatureTable`](crate::hybrid::chain::FeatureTable)
    /// records): `table` holds `table_len() · width` values (listed entries in pattern
    /// order, then the default), `out` receives `rows · columns · width`, the default
    /// row in every unlisted entry. O(rows · columns · width).
    ///
    /// # Panics
    /// If `table` or `out` has another length.
    pub fn expand(&self, table: &[f64], width: usize, out: &mut [f64]) {
        assert_eq!(
            table.len(),
            self.table_len() * width,
            "table over a pattern of {} entries with {width} values each",
            self.len()
        );
        assert_eq!(
            out.len(),
            self.rows * self.columns * width,
            "dense {} x {} table with {width} values per entry",
            self.rows,
            self.columns
        );
        let default = &table[self.len() * width..];
        for entry in out.chunks_exact_mut(width.max(1)) {
            entry.copy_from_slice(default);
        }
        for a in 0..self.rows {
            for p in self.row_positions(a) {
                let e = a * self.columns + self.column[p];
                out[e * width..(e + 1) * width].copy_from_slice(&table[p * width..(p + 1) * width]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_entries_are_refused() {
        assert!(PairPattern::new(2, 2, &[(0, 1), (0, 1)]).is_err());
        assert!(PairPattern::new(2, 2, &[(1, 0), (0, 1)]).is_err());
        assert!(PairPattern::new(2, 2, &[(2, 0)]).is_err());
        assert!(PairPattern::new(2, 2, &[(0, 2)]).is_err());
        let p = PairPattern::new(2, 3, &[(0, 2), (1, 0), (1, 1)]).unwrap();
        assert_eq!(
            p,
            PairPattern::from_fn(2, 3, |a, b| (a, b) != (0, 0)
                && (a, b) != (0, 1)
                && (a, b) != (1, 2))
        );
        assert_eq!(
            (0..3).map(|q| p.entry(q)).collect::<Vec<_>>(),
            [(0, 2), (1, 0), (1, 1)]
        );
    }

    #[test]
    fn empty_and_full_patterns() {
        let empty = PairPattern::from_fn(3, 2, |_, _| false);
        assert!(empty.is_empty());
        assert_eq!(empty.column_rows(1), &[] as &[usize]);
        let mut out = [0.0; 6];
        empty.expand(&[7.0], 1, &mut out);
        assert_eq!(out, [7.0; 6]);
        let full = PairPattern::from_fn(3, 2, |_, _| true);
        assert_eq!(full.len(), 6);
        assert_eq!(full.column_rows(1), &[0, 1, 2]);
        assert_eq!(full.column_positions(1), &[1, 3, 5]);
        let none = PairPattern::from_fn(0, 0, |_, _| true);
        assert_eq!((none.len(), none.table_len()), (0, 1));
    }

    #[test]
    fn runs_and_depths() {
        // A band around the next column plus the last row and column.
        let p = PairPattern::from_fn(5, 5, |a, b| b.abs_diff(a + 1) <= 1 || a == 4 || b == 4);
        assert_eq!(p.row_runs(0), &[(0, 0, 3), (4, 3, 1)]);
        assert_eq!(p.row_runs(2), &[(2, p.position(2, 2).unwrap(), 3)]);
        assert_eq!(p.row_runs(4), &[(0, p.position(4, 0).unwrap(), 5)]);
        // Column 4 is full; the longest other columns (2: rows 0, 1, 2, 4; 3: rows
        // 1, 2, 3, 4) have 4 entries.
        assert_eq!(p.column_depth(), 5);
        // Row 4 is full; rows 0-3 have 2 to 4 entries.
        assert_eq!(p.row_depth(), 5);
        let full = PairPattern::from_fn(2, 3, |_, _| true);
        assert_eq!((full.column_depth(), full.row_depth()), (0, 0));
        let empty = PairPattern::from_fn(2, 3, |_, _| false);
        assert_eq!((empty.column_depth(), empty.row_depth()), (1, 1));
    }

    #[test]
    fn expands_feature_rows() {
        let p = PairPattern::from_fn(2, 2, |a, b| a == b);
        // Two values per entry: (0,0) → [1, 2], (1,1) → [3, 4], default [9, 8].
        let mut out = [0.0; 8];
        p.expand(&[1.0, 2.0, 3.0, 4.0, 9.0, 8.0], 2, &mut out);
        assert_eq!(out, [1.0, 2.0, 9.0, 8.0, 9.0, 8.0, 3.0, 4.0]);
    }
}
