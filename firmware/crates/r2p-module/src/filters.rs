//! Filters for sensor channels: a running median (rejects spikes) and a first-order low-pass
//! (smooths noise). Both are small, allocation-free and deterministic.

/// Median of the last `N` samples (`N` odd). Until `N` samples have arrived, the median of
/// those seen.
#[derive(Clone, Copy, Debug)]
pub struct Median<T, const N: usize> {
    window: [T; N],
    len: usize,
    head: usize,
}

impl<T: Copy + PartialOrd + Default, const N: usize> Median<T, N> {
    /// An empty filter.
    pub fn new() -> Self {
        assert!(!N.is_multiple_of(2), "a median window has an odd length");
        Self { window: [T::default(); N], len: 0, head: 0 }
    }

    /// Adds `x` and returns the median of the window.
    pub fn push(&mut self, x: T) -> T {
        self.window[self.head] = x;
        self.head = (self.head + 1) % N;
        self.len = (self.len + 1).min(N);
        let mut sorted = self.window;
        let s = &mut sorted[..self.len];
        // Insertion sort: N is tiny (3–9).
        for i in 1..s.len() {
            let mut j = i;
            while j > 0 && s[j - 1] > s[j] {
                s.swap(j - 1, j);
                j -= 1;
            }
        }
        s[s.len() / 2]
    }

    /// Forgets every sample.
    pub fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
    }
}

impl<T: Copy + PartialOrd + Default, const N: usize> Default for Median<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

/// First-order low-pass `y += α (x − y)`; the first sample initialises `y`.
#[derive(Clone, Copy, Debug)]
pub struct LowPass {
    alpha: f32,
    y: Option<f32>,
}

impl LowPass {
    /// A filter with cut-off `cutoff_hz` sampled every `dt_s`: α = dt / (RC + dt), RC = 1/(2π fc).
    pub fn new(cutoff_hz: f32, dt_s: f32) -> Self {
        let rc = 1.0 / (2.0 * core::f32::consts::PI * cutoff_hz);
        Self { alpha: dt_s / (rc + dt_s), y: None }
    }

    /// Adds `x`, returns the filtered value.
    pub fn push(&mut self, x: f32) -> f32 {
        let y = match self.y {
            None => x,
            Some(y) => y + self.alpha * (x - y),
        };
        self.y = Some(y);
        y
    }

    /// The filtered value, if any sample arrived.
    pub fn value(&self) -> Option<f32> {
        self.y
    }

    /// Forgets the state (the next sample initialises it).
    pub fn reset(&mut self) {
        self.y = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_rejects_a_spike() {
        let mut m: Median<u16, 5> = Median::new();
        let out: std::vec::Vec<u16> =
            [100, 101, 4000, 99, 100, 102].iter().map(|&x| m.push(x)).collect();
        assert_eq!(out, [100, 101, 101, 101, 100, 101], "the 4000 spike never comes out");
    }

    #[test]
    fn low_pass_reaches_63_percent_after_one_time_constant() {
        let dt = 0.001;
        let fc = 10.0;
        let mut f = LowPass::new(fc, dt);
        f.push(0.0);
        let tau = 1.0 / (2.0 * core::f32::consts::PI * fc);
        let steps = (tau / dt).round() as usize;
        let mut y = 0.0;
        for _ in 0..steps {
            y = f.push(1.0);
        }
        assert!((y - 0.632).abs() < 0.03, "{y}");
    }
}
