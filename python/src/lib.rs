//! Python bindings of pgm's graphical-model core (module `pgm._native`, re-exported by
//! the Python package `pgm`).
//!
//! A [`FactorGraph`](PyFactorGraph) is built from numpy tables (or read from a UAI
//! file); `map` and `marginals` run loopy belief propagation in log space with any of
//! the engine's schedules and damping, `trws` runs TRW-S with its upper bound. Every
//! error the engine reports is raised as `pgm.PgmError` (a `ValueError`) carrying the
//! same message the command-line tool prints; results are dicts of numpy arrays.
//! Inference releases the GIL.

use numpy::{PyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pgm_core::factor::TableFactor;
use pgm_core::uai::{Evidence, UaiModel};
use pgm_core::{
    BpParams, BpResult, FactorGraph, Mode, ParamGuard, ScheduleKind, TrwsParams, TrwsTermination,
    VariableId,
};
use pyo3::create_exception;
use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

mod learning;
mod methods;
mod scans;
mod tracking;

create_exception!(
    _native,
    PgmError,
    PyValueError,
    "An error reported by pgm: invalid input, a parameter out of range, or a model the \
     method cannot answer (the message names the value and where it came from)."
);

/// The engine's error as a Python exception, with `context` (a file name) in front
/// when there is one, as the command-line tool prints it.
fn pgm_err(context: Option<&str>, e: impl std::fmt::Display) -> PyErr {
    match context {
        Some(c) => PgmError::new_err(format!("{c}: {e}")),
        None => PgmError::new_err(e.to_string()),
    }
}

/// A whole number >= 0 from Python (a count, an index, a state), or an error naming
/// the argument (Python's own conversion says only "can't convert negative int").
pub(crate) fn count(name: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v)
        .map_err(|_| PgmError::new_err(format!("{name} = {v}: expected a whole number >= 0")))
}

/// [`count`] for each entry, named `name[i]`.
pub(crate) fn counts(name: &str, v: &[i64]) -> PyResult<Vec<usize>> {
    v.iter()
        .enumerate()
        .map(|(i, &x)| count(&format!("{name}[{i}]"), x))
        .collect()
}

/// Any array-like of numbers (a numpy array of any dtype, a list, nested lists) as a
/// float64 array, or an error naming the argument.
pub(crate) fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let numpy = obj.py().import("numpy")?;
    numpy
        .call_method1("asarray", (obj, "float64"))
        .and_then(|a| a.extract::<PyReadonlyArrayDyn<'py, f64>>())
        .map_err(|e| PgmError::new_err(format!("{name}: {e} (expected an array of numbers)")))
}

/// A discrete factor graph: variables with finite cardinalities and factors given
/// by dense tables over them.
///
/// `FactorGraph(cardinalities)` makes the variables (numbered from 0);
/// `add_factor(scope, table)` adds a factor whose table is a numpy array with one axis
/// per scope variable (C order: the last scope variable varies fastest, as in UAI).
#[pyclass(name = "FactorGraph", module = "pgm")]
pub(crate) struct PyFactorGraph {
    graph: FactorGraph,
    /// Where the model came from, for error messages (`None`: built from tables).
    source: Option<String>,
    /// Whether Potts-shaped tables were given their O(K) message path yet.
    specialised: bool,
}

impl PyFactorGraph {
    /// A graph built in Rust (a learned model's), with no file behind it.
    pub(crate) fn from_graph(graph: FactorGraph) -> Self {
        Self {
            graph,
            source: None,
            specialised: false,
        }
    }

    fn context(&self) -> Option<&str> {
        self.source.as_deref()
    }

    /// Gives Potts-shaped tables their O(K) messages (as `pgm map` does) once, before
    /// the first run; results are the same, only faster.
    fn prepare(&mut self) {
        if !self.specialised {
            self.graph.specialise_factors();
            self.specialised = true;
        }
    }
}

fn schedule_kind(schedule: &str) -> PyResult<ScheduleKind> {
    schedule.parse().map_err(|e| pgm_err(None, e))
}

fn bp_result_dict<'py>(
    py: Python<'py>,
    r: &BpResult,
    beliefs_key: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let assignment: Vec<i64> = r.assignment.iter().map(|&s| s as i64).collect();
    d.set_item("assignment", PyArray1::from_vec(py, assignment))?;
    d.set_item("log_score", r.log_score)?;
    let rows: Vec<&[f64]> = r.beliefs.iter().map(Vec::as_slice).collect();
    d.set_item(beliefs_key, scans::rows(py, &rows)?)?;
    d.set_item("iterations", r.iterations)?;
    d.set_item("converged", r.converged)?;
    d.set_item("residual", r.residual)?;
    d.set_item("contradictions", r.contradictions)?;
    Ok(d)
}

#[pymethods]
impl PyFactorGraph {
    /// A graph with one variable per entry of `cardinalities` (each at least 1) and no
    /// factors.
    #[new]
    fn new(cardinalities: Vec<i64>) -> PyResult<Self> {
        let cardinalities = counts("cardinalities", &cardinalities)?;
        let graph = FactorGraph::with_variables(&cardinalities).map_err(|e| pgm_err(None, e))?;
        Ok(Self {
            graph,
            source: None,
            specialised: false,
        })
    }

    /// Reads a model in the UAI format (MARKOV or BAYES), with an optional evidence
    /// file (UAI 2014 `q v x …`, or the 2010 variant: `sample` picks the sample).
    #[staticmethod]
    #[pyo3(signature = (path, evidence=None, sample=0))]
    fn from_uai(path: PathBuf, evidence: Option<PathBuf>, sample: i64) -> PyResult<Self> {
        let sample = count("sample", sample)?;
        let shown = path.display().to_string();
        let model = UaiModel::read(&path).map_err(|e| pgm_err(None, e))?;
        let mut graph = model
            .to_factor_graph()
            .map_err(|e| pgm_err(Some(&shown), e))?;
        let mut source = shown.clone();
        let mut chosen = Evidence::default();
        if let Some(evidence_path) = evidence {
            let shown_evidence = evidence_path.display().to_string();
            let read = Evidence::read_samples(&evidence_path, &model.cardinalities)
                .map_err(|e| pgm_err(None, e))?;
            let count = read.samples.len();
            if sample >= count {
                return Err(PgmError::new_err(format!(
                    "{shown_evidence}: sample {sample}, but the file holds {count} evidence sample{} (counted from 0)",
                    if count == 1 { "" } else { "s" }
                )));
            }
            chosen = read.samples.into_iter().nth(sample).unwrap_or_default();
            chosen
                .apply(&mut graph)
                .map_err(|e| pgm_err(Some(&shown_evidence), e))?;
            source = format!("{shown} with {shown_evidence}");
        }
        // As `pgm map`: a model (or evidence) that arc consistency proves to have no
        // assignment of positive probability is refused here, naming the table.
        model
            .check_positive(&chosen)
            .map_err(|e| pgm_err(Some(&source), e))?;
        Ok(Self {
            graph,
            source: Some(source),
            specialised: false,
        })
    }

    /// Adds a factor over `scope` (variable indices, no repeats) with `table`, a numpy
    /// array of shape `[cardinality of v for v in scope]`: potentials (>= 0, zeros are
    /// hard constraints) or, with `log=True`, log-potentials (finite or −inf). Returns
    /// the factor's index.
    #[pyo3(signature = (scope, table, log=false))]
    fn add_factor(
        &mut self,
        scope: Vec<i64>,
        table: &Bound<'_, PyAny>,
        log: bool,
    ) -> PyResult<usize> {
        let scope = counts("scope", &scope)?;
        let table = float_array(table, "table")?;
        let shape = table.shape().to_vec();
        if shape.len() != scope.len() {
            return Err(PgmError::new_err(format!(
                "table: {} axes for a scope of {} variables {:?}: a factor's table has one axis per scope variable",
                shape.len(),
                scope.len(),
                scope
            )));
        }
        for (axis, (&v, &k)) in scope.iter().zip(&shape).enumerate() {
            if v >= self.graph.num_variables() {
                return Err(PgmError::new_err(format!(
                    "scope[{axis}] = {v}: the graph has {} variables (0 to {})",
                    self.graph.num_variables(),
                    self.graph.num_variables().saturating_sub(1)
                )));
            }
            let card = self.graph.cardinality(VariableId(v));
            if card != k {
                return Err(PgmError::new_err(format!(
                    "table: axis {axis} has {k} entries, but variable {v} has cardinality {card}"
                )));
            }
        }
        // C order whatever the array's memory layout.
        let values: Vec<f64> = table.as_array().iter().copied().collect();
        let bad = values.iter().position(|&x| {
            if log {
                x.is_nan() || x == f64::INFINITY
            } else {
                !(x.is_finite() && x >= 0.0)
            }
        });
        if let Some(flat) = bad {
            // The entry's index in the table's own axes.
            let mut index = vec![0usize; shape.len()];
            let mut rest = flat;
            for (axis, &k) in shape.iter().enumerate().rev() {
                index[axis] = rest % k;
                rest /= k;
            }
            let expected = if log {
                "log-potentials (log=True) must be finite or -inf"
            } else {
                "potentials must be finite and >= 0 (0 is a hard constraint; log=True takes log-potentials)"
            };
            return Err(PgmError::new_err(format!(
                "table{index:?} = {}: {expected}",
                values[flat]
            )));
        }
        let ids: Vec<VariableId> = scope.iter().map(|&v| VariableId(v)).collect();
        let factor = if log {
            TableFactor::new(ids, shape, values)
        } else {
            TableFactor::from_potentials(ids, shape, &values)
        }
        .map_err(|e| pgm_err(None, e))?;
        let id = self
            .graph
            .add_factor(factor)
            .map_err(|e| pgm_err(None, e))?;
        self.specialised = false;
        Ok(id.0)
    }

    /// Number of variables.
    #[getter]
    fn num_variables(&self) -> usize {
        self.graph.num_variables()
    }

    /// Number of factors.
    #[getter]
    fn num_factors(&self) -> usize {
        self.graph.num_factors()
    }

    /// The cardinality of each variable.
    #[getter]
    fn cardinalities(&self) -> Vec<usize> {
        self.graph.cardinalities().to_vec()
    }

    /// The log-score of a complete assignment: the sum of its log-potentials (−inf
    /// where a table is 0).
    fn log_score(&self, assignment: Vec<i64>) -> PyResult<f64> {
        let assignment = counts("assignment", &assignment)?;
        self.graph
            .log_score(&assignment)
            .map_err(|e| pgm_err(self.context(), e))
    }

    /// MAP assignment by max-product belief propagation.
    ///
    /// Returns a dict: `assignment` (int64 array, one state per variable),
    /// `log_score`, `max_marginals` (one row per variable, max-marginals rescaled
    /// to sum to 1), `iterations`, `converged`, `residual` (the last undamped message
    /// change), `contradictions` and `seconds` (the run alone, as `pgm map --stats`
    /// times it). Raises `PgmError` for bad settings or a model
    /// with no assignment of positive probability.
    #[pyo3(signature = (schedule="sequential", damping=0.0, tolerance=1e-9, max_iterations=1000))]
    fn map<'py>(
        &mut self,
        py: Python<'py>,
        schedule: &str,
        damping: f64,
        tolerance: f64,
        max_iterations: i64,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.run_bp(
            py,
            Mode::MaxProduct,
            schedule,
            damping,
            tolerance,
            max_iterations,
        )
    }

    /// Marginals by sum-product belief propagation (exact on trees, approximate on
    /// loopy graphs).
    ///
    /// Returns a dict: `marginals` (one row of probabilities per variable: a 2-D
    /// array when every variable has the same cardinality, else a list of arrays),
    /// `assignment` (the most probable state of each), `log_score` (of that
    /// assignment), `iterations`, `converged`, `residual`, `contradictions` and
    /// `seconds` (the run alone).
    #[pyo3(signature = (schedule="sequential", damping=0.0, tolerance=1e-9, max_iterations=1000))]
    fn marginals<'py>(
        &mut self,
        py: Python<'py>,
        schedule: &str,
        damping: f64,
        tolerance: f64,
        max_iterations: i64,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.run_bp(
            py,
            Mode::SumProduct,
            schedule,
            damping,
            tolerance,
            max_iterations,
        )
    }

    /// MAP assignment by TRW-S (sequential tree-reweighted message passing), with an
    /// upper bound on the best log-score.
    ///
    /// Returns a dict: `assignment`, `log_score`, `bound` (no assignment scores
    /// higher), `gap` (`bound − log_score`, 0 proves the assignment optimal),
    /// `iterations`, `converged`, `termination` and `seconds` (the run alone).
    #[pyo3(signature = (tolerance=1e-9, max_iterations=1000))]
    fn trws<'py>(
        &mut self,
        py: Python<'py>,
        tolerance: f64,
        max_iterations: i64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let trws = TrwsParams::default()
            .max_iterations(count("max_iterations", max_iterations)?)
            .tolerance(tolerance)
            .check()
            .map_err(|e| pgm_err(None, e))?;
        self.prepare();
        let graph = &self.graph;
        let (result, seconds) = py.detach(|| {
            let started = std::time::Instant::now();
            let result = trws.run(graph);
            (result, started.elapsed().as_secs_f64())
        });
        let result = result.map_err(|e| pgm_err(self.context(), e))?;
        if let Some(zero) = &result.zero_decoding {
            let message = format!(
                "TRW-S decoded {:?}, which has probability 0 ({}); returning instead the first assignment of positive probability found by a search guided by its messages (log-score {}, gap {} to the bound)",
                zero.assignment, zero.violated, result.log_score, result.gap
            );
            PyErr::warn(
                py,
                &py.get_type::<PyUserWarning>(),
                &std::ffi::CString::new(message)?,
                1,
            )?;
        }
        let d = PyDict::new(py);
        let assignment: Vec<i64> = result.assignment.iter().map(|&s| s as i64).collect();
        d.set_item("assignment", PyArray1::from_vec(py, assignment))?;
        d.set_item("log_score", result.log_score)?;
        d.set_item("bound", result.bound)?;
        d.set_item("gap", result.gap)?;
        d.set_item("iterations", result.iterations)?;
        d.set_item("converged", result.converged)?;
        let termination = match result.termination {
            TrwsTermination::GapClosed => "gap_closed",
            TrwsTermination::BoundSettled => "bound_settled",
            TrwsTermination::IterationLimit => "iteration_limit",
            TrwsTermination::TimeBudget => "time_budget",
            TrwsTermination::Observer => "observer",
        };
        d.set_item("termination", termination)?;
        d.set_item("seconds", seconds)?;
        Ok(d)
    }

    /// The model in the UAI format (MARKOV), as `pgm` writes it.
    fn to_uai(&self) -> String {
        UaiModel::from_factor_graph(&self.graph).to_uai_string()
    }

    fn __repr__(&self) -> String {
        format!(
            "FactorGraph(variables={}, factors={})",
            self.graph.num_variables(),
            self.graph.num_factors()
        )
    }
}

impl PyFactorGraph {
    fn run_bp<'py>(
        &mut self,
        py: Python<'py>,
        mode: Mode,
        schedule: &str,
        damping: f64,
        tolerance: f64,
        max_iterations: i64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let kind = schedule_kind(schedule)?;
        let max_iterations = count("max_iterations", max_iterations)?;
        let bp = BpParams::new(mode)
            .damping(damping)
            .tolerance(tolerance)
            .max_iterations(max_iterations)
            .check()
            .map_err(|e| pgm_err(None, e))?;
        self.prepare();
        let graph = &self.graph;
        // `seconds` times the run alone, as `pgm map --stats` does.
        let (result, seconds) = py.detach(|| {
            let mut schedule = kind.build();
            let started = std::time::Instant::now();
            let result = bp.run(graph, &mut schedule);
            (result, started.elapsed().as_secs_f64())
        });
        let result = result.map_err(|e| pgm_err(self.context(), e))?;
        if let Some(zero) = &result.zero_decoding {
            let message = format!(
                "max-product ({schedule} schedule) decoded {:?}, which has probability 0 ({}); returning instead the first assignment of positive probability found by a search guided by its messages (log-score {}, no optimality claim: trws() bounds the gap)",
                zero.assignment, zero.violated, result.log_score
            );
            PyErr::warn(
                py,
                &py.get_type::<PyUserWarning>(),
                &std::ffi::CString::new(message)?,
                1,
            )?;
        }
        if result.support_undecided {
            let message = "the search for an assignment of positive probability gave up before a verdict, so Z > 0 is unverified and these marginals may describe a model with none";
            PyErr::warn(
                py,
                &py.get_type::<PyUserWarning>(),
                &std::ffi::CString::new(message)?,
                1,
            )?;
        }
        if mode == Mode::SumProduct && result.log_score == f64::NEG_INFINITY {
            let message = "the most probable state of each variable makes an assignment of probability 0 (log_score -inf): on a loopy model with hard zeros the marginals' modes need not fit together; map() or trws() give a feasible assignment";
            PyErr::warn(
                py,
                &py.get_type::<PyUserWarning>(),
                &std::ffi::CString::new(message)?,
                1,
            )?;
        }
        let key = match mode {
            Mode::MaxProduct => "max_marginals",
            Mode::SumProduct => "marginals",
        };
        let d = bp_result_dict(py, &result, key)?;
        d.set_item("seconds", seconds)?;
        Ok(d)
    }
}

/// pgm's graphical-model core, compiled (use it through the `pgm` package).
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFactorGraph>()?;
    m.add_class::<tracking::PyOnlineTracker>()?;
    m.add_class::<learning::PyFeatureSet>()?;
    m.add_class::<learning::PyLogLinearModel>()?;
    m.add_function(wrap_pyfunction!(learning::learn, m)?)?;
    m.add_function(wrap_pyfunction!(scans::read_carmen, m)?)?;
    m.add_function(wrap_pyfunction!(scans::read_leigh, m)?)?;
    m.add_function(wrap_pyfunction!(scans::read_bag_scans, m)?)?;
    m.add_function(wrap_pyfunction!(scans::read_people, m)?)?;
    m.add_function(wrap_pyfunction!(scans::read_relations, m)?)?;
    m.add_function(wrap_pyfunction!(methods::match_scans, m)?)?;
    m.add_function(wrap_pyfunction!(methods::associate, m)?)?;
    m.add_function(wrap_pyfunction!(methods::cluster, m)?)?;
    m.add("PgmError", m.py().get_type::<PgmError>())?;
    Ok(())
}
