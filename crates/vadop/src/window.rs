//! Time windows: the half-open interval `[start, end)` every stage of the pipeline works over.
//!
//! It owns one convention, the one that makes every contact count exactly once: a contact at
//! time t belongs to the window (and the frame) whose `[start, end)` holds t. A contact exactly at
//! a frame's end belongs to the next frame. It never computes times itself.

/// The half-open time interval `[start, end)`.
///
/// ```
/// use vadop::window::Window;
/// let frame = Window::new(1.0, 2.0);
/// assert!(frame.contains(1.0) && frame.contains(1.5));
/// // The end belongs to the next window: a contact on a frame boundary is reported once.
/// assert!(!frame.contains(2.0));
/// assert_eq!(frame.from(1.25), Window::new(1.25, 2.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Window {
    pub start: f64,
    pub end: f64,
}

impl Window {
    /// The window `[start, end)`.
    #[inline]
    pub const fn new(start: f64, end: f64) -> Window {
        Window { start, end }
    }

    /// True when `t` lies in `[start, end)`.
    #[inline]
    pub fn contains(&self, t: f64) -> bool {
        self.start <= t && t < self.end
    }

    /// `end - start`.
    #[inline]
    pub fn duration(&self) -> f64 {
        self.end - self.start
    }

    /// The part of this window from `t` on.
    #[inline]
    pub fn from(&self, t: f64) -> Window {
        Window { start: self.start.max(t), end: self.end }
    }

    /// The common part of two windows (empty when `start >= end`).
    #[inline]
    pub fn intersect(&self, other: Window) -> Window {
        // Plain comparisons rather than `f64::max` and `min`, whose NaN handling costs a dozen
        // instructions: every candidate pair of a broad phase pays them, and no window holds NaN.
        let start = if other.start > self.start { other.start } else { self.start };
        let end = if other.end < self.end { other.end } else { self.end };
        Window { start, end }
    }

    /// True when the window holds no time.
    #[inline]
    pub fn is_empty(&self) -> bool {
        !(self.start < self.end)
    }
}
