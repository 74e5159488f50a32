//! The UAI inference-competition formats: MARKOV and BAYES model files, evidence
//! files, and MPE / MAR result files.
//!
//! Model tables list entries with the last scope variable changing fastest (row-major),
//! the same order as [`TableFactor`]. Values are potentials (not
//! logs); zeros become −∞ log-potentials. BAYES tables are conditional probability
//! tables with the child last; semantically the model is the product of all tables,
//! so both kinds convert to the same factor graph. Lines starting with `c` are comments
//! (UAI 2016+).
//!
//! Sizes in the file are checked before they are used: the number of joint states of
//! a scope is a checked product (an overflow is a parse error naming the line), and
//! no buffer is reserved beyond what the rest of the file can fill, so a 150-byte file
//! declaring a table of 2^36 entries is an "unexpected end of file", not an
//! allocation of 512 GiB.
//!
//! Evidence files come in two layouts ([`EvidenceFormat`]): UAI 2014 holds one sample,
//! `q v_1 x_1 … v_q x_q`; UAI 2010 holds a count of samples `N` followed by `N`
//! samples in that form, each on its own line. The two can read the same tokens
//! differently (`2 / 1 0 1 / 0` is two samples in 2010 but two observations of
//! variable 1 in 2014), so the layout is decided as follows: a file on one line is
//! UAI 2014 when it parses as such; a file whose first line holds a single number `N`
//! followed by exactly `N` lines that each hold one complete sample is UAI 2010;
//! otherwise whichever of the two reads every token (2014 first).
//! [`Evidence::read_samples`] returns every sample; [`Evidence::read`] the first.
//!
//! [`UaiModel::check_positive`] decides, by propagating the zeros of the tables
//! (generalised arc consistency), whether a model with evidence can have an assignment
//! of positive probability, and says why not when it cannot (`Z = 0` or
//! `P(evidence) = 0`).

use crate::error::{Error, Result};
use crate::factor::TableFactor;
use crate::graph::{FactorGraph, VariableId};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The kind of a UAI model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UaiKind {
    /// Undirected model.
    Markov,
    /// Bayesian network (tables are CPTs, child last).
    Bayes,
}

/// A UAI model as written in the file: potentials, not logs.
#[derive(Clone, Debug, PartialEq)]
pub struct UaiModel {
    /// MARKOV or BAYES.
    pub kind: UaiKind,
    /// Cardinality of each variable.
    pub cardinalities: Vec<usize>,
    /// Scope of each function.
    pub scopes: Vec<Vec<usize>>,
    /// Table of each function, row-major (last scope variable fastest).
    pub tables: Vec<Vec<f64>>,
}

/// Reads a whole text file; bytes that are not UTF-8 (a binary or compressed file) are
/// a parse error naming the line and byte offset of the first one.
fn read_text(path: &Path) -> Result<String> {
    let text = crate::fsutil::read_utf8(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    text.map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        line: e.line,
        message: format!(
            "byte {} (0x{:02x}) is not UTF-8 text: not a UAI file (a binary or compressed \
             file?)",
            e.offset, e.byte
        ),
    })
}

struct Tokens {
    path: PathBuf,
    tokens: Vec<(String, usize)>,
    next: usize,
}

impl Tokens {
    fn read(path: &Path) -> Result<Self> {
        let text = read_text(path)?;
        Ok(Self::from_text(path, &text))
    }

    fn from_text(path: &Path, text: &str) -> Self {
        let mut tokens = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let trimmed = line.trim();
            if trimmed == "c" || trimmed.starts_with("c ") || trimmed.starts_with("c\t") {
                continue;
            }
            tokens.extend(trimmed.split_whitespace().map(|t| (t.to_string(), i + 1)));
        }
        Self {
            path: path.to_path_buf(),
            tokens,
            next: 0,
        }
    }

    fn error(&self, line: usize, message: String) -> Error {
        Error::Parse {
            path: self.path.clone(),
            line,
            message,
        }
    }

    fn last_line(&self) -> usize {
        self.tokens.last().map_or(0, |t| t.1)
    }

    fn token(&mut self, what: &str) -> Result<(String, usize)> {
        match self.tokens.get(self.next) {
            Some(t) => {
                self.next += 1;
                Ok(t.clone())
            }
            None => Err(self.error(
                self.last_line(),
                format!("unexpected end of file: expected {what}"),
            )),
        }
    }

    fn integer(&mut self, what: &str, min: usize, max: usize) -> Result<usize> {
        let (t, line) = self.token(what)?;
        let v: usize = t.parse().map_err(|_| {
            self.error(
                line,
                format!("expected {what} (an integer >= {min}), found {t:?}"),
            )
        })?;
        if v < min || v > max {
            return Err(self.error(line, format!("{what} = {v} is outside [{min}, {max}]")));
        }
        Ok(v)
    }

    fn potential(&mut self, what: &str) -> Result<f64> {
        let (t, line) = self.token(what)?;
        let v: f64 = t
            .parse()
            .map_err(|_| self.error(line, format!("expected {what} (a number), found {t:?}")))?;
        if !(v.is_finite() && v >= 0.0) {
            return Err(self.error(
                line,
                format!("{what} = {t}: potentials must be finite and >= 0"),
            ));
        }
        Ok(v)
    }

    fn expect_end(&self) -> Result<()> {
        match self.tokens.get(self.next) {
            None => Ok(()),
            Some((t, line)) => Err(self.error(
                *line,
                format!("unexpected trailing token {t:?} after the last table"),
            )),
        }
    }
}

impl UaiModel {
    /// Reads a model file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        Self::parse(&mut Tokens::read(path)?)
    }

    /// Parses model text; `path` is used in error messages only.
    pub fn parse_str(path: impl AsRef<Path>, text: &str) -> Result<Self> {
        Self::parse(&mut Tokens::from_text(path.as_ref(), text))
    }

    fn parse(tk: &mut Tokens) -> Result<Self> {
        let (header, line) = tk.token("the model type MARKOV or BAYES")?;
        let kind = match header.to_ascii_uppercase().as_str() {
            "MARKOV" => UaiKind::Markov,
            "BAYES" => UaiKind::Bayes,
            _ => return Err(tk.error(line, format!("expected MARKOV or BAYES, found {header:?}"))),
        };
        const LIMIT: usize = 1 << 40;
        let n = tk.integer("the number of variables", 0, LIMIT)?;
        let mut cardinalities = Vec::with_capacity(n.min(tk.tokens.len()));
        let first_cardinality = tk.next;
        for i in 0..n {
            cardinalities.push(tk.integer(
                &format!("the cardinality of variable {i}"),
                1,
                LIMIT,
            )?);
        }
        let num_functions = tk.integer("the number of functions", 0, LIMIT)?;
        let mut scopes = Vec::with_capacity(num_functions.min(tk.tokens.len()));
        // in_scope[v] = the last function whose scope lists v (repeats in O(1)).
        let mut in_scope = vec![usize::MAX; n];
        for f in 0..num_functions {
            let arity = tk.integer(&format!("the scope size of function {f}"), 0, n)?;
            let mut scope = Vec::with_capacity(arity.min(tk.tokens.len() - tk.next));
            for j in 0..arity {
                let before = tk.next;
                let v = tk.integer(
                    &format!("variable {j} of the scope of function {f}"),
                    0,
                    n.saturating_sub(1),
                )?;
                if std::mem::replace(&mut in_scope[v], f) == f {
                    let line = tk.tokens[before].1;
                    return Err(tk.error(
                        line,
                        format!("function {f} lists variable {v} twice in its scope"),
                    ));
                }
                scope.push(v);
            }
            if kind == UaiKind::Bayes && arity == 0 {
                return Err(tk.error(
                    tk.last_line(),
                    format!("function {f}: a BAYES table needs a child variable"),
                ));
            }
            scopes.push(scope);
        }
        let mut tables = Vec::with_capacity(num_functions.min(tk.tokens.len()));
        for (f, scope) in scopes.iter().enumerate() {
            let before = tk.next;
            let size = tk.integer(&format!("the table size of function {f}"), 0, LIMIT)?;
            let line = tk.tokens[before].1;
            let expected = scope
                .iter()
                .try_fold(1usize, |acc, &v| acc.checked_mul(cardinalities[v]));
            let Some(expected) = expected else {
                let mut cards: Vec<String> = scope
                    .iter()
                    .take(6)
                    .map(|&v| cardinalities[v].to_string())
                    .collect();
                if scope.len() > 6 {
                    cards.push("…".into());
                }
                return Err(tk.error(
                    line,
                    format!(
                        "function {f}: the product of the cardinalities of its {} scope \
                         variables ({}) overflows: no table has that many joint states",
                        scope.len(),
                        cards.join(" × ")
                    ),
                ));
            };
            if size != expected {
                return Err(tk.error(
                    line,
                    format!("function {f}: table size {size}, but its scope has {expected} joint states"),
                ));
            }
            let remaining = tk.tokens.len() - tk.next;
            if size > remaining {
                return Err(tk.error(
                    tk.last_line(),
                    format!(
                        "unexpected end of file: function {f} declares {size} table entries \
                         (line {line}), but only {remaining} numbers follow"
                    ),
                ));
            }
            let mut table = Vec::with_capacity(size);
            for i in 0..size {
                table.push(tk.potential(&format!("entry {i} of the table of function {f}"))?);
            }
            tables.push(table);
        }
        tk.expect_end()?;
        // A variable in some scope has at most as many states as that table has entries;
        // the states of a variable in no scope are backed by nothing in the file, so
        // together they may not outnumber the file's tokens (else results and beliefs
        // would be sized by a bare number).
        let mut unbacked: usize = 0;
        for (v, &k) in cardinalities.iter().enumerate() {
            if in_scope[v] == usize::MAX {
                unbacked = unbacked.saturating_add(k);
                if unbacked > tk.tokens.len() {
                    let line = tk.tokens[first_cardinality + v].1;
                    return Err(tk.error(
                        line,
                        format!(
                            "variable {v} has {k} states but appears in no function: nothing \
                             in the file backs them (variables in no function may have at \
                             most {} states together, the number of tokens in the file)",
                            tk.tokens.len()
                        ),
                    ));
                }
            }
        }
        Ok(Self {
            kind,
            cardinalities,
            scopes,
            tables,
        })
    }

    /// The factor graph of this model (log-potentials; zeros are −∞).
    pub fn to_factor_graph(&self) -> Result<FactorGraph> {
        let mut g = FactorGraph::with_variables(&self.cardinalities)?;
        for (scope, table) in self.scopes.iter().zip(&self.tables) {
            let shape = scope.iter().map(|&v| self.cardinalities[v]).collect();
            let scope = scope.iter().map(|&v| VariableId(v)).collect();
            g.add_factor(TableFactor::from_potentials(scope, shape, table)?)?;
        }
        Ok(g)
    }

    /// A MARKOV model of a factor graph (potentials `exp(log-potential)`).
    pub fn from_factor_graph(graph: &FactorGraph) -> Self {
        Self {
            kind: UaiKind::Markov,
            cardinalities: graph.cardinalities().to_vec(),
            scopes: graph
                .factors()
                .map(|f| f.scope().iter().map(|v| v.0).collect())
                .collect(),
            tables: graph
                .factors()
                .map(|f| f.log_table().iter().map(|l| l.exp()).collect())
                .collect(),
        }
    }

    /// The model in UAI text. Numbers use Rust's shortest round-trip formatting, so
    /// reading the text back gives bit-identical values.
    pub fn to_uai_string(&self) -> String {
        let mut s = String::new();
        s.push_str(match self.kind {
            UaiKind::Markov => "MARKOV\n",
            UaiKind::Bayes => "BAYES\n",
        });
        let _ = writeln!(s, "{}", self.cardinalities.len());
        let _ = writeln!(s, "{}", join(self.cardinalities.iter()));
        let _ = writeln!(s, "{}", self.scopes.len());
        for scope in &self.scopes {
            let _ = writeln!(s, "{} {}", scope.len(), join(scope.iter()));
        }
        for table in &self.tables {
            let _ = writeln!(s, "\n{}", table.len());
            let _ = writeln!(s, "{}", join(table.iter()));
        }
        s
    }

    /// Writes the model to a file (through a temporary file, then renamed).
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        write_atomically(path.as_ref(), &self.to_uai_string())
    }
}

fn join<T: std::fmt::Display>(items: impl Iterator<Item = T>) -> String {
    let mut s = String::new();
    for (i, x) in items.enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{x}");
    }
    s
}

fn write_atomically(path: &Path, text: &str) -> Result<()> {
    crate::fsutil::write_atomically(path, text.as_bytes())
}

/// Observed values: `(variable, state)` pairs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Evidence(pub Vec<(usize, usize)>);

/// The layout of an evidence file (see the module docs for how it is decided).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EvidenceFormat {
    /// One sample: `q v_1 x_1 … v_q x_q`.
    Uai2014,
    /// A sample count `N`, then `N` samples in the 2014 form.
    Uai2010,
}

/// Every sample of an evidence file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EvidenceSamples {
    /// The layout the file was read in.
    pub format: EvidenceFormat,
    /// The samples in file order (at least one; an empty file is one empty sample).
    pub samples: Vec<Evidence>,
}

impl Evidence {
    /// Reads an evidence file and checks it against the model's cardinalities. A UAI
    /// 2010 file with several samples gives its first sample
    /// ([`Evidence::read_samples`] gives them all).
    pub fn read(path: impl AsRef<Path>, cardinalities: &[usize]) -> Result<Self> {
        Ok(Self::read_samples(path, cardinalities)?
            .samples
            .swap_remove(0))
    }

    /// Parses evidence text (the first sample, as [`Evidence::read`]); `path` is used
    /// in error messages only.
    pub fn parse_str(path: impl AsRef<Path>, text: &str, cardinalities: &[usize]) -> Result<Self> {
        Ok(Self::parse_samples_str(path, text, cardinalities)?
            .samples
            .swap_remove(0))
    }

    /// Reads every sample of an evidence file, checked against the model's
    /// cardinalities.
    pub fn read_samples(
        path: impl AsRef<Path>,
        cardinalities: &[usize],
    ) -> Result<EvidenceSamples> {
        let path = path.as_ref();
        let text = read_text(path)?;
        Self::parse_samples_str(path, &text, cardinalities)
    }

    /// Parses every sample of evidence text; `path` is used in error messages only.
    pub fn parse_samples_str(
        path: impl AsRef<Path>,
        text: &str,
        cardinalities: &[usize],
    ) -> Result<EvidenceSamples> {
        let path = path.as_ref();
        let tk = Tokens::from_text(path, text);
        if tk.tokens.is_empty() {
            return Ok(EvidenceSamples {
                format: EvidenceFormat::Uai2014,
                samples: vec![Self::default()],
            });
        }
        let lines: Vec<usize> = {
            let mut l: Vec<usize> = tk.tokens.iter().map(|t| t.1).collect();
            l.dedup();
            l
        };
        let as_2014 = || {
            let mut tk = Tokens::from_text(path, text);
            let sample = Self::parse_sample(&mut tk, cardinalities, "")?;
            tk.expect_end()?;
            Ok(EvidenceSamples {
                format: EvidenceFormat::Uai2014,
                samples: vec![sample],
            })
        };
        let as_2010 = || {
            let mut tk = Tokens::from_text(path, text);
            let count = tk.integer("the number of evidence samples (UAI 2010)", 1, usize::MAX)?;
            let mut samples = Vec::with_capacity(count.min(tk.tokens.len()));
            for s in 0..count {
                samples.push(Self::parse_sample(
                    &mut tk,
                    cardinalities,
                    &format!("sample {s}: "),
                )?);
            }
            tk.expect_end()?;
            Ok(EvidenceSamples {
                format: EvidenceFormat::Uai2010,
                samples,
            })
        };
        if lines.len() == 1 {
            // One line: UAI 2014 unless only the 2010 reading parses.
            return as_2014().or_else(|e: Error| as_2010().map_err(|_| e));
        }
        // First line a lone count N, then N lines of one sample each: UAI 2010.
        let first_line_alone = tk.tokens.len() >= 2 && tk.tokens[0].1 != tk.tokens[1].1;
        if first_line_alone {
            let count: Option<usize> = tk.tokens[0].0.parse().ok();
            if count == Some(lines.len() - 1) {
                if let Ok(read) = as_2010() {
                    let one_line_each = read.samples.len() == lines.len() - 1
                        && Self::samples_follow_lines(&tk, &read);
                    if one_line_each {
                        return Ok(read);
                    }
                }
            }
        }
        match as_2014() {
            Ok(read) => Ok(read),
            Err(e14) => as_2010().map_err(|e10| if first_line_alone { e10 } else { e14 }),
        }
    }

    /// True when sample `s` of `read` sits on line `s + 1` of the token stream's lines.
    fn samples_follow_lines(tk: &Tokens, read: &EvidenceSamples) -> bool {
        let mut at = 1;
        for sample in &read.samples {
            let len = 1 + 2 * sample.0.len();
            let Some(slice) = tk.tokens.get(at..at + len) else {
                return false;
            };
            if slice.iter().any(|t| t.1 != slice[0].1)
                || tk.tokens.get(at + len).is_some_and(|t| t.1 == slice[0].1)
            {
                return false;
            }
            at += len;
        }
        at == tk.tokens.len()
    }

    /// One sample `q v_1 x_1 …` read from the current position.
    fn parse_sample(tk: &mut Tokens, cardinalities: &[usize], prefix: &str) -> Result<Self> {
        let n = cardinalities.len();
        let q = tk.integer(&format!("{prefix}the number of observed variables"), 0, n)?;
        let mut pairs: Vec<(usize, usize)> = Vec::with_capacity(q.min(tk.tokens.len()));
        let mut seen: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
        for i in 0..q {
            let v = tk.integer(
                &format!("{prefix}the variable of observation {i}"),
                0,
                n.saturating_sub(1),
            )?;
            let before = tk.next;
            let x = tk.integer(
                &format!("{prefix}the state of observation {i} (variable {v})"),
                0,
                usize::MAX,
            )?;
            if x >= cardinalities[v] {
                let line = tk.tokens[before].1;
                return Err(tk.error(
                    line,
                    format!(
                        "{prefix}observation {i}: state {x} of variable {v}, which has {} states",
                        cardinalities[v]
                    ),
                ));
            }
            if let Some(prev) = seen.insert(v, x) {
                if prev != x {
                    let line = tk.tokens[before].1;
                    return Err(tk.error(
                        line,
                        format!("{prefix}variable {v} observed twice, as {prev} and {x}"),
                    ));
                }
            }
            pairs.push((v, x));
        }
        Ok(Self(pairs))
    }

    /// The observed state of `variable`, if it is observed.
    pub fn state_of(&self, variable: usize) -> Option<usize> {
        self.0.iter().find(|(v, _)| *v == variable).map(|(_, x)| *x)
    }

    /// Clamps the observed variables by adding hard unary factors (0 at the observed
    /// state, −∞ elsewhere).
    pub fn apply(&self, graph: &mut FactorGraph) -> Result<()> {
        for &(v, x) in &self.0 {
            let k = graph.cardinality(VariableId(v));
            let mut table = vec![f64::NEG_INFINITY; k];
            table[x] = 0.0;
            graph.add_factor(TableFactor::new(vec![VariableId(v)], vec![k], table)?)?;
        }
        Ok(())
    }
}

/// Why a model (with evidence) has no assignment of positive probability
/// ([`UaiModel::check_positive`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NoPositiveAssignment {
    /// The evidence, when the model alone has positive assignments but none agrees
    /// with it (`P(evidence) = 0`); `None` when the model alone has none (`Z = 0`).
    pub evidence: Option<Vec<(usize, usize)>>,
    /// The variable left with no possible state (`None` when the function is a
    /// constant, of empty scope, equal to 0).
    pub variable: Option<usize>,
    /// The function whose zeros removed that variable's last state.
    pub function: usize,
    /// The scope of that function.
    pub scope: Vec<usize>,
}

impl std::fmt::Display for NoPositiveAssignment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let cause = match self.variable {
            Some(v) => format!(
                "function {} (scope {:?}) is zero for every remaining state of variable {v}",
                self.function, self.scope
            ),
            None => format!("function {} is the constant 0", self.function),
        };
        match &self.evidence {
            None => write!(
                f,
                "no assignment has positive probability (Z = 0): after propagating the \
                 model's zeros, {cause}"
            ),
            Some(evidence) => {
                let observed: Vec<String> = evidence
                    .iter()
                    .map(|(v, x)| format!("x{v} = {x}"))
                    .collect();
                write!(
                    f,
                    "the evidence has probability 0 (P(evidence) = 0): with {}, {cause}",
                    observed.join(", ")
                )
            }
        }
    }
}

impl std::error::Error for NoPositiveAssignment {}

/// Work limit of [`UaiModel::check_positive`] (table entries visited).
const SUPPORT_WORK_LIMIT: u64 = 1 << 28;

impl UaiModel {
    /// Checks that some assignment agreeing with `evidence` has positive probability,
    /// by generalised arc consistency on the tables' zeros: states without support in
    /// some table are removed until nothing changes. An emptied variable proves that
    /// no such assignment exists; the error says whether the model alone has none
    /// (`Z = 0`) or only none that agrees with the evidence. Passing the check does not
    /// prove that one exists on a loopy model (that is NP-hard), but it is exact on
    /// trees. The work is bounded (2^28 table entries visited); past that the check
    /// passes without a verdict.
    pub fn check_positive(
        &self,
        evidence: &Evidence,
    ) -> std::result::Result<(), NoPositiveAssignment> {
        if let Err((variable, function)) = self.propagate_zeros(&[]) {
            return Err(NoPositiveAssignment {
                evidence: None,
                variable,
                function,
                scope: self.scopes[function].clone(),
            });
        }
        if evidence.0.is_empty() {
            return Ok(());
        }
        self.propagate_zeros(&evidence.0)
            .map_err(|(variable, function)| NoPositiveAssignment {
                evidence: Some(evidence.0.clone()),
                variable,
                function,
                scope: self.scopes[function].clone(),
            })
    }

    /// Arc consistency over the positive entries; `Err((variable, function))` names the
    /// variable that lost its last state (none for a constant function of value 0) and
    /// the function that removed it.
    fn propagate_zeros(
        &self,
        evidence: &[(usize, usize)],
    ) -> std::result::Result<(), (Option<usize>, usize)> {
        let n = self.cardinalities.len();
        let mut domains: Vec<Vec<bool>> =
            self.cardinalities.iter().map(|&k| vec![true; k]).collect();
        for &(v, x) in evidence {
            if v < n && x < self.cardinalities[v] {
                let keep = domains[v][x];
                domains[v].iter_mut().for_each(|d| *d = false);
                domains[v][x] = keep;
            }
        }
        let mut functions_of: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (f, scope) in self.scopes.iter().enumerate() {
            for &v in scope {
                functions_of[v].push(f);
            }
        }
        let mut queued = vec![true; self.scopes.len()];
        let mut queue: std::collections::VecDeque<usize> = (0..self.scopes.len()).collect();
        let mut work: u64 = 0;
        let mut states = Vec::new();
        let mut supported: Vec<Vec<bool>> = Vec::new();
        while let Some(f) = queue.pop_front() {
            queued[f] = false;
            let scope = &self.scopes[f];
            let table = &self.tables[f];
            work += table.len() as u64 * (scope.len() as u64 + 1);
            if work > SUPPORT_WORK_LIMIT {
                return Ok(());
            }
            supported.clear();
            supported.extend(scope.iter().map(|&v| vec![false; self.cardinalities[v]]));
            states.clear();
            states.resize(scope.len(), 0);
            for &p in table {
                if p > 0.0 && scope.iter().zip(&states).all(|(&v, &x)| domains[v][x]) {
                    for (j, &x) in states.iter().enumerate() {
                        supported[j][x] = true;
                    }
                }
                // Next joint state, last scope position fastest.
                for j in (0..scope.len()).rev() {
                    states[j] += 1;
                    if states[j] < self.cardinalities[scope[j]] {
                        break;
                    }
                    states[j] = 0;
                }
            }
            if scope.is_empty() && !table.iter().any(|&p| p > 0.0) {
                return Err((None, f));
            }
            for (j, &v) in scope.iter().enumerate() {
                let mut changed = false;
                for (x, d) in domains[v].iter_mut().enumerate() {
                    if *d && !supported[j][x] {
                        *d = false;
                        changed = true;
                    }
                }
                if !domains[v].iter().any(|d| *d) {
                    return Err((Some(v), f));
                }
                if changed {
                    for &g in &functions_of[v] {
                        if g != f && !queued[g] {
                            queued[g] = true;
                            queue.push_back(g);
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// The UAI 2014 MPE result: `MPE` then `n x_0 … x_{n-1}`.
pub fn mpe_result(assignment: &[usize]) -> String {
    format!("MPE\n{} {}\n", assignment.len(), join(assignment.iter()))
}

/// The UAI 2014 MAR result: `MAR` then `n K_0 p_0,0 … K_1 p_1,0 …`.
pub fn mar_result(marginals: &[Vec<f64>]) -> String {
    let mut s = format!("MAR\n{}", marginals.len());
    for m in marginals {
        let _ = write!(s, " {}", m.len());
        for p in m {
            let _ = write!(s, " {p}");
        }
    }
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(text: &str) -> Result<UaiModel> {
        UaiModel::parse_str("m.uai", text)
    }

    /// Asserts that `text` is refused with an error that mentions every one of `needles`.
    fn assert_parse_error(text: &str, needles: &[&str]) {
        let err = model(text).unwrap_err().to_string();
        assert!(needles.iter().all(|n| err.contains(n)), "{err}");
    }

    /// The preamble of a MARKOV file of `n` binary variables and one function over all
    /// of them, up to its table.
    fn one_scope_over_binaries(n: usize) -> String {
        let cards = vec!["2"; n].join(" ");
        let scope: Vec<String> = (0..n).map(|v| v.to_string()).collect();
        format!("MARKOV\n{n}\n{cards}\n1\n{n} {}\n", scope.join(" "))
    }

    #[test]
    fn joint_state_products_that_overflow_are_parse_errors() {
        // 64 binary variables in one scope: 2^64 wraps to 0, which must not match a
        // table of size 0.
        let text = format!("{}0\n", one_scope_over_binaries(64));
        assert_parse_error(&text, &["m.uai:6:", "overflows"]);
    }

    #[test]
    fn declared_table_sizes_are_not_allocated_before_the_data_is_there() {
        // 36 binary variables: the table would need 2^36 entries (512 GiB of f64).
        let text = format!("{}{}\n0.5 0.5\n", one_scope_over_binaries(36), 1u64 << 36);
        assert_parse_error(&text, &["unexpected end of file", "68719476736"]);
    }

    #[test]
    fn states_of_a_variable_in_no_function_are_bounded_by_the_file() {
        // Found by fuzzing: 77777777773 states for a variable no table mentions made
        // the zero propagation (and BP's beliefs) allocate 78 GB.
        assert_parse_error(
            "MARKOV\n2\n2 77777777773\n1\n0\n1 0\n",
            &["m.uai:3:", "variable 1"],
        );
        assert!(model("MARKOV\n2\n2 3\n1\n1 0\n2 1 1\n").is_ok());
    }

    #[test]
    fn table_factor_refuses_a_shape_whose_product_overflows() {
        let scope: Vec<VariableId> = (0..64).map(VariableId).collect();
        let err = TableFactor::new(scope, vec![2; 64], vec![]).unwrap_err();
        assert!(err.to_string().contains("fits in usize"), "{err}");
    }

    #[test]
    fn evidence_layouts_are_told_apart() {
        let cards = [2, 2, 2];
        let read = |text: &str| Evidence::parse_samples_str("e.evid", text, &cards);
        // UAI 2010: two samples, the first observes x0 = 1 (B09).
        let two = read("2\n1 0 1\n0\n").unwrap();
        assert_eq!(two.format, EvidenceFormat::Uai2010);
        assert_eq!(two.samples, vec![Evidence(vec![(0, 1)]), Evidence(vec![])]);
        assert_eq!(
            Evidence::parse_str("e.evid", "2\n1 0 1\n0\n", &cards).unwrap(),
            Evidence(vec![(0, 1)])
        );
        // UAI 2014 on one line, even when its tokens would also read as 2010.
        let one = read("2 0 1 1 0\n").unwrap();
        assert_eq!(one.format, EvidenceFormat::Uai2014);
        assert_eq!(one.samples, vec![Evidence(vec![(0, 1), (1, 0)])]);
        // UAI 2014 spread over lines without one sample per line.
        let spread = read("2\n0 1\n1 0\n").unwrap();
        assert_eq!(spread.format, EvidenceFormat::Uai2014);
        assert_eq!(spread.samples, vec![Evidence(vec![(0, 1), (1, 0)])]);
        // UAI 2010 with one sample on one line (only 2010 parses).
        let single = read("1 2 0 1 2 1\n").unwrap();
        assert_eq!(single.format, EvidenceFormat::Uai2010);
        assert_eq!(single.samples, vec![Evidence(vec![(0, 1), (2, 1)])]);
        // Empty: no evidence.
        assert_eq!(read("").unwrap().samples, vec![Evidence(vec![])]);
        // Neither layout: an error naming the file and line.
        let err = read("3 0 1\n").unwrap_err().to_string();
        assert!(err.starts_with("e.evid:1:"), "{err}");
    }

    fn tiny(table: &str) -> UaiModel {
        model(&format!("MARKOV\n1\n2\n1\n1 0\n2\n{table}\n")).unwrap()
    }

    #[test]
    fn models_and_evidence_without_positive_assignment_are_refused_with_the_reason() {
        // B04: the only table is zero.
        let err = tiny("0 0")
            .check_positive(&Evidence::default())
            .unwrap_err();
        assert_eq!(err.evidence, None);
        assert!(err.to_string().contains("Z = 0"), "{err}");
        // B10: the evidence observes a state of probability 0.
        let m = tiny("1 0");
        assert_eq!(m.check_positive(&Evidence::default()), Ok(()));
        let err = m.check_positive(&Evidence(vec![(0, 1)])).unwrap_err();
        assert_eq!(err.evidence, Some(vec![(0, 1)]));
        assert!(err.to_string().contains("P(evidence) = 0"), "{err}");
        assert_eq!(m.check_positive(&Evidence(vec![(0, 0)])), Ok(()));
        // ev-contradict: an equality chain with its ends observed apart.
        let chain = model("MARKOV\n3\n2 2 2\n2\n2 0 1\n2 1 2\n4\n1 0 0 1\n4\n1 0 0 1\n").unwrap();
        assert_eq!(
            chain.check_positive(&Evidence(vec![(0, 1), (2, 1)])),
            Ok(())
        );
        let err = chain
            .check_positive(&Evidence(vec![(0, 0), (2, 1)]))
            .unwrap_err();
        assert!(err.to_string().contains("x0 = 0, x2 = 1"), "{err}");
        // A constant function of value 0.
        let constant = model("MARKOV\n1\n2\n2\n0\n1 0\n1\n0\n2\n1 1\n").unwrap();
        let err = constant.check_positive(&Evidence::default()).unwrap_err();
        assert_eq!(err.variable, None);
        assert!(err.to_string().contains("constant 0"), "{err}");
    }
}
