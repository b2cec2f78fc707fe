//! What the session's integrity test ([`crate::integrity`]) needs of a
//! navigator: a copy that fuses no aid that is not autonomous (the
//! reference), the test of a sample against a navigator without changing
//! it, and the main navigator taking the reference's state when an aid is
//! excluded.

use msgs::AidSample;
use nalgebra::{Matrix3, SMatrix, Vector3};

use crate::aids::{AnyMeasurement, Context, Measured, OwnOf};
use crate::integrity::{self, Test};

use super::{Navigator, SwitchEvent};

impl Navigator {
    /// A copy of this navigator to serve as the reference of the
    /// integrity test: the same state, covariance and history, no
    /// smoother's record. It must be fed every input but the samples of
    /// the aids that are not autonomous. Its work ([`Navigator::work`])
    /// starts from zero.
    pub fn reference_copy(&mut self) -> Navigator {
        let tape = self.err.tape.take();
        let mut r = self.clone();
        self.err.tape = tape;
        r.work = 0;
        r.err.propagations = 0;
        r
    }

    /// The integrity test of `sample` against this navigator, its alarm
    /// threshold `threshold` (the aid's monitor forms it from the stamps,
    /// [`integrity::Monitor::threshold`]): the sample's innovation through
    /// its aid's model at its own time, with S = H P Hᵀ + R (P brought to
    /// the current time on a copy: this navigator is left exactly as it
    /// was). `None` when the sample cannot be tested: its time is outside
    /// the state history's reach or its content is refused (the navigator
    /// that is offered it counts why).
    pub fn test_aid(
        &self,
        sample: &AidSample,
        settings: &integrity::IntegritySettings,
        threshold: f64,
    ) -> Option<Test> {
        msgs::match_aid!(sample, x => self.test_of(x, settings, threshold))
    }

    fn test_of<A: OwnOf>(
        &self,
        x: &A,
        settings: &integrity::IntegritySettings,
        threshold: f64,
    ) -> Option<Test> {
        let t_ns = x.t_ns();
        let age = self.aid_age(t_ns).ok()?;
        let at = self.state_at(t_ns, age);
        let ctx = Context {
            omega_ib_b: self.body_rate(),
        };
        let Measured { m, shares, .. } =
            x.measure(&at, &ctx, A::own(&self.aids.settings.own)).ok()?;
        let (p, c) = self.err.current_p(&self.nominal);
        // The receiver's correlated error and this navigator's errors are
        // correlated when this navigator's state came from one that had
        // fused the receiver (a copy taken after a resumed checkpoint).
        let c = shares.correlated.map(|_| c);
        let decl = A::KIND.decl();
        let q = match &m {
            AnyMeasurement::D1(m) => statistic(m, &p, c.as_ref(), decl.components),
            AnyMeasurement::D2(m) => statistic(m, &p, c.as_ref(), decl.components),
            AnyMeasurement::D3(m) => statistic(m, &p, c.as_ref(), decl.components),
            AnyMeasurement::D6(m) => statistic(m, &p, c.as_ref(), decl.components),
        };
        let (q, by_unit, with_r, reference) = q?;
        let level = |[[a, b], [_, c]]: Block2| integrity::protection_level(threshold, a, b, c);
        Some(Test {
            q,
            threshold,
            cause: by_unit,
            protection_m: level(with_r),
            reference_protection_m: level(reference),
            alert_limit_m: settings.integrity_alert_limit_m,
        })
    }

    /// Takes `reference`'s navigation state, covariance, biases, history
    /// and aid gating (an aid has been excluded: what the main navigator
    /// fused of it is dropped), keeping this navigator's accounting
    /// (counters, sequence numbers, switch count, aid statuses) and its
    /// smoother's record, which breaks here. The step is published as a
    /// reset. A reference in the other frame is a frame switch, returned.
    pub fn adopt(&mut self, reference: Navigator) -> Option<SwitchEvent> {
        let old = self.solution();
        let from = self.nominal.nav().kind();
        let mut new = reference;
        self.carry_accounting(&mut new);
        for ((_, n), (_, o)) in new.aids.controls.iter_mut().zip(self.aids.controls.iter()) {
            n.status = o.status;
        }
        new.aids.resets = self.aids.resets;
        new.aids.enabled = self.aids.enabled;
        self.err.tape_break();
        new.err.tape = self.err.tape.take();
        new.err.tape_break();
        *self = new;
        let to = self.nominal.nav().kind();
        let switch = (to != from).then(|| {
            self.switch_count += 1;
            self.last_switch_t_ns = self.t_ns;
            SwitchEvent {
                t_ns: self.t_ns,
                from,
                to,
                count: self.switch_count,
                lat_rad: self.nominal.geo().lat_rad,
            }
        });
        self.record_reset(&old);
        switch
    }
}

/// A symmetric 2×2 block, rows of a matrix.
type Block2 = [[f64; 2]; 2];

/// q = zᵀ S⁻¹ z of a measurement, S = H P Hᵀ + R (+ H C Uᵀ + U Cᵀ Hᵀ
/// for a measurement whose first three components share a correlated
/// error b with cov(δx, b) = C, given), the cause its largest share of q
/// points to (the block of components of one unit, position or velocity,
/// whose own q over its own χ² quantile is the largest), and the
/// horizontal position blocks (the first two components in metres: east
/// and north in g, grid x and y in G) of S and of the reference's part
/// H P Hᵀ, from which the protection levels follow (NaN without two such
/// components: no level).
fn statistic<const M: usize>(
    m: &crate::aids::Measurement<M>,
    p: &crate::error_model::Mat15,
    correlated_c: Option<&SMatrix<f64, 15, 3>>,
    components: &[msgs::aids::Component],
) -> Option<(f64, u8, Block2, Block2)> {
    use msgs::aids::Unit;
    let hph: SMatrix<f64, M, M> = m.h * p * m.h.transpose();
    let mut s = hph + m.r;
    if let Some(c) = correlated_c.filter(|c| **c != SMatrix::<f64, 15, 3>::zeros()) {
        let hc = m.h * c;
        for i in 0..M {
            for j in 0..M.min(3) {
                s[(i, j)] += hc[(i, j)];
                s[(j, i)] += hc[(i, j)];
            }
        }
    }
    let chol = s.cholesky()?;
    let q = m.z.dot(&chol.solve(&m.z));
    let (with_r, reference) = {
        let mut metres = components
            .iter()
            .enumerate()
            .take(M)
            .filter(|(_, c)| c.unit == Unit::M)
            .map(|(k, _)| k);
        match (metres.next(), metres.next()) {
            (Some(i), Some(j)) => {
                let block =
                    |m: &SMatrix<f64, M, M>| [[m[(i, i)], m[(i, j)]], [m[(j, i)], m[(j, j)]]];
                (block(&s), block(&hph))
            }
            _ => ([[f64::NAN; 2]; 2], [[f64::NAN; 2]; 2]),
        }
    };
    if !q.is_finite() {
        return Some((
            f64::INFINITY,
            integrity::cause::MEASUREMENT,
            with_r,
            reference,
        ));
    }
    // The blocks: position (m), velocity (m/s), the rest; each is a run
    // of at most 3 neighbouring components (as the declarations list
    // them), tested in a 3×3 block padded with the identity (no heap).
    let block = |c: &msgs::aids::Component| match c.unit {
        Unit::M | Unit::LatitudeInG | Unit::LongitudeInG => integrity::cause::POSITION,
        Unit::Mps => integrity::cause::VELOCITY,
        Unit::Rad => integrity::cause::MEASUREMENT,
    };
    let mut best = (f64::NEG_INFINITY, integrity::cause::MEASUREMENT);
    for cause in [
        integrity::cause::POSITION,
        integrity::cause::VELOCITY,
        integrity::cause::MEASUREMENT,
    ] {
        let mut rows = [0usize; 3];
        let mut n = 0;
        for (k, c) in components.iter().enumerate().take(M) {
            if block(c) == cause && n < 3 {
                rows[n] = k;
                n += 1;
            }
        }
        if n == 0 {
            continue;
        }
        let mut sub = Matrix3::identity();
        let mut zs = Vector3::zeros();
        for i in 0..n {
            zs[i] = m.z[rows[i]];
            for j in 0..n {
                sub[(i, j)] = s[(rows[i], rows[j])];
            }
        }
        let Some(c) = sub.cholesky() else { continue };
        let share = zs.dot(&c.solve(&zs)) / crate::filter::chi2_999(n);
        if share > best.0 {
            best = (share, cause);
        }
    }
    Some((q, best.1, with_r, reference))
}
