//! The one check of a numeric setting against its physical bound, and the
//! error that names where a value came from and its key: shared by the
//! settings and by each aid's own settings (`crate::aids`).

/// A settings value out of range: names where it came from and the key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{origin}: key `{key}`: {message}")]
pub struct SettingsError {
    /// The file, header or option the value came from.
    pub origin: String,
    /// The key, `table.name`.
    pub key: String,
    /// What was expected and what was found.
    pub message: String,
}

/// The longest time any setting may span: about 116 days, above the
/// longest HALE flight flown (64 days, 5.5e6 s). A period or timeout
/// beyond it never comes round in a flight.
pub const MAX_FLIGHT_S: f64 = 1e7;

/// A physical bound of a numeric setting: `[lo, hi]` in `unit`, and why a
/// value below `lo` or above `hi` cannot work. [`Bound::check`] refuses NaN,
/// ±Inf and values outside, naming the key and the reason.
#[derive(Debug, Clone, Copy)]
pub struct Bound<'a> {
    pub lo: f64,
    pub hi: f64,
    pub unit: &'a str,
    /// Why a value below `lo` cannot work.
    pub below: &'a str,
    /// Why a value above `hi` cannot work.
    pub above: &'a str,
}

impl Bound<'_> {
    /// `Ok` if `v` is finite and in `[lo, hi]`; else an error naming
    /// `origin`, `key`, the bound, the value and the reason.
    pub fn check(&self, origin: &str, key: &str, v: f64) -> Result<(), SettingsError> {
        let message = if !v.is_finite() {
            format!(
                "expected a finite number in [{}, {}] {}, got {v}",
                self.lo, self.hi, self.unit
            )
        } else if v < self.lo {
            format!(
                "expected at least {} {}, got {v}: {}",
                self.lo, self.unit, self.below
            )
        } else if v > self.hi {
            format!(
                "expected at most {} {}, got {v}: {}",
                self.hi, self.unit, self.above
            )
        } else {
            return Ok(());
        };
        Err(SettingsError {
            origin: origin.to_owned(),
            key: key.to_owned(),
            message,
        })
    }
}
