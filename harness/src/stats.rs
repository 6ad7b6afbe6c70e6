//! Small statistics shared by the run summaries, tables and timings.

/// Median of a non-empty slice (`None` when empty).
pub fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 { values[n / 2] } else { 0.5 * (values[n / 2 - 1] + values[n / 2]) })
}

/// Shifted geometric mean `(prod (v_i + shift))^(1/n) - shift` (the aggregate of H. Mittelmann's
/// benchmarks and of SCIP): a geometric mean, so one hard instance does not decide it, whose
/// shift keeps values far below `shift` from dominating. `None` when empty or when some
/// `v_i + shift` is not positive and finite.
pub fn shifted_geometric_mean(values: &[f64], shift: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut log_sum = 0.0;
    for v in values {
        let x = v + shift;
        if !(x > 0.0 && x.is_finite()) {
            return None;
        }
        log_sum += x.ln();
    }
    Some((log_sum / values.len() as f64).exp() - shift)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians() {
        assert_eq!(median(&mut []), None);
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), Some(2.5));
    }

    #[test]
    fn shifted_geometric_means() {
        let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-9 * b.abs().max(1.0));
        // Shift 0: the plain geometric mean.
        assert!(close(shifted_geometric_mean(&[1.0, 10.0, 100.0], 0.0), 10.0));
        // (11 * 20 * 110)^(1/3) - 10
        assert!(close(shifted_geometric_mean(&[1.0, 10.0, 100.0], 10.0), 24_200f64.cbrt() - 10.0));
        // Equal values give the value, whatever the shift.
        assert!(close(shifted_geometric_mean(&[7.0, 7.0], 10.0), 7.0));
        // A huge shift tends to the arithmetic mean.
        assert!((shifted_geometric_mean(&[1.0, 3.0], 1e9).unwrap() - 2.0).abs() < 1e-6);
        // One hard instance moves it far less than it moves the arithmetic mean (37).
        assert!(shifted_geometric_mean(&[1.0, 10.0, 100.0], 10.0).unwrap() < 20.0);
        assert_eq!(shifted_geometric_mean(&[], 10.0), None);
        assert_eq!(shifted_geometric_mean(&[-20.0], 10.0), None);
        assert_eq!(shifted_geometric_mean(&[f64::INFINITY], 10.0), None);
    }
}
