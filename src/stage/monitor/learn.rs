//! The monitor's learning rule, shared by its tests: a channel's own no-effect value is learned
//! from the windows that raised no alarm, each one only after a delay (two windows), and
//! dropped if an alarm comes meanwhile — so the rise of an effect, seen in the windows just
//! before the one that crossed the bar, does not teach the detector that the effect is ordinary.

use std::collections::VecDeque;

/// Values waiting `delay` further offers before they are learned from.
#[derive(Debug, Clone)]
pub struct Delayed<T> {
    pending: VecDeque<T>,
    delay: usize,
}

impl<T> Delayed<T> {
    /// Each value is learned from after `delay` more values were offered.
    pub fn new(delay: usize) -> Self {
        Delayed {
            pending: VecDeque::with_capacity(delay + 1),
            delay,
        }
    }

    /// Offers one quiet window's value; returns the value that has now waited long enough.
    pub fn offer(&mut self, v: T) -> Option<T> {
        self.pending.push_back(v);
        if self.pending.len() > self.delay {
            self.pending.pop_front()
        } else {
            None
        }
    }

    /// An alarm: every value still waiting is dropped.
    pub fn drop_pending(&mut self) {
        self.pending.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_wait_their_delay_and_an_alarm_drops_them() {
        let mut d = Delayed::new(2);
        assert_eq!(d.offer(1), None);
        assert_eq!(d.offer(2), None);
        assert_eq!(d.offer(3), Some(1));
        d.drop_pending();
        assert_eq!(d.offer(4), None);
        assert_eq!(d.offer(5), None);
        assert_eq!(d.offer(6), Some(4));
    }
}
