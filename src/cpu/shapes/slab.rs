//! The slab |o + t·d| ≤ 0.5 along one object axis: the cube is three of them, the
//! cylinder's caps one.

use super::Crossing;

/// Narrows `[enter, exit]` to where the line `o + t·d` (one axis's coordinates) lies in the
/// slab, the crossings of its −0.5 and +0.5 planes carrying faces `lo` and `hi`; false when
/// the line runs parallel to the slab outside it.
///
/// Divisions (not reciprocals) keep the t of coincident faces of different shapes
/// bit-identical when their transforms agree along the axis; a parallel line is decided by
/// its origin alone (no 0·∞ = NaN when the origin lies on a plane); a crossing replaces an
/// end only when strictly nearer the middle (`>`/`<`), so ties at edges and corners keep
/// the earlier axis's face.
pub(super) fn clip(enter: &mut Crossing, exit: &mut Crossing, o: f64, d: f64, lo: u8, hi: u8) -> bool {
    if d == 0.0 {
        // Written as a test for outside, so that a NaN origin is not rejected here (the
        // span's own `enter ≤ exit` test decides it).
        if o.abs() > 0.5 {
            return false;
        }
        return true;
    }
    let t_lo = (-0.5 - o) / d;
    let t_hi = (0.5 - o) / d;
    let (near, far) = if d > 0.0 {
        (Crossing::new(t_lo, lo), Crossing::new(t_hi, hi))
    } else {
        (Crossing::new(t_hi, hi), Crossing::new(t_lo, lo))
    };
    if near.t > enter.t {
        *enter = near;
    }
    if far.t < exit.t {
        *exit = far;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn whole_line() -> (Crossing, Crossing) {
        (Crossing::open(f64::NEG_INFINITY), Crossing::open(f64::INFINITY))
    }

    #[test]
    fn a_crossing_line_enters_by_the_face_it_meets_first() {
        // From z = −2 upward at speed 2: the −0.5 plane at t = 0.75, the +0.5 plane at 1.25.
        let (mut enter, mut exit) = whole_line();
        assert!(clip(&mut enter, &mut exit, -2.0, 2.0, 4, 5));
        assert_eq!((enter, exit), (Crossing::new(0.75, 4), Crossing::new(1.25, 5)));
        // Downward from z = 2: the +0.5 plane first.
        let (mut enter, mut exit) = whole_line();
        assert!(clip(&mut enter, &mut exit, 2.0, -2.0, 4, 5));
        assert_eq!((enter, exit), (Crossing::new(0.75, 5), Crossing::new(1.25, 4)));
    }

    #[test]
    fn only_strictly_nearer_crossings_replace_an_end() {
        let (mut enter, mut exit) = (Crossing::new(0.75, 0), Crossing::new(1.0, 1));
        assert!(clip(&mut enter, &mut exit, -2.0, 2.0, 4, 5));
        assert_eq!((enter, exit), (Crossing::new(0.75, 0), Crossing::new(1.0, 1)));
    }

    #[test]
    fn a_parallel_line_is_decided_by_its_origin() {
        let (mut enter, mut exit) = whole_line();
        assert!(clip(&mut enter, &mut exit, 0.5, 0.0, 0, 1));
        assert_eq!((enter, exit), whole_line());
        assert!(!clip(&mut enter, &mut exit, 0.5000001, 0.0, 0, 1));
        assert!(!clip(&mut enter, &mut exit, f64::NEG_INFINITY, 0.0, 0, 1));
        // A NaN origin is left to the span's own test.
        assert!(clip(&mut enter, &mut exit, f64::NAN, 0.0, 0, 1));
    }
}
