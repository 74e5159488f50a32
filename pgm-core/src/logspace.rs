//! Small numerical kernels for log-space vectors: log-sum-exp, normalisation and
//! message distances that treat −∞ (a hard zero) exactly.

/// `log(exp(a) + exp(b))`, exact for −∞ operands.
#[inline]
pub fn log_add_exp(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
    if lo == f64::NEG_INFINITY {
        return hi;
    }
    hi + (lo - hi).exp().ln_1p()
}

/// Maximum entry (−∞ for an empty or all −∞ slice; NaN entries are skipped).
#[inline]
pub fn max(v: &[f64]) -> f64 {
    if v.len() < 16 {
        let mut m = f64::NEG_INFINITY;
        for &x in v {
            m = if x > m { x } else { m };
        }
        return m;
    }
    // Four independent lanes let the compiler use packed max instructions.
    let mut lanes = [f64::NEG_INFINITY; 4];
    let chunks = v.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (m, &x) in lanes.iter_mut().zip(c) {
            *m = if x > *m { x } else { *m };
        }
    }
    let mut m = f64::NEG_INFINITY;
    for &x in lanes.iter().chain(rest) {
        m = if x > m { x } else { m };
    }
    m
}

/// `log Σ exp(v)`, stable; −∞ when every entry is −∞.
pub fn log_sum_exp(v: &[f64]) -> f64 {
    let m = max(v);
    if m == f64::NEG_INFINITY {
        return m;
    }
    let s: f64 = v.iter().map(|x| (x - m).exp()).sum();
    m + s.ln()
}

/// Which normalisation a log-vector gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normalisation {
    /// Shift so that the maximum is 0 (max-product).
    Max,
    /// Shift so that `log Σ exp = 0` (sum-product).
    Sum,
}

/// Normalises a log-vector in place. Returns `false` (and sets the vector to the
/// uniform log-vector) when every entry is −∞, i.e. when the message carries a
/// contradiction; callers report that instead of propagating NaN.
pub fn normalise(v: &mut [f64], how: Normalisation) -> bool {
    let shift = match how {
        Normalisation::Max => max(v),
        Normalisation::Sum => log_sum_exp(v),
    };
    if shift == f64::NEG_INFINITY || !shift.is_finite() {
        let u = match how {
            Normalisation::Max => 0.0,
            Normalisation::Sum => -(v.len() as f64).ln(),
        };
        v.iter_mut().for_each(|x| *x = u);
        return false;
    }
    v.iter_mut().for_each(|x| *x -= shift);
    true
}

/// Largest absolute entry-wise difference of two normalised log-vectors, where two
/// −∞ entries are equal and −∞ against a finite value is +∞.
#[inline]
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    // −∞ − −∞ is NaN, and NaN never compares greater: equal hard zeros count as 0.
    let mut lanes = [0.0f64; 4];
    let n = a.len().min(b.len());
    let (a4, b4) = (a[..n].chunks_exact(4), b[..n].chunks_exact(4));
    let (ra, rb) = (a4.remainder(), b4.remainder());
    for (ca, cb) in a4.zip(b4) {
        for i in 0..4 {
            let diff = (ca[i] - cb[i]).abs();
            lanes[i] = if diff > lanes[i] { diff } else { lanes[i] };
        }
    }
    let mut d = lanes.iter().fold(0.0f64, |d, &x| if x > d { x } else { d });
    for (x, y) in ra.iter().zip(rb) {
        let diff = (x - y).abs();
        d = if diff > d { diff } else { d };
    }
    d
}

/// Converts a normalised log-vector into probabilities summing to one.
pub fn to_probabilities(log_values: &[f64]) -> Vec<f64> {
    let z = log_sum_exp(log_values);
    if !z.is_finite() {
        let n = log_values.len().max(1) as f64;
        return vec![1.0 / n; log_values.len()];
    }
    log_values.iter().map(|x| (x - z).exp()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_add_exp_handles_neg_infinity() {
        assert_eq!(log_add_exp(f64::NEG_INFINITY, 1.5), 1.5);
        assert_eq!(
            log_add_exp(f64::NEG_INFINITY, f64::NEG_INFINITY),
            f64::NEG_INFINITY
        );
        assert!((log_add_exp(0.0, 0.0) - 2f64.ln()).abs() < 1e-15);
    }

    #[test]
    fn normalise_all_neg_infinity_is_uniform_and_reported() {
        let mut v = vec![f64::NEG_INFINITY; 4];
        assert!(!normalise(&mut v, Normalisation::Sum));
        assert!((log_sum_exp(&v)).abs() < 1e-15);
    }

    #[test]
    fn distance_treats_infinities() {
        let inf = f64::NEG_INFINITY;
        assert_eq!(distance(&[inf, 0.0], &[inf, 0.0]), 0.0);
        assert_eq!(distance(&[inf, 0.0], &[-1.0, 0.0]), f64::INFINITY);
    }
}
