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
        RECORD.with_borrow_mut(|r| {
            if let Some(r) = r {
                r.push(Checked {
                    key: key.to_owned(),
                    lo: self.lo,
                    hi: self.hi,
                    unit: self.unit.to_owned(),
                    below: self.below.to_owned(),
                    above: self.above.to_owned(),
                    value: v,
                });
            }
        });
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

/// One bound [`Bound::check`]ed while [`record`] ran: the key, the bound
/// as declared at the check, and the value checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    pub key: String,
    pub lo: f64,
    pub hi: f64,
    pub unit: String,
    pub below: String,
    pub above: String,
    pub value: f64,
}

thread_local! {
    static RECORD: std::cell::RefCell<Option<Vec<Checked>>> =
        const { std::cell::RefCell::new(None) };
}

/// Runs `f` and returns, with its result, every bound checked on this
/// thread meanwhile, in the order checked. The settings reference
/// (`docs/src/reference/settings.generated.md`, `tests/tests/references.rs`)
/// is made from these: it lists the bounds the checks apply, not a copy of
/// them. Checks outside `record` record nothing.
pub fn record<R>(f: impl FnOnce() -> R) -> (R, Vec<Checked>) {
    let outer = RECORD.replace(Some(Vec::new()));
    let r = f();
    let checked = RECORD.replace(outer).unwrap_or_default();
    // A `record` inside another: the outer one sees these checks too.
    RECORD.with_borrow_mut(|o| {
        if let Some(o) = o {
            o.extend(checked.iter().cloned());
        }
    });
    (r, checked)
}

#[cfg(test)]
mod tests {
    use super::*;

    const B: Bound<'static> = Bound {
        lo: 1.0,
        hi: 2.0,
        unit: "s",
        below: "too short",
        above: "too long",
    };

    #[test]
    fn record_returns_the_bounds_checked_inside_it_and_only_those() {
        B.check("f", "before", 1.5).unwrap();
        let (r, checked) = record(|| {
            B.check("f", "a.x", 1.5).unwrap();
            let (_, inner) = record(|| B.check("f", "a.y", 3.0));
            assert_eq!(inner.len(), 1);
            B.check("f", "a.z", 0.0)
        });
        assert!(r.is_err(), "a recorded check still refuses");
        let keys: Vec<&str> = checked.iter().map(|c| c.key.as_str()).collect();
        assert_eq!(keys, ["a.x", "a.y", "a.z"]);
        let bits = |v: f64| v.to_bits();
        assert_eq!(bits(checked[1].value), bits(3.0));
        assert_eq!(
            [bits(checked[0].lo), bits(checked[0].hi)],
            [bits(1.0), bits(2.0)]
        );
        assert_eq!(checked[0].below, "too short");
        B.check("f", "after", 1.5).unwrap();
        let (_, none) = record(|| ());
        assert!(none.is_empty());
    }
}
