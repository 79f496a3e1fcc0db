//! One way to compare GPU results with their reference: every value is counted, a NaN or an
//! infinity anywhere is a failure (never swallowed by `f64::max`), and the comparison asserts a
//! floor on how many values were actually compared, so no exclusion can empty it.

use std::fmt::Display;

/// A running comparison of GPU values against reference values.
///
/// ```
/// use hadou::testing::Comparison;
/// let mut energy = Comparison::new("energy vs f64");
/// for (i, (gpu, reference)) in [(1.0, 1.0), (2.0, 2.000_001)].into_iter().enumerate() {
///     energy.rel(i, gpu, reference);
/// }
/// energy.assert_within(1e-6, 2);
/// ```
#[derive(Clone, Debug)]
pub struct Comparison {
    what: String,
    compared: usize,
    excluded: usize,
    worst: f64,
    worst_at: String,
    non_finite: usize,
    first_non_finite: String,
}

impl Comparison {
    /// An empty comparison; `what` names it in every message.
    pub fn new(what: impl Into<String>) -> Self {
        Comparison {
            what: what.into(),
            compared: 0,
            excluded: 0,
            worst: 0.0,
            worst_at: String::new(),
            non_finite: 0,
            first_non_finite: String::new(),
        }
    }

    /// Records one compared value whose error is `error` (≥ 0 when finite). A NaN or infinite
    /// error is a failure of the comparison, whatever the tolerance. Returns `error`.
    pub fn error(&mut self, at: impl Display, error: f64) -> f64 {
        self.compared += 1;
        if !error.is_finite() {
            if self.non_finite == 0 {
                self.first_non_finite = format!("{at} (error {error})");
            }
            self.non_finite += 1;
        } else if error > self.worst || self.compared == 1 {
            self.worst = error;
            self.worst_at = at.to_string();
        }
        error
    }

    /// Records `|gpu − reference|`. A non-finite value on either side is a failure.
    pub fn abs(&mut self, at: impl Display, gpu: f64, reference: f64) -> f64 {
        let error = if gpu.is_finite() && reference.is_finite() { (gpu - reference).abs() } else { f64::NAN };
        self.error(Values(at, gpu, reference), error)
    }

    /// Records `|gpu − reference| / |reference|` (a zero reference gives an infinite error unless
    /// the GPU value is zero too). A non-finite value on either side is a failure.
    pub fn rel(&mut self, at: impl Display, gpu: f64, reference: f64) -> f64 {
        let error = if !(gpu.is_finite() && reference.is_finite()) {
            f64::NAN
        } else if gpu == reference {
            0.0
        } else {
            (gpu - reference).abs() / reference.abs()
        };
        self.error(Values(at, gpu, reference), error)
    }

    /// Records a value left out of the comparison (a tangency band, a silhouette pixel); the
    /// share of such values can be capped by [`Comparison::assert_excluded_at_most`].
    pub fn exclude(&mut self) {
        self.excluded += 1;
    }

    /// How many values were compared (non-finite ones included).
    pub fn compared(&self) -> usize {
        self.compared
    }

    /// How many values were left out.
    pub fn excluded(&self) -> usize {
        self.excluded
    }

    /// How many compared values had a NaN or infinite error.
    pub fn non_finite(&self) -> usize {
        self.non_finite
    }

    /// The largest error; NaN when any error was not finite (NaN-aware: it never hides one).
    pub fn worst(&self) -> f64 {
        if self.non_finite > 0 {
            f64::NAN
        } else {
            self.worst
        }
    }

    /// One line for the test's output: what, how many compared and left out, the worst error.
    pub fn summary(&self) -> String {
        format!(
            "{}: {} compared, {} excluded, {} non-finite, worst {:.3e} at {}",
            self.what, self.compared, self.excluded, self.non_finite, self.worst, self.worst_at
        )
    }

    /// `Ok(summary)` when every error is finite and ≤ `tolerance` and at least `min_compared`
    /// values were compared; otherwise what failed.
    pub fn check(&self, tolerance: f64, min_compared: usize) -> Result<String, String> {
        if self.non_finite > 0 {
            return Err(format!(
                "{}: {} non-finite values, the first at {}",
                self.what, self.non_finite, self.first_non_finite
            ));
        }
        if self.compared < min_compared {
            return Err(format!(
                "{}: only {} values compared, the test needs at least {min_compared} ({} excluded)",
                self.what, self.compared, self.excluded
            ));
        }
        if self.worst > tolerance {
            return Err(format!("{} exceeds the tolerance {tolerance:.3e}", self.summary()));
        }
        Ok(self.summary())
    }

    /// Panics unless every error is finite and ≤ `tolerance` and at least `min_compared` values
    /// were compared; prints the summary either way.
    #[track_caller]
    pub fn assert_within(&self, tolerance: f64, min_compared: usize) {
        match self.check(tolerance, min_compared) {
            Ok(summary) => println!("{summary}"),
            Err(failure) => panic!("{failure}"),
        }
    }

    /// Panics when more than `share` of all values (compared + excluded) were excluded.
    #[track_caller]
    pub fn assert_excluded_at_most(&self, share: f64) {
        let total = self.compared + self.excluded;
        assert!(
            self.excluded as f64 <= share * total as f64,
            "{}: {} of {total} values excluded, more than the allowed share {share}",
            self.what,
            self.excluded
        );
    }
}

/// Where a value was compared, with both values (formatted only when it is the worst so far).
struct Values<A>(A, f64, f64);

impl<A: Display> Display for Values<A> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (gpu {:e}, reference {:e})", self.0, self.1, self.2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_nan_anywhere_fails_whatever_the_tolerance() {
        let mut c = Comparison::new("t");
        c.abs(0, 1.0, 1.0);
        c.abs(1, f64::NAN, 1.0);
        c.abs(2, 1.0, 1.5);
        assert!(c.worst().is_nan());
        assert!(c.check(f64::INFINITY, 0).unwrap_err().contains("non-finite"));
        let mut inf = Comparison::new("t");
        inf.rel(0, f64::INFINITY, f64::INFINITY);
        assert!(inf.check(1.0, 1).is_err());
    }

    #[test]
    fn the_floor_counts_only_compared_values() {
        let mut c = Comparison::new("t");
        c.abs(0, 1.0, 1.0);
        (0..10).for_each(|_| c.exclude());
        assert!(c.check(0.0, 2).unwrap_err().contains("only 1"));
        assert!(c.check(0.0, 1).is_ok());
        let excluded = std::panic::catch_unwind(|| c.assert_excluded_at_most(0.5));
        assert!(excluded.is_err());
    }

    #[test]
    fn worst_error_and_its_place() {
        let mut c = Comparison::new("t");
        c.rel("a", 1.0, 1.0);
        c.rel("b", 1.1, 1.0);
        c.rel("c", 0.0, 0.0);
        assert!((c.worst() - 0.1).abs() < 1e-12);
        assert!(c.summary().contains("at b"));
        assert!(c.check(0.05, 3).is_err());
        assert!(c.check(0.2, 3).is_ok());
        assert!(c.rel("d", 1.0, 0.0).is_infinite());
        assert!(c.check(1.0, 1).is_err());
    }
}
