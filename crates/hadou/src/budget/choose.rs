//! Picking one level per effect: the least summed error whose predicted cost fits the budget (a
//! multiple-choice knapsack, small: a few effects of a few levels each, searched whole), and when
//! to leave the levels in use alone.

/// Searched whole up to this many combinations; beyond it, greedily (never reached by hadou's
/// own effects: 4 × 4 levels).
pub const MAX_COMBINATIONS: usize = 1 << 16;
/// A choice more exact than the one in use is taken only if it is predicted at least this share
/// under the budget: predictions near the budget would otherwise switch back and forth.
pub const MARGIN: f64 = 0.05;

/// Levels, one per effect, with their predicted cost (with the fixed passes) and summed error.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// A level per effect.
    pub levels: Vec<usize>,
    /// Predicted ms with the fixed passes.
    pub cost: f64,
    /// The summed error bound.
    pub error: f64,
    /// The cost fits the budget.
    pub fits: bool,
}

/// Each effect's levels as (predicted ms, error bound).
pub type Options = [Vec<(f64, f64)>];

fn evaluate(budget: f64, fixed: f64, options: &Options, levels: Vec<usize>) -> Choice {
    let cost = fixed + levels.iter().zip(options).map(|(&l, o)| o[l].0).sum::<f64>();
    let error = levels.iter().zip(options).map(|(&l, o)| o[l].1).sum();
    Choice { levels, cost, error, fits: cost <= budget }
}

/// Whether `a` is the better choice: fitting first, then the least error (fitting) or the least
/// cost (not fitting), the other as the tie-break.
fn better(a: &Choice, b: &Choice) -> bool {
    match (a.fits, b.fits) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => (a.error, a.cost) < (b.error, b.cost),
        (false, false) => (a.cost, a.error) < (b.cost, b.error),
    }
}

/// The best levels for `budget` ms given the passes without levels take `fixed` ms. A NaN cost
/// never fits.
pub fn choose(budget: f64, fixed: f64, options: &Options) -> Choice {
    let combinations = options.iter().try_fold(1usize, |n, o| n.checked_mul(o.len().max(1)));
    if options.iter().any(|o| o.is_empty()) {
        return evaluate(budget, fixed, &[], Vec::new());
    }
    match combinations {
        Some(n) if n <= MAX_COMBINATIONS => exhaustive(budget, fixed, options, n),
        _ => greedy(budget, fixed, options),
    }
}

fn exhaustive(budget: f64, fixed: f64, options: &Options, n: usize) -> Choice {
    let mut best: Option<Choice> = None;
    for mut k in 0..n {
        let levels = options
            .iter()
            .map(|o| {
                let l = k % o.len();
                k /= o.len();
                l
            })
            .collect();
        let c = evaluate(budget, fixed, options, levels);
        if best.as_ref().is_none_or(|b| better(&c, b)) {
            best = Some(c);
        }
    }
    best.unwrap_or_else(|| evaluate(budget, fixed, options, vec![0; options.len()]))
}

/// From every level 0, the move to a cheaper level that gives up the least error per ms saved,
/// until the cost fits or nothing is cheaper.
fn greedy(budget: f64, fixed: f64, options: &Options) -> Choice {
    let mut c = evaluate(budget, fixed, options, vec![0; options.len()]);
    while !c.fits {
        let mut best: Option<(f64, usize, usize)> = None;
        for (e, o) in options.iter().enumerate() {
            let (cost, error) = o[c.levels[e]];
            for (l, &(cl, el)) in o.iter().enumerate() {
                let saved = cost - cl;
                if saved > 0.0 || (cost.is_nan() && cl.is_finite()) {
                    let rate = if saved > 0.0 { (el - error) / saved } else { f64::NEG_INFINITY };
                    if best.is_none_or(|b| rate < b.0) {
                        best = Some((rate, e, l));
                    }
                }
            }
        }
        let Some((_, e, l)) = best else { break };
        let mut levels = c.levels.clone();
        levels[e] = l;
        c = evaluate(budget, fixed, options, levels);
    }
    c
}

/// The levels to use next: the best choice, unless the levels in use still fit and the best
/// one is not clearly better (more exact and at least `MARGIN` under the budget, or as exact and
/// cheaper).
pub fn decide(budget: f64, fixed: f64, options: &Options, current: &[usize]) -> Choice {
    let best = choose(budget, fixed, options);
    let valid = current.len() == options.len() && current.iter().zip(options).all(|(&l, o)| l < o.len());
    if !valid {
        return best;
    }
    let now = evaluate(budget, fixed, options, current.to_vec());
    let switch = !now.fits
        || (best.error < now.error && best.cost <= budget * (1.0 - MARGIN))
        || (best.error == now.error && best.cost < now.cost);
    if switch {
        best
    } else {
        now
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave_and_light() -> Vec<Vec<(f64, f64)>> {
        vec![
            vec![(10.0, 0.0), (8.0, 1e-4), (6.0, 1e-3), (5.0, 1e-2)],
            vec![(4.0, 1e-3), (2.0, 2e-3), (1.0, 4e-3)],
        ]
    }

    #[test]
    fn the_least_error_that_fits() {
        let o = wave_and_light();
        assert_eq!(choose(100.0, 3.0, &o).levels, [0, 0]);
        // 3 + 10 + 4 = 17 does not fit 14; of the 13s, [1, 1] (error 1e-4 + 2e-3) loses to [2, 0]
        // (1e-3 + 1e-3).
        let c = choose(14.0, 3.0, &o);
        assert_eq!(c.levels, [2, 0]);
        assert!(c.fits && (c.error - 2e-3).abs() < 1e-15);
        // Nothing fits: the cheapest.
        let c = choose(5.0, 3.0, &o);
        assert_eq!((c.levels.as_slice(), c.fits), ([3, 2].as_slice(), false));
    }

    #[test]
    fn halving_the_budget_never_lowers_the_error_nor_raises_the_cost() {
        // A small generator (no dependency): effects of 1–4 levels, costs falling and errors
        // rising level by level.
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..300 {
            let effects = 1 + (next() * 4.0) as usize;
            let options: Vec<Vec<(f64, f64)>> = (0..effects)
                .map(|_| {
                    let (mut cost, mut error) = (1.0 + 20.0 * next(), 0.0);
                    (0..1 + (next() * 4.0) as usize)
                        .map(|_| {
                            let level = (cost, error);
                            cost *= 0.3 + 0.7 * next();
                            error += 1e-3 * next();
                            level
                        })
                        .collect()
                })
                .collect();
            let fixed = 5.0 * next();
            let mut budget = 100.0;
            let mut last = choose(budget, fixed, &options);
            for _ in 0..8 {
                budget /= 2.0;
                let c = choose(budget, fixed, &options);
                assert!(c.error >= last.error, "{options:?} at {budget}: {c:?} after {last:?}");
                assert!(c.cost <= last.cost, "{options:?} at {budget}: {c:?} after {last:?}");
                last = c;
            }
        }
    }

    #[test]
    fn the_levels_in_use_stay_unless_clearly_beaten() {
        let o = wave_and_light();
        // In use: [2, 0] at 13 of 14, the best there. At 100, [0, 0] is more exact and far under.
        assert_eq!(decide(14.0, 3.0, &o, &[2, 0]).levels, [2, 0]);
        assert_eq!(decide(100.0, 3.0, &o, &[2, 0]).levels, [0, 0]);
        // [0, 0] costs 17: at 17.5 it fits but not by the margin, so [1, 0] (15) stays.
        assert_eq!(decide(17.5, 3.0, &o, &[1, 0]).levels, [1, 0]);
        // Over the budget: always switched.
        assert_eq!(decide(14.0, 3.0, &o, &[0, 0]).levels, [2, 0]);
        // A stale choice (another effect count) is replaced.
        assert_eq!(decide(100.0, 3.0, &o, &[0]).levels, [0, 0]);
    }

    #[test]
    fn greedy_beyond_the_search_and_nan_costs() {
        let many: Vec<Vec<(f64, f64)>> = (0..20).map(|_| vec![(2.0, 0.0), (1.0, 1e-3)]).collect();
        let c = choose(30.0, 0.0, &many);
        assert!(c.fits && c.cost == 30.0 && (c.error - 10e-3).abs() < 1e-12, "{c:?}");
        let c = choose(10.0, 0.0, &[vec![(f64::NAN, 0.0), (1.0, 1e-2)]]);
        assert_eq!((c.levels.as_slice(), c.fits), ([1].as_slice(), true));
        assert!(choose(10.0, 0.0, &[]).fits);
    }
}
