//! Choice of the navigation frame: by the computed latitude with hysteresis,
//! or at forced times (the low-latitude experiments of the papers).

use crate::mech::FrameKind;

/// Latitude thresholds of the automatic switch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchLatitudes {
    /// Enter the grid frame when |L| ≥ this (rad).
    pub enter_rad: f64,
    /// Leave the grid frame when |L| ≤ this (rad); must be below `enter_rad`.
    pub leave_rad: f64,
}

impl Default for SwitchLatitudes {
    fn default() -> Self {
        Self {
            enter_rad: 70f64.to_radians(),
            leave_rad: 69.5f64.to_radians(),
        }
    }
}

/// How the frame is chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum FramePolicy {
    /// By computed latitude with hysteresis.
    Latitude(SwitchLatitudes),
    /// Toggle g↔G at each of these times (ns, ascending); latitude is ignored.
    /// Starts in g.
    Forced(Vec<u64>),
}

impl Default for FramePolicy {
    fn default() -> Self {
        FramePolicy::Latitude(SwitchLatitudes::default())
    }
}

/// Stateful selector: remembers which forced times have been used.
#[derive(Debug, Clone)]
pub struct FrameSelector {
    policy: FramePolicy,
    next_forced: usize,
}

impl FrameSelector {
    pub fn new(policy: FramePolicy) -> Self {
        Self {
            policy,
            next_forced: 0,
        }
    }

    /// Frame to start in at latitude `lat_rad`.
    pub fn initial(&self, lat_rad: f64) -> FrameKind {
        match &self.policy {
            FramePolicy::Latitude(l) if lat_rad.abs() >= l.enter_rad => FrameKind::Grid,
            _ => FrameKind::Geographic,
        }
    }

    /// The frame to use from time `t_ns` on, given the current frame and the
    /// computed latitude. Returns the current frame when no switch is due.
    pub fn decide(&mut self, current: FrameKind, lat_rad: f64, t_ns: u64) -> FrameKind {
        match &self.policy {
            FramePolicy::Latitude(l) => match current {
                FrameKind::Geographic if lat_rad.abs() >= l.enter_rad => FrameKind::Grid,
                FrameKind::Grid if lat_rad.abs() <= l.leave_rad => FrameKind::Geographic,
                _ => current,
            },
            FramePolicy::Forced(times) => {
                let mut frame = current;
                while self.next_forced < times.len() && t_ns >= times[self.next_forced] {
                    frame = match frame {
                        FrameKind::Geographic => FrameKind::Grid,
                        FrameKind::Grid => FrameKind::Geographic,
                    };
                    self.next_forced += 1;
                }
                frame
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hysteresis_prevents_chatter_at_the_threshold() {
        let mut s = FrameSelector::new(FramePolicy::default());
        let d = |x: f64| x.to_radians();
        let mut f = s.initial(d(69.0));
        assert_eq!(f, FrameKind::Geographic);
        let mut switches = 0;
        // Latitude oscillating ±0.2° around 70°: one switch in, none back.
        for k in 0..100 {
            let lat = 70.0 + 0.2 * (k as f64 * 0.7).sin();
            let nf = s.decide(f, d(lat), k);
            if nf != f {
                switches += 1;
            }
            f = nf;
        }
        assert_eq!(switches, 1);
        assert_eq!(s.decide(FrameKind::Grid, d(69.6), 0), FrameKind::Grid);
        assert_eq!(s.decide(FrameKind::Grid, d(69.5), 0), FrameKind::Geographic);
        assert_eq!(
            s.decide(FrameKind::Geographic, d(-70.0), 0),
            FrameKind::Grid
        );
    }

    #[test]
    fn forced_switches_toggle_at_given_times_only() {
        let mut s = FrameSelector::new(FramePolicy::Forced(vec![300_000_000_000, 900_000_000_000]));
        assert_eq!(s.initial(89f64.to_radians()), FrameKind::Geographic);
        let mut f = FrameKind::Geographic;
        f = s.decide(f, 0.5, 299_999_999_999);
        assert_eq!(f, FrameKind::Geographic);
        f = s.decide(f, 0.5, 300_000_000_000);
        assert_eq!(f, FrameKind::Grid);
        f = s.decide(f, 0.5, 600_000_000_000);
        assert_eq!(f, FrameKind::Grid);
        f = s.decide(f, 0.5, 900_000_000_001);
        assert_eq!(f, FrameKind::Geographic);
        assert_eq!(s.decide(f, 0.5, 2_000_000_000_000), FrameKind::Geographic);
    }
}
