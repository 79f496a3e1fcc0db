//! The Pareto front of (time, error) points: the variants no other variant beats on both.

/// Indices of the points not dominated by any other (another point dominates p when it is no
/// worse on both coordinates and better on one; both are minimized), sorted by x then y. Points
/// with a non-finite coordinate are never on the front and never dominate.
pub fn front(points: &[(f64, f64)]) -> Vec<usize> {
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let dominates = |a: &(f64, f64), b: &(f64, f64)| a.0 <= b.0 && a.1 <= b.1 && (a.0 < b.0 || a.1 < b.1);
    let mut out: Vec<usize> = (0..points.len())
        .filter(|&i| finite(&points[i]))
        .filter(|&i| !points.iter().any(|q| finite(q) && dominates(q, &points[i])))
        .collect();
    out.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(points[a].1.total_cmp(&points[b].1)));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_undominated_points_in_x_order() {
        // (1, 10) fast and rough, (5, 1) slow and exact, (3, 3) between: all on the front;
        // (4, 5) is beaten by (3, 3); (6, 1) by (5, 1) (same error, slower).
        let pts = [(5.0, 1.0), (4.0, 5.0), (1.0, 10.0), (3.0, 3.0), (6.0, 1.0)];
        assert_eq!(front(&pts), [2, 3, 0]);
    }

    #[test]
    fn ties_non_finite_and_empty() {
        // Two identical points do not dominate each other: both stay.
        assert_eq!(front(&[(1.0, 1.0), (1.0, 1.0), (2.0, 2.0)]), [0, 1]);
        // NaN or infinite points are left out and do not hide others.
        assert_eq!(front(&[(f64::NAN, 0.0), (1.0, f64::INFINITY), (2.0, 3.0)]), [2]);
        assert_eq!(front(&[(0.0, f64::NEG_INFINITY), (2.0, 3.0)]), [1]);
        assert!(front(&[]).is_empty());
        // A single point is its own front.
        assert_eq!(front(&[(7.0, 0.5)]), [0]);
    }
}
