//! Insertion sort for frame-to-frame coherent data, with a budget.
//!
//! Owns one algorithm shared by the VADOP lists and the pseudo-dynamic baseline: insertion sort,
//! which costs O(n + moves) and so is near-linear when little moved since the last frame; when
//! the moves pass a linear budget (first frame, mass insertions, tile changes) it finishes with a
//! merge sort instead, so no frame ever costs O(n^2). It knows nothing about what it sorts.

/// Sorts `items` by `less`; returns the number of single-place moves insertion sort made.
pub fn coherent_sort<T: Copy>(items: &mut [T], less: impl Fn(&T, &T) -> bool) -> u64 {
    let budget = 8 * items.len() as u64 + 1024;
    let mut moves = 0u64;
    for i in 1..items.len() {
        let item = items[i];
        let mut j = i;
        while j > 0 && less(&item, &items[j - 1]) {
            items[j] = items[j - 1];
            j -= 1;
        }
        moves += (i - j) as u64;
        items[j] = item;
        if moves > budget {
            items.sort_by(|a, b| {
                if less(a, b) {
                    std::cmp::Ordering::Less
                } else if less(b, a) {
                    std::cmp::Ordering::Greater
                } else {
                    std::cmp::Ordering::Equal
                }
            });
            break;
        }
    }
    moves
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coherent_sort_example() {
        let mut v = vec![1.0, 3.0, 2.0, 4.0];
        assert_eq!(coherent_sort(&mut v, |a: &f64, b: &f64| a < b), 1);
        assert_eq!(v, [1.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn reversed_input_falls_back_and_still_sorts() {
        let mut v: Vec<u32> = (0..100_000).rev().collect();
        let moves = coherent_sort(&mut v, |a, b| a < b);
        assert!(moves <= 8 * 100_000 + 1024 + 100_000);
        assert!(v.windows(2).all(|w| w[0] <= w[1]));
    }
}
