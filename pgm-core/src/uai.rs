//! The UAI inference-competition formats: MARKOV and BAYES model files, evidence
//! files, and MPE / MAR result files.
//!
//! Model tables list entries with the last scope variable changing fastest (row-major),
//! the same order as [`TableFactor`]. Values are potentials (not
//! logs); zeros become −∞ log-potentials. BAYES tables are conditional probability
//! tables with the child last; semantically the model is the product of all tables,
//! so both kinds convert to the same factor graph. Lines starting with `c` are comments
//! (UAI 2016+). Evidence files hold `q v_1 x_1 … v_q x_q` (UAI 2014) or the 2010
//! variant with a leading sample count of 1.

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

struct Tokens {
    path: PathBuf,
    tokens: Vec<(String, usize)>,
    next: usize,
}

impl Tokens {
    fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
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
        let mut cardinalities = Vec::with_capacity(n.min(1 << 20));
        for i in 0..n {
            cardinalities.push(tk.integer(
                &format!("the cardinality of variable {i}"),
                1,
                LIMIT,
            )?);
        }
        let num_functions = tk.integer("the number of functions", 0, LIMIT)?;
        let mut scopes = Vec::with_capacity(num_functions.min(1 << 20));
        for f in 0..num_functions {
            let arity = tk.integer(&format!("the scope size of function {f}"), 0, n)?;
            let mut scope = Vec::with_capacity(arity);
            for j in 0..arity {
                let before = tk.next;
                let v = tk.integer(
                    &format!("variable {j} of the scope of function {f}"),
                    0,
                    n.saturating_sub(1),
                )?;
                if scope.contains(&v) {
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
        let mut tables = Vec::with_capacity(num_functions.min(1 << 20));
        for (f, scope) in scopes.iter().enumerate() {
            let expected: usize = scope.iter().map(|&v| cardinalities[v]).product();
            let before = tk.next;
            let size = tk.integer(&format!("the table size of function {f}"), 0, LIMIT)?;
            if size != expected {
                let line = tk.tokens[before].1;
                return Err(tk.error(
                    line,
                    format!("function {f}: table size {size}, but its scope has {expected} joint states"),
                ));
            }
            let mut table = Vec::with_capacity(size);
            for i in 0..size {
                table.push(tk.potential(&format!("entry {i} of the table of function {f}"))?);
            }
            tables.push(table);
        }
        tk.expect_end()?;
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
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, text).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// Observed values: `(variable, state)` pairs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Evidence(pub Vec<(usize, usize)>);

impl Evidence {
    /// Reads an evidence file and checks it against the model's cardinalities.
    pub fn read(path: impl AsRef<Path>, cardinalities: &[usize]) -> Result<Self> {
        let path = path.as_ref();
        Self::parse(&mut Tokens::read(path)?, cardinalities)
    }

    /// Parses evidence text; `path` is used in error messages only.
    pub fn parse_str(path: impl AsRef<Path>, text: &str, cardinalities: &[usize]) -> Result<Self> {
        Self::parse(&mut Tokens::from_text(path.as_ref(), text), cardinalities)
    }

    fn parse(tk: &mut Tokens, cardinalities: &[usize]) -> Result<Self> {
        let total = tk.tokens.len();
        if total == 0 {
            return Ok(Self::default());
        }
        // UAI 2014: "q v x ..." has 1 + 2q tokens; UAI 2010 prefixes a sample count of 1.
        let first: Option<usize> = tk.tokens[0].0.parse().ok();
        if first == Some(1) && total != 3 {
            tk.next = 1;
        }
        let n = cardinalities.len();
        let q = tk.integer("the number of observed variables", 0, n)?;
        let mut pairs = Vec::with_capacity(q);
        for i in 0..q {
            let v = tk.integer(
                &format!("the variable of observation {i}"),
                0,
                n.saturating_sub(1),
            )?;
            let before = tk.next;
            let x = tk.integer(
                &format!("the state of observation {i} (variable {v})"),
                0,
                usize::MAX,
            )?;
            if x >= cardinalities[v] {
                let line = tk.tokens[before].1;
                return Err(tk.error(
                    line,
                    format!(
                        "observation {i}: state {x} of variable {v}, which has {} states",
                        cardinalities[v]
                    ),
                ));
            }
            if let Some(&(_, prev)) = pairs.iter().find(|(u, _)| *u == v) {
                if prev != x {
                    let line = tk.tokens[before].1;
                    return Err(tk.error(
                        line,
                        format!("variable {v} observed twice, as {prev} and {x}"),
                    ));
                }
            }
            pairs.push((v, x));
        }
        tk.expect_end()?;
        Ok(Self(pairs))
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
