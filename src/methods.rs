//! The methods the command-line tool, the examples and the tests know by name: one
//! table per interface ([`MotionClusterer`], [`ScanMatcher`],
//! [`AssociationSource`], [`JointEstimator`]) of [`Method`] entries. A model crate
//! implements the interface; adding it here is one entry, never a branch in a
//! command: the commands build their `--method` choices from these tables.
//!
//! ```
//! use pgm::methods::{association_source, clusterer, joint_estimator, MethodOptions};
//!
//! let options = MethodOptions::default();
//! let icp = association_source("icp", &options).unwrap();
//! let crf = clusterer("crf", icp, &options).unwrap();
//! assert_eq!(crf.name(), "crf (icp)");
//! assert!(clusterer("no-such-method", association_source("true", &options).unwrap(), &options).is_err());
//!
//! let separate = joint_estimator("separate", &options).unwrap();
//! assert_eq!(separate.name(), "separate");
//! ```

use pgm_baselines::consistency::ConsistencyParams;
use pgm_baselines::motion_kmeans::MotionKMeansParams;
use pgm_crf_clustering::{ClusteringParams, ClusteringWeights};
use pgm_crf_matching::{MatchingParams, MatchingWeights};
use pgm_joint::{JointParams, JointWeights};
use pgm_scan::association::{
    AssociationSource, GroundTruthAssociations, NearestParams, SegmentParams,
};
use pgm_scan::methods::{
    Associated, JointClusters, JointEgoMotion, JointEstimator, MotionClusterer, Odometry,
    OneCluster, ScanMatcher, TwoSteps,
};
use pgm_scan::registration::IcpParams;
use pgm_scan::{ParamGuard, ScanPair};
use std::fmt;
use std::sync::Arc;

/// Why a method could not be made: an unknown name (with the known ones) or invalid
/// parameters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MethodError(pub String);

impl fmt::Display for MethodError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for MethodError {}

fn invalid(e: impl fmt::Display) -> MethodError {
    MethodError(e.to_string())
}

/// `e` prefixed with the method whose parameter it concerns.
fn of(method: &str, e: impl fmt::Display) -> MethodError {
    MethodError(format!("{method}: {e}"))
}

/// The parameters of every method, as the command line sets them (defaults: each
/// method's own).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MethodOptions {
    /// CRF-Clustering.
    pub crf: ClusteringParams,
    /// Motion K-Means.
    pub kmeans: MotionKMeansParams,
    /// The consistency-based detector.
    pub cbd: ConsistencyParams,
    /// ICP (scan matching).
    pub icp: IcpParams,
    /// Nearest neighbour after ICP (associations).
    pub nearest: NearestParams,
    /// Segment-wise ICP (associations).
    pub segment: SegmentParams,
    /// CRF-Matching (associations and scan matching).
    pub matching: MatchingParams,
    /// The joint model (associations, clusters and motions together).
    pub joint: JointParams,
}

impl MethodOptions {
    /// These options with the CRF-Matching weights and boosters loaded from `path` (a
    /// file written by `pgm train matching`).
    pub fn with_matching_weights(mut self, path: &std::path::Path) -> Result<Self, MethodError> {
        self.matching.weights =
            load_weights(path, WeightKind::Matching, |p| MatchingWeights::load(p))?;
        Ok(self)
    }

    /// Checks the parameters of every method, used or not: a value that means nothing
    /// is an error even when the chosen method would not read it (`pgm cluster
    /// --associations true --gate nan` is refused, not silently ignored).
    /// The error names the method whose parameter it is (`motion K-Means: parameter
    /// `k` = 0: …`).
    pub fn check(&self) -> Result<(), MethodError> {
        self.crf.check_ref().map_err(|e| of("CRF-Clustering", e))?;
        self.kmeans
            .check_ref()
            .map_err(|e| of("motion K-Means", e))?;
        self.cbd.check_ref().map_err(|e| of("CBD", e))?;
        self.icp.check_ref().map_err(|e| of("ICP", e))?;
        self.nearest
            .check_ref()
            .map_err(|e| of("ICP associations", e))?;
        self.segment
            .check_ref()
            .map_err(|e| of("segment-wise ICP", e))?;
        self.matching
            .check_ref()
            .map_err(|e| of("CRF-Matching", e))?;
        self.joint.check_ref().map_err(|e| of("the joint model", e))
    }

    /// These options with the joint model's weights and boosters loaded from `path` (a
    /// file written by `pgm train joint`).
    pub fn with_joint_weights(mut self, path: &std::path::Path) -> Result<Self, MethodError> {
        self.joint.weights = load_weights(path, WeightKind::Joint, |p| JointWeights::load(p))?;
        Ok(self)
    }

    /// These options with the CRF-Clustering weights loaded from `path` (a file
    /// written by `pgm train clustering`).
    pub fn with_crf_weights(mut self, path: &std::path::Path) -> Result<Self, MethodError> {
        self.crf.weights =
            load_weights(path, WeightKind::Clustering, |p| ClusteringWeights::load(p))?;
        Ok(self)
    }
}

/// The kinds of weight file, by the model that reads them (the `model` field every
/// weight file starts with).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightKind {
    /// CRF-Clustering (`pgm train clustering`; `--weights`, `--crf-weights`).
    Clustering,
    /// CRF-Matching (`pgm train matching`; `--matching-weights`,
    /// `--association-weights`).
    Matching,
    /// The joint model (`pgm train joint`; `--weights` of the joint commands,
    /// `--joint-weights`).
    Joint,
}

impl WeightKind {
    const ALL: [WeightKind; 3] = [
        WeightKind::Clustering,
        WeightKind::Matching,
        WeightKind::Joint,
    ];

    /// The `model` field of such a file.
    pub fn model(self) -> &'static str {
        match self {
            WeightKind::Clustering => "crf-clustering",
            WeightKind::Matching => "crf-matching",
            WeightKind::Joint => "joint",
        }
    }

    /// The model's name in messages.
    pub fn title(self) -> &'static str {
        match self {
            WeightKind::Clustering => "CRF-Clustering",
            WeightKind::Matching => "CRF-Matching",
            WeightKind::Joint => "joint-model",
        }
    }

    /// The command that writes such a file.
    pub fn trainer(self) -> &'static str {
        match self {
            WeightKind::Clustering => "pgm train clustering",
            WeightKind::Matching => "pgm train matching",
            WeightKind::Joint => "pgm train joint",
        }
    }

    /// The shipped weights of this kind, and how they were made (the commands'
    /// reports of the weights they ran with).
    pub fn shipped(self) -> &'static str {
        match self {
            WeightKind::Clustering => {
                "shipped CRF-Clustering weights (pgm train clustering --simulate 40 --seed 1000)"
            }
            WeightKind::Matching => {
                "shipped CRF-Matching weights (pgm train matching --simulate 40 --seed 1000)"
            }
            WeightKind::Joint => {
                "shipped joint weights (pgm train joint --simulate 40 --seed 1000 \
                 --association-weights models/crf-matching/weights/default.json)"
            }
        }
    }
}

/// The weights a method with weight files of `kinds` (its registry entry's
/// [`Method::weights`]) runs with, for a report: per kind the file `given` names, else
/// the shipped ones ([`WeightKind::shipped`]), joined by `; `; `none (no learned
/// weights)` for a method without.
pub fn weights_used<'p>(
    kinds: &[WeightKind],
    given: impl Fn(WeightKind) -> Option<&'p std::path::Path>,
) -> String {
    if kinds.is_empty() {
        return "none (no learned weights)".into();
    }
    kinds
        .iter()
        .map(|&k| given(k).map_or(k.shipped().into(), |p| p.display().to_string()))
        .collect::<Vec<String>>()
        .join("; ")
}

/// Loads a weight file of `kind` with `load`. The error names the file once (the
/// loaders' own errors name it already, and a prefix made `PATH: PATH: …`) and, for a
/// weight file of another model, says which kind of file it is instead of the parser's
/// complaint about the first field it does not know.
pub fn load_weights<T, E: fmt::Display>(
    path: &std::path::Path,
    kind: WeightKind,
    load: impl FnOnce(&std::path::Path) -> Result<T, E>,
) -> Result<T, MethodError> {
    load(path).map_err(|e| {
        let shown = path.display().to_string();
        if let Some(other) = weight_kind_of(path).filter(|k| *k != kind) {
            return MethodError(format!(
                "{shown}: not a {} weight file: it is a {} weight file (`\"model\": \"{}\"`, \
                 written by `{}`); {} weights are written by `{}`",
                kind.title(),
                other.title(),
                other.model(),
                other.trainer(),
                kind.title(),
                kind.trainer()
            ));
        }
        let message = e.to_string();
        if message.starts_with(&shown) {
            MethodError(message)
        } else {
            MethodError(format!("{shown}: {message}"))
        }
    })
}

/// The kind of weight file at `path` by its `model` field, if it is JSON with one
/// that names a model of this workspace.
fn weight_kind_of(path: &std::path::Path) -> Option<WeightKind> {
    let text = std::fs::read_to_string(path).ok()?;
    let value: serde_json::Value = serde_json::from_str(&text).ok()?;
    let model = value.get("model")?.as_str()?;
    WeightKind::ALL.into_iter().find(|k| k.model() == model)
}

/// A registered method: the name the command line and the tables use, what it is,
/// and how it is built from the [`MethodOptions`] (`B` is the builder's type, one per
/// interface). Adding a method is one entry in its interface's table: every command,
/// example and test looks methods up there.
#[derive(Clone, Copy)]
pub struct Method<B> {
    /// The name, as typed (`--method NAME`).
    pub name: &'static str,
    /// What it is, in one line (the command line's help).
    pub about: &'static str,
    /// The kinds of weight file it reads (none for a method without learned weights):
    /// the commands report which weights it ran with ([`weights_used`]).
    pub weights: &'static [WeightKind],
    /// How it is built.
    pub build: B,
}

impl<B> fmt::Debug for Method<B> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Method").field("name", &self.name).finish()
    }
}

/// The entry of `table` named `name`, if there is one.
pub fn find<B>(table: &'static [Method<B>], name: &str) -> Option<&'static Method<B>> {
    table.iter().find(|m| m.name == name)
}

/// The entry of `table` named `name`, or the error listing the known names.
fn lookup<'t, B>(
    table: &'t [Method<B>],
    kind: &str,
    name: &str,
) -> Result<&'t Method<B>, MethodError> {
    table.iter().find(|m| m.name == name).ok_or_else(|| {
        let names: Vec<&str> = table.iter().map(|m| m.name).collect();
        MethodError(format!(
            "unknown {kind} `{name}`: expected one of {}",
            names.join(", ")
        ))
    })
}

/// Builds an association source.
pub type BuildAssociations = fn(&MethodOptions) -> Result<Arc<dyn AssociationSource>, MethodError>;

/// The association sources.
pub const ASSOCIATION_SOURCES: &[Method<BuildAssociations>] = &[
    Method {
        name: "true",
        about: "the pair's ground-truth associations (simulated data)",
        weights: &[],
        build: |_| Ok(Arc::new(GroundTruthAssociations)),
    },
    Method {
        name: "icp",
        about: "nearest neighbour after ICP (ego-motion only)",
        weights: &[],
        build: |o| Ok(Arc::new(o.nearest.check().map_err(invalid)?)),
    },
    Method {
        name: "segment-icp",
        about: "segment-wise ICP, then nearest neighbours under each segment's motion",
        weights: &[],
        build: |o| Ok(Arc::new(o.segment.check().map_err(invalid)?)),
    },
    Method {
        name: "crf-matching",
        about: "CRF-Matching: learned association by a chain CRF over boosted shape features",
        weights: &[WeightKind::Matching],
        build: |o| Ok(Arc::new(o.matching.clone().check().map_err(invalid)?)),
    },
];

/// The association source named `name` (see [`ASSOCIATION_SOURCES`]).
pub fn association_source(
    name: &str,
    options: &MethodOptions,
) -> Result<Arc<dyn AssociationSource>, MethodError> {
    (lookup(ASSOCIATION_SOURCES, "association source", name)?.build)(options)
}

/// The default association source for `pairs`: their ground truth when every pair has
/// it, else nearest neighbour after ICP (segment-wise ICP is better on simulated
/// street scenes but worse on leigh-gtm1; docs/decisions.md).
pub fn default_association(pairs: &[ScanPair]) -> &'static str {
    if !pairs.is_empty()
        && pairs
            .iter()
            .all(|p| p.truth.as_ref().is_some_and(|t| t.associations.is_some()))
    {
        "true"
    } else {
        "icp"
    }
}

/// A motion clusterer built, or why not.
pub type ClustererResult = Result<Box<dyn MotionClusterer>, MethodError>;

/// How a motion clusterer is built: on its own, or fed by an association source.
#[derive(Clone, Copy)]
pub enum BuildClusterer {
    /// A clusterer that reads the pair alone.
    Alone(fn(&MethodOptions) -> ClustererResult),
    /// A clusterer fed by any association source (`--associations`).
    WithAssociations(fn(Arc<dyn AssociationSource>, &MethodOptions) -> ClustererResult),
}

/// A motion clusterer's entry: how it is built and what it reports.
#[derive(Clone, Copy)]
pub struct Clusterer {
    /// How it is built.
    pub build: BuildClusterer,
    /// Whether it estimates its clusters' motions (`pgm eval clustering` then reports
    /// their errors).
    pub motions: bool,
}

/// The motion clusterers.
pub const CLUSTERERS: &[Method<Clusterer>] = &[
    Method {
        name: "crf",
        about: "CRF-Clustering (Tipaldi and Ramos), fed by an association source",
        weights: &[WeightKind::Clustering],
        build: Clusterer {
            build: BuildClusterer::WithAssociations(|a, o| {
            Ok(Box::new(Associated::new(
                o.crf.clone().check().map_err(invalid)?,
                a,
            )))
        }),
            motions: true,
        },
    },
    Method {
        name: "cbd",
        about: "the consistency-based detector (Wang et al.)",
        weights: &[],
        build: Clusterer {
            build: BuildClusterer::Alone(|o| Ok(Box::new(o.cbd.check().map_err(invalid)?))),
            motions: false,
        },
    },
    Method {
        name: "kmeans",
        about: "motion K-Means (eq. 10), fed by an association source",
        weights: &[],
        build: Clusterer {
            build: BuildClusterer::WithAssociations(|a, o| {
            Ok(Box::new(Associated::new(o.kmeans.check().map_err(invalid)?, a)))
        }),
            motions: true,
        },
    },
    Method {
        name: "one-cluster",
        about: "every return in the background cluster",
        weights: &[],
        build: Clusterer {
            build: BuildClusterer::Alone(|_| Ok(Box::new(OneCluster))),
            motions: false,
        },
    },
    Method {
        name: "joint",
        about: "the joint model (van de Ven, Ramos and Tipaldi): its clusters, the outlier cluster as background",
        weights: &[WeightKind::Joint],
        build: Clusterer {
            build: BuildClusterer::Alone(|o| {
            Ok(Box::new(JointClusters(o.joint.clone().check().map_err(invalid)?)))
        }),
            motions: true,
        },
    },
];

/// Whether the clusterer `name` takes point associations (false for an unknown name).
pub fn clusterer_needs_associations(name: &str) -> bool {
    find(CLUSTERERS, name)
        .is_some_and(|m| matches!(m.build.build, BuildClusterer::WithAssociations(_)))
}

/// The motion clusterer named `name` (see [`CLUSTERERS`]); `associations` feeds the
/// methods that need them.
pub fn clusterer(
    name: &str,
    associations: Arc<dyn AssociationSource>,
    options: &MethodOptions,
) -> Result<Box<dyn MotionClusterer>, MethodError> {
    match lookup(CLUSTERERS, "clustering method", name)?.build.build {
        BuildClusterer::Alone(build) => build(options),
        BuildClusterer::WithAssociations(build) => build(associations, options),
    }
}

/// Builds a scan matcher.
pub type BuildMatcher = fn(&MethodOptions) -> Result<Box<dyn ScanMatcher>, MethodError>;

/// The scan matchers.
pub const SCAN_MATCHERS: &[Method<BuildMatcher>] = &[
    Method {
        name: "odometry",
        about: "the odometry prior (the identity without odometry)",
        weights: &[],
        build: |_| Ok(Box::new(Odometry)),
    },
    Method {
        name: "icp",
        about: "point-to-point ICP from the odometry prior",
        weights: &[],
        build: |o| Ok(Box::new(o.icp.check().map_err(invalid)?)),
    },
    Method {
        name: "icp+csm",
        about: "correlative search around the prior (±1 m, ±30°), refined by ICP",
        weights: &[],
        build: |_| {
            Ok(Box::new(
                pgm_scan::correlative::CorrelativeIcpMatcher::default(),
            ))
        },
    },
    Method {
        name: "crf-matching",
        about: "CRF-Matching: the ego-motion of its MAP associations",
        weights: &[WeightKind::Matching],
        build: |o| Ok(Box::new(o.matching.clone().check().map_err(invalid)?)),
    },
    Method {
        name: "joint",
        about: "the joint model: the background cluster's motion",
        weights: &[WeightKind::Joint],
        build: |o| {
            Ok(Box::new(JointEgoMotion(
                o.joint.clone().check().map_err(invalid)?,
            )))
        },
    },
];

/// The scan matcher named `name` (see [`SCAN_MATCHERS`]).
pub fn scan_matcher(
    name: &str,
    options: &MethodOptions,
) -> Result<Box<dyn ScanMatcher>, MethodError> {
    (lookup(SCAN_MATCHERS, "scan-matching method", name)?.build)(options)
}

/// The number of clusters of motion K-Means in the joint paper's experiments
/// ("the number of clusters is set to 4"); `pgm eval joint`, `pgm demo` and the
/// `tables_joint` example run the K-Means pipelines with it.
pub const JOINT_PAPER_KMEANS_K: usize = 4;

/// Builds a joint method.
pub type BuildJoint = fn(&MethodOptions) -> Result<Box<dyn JointEstimator>, MethodError>;

/// The joint methods (associations, clusters and motions of a pair together). The
/// two-step pipelines are the joint paper's baselines; they put a return their
/// association source calls an outlier in the outlier cluster
/// ([`pgm_scan::methods::JointEstimate::from_two_steps`]).
pub const JOINT_ESTIMATORS: &[Method<BuildJoint>] = &[
    Method {
        name: "joint",
        about: "the joint model: association and clustering chains coupled by per-cluster motions",
        weights: &[WeightKind::Joint],
        build: |o| Ok(Box::new(o.joint.clone().check().map_err(invalid)?)),
    },
    Method {
        name: "icp+kmeans",
        about: "nearest neighbour after ICP, then motion K-Means on those associations",
        weights: &[],
        build: |o| {
            Ok(Box::new(TwoSteps::new(
                "icp+kmeans",
                o.kmeans.check().map_err(invalid)?,
                association_source("icp", o)?,
            )))
        },
    },
    Method {
        name: "crf-matching+kmeans",
        about: "CRF-Matching, then motion K-Means on its associations",
        weights: &[WeightKind::Matching],
        build: |o| {
            Ok(Box::new(TwoSteps::new(
                "crf-matching+kmeans",
                o.kmeans.check().map_err(invalid)?,
                association_source("crf-matching", o)?,
            )))
        },
    },
    Method {
        name: "separate",
        about: "CRF-Matching, then CRF-Clustering on its associations (the chains without the shared motions)",
        weights: &[WeightKind::Matching, WeightKind::Clustering],
        build: |o| {
            Ok(Box::new(TwoSteps::new(
                "separate",
                o.crf.clone().check().map_err(invalid)?,
                association_source("crf-matching", o)?,
            )))
        },
    },
];

/// The joint method named `name` (see [`JOINT_ESTIMATORS`]).
pub fn joint_estimator(
    name: &str,
    options: &MethodOptions,
) -> Result<Box<dyn JointEstimator>, MethodError> {
    (lookup(JOINT_ESTIMATORS, "joint method", name)?.build)(options)
}
