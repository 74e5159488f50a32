//! The weight file every model reads and writes: one type, [`WeightFile`], for
//! CRF-Clustering, CRF-Matching and the joint model.
//!
//! A weight file is a JSON object: the model's kind tag (`model`, `version`), its named
//! weights in the core's format ([`Weights`]: `"weights": {name: value}` in feature
//! order) and the model's other learned parts, one field each ([`WeightParts`]: none for
//! CRF-Clustering, the two association boosters `data_booster` and `outlier_booster`
//! for CRF-Matching and the joint model):
//!
//! ```json
//! {
//!   "model": "crf-matching",
//!   "version": 1,
//!   "weights": {
//!     "data_boosting.score": 0.88,
//!     …
//!   },
//!   "data_booster": {"features": 19, "stumps": […]},
//!   "outlier_booster": {"features": 6, "stumps": […]}
//! }
//! ```
//!
//! Reading checks the kind tag first (a file of another model or version is named as
//! such), then every field, and refuses a missing, unknown or malformed one naming the
//! source and the field ([`WeightFileError`]); a model's own checks of the values
//! ([`ModelWeights::check_values`]) come last and name the source too. Writing is
//! atomic ([`pgm_core::fsutil::write_atomically`]). A model's weight type implements
//! [`ModelWeights`] and gets its `from_json`, `to_json`, `load`, `save`, `named` and
//! `default_weights` from [`model_weights_api!`](crate::model_weights_api).
//!
//! ```
//! use pgm_features::weight_file::{feature_set, WeightFile};
//!
//! let features = feature_set("toy", 1, [("pair", &["same", "different"][..])]);
//! let text = r#"{"model": "toy", "version": 1, "weights": {"pair.same": 1.5, "pair.different": -0.25}}"#;
//! let file = WeightFile::<()>::from_json(features.clone(), "toy", text, "toy.json").unwrap();
//! assert_eq!(file.weights.get("pair.different"), Some(-0.25));
//! assert_eq!(WeightFile::<()>::from_json(features.clone(), "toy", &file.to_json(), "again").unwrap(), file.with_origin("again"));
//!
//! let other = r#"{"model": "crf-matching", "version": 1, "weights": {}}"#;
//! let e = WeightFile::<()>::from_json(features.clone(), "toy", other, "m.json").unwrap_err();
//! assert!(e.to_string().starts_with("m.json: not a toy weight file: field `model` is \"crf-matching\""), "{e}");
//! let e = WeightFile::<()>::from_json(features, "toy", r#"{"model": "toy", "version": 1}"#, "t.json").unwrap_err();
//! assert_eq!(e.to_string(), "t.json: field `weights`: missing");
//! ```

use crate::boosting::Booster;
use crate::matching_features::AssociationBoosters;
use crate::{ModelError, ModelResult};
use pgm_core::learning::FeatureSet;
pub use pgm_core::learning::Weights;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why a weight file cannot be read, written or used. Every variant names the file (or
/// the other source the weights came from) first.
#[derive(Debug, thiserror::Error)]
pub enum WeightFileError {
    /// The file cannot be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The text is not a JSON object.
    #[error("{origin}: not a {title} weight file: {source}")]
    NotJson {
        /// The source of the weights.
        origin: String,
        /// The model's name in messages (`CRF-Matching`).
        title: &'static str,
        /// The parser's error.
        source: serde_json::Error,
    },
    /// The kind tag names another model, or another version of this one.
    #[error(
        "{origin}: not a {title} weight file: field `model` is {found_model:?} version \
         {found_version}, expected {expected_model:?} version {expected_version}"
    )]
    ModelMismatch {
        /// The source of the weights.
        origin: String,
        /// The model's name in messages.
        title: &'static str,
        /// The `model` field expected.
        expected_model: String,
        /// The `version` expected.
        expected_version: u32,
        /// The `model` field found.
        found_model: String,
        /// The `version` found.
        found_version: u32,
    },
    /// A field is missing, unknown or malformed (`weights.NAME` for one weight).
    #[error("{origin}: field `{field}`: {problem}")]
    Field {
        /// The source of the weights.
        origin: String,
        /// The field.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The file reads, but the model refuses its values (the model's error says why).
    #[error("{origin}: {source}")]
    Rejected {
        /// The source of the weights.
        origin: String,
        /// The model's reason.
        source: Box<ModelError>,
    },
}

/// What a weight file holds besides the kind tag and the named weights: one JSON field
/// each, all required.
pub trait WeightParts: Sized {
    /// The names of the fields.
    const FIELDS: &'static [&'static str];

    /// Reads the parts from `field(name)`, the JSON of each of [`Self::FIELDS`]; the
    /// error is `(field, problem)`.
    fn read(field: impl FnMut(&'static str) -> Value) -> Result<Self, (&'static str, String)>;

    /// The fields, in [`Self::FIELDS`] order.
    fn write(&self) -> Vec<(&'static str, Value)>;
}

/// No parts (CRF-Clustering: the named weights are the whole model).
impl WeightParts for () {
    const FIELDS: &'static [&'static str] = &[];

    fn read(_: impl FnMut(&'static str) -> Value) -> Result<Self, (&'static str, String)> {
        Ok(())
    }

    fn write(&self) -> Vec<(&'static str, Value)> {
        Vec::new()
    }
}

/// The association chain's two boosters (CRF-Matching, the joint model):
/// `data_booster` and `outlier_booster`.
impl WeightParts for AssociationBoosters {
    const FIELDS: &'static [&'static str] = &["data_booster", "outlier_booster"];

    fn read(mut field: impl FnMut(&'static str) -> Value) -> Result<Self, (&'static str, String)> {
        let mut booster = |name| {
            serde_json::from_value::<Booster>(field(name)).map_err(|e| (name, e.to_string()))
        };
        Ok(AssociationBoosters {
            data: booster("data_booster")?,
            outlier: booster("outlier_booster")?,
        })
    }

    fn write(&self) -> Vec<(&'static str, Value)> {
        let json = |b: &Booster| serde_json::to_value(b).expect("boosters serialise");
        vec![
            ("data_booster", json(&self.data)),
            ("outlier_booster", json(&self.outlier)),
        ]
    }
}

/// A model's weight file: its named weights (whose feature set carries the kind tag,
/// `model` and `version`, and the feature names), the model's other parts, and where
/// it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct WeightFile<P> {
    /// The named weights.
    pub weights: Weights,
    /// The model's other learned parts.
    pub parts: P,
    /// Provenance: the file or other source the weights were read from (`new weights`
    /// for weights made in memory), as named in errors.
    pub origin: String,
}

impl<P: WeightParts> WeightFile<P> {
    /// Weights made in memory (trained, or converted).
    pub fn new(weights: Weights, parts: P) -> Self {
        Self {
            weights,
            parts,
            origin: "new weights".into(),
        }
    }

    /// The same weights with another provenance.
    pub fn with_origin(mut self, origin: &str) -> Self {
        self.origin = origin.to_string();
        self
    }

    /// Reads the text of a weight file of the model of `features` (`title` names the
    /// model in messages, `origin` the source).
    ///
    /// # Errors
    /// [`WeightFileError`] naming `origin`: not a JSON object, the kind tag of another
    /// model or version, a field missing, unknown or malformed, weight names that do
    /// not match `features`.
    pub fn from_json(
        features: Arc<FeatureSet>,
        title: &'static str,
        json: &str,
        origin: &str,
    ) -> ModelResult<Self> {
        let field_error = |field: &str, problem: String| WeightFileError::Field {
            origin: origin.to_string(),
            field: field.to_string(),
            problem,
        };
        let mut file: Map<String, Value> =
            serde_json::from_str(json).map_err(|source| WeightFileError::NotJson {
                origin: origin.to_string(),
                title,
                source,
            })?;
        let mut take = |field: &'static str| {
            file.remove(field)
                .ok_or_else(|| field_error(field, "missing".into()))
        };
        let model = take("model")?;
        let version = take("version")?;
        let (Some(found_model), Some(found_version)) = (
            model.as_str(),
            version.as_u64().and_then(|v| u32::try_from(v).ok()),
        ) else {
            let (field, value, expected) = match model.as_str() {
                None => ("model", &model, "a model name"),
                Some(_) => ("version", &version, "a version number"),
            };
            return Err(field_error(field, format!("{value}, expected {expected}")).into());
        };
        if found_model != features.model() || found_version != features.version() {
            return Err(WeightFileError::ModelMismatch {
                origin: origin.to_string(),
                title,
                expected_model: features.model().to_string(),
                expected_version: features.version(),
                found_model: found_model.to_string(),
                found_version,
            }
            .into());
        }
        let Value::Object(mut named) = take("weights")? else {
            return Err(
                field_error("weights", "expected an object of named weights".into()).into(),
            );
        };
        let mut values = Vec::with_capacity(features.num_weights());
        for name in features.names() {
            match named.remove(name) {
                Some(v) => values.push(v.as_f64().ok_or_else(|| {
                    field_error(
                        &format!("weights.{name}"),
                        format!("{v}, expected a number"),
                    )
                })?),
                None => {
                    return Err(field_error(&format!("weights.{name}"), "missing".into()).into())
                }
            }
        }
        if let Some(extra) = named.keys().next() {
            let problem = format!("not a weight of the {title} model");
            return Err(field_error(&format!("weights.{extra}"), problem).into());
        }
        let parts = P::read(|field| file.remove(field).unwrap_or(Value::Null))
            .map_err(|(field, problem)| field_error(field, problem))?;
        if let Some(extra) = file.keys().next() {
            let problem = format!("not a field of a {title} weight file");
            return Err(field_error(extra, problem).into());
        }
        let weights = Weights::new(features, values)
            .map_err(|e| ModelError::from(e).in_weight_file(origin))?;
        Ok(Self {
            weights,
            parts,
            origin: origin.to_string(),
        })
    }

    /// [`WeightFile::from_json`] of the file at `path` (named in errors).
    ///
    /// # Errors
    /// As `from_json`, and [`WeightFileError::Io`] when the file cannot be read.
    pub fn load(features: Arc<FeatureSet>, title: &'static str, path: &Path) -> ModelResult<Self> {
        Self::from_json(features, title, &read(path)?, &path.display().to_string())
    }

    /// The JSON text: the core's weight file ([`Weights::to_json`], pretty-printed, the
    /// weights in feature order) followed by the parts, pretty-printed.
    pub fn to_json(&self) -> String {
        let core = self.weights.to_json();
        let mut out = core
            .strip_suffix("\n}\n")
            .expect("the core's weight file ends with its closing brace")
            .to_string();
        for (field, value) in self.parts.write() {
            let value = serde_json::to_string_pretty(&value).expect("JSON values print");
            // Pretty JSON has no newline inside a string, so this indents one level.
            out += &format!(",\n  \"{field}\": {}", value.replace('\n', "\n  "));
        }
        out + "\n}\n"
    }

    /// Writes the file atomically: `path` holds the old file or the new one, never a
    /// part ([`pgm_core::fsutil::write_atomically`]).
    ///
    /// # Errors
    /// [`WeightFileError::Io`] naming the file that could not be written.
    pub fn save(&self, path: &Path) -> ModelResult<()> {
        pgm_core::fsutil::write_atomically(path, self.to_json().as_bytes()).map_err(|e| match e {
            pgm_core::Error::Io { path, source } => WeightFileError::Io { path, source }.into(),
            other => ModelError::Core(other),
        })
    }
}

/// The text of the file at `path`, or [`WeightFileError::Io`] naming it.
fn read(path: &Path) -> ModelResult<String> {
    std::fs::read_to_string(path).map_err(|source| {
        WeightFileError::Io {
            path: path.to_path_buf(),
            source,
        }
        .into()
    })
}

/// A feature set of `model` and `version` with `templates` (name, feature names) in
/// order.
///
/// # Panics
/// When the template names are not valid and distinct (they are fixed in the models).
pub fn feature_set<'a>(
    model: &str,
    version: u32,
    templates: impl IntoIterator<Item = (&'a str, &'a [&'a str])>,
) -> Arc<FeatureSet> {
    let mut f = FeatureSet::new(model, version);
    for (name, features) in templates {
        f.add_template(name, features)
            .expect("fixed template names are valid and distinct");
    }
    Arc::new(f)
}

/// A model's learned parameters as they are kept in a [`WeightFile`]. Implement it and
/// call [`model_weights_api!`](crate::model_weights_api) to give the type its
/// `from_json`, `to_json`, `load`, `save`, `named` and `default_weights`.
pub trait ModelWeights: Sized {
    /// The model's name in messages (`CRF-Clustering`, `CRF-Matching`, `joint-model`).
    const TITLE: &'static str;

    /// What the file holds besides the named weights.
    type Parts: WeightParts;

    /// The named weights (the kind tag is its model name and version).
    fn feature_set() -> Arc<FeatureSet>;

    /// The weights from a file's weights (in [`ModelWeights::feature_set`] order) and
    /// parts, unchecked.
    fn from_file(weights: &[f64], parts: Self::Parts) -> Self;

    /// The weights (in feature-set order) and parts to write.
    fn to_file(&self) -> (Vec<f64>, Self::Parts);

    /// The model's own checks of the values (sizes, finiteness, signs).
    ///
    /// # Errors
    /// The model's error naming what is wrong.
    fn check_values(&self) -> ModelResult<()>;

    /// All-zero weights with `parts`: the starting point of training, not a usable
    /// model.
    fn untrained(parts: Self::Parts) -> Self {
        Self::from_file(&vec![0.0; Self::feature_set().num_weights()], parts)
    }

    /// Parses the text of a weight file; `origin` names the source in errors.
    ///
    /// # Errors
    /// [`WeightFileError`] naming `origin`: not a weight file of this model (see
    /// [`WeightFile::from_json`]) or values the model refuses.
    fn from_json(json: &str, origin: &str) -> ModelResult<Self> {
        let file =
            WeightFile::<Self::Parts>::from_json(Self::feature_set(), Self::TITLE, json, origin)?;
        let weights = Self::from_file(file.weights.values(), file.parts);
        weights
            .check_values()
            .map_err(|e| e.in_weight_file(origin))?;
        Ok(weights)
    }

    /// Loads a weight file.
    ///
    /// # Errors
    /// As [`ModelWeights::from_json`] naming the file, and [`WeightFileError::Io`] when
    /// it cannot be read.
    fn load(path: impl AsRef<Path>) -> ModelResult<Self> {
        let path = path.as_ref();
        Self::from_json(&read(path)?, &path.display().to_string())
    }

    /// The weights as a [`WeightFile`].
    ///
    /// # Errors
    /// When the weights do not fit the feature set.
    fn to_weight_file(&self) -> ModelResult<WeightFile<Self::Parts>> {
        let (values, parts) = self.to_file();
        Ok(WeightFile::new(
            Weights::new(Self::feature_set(), values)?,
            parts,
        ))
    }

    /// The JSON text of the weight file.
    ///
    /// # Errors
    /// When the weights do not fit the feature set.
    fn to_json(&self) -> ModelResult<String> {
        Ok(self.to_weight_file()?.to_json())
    }

    /// Writes the weight file atomically.
    ///
    /// # Errors
    /// When the weights do not fit the feature set or the file cannot be written
    /// (named).
    fn save(&self, path: impl AsRef<Path>) -> ModelResult<()> {
        self.to_weight_file()?.save(path.as_ref())
    }
}

/// Gives a [`ModelWeights`] type its weight-file methods as inherent methods (so that
/// callers need not import the trait) and `Default` as the shipped weights:
/// `model_weights_api!(Type, DEFAULT_JSON)`, with `DEFAULT_JSON` the text of the
/// shipped weight file.
#[macro_export]
macro_rules! model_weights_api {
    ($weights:ty, $shipped:expr) => {
        impl $weights {
            /// Parses the text of a weight file; `origin` names the source in errors.
            ///
            /// # Errors
            /// A [`WeightFileError`]($crate::WeightFileError) naming `origin`: not a
            /// weight file of this model, or values it refuses.
            pub fn from_json(json: &str, origin: &str) -> $crate::ModelResult<Self> {
                <Self as $crate::weight_file::ModelWeights>::from_json(json, origin)
            }

            /// The JSON text of the weight file (the named weights, then the other
            /// parts).
            ///
            /// # Errors
            /// When the weights do not fit the feature set.
            pub fn to_json(&self) -> $crate::ModelResult<String> {
                <Self as $crate::weight_file::ModelWeights>::to_json(self)
            }

            /// Loads a weight file (written by `pgm train`).
            ///
            /// # Errors
            /// When the file cannot be read or is not a usable weight file of this
            /// model (both named).
            pub fn load(path: impl AsRef<::std::path::Path>) -> $crate::ModelResult<Self> {
                <Self as $crate::weight_file::ModelWeights>::load(path)
            }

            /// Writes the weight file atomically: `path` holds the old file or the new
            /// one, never a part.
            ///
            /// # Errors
            /// When the file cannot be written (named).
            pub fn save(&self, path: impl AsRef<::std::path::Path>) -> $crate::ModelResult<()> {
                <Self as $crate::weight_file::ModelWeights>::save(self, path)
            }

            /// The weights as named [`Weights`]($crate::weight_file::Weights).
            ///
            /// # Errors
            /// When the count does not match the feature set.
            pub fn named(&self) -> $crate::ModelResult<$crate::weight_file::Weights> {
                Ok(<Self as $crate::weight_file::ModelWeights>::to_weight_file(self)?.weights)
            }

            /// The shipped default weights.
            pub fn default_weights() -> Self {
                Self::from_json($shipped, "the shipped default weights")
                    .expect("the shipped default weights are valid (checked by a test)")
            }
        }

        impl ::std::default::Default for $weights {
            fn default() -> Self {
                Self::default_weights()
            }
        }
    };
}

/// Implements [`ModelWeights`] for a struct of the association-chain models
/// (`{weights: Vec<f64>, boosters: AssociationBoosters}`, the weights in feature-set
/// order, checked by its `check_ref`): `boosted_model_weights!(Type, "Title",
/// feature_set())`, with the title the model's name in messages and the expression
/// its feature set.
#[macro_export]
macro_rules! boosted_model_weights {
    ($weights:ty, $title:literal, $feature_set:expr) => {
        impl $crate::weight_file::ModelWeights for $weights {
            const TITLE: &'static str = $title;
            type Parts = $crate::matching_features::AssociationBoosters;

            fn feature_set() -> ::std::sync::Arc<::pgm_core::learning::FeatureSet> {
                $feature_set
            }

            fn from_file(weights: &[f64], boosters: Self::Parts) -> Self {
                let weights = weights.to_vec();
                Self { weights, boosters }
            }

            fn to_file(&self) -> (Vec<f64>, Self::Parts) {
                (self.weights.clone(), self.boosters.clone())
            }

            fn check_values(&self) -> $crate::ModelResult<()> {
                self.check_ref()
            }
        }
    };
}
