//! Checked parameters: one pattern for every algorithm of the workspace.
//!
//! As in linfa (`linfa::ParamGuard`), an algorithm's hyper-parameters come in two
//! types: a plain, unchecked parameter struct that users fill in (public fields or
//! builder methods, with `Default`), and a checked type that only
//! [`ParamGuard::check`] can make. Algorithms take the checked type, so an invalid
//! value is reported once, where the parameters are set, naming the parameter and the
//! offending value, and never reaches the algorithm.
//!
//! One difference from linfa: our parameter structs have public fields (they are
//! read by command-line tools and serialised into reports), so the checked type is a
//! separate struct (often the algorithm itself, e.g. `LearnerParams` → `Learner`),
//! and [`ParamGuard::check_ref`] validates without building it.
//!
//! Every crate reports a bad value with the same shape, an [`InvalidParameter`]
//! (parameter name, offending value as written, what would have been accepted), and
//! every crate's error type has an `InvalidParameter { name, value, expected }`
//! variant with exactly these fields and the same message, converted with `From`.
//!
//! ```
//! use pgm_core::param::{InvalidParameter, ParamGuard};
//!
//! /// Unchecked parameters of a toy algorithm.
//! #[derive(Clone, Debug, Default)]
//! struct SmoothingParams { window: usize }
//! /// The checked algorithm.
//! struct Smoothing { window: usize }
//!
//! impl ParamGuard for SmoothingParams {
//!     type Checked = Smoothing;
//!     type Error = InvalidParameter;
//!     fn check_ref(&self) -> Result<(), InvalidParameter> {
//!         if self.window == 0 {
//!             return Err(InvalidParameter::new("window", self.window, "at least 1"));
//!         }
//!         Ok(())
//!     }
//!     fn check(self) -> Result<Smoothing, InvalidParameter> {
//!         self.check_ref()?;
//!         Ok(Smoothing { window: self.window })
//!     }
//! }
//!
//! let err = SmoothingParams::default().check().err().unwrap();
//! assert_eq!(err.to_string(), "parameter `window` = 0: expected at least 1");
//! assert_eq!(SmoothingParams { window: 3 }.check().unwrap().window, 3);
//! ```

use std::fmt;

/// A parameter outside its allowed range: the one shape every crate reports.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("parameter `{name}` = {value}: expected {expected}")]
pub struct InvalidParameter {
    /// Parameter name, as the user sets it (a field or option name).
    pub name: &'static str,
    /// The offending value, as written (`Debug` of the value).
    pub value: String,
    /// What would have been accepted.
    pub expected: &'static str,
}

impl InvalidParameter {
    /// The parameter `name` has the offending `value`; `expected` says what is allowed.
    pub fn new(name: &'static str, value: impl fmt::Debug, expected: &'static str) -> Self {
        Self {
            name,
            value: format!("{value:?}"),
            expected,
        }
    }

    /// `Ok(())` when `value` is finite and positive, else the error.
    pub fn positive(name: &'static str, value: f64, expected: &'static str) -> Result<(), Self> {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(Self::new(name, value, expected))
        }
    }

    /// `Ok(())` when `value` is finite and at least 0, else the error.
    pub fn non_negative(
        name: &'static str,
        value: f64,
        expected: &'static str,
    ) -> Result<(), Self> {
        if value.is_finite() && value >= 0.0 {
            Ok(())
        } else {
            Err(Self::new(name, value, expected))
        }
    }

    /// `Ok(())` when the count `value` is at least 1 (iterations, sweeps), else the
    /// error, expecting "at least 1".
    pub(crate) fn at_least_one(name: &'static str, value: usize) -> Result<(), Self> {
        if value >= 1 {
            Ok(())
        } else {
            Err(Self::new(name, value, "at least 1"))
        }
    }

    /// `Ok(())` for a convergence tolerance (finite, ≥ 0), else the error, expecting
    /// "a finite number >= 0".
    pub(crate) fn tolerance(name: &'static str, value: f64) -> Result<(), Self> {
        Self::non_negative(name, value, "a finite number >= 0")
    }

    /// `Ok(())` when `value` lies in `[0, 1]`, else the error.
    pub fn fraction(name: &'static str, value: f64) -> Result<(), Self> {
        if (0.0..=1.0).contains(&value) {
            Ok(())
        } else {
            Err(Self::new(name, value, "a fraction in [0, 1]"))
        }
    }
}

impl From<InvalidParameter> for crate::Error {
    fn from(e: InvalidParameter) -> Self {
        crate::Error::InvalidParameter {
            name: e.name,
            value: e.value,
            expected: e.expected,
        }
    }
}

/// Unchecked parameters that turn into a checked type (see the module docs).
pub trait ParamGuard {
    /// The checked parameters, or the algorithm built from them.
    type Checked;
    /// The error of a failed check (the crate's error type).
    type Error: std::error::Error;

    /// Checks every value; the error names the first invalid one and its value.
    fn check_ref(&self) -> Result<(), Self::Error>;

    /// Checks every value and builds the checked type.
    fn check(self) -> Result<Self::Checked, Self::Error>;

    /// [`ParamGuard::check`] for parameters known to be valid (defaults, constants).
    ///
    /// # Panics
    /// If the parameters are invalid; use [`ParamGuard::check`] for user input.
    fn check_unwrap(self) -> Self::Checked
    where
        Self: Sized,
    {
        match self.check() {
            Ok(checked) => checked,
            Err(e) => panic!("invalid parameters: {e}"),
        }
    }
}

/// Declares the checked type of a parameter struct that holds nothing but the
/// parameters, and implements [`ParamGuard`] with it.
///
/// `checked_params! { #[derive(…)] pub struct Checked(Params) -> Error; }` declares
/// `pub struct Checked { params: Params }` with the given attributes and docs, and
/// implements:
/// - [`ParamGuard`] for `Params`: `check_ref` is `Params`'s own inherent
///   `fn validate(&self) -> Result<(), Error>` (which the caller writes), `check`
///   validates and wraps;
/// - `Default` for `Checked`: the default parameters, checked (it panics only if the
///   defaults themselves are invalid, which every crate's tests rule out);
/// - `Checked::params(&self) -> &Params`.
///
/// Every algorithm of the workspace whose checked type is just its parameters is
/// declared this way (ICP, the association sources, belief propagation, TRW-S, the
/// learner, the baselines, …), so the pattern is written once.
///
/// ```
/// use pgm_core::param::{InvalidParameter, ParamGuard};
///
/// /// Unchecked parameters of a toy algorithm.
/// #[derive(Clone, Debug, Default, PartialEq)]
/// pub struct SmoothingParams {
///     /// Window length in samples (at least 1).
///     pub window: usize,
/// }
///
/// impl SmoothingParams {
///     fn validate(&self) -> Result<(), InvalidParameter> {
///         if self.window == 0 {
///             return Err(InvalidParameter::new("window", self.window, "at least 1"));
///         }
///         Ok(())
///     }
/// }
///
/// pgm_core::checked_params! {
///     /// The smoothing with checked parameters.
///     #[derive(Clone, Debug, PartialEq)]
///     pub struct Smoothing(SmoothingParams) -> InvalidParameter;
/// }
///
/// let err = SmoothingParams::default().check().unwrap_err();
/// assert_eq!(err.to_string(), "parameter `window` = 0: expected at least 1");
/// let smoothing = SmoothingParams { window: 3 }.check().unwrap();
/// assert_eq!(smoothing.params().window, 3);
/// ```
#[macro_export]
macro_rules! checked_params {
    ($(#[$meta:meta])* $vis:vis struct $checked:ident($params:ty) -> $error:ty;) => {
        $(#[$meta])*
        $vis struct $checked {
            params: $params,
        }

        impl $crate::param::ParamGuard for $params {
            type Checked = $checked;
            type Error = $error;

            fn check_ref(&self) -> ::core::result::Result<(), $error> {
                self.validate()
            }

            fn check(self) -> ::core::result::Result<$checked, $error> {
                self.validate()?;
                ::core::result::Result::Ok($checked { params: self })
            }
        }

        impl ::core::default::Default for $checked {
            fn default() -> Self {
                $crate::param::ParamGuard::check_unwrap(
                    <$params as ::core::default::Default>::default(),
                )
            }
        }

        impl $checked {
            /// The parameters (checked).
            $vis fn params(&self) -> &$params {
                &self.params
            }
        }
    };
}
