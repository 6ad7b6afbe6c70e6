//! Grouping by key with a counting sort: the CSR layout of the mesh's adjacency, of sparse
//! patterns, of the orderings' graphs and of the assembly's chunks. Its callers pass only keys in range (vertices of
//! proper faces, or the indices of an analysed sparse pattern), so it may panic on others.

/// `items` grouped by key (every key `< n`), each group sorted: a CSR `(start, values)` with
/// the group of key `k` at `values[start[k]..start[k + 1]]`. The same order as one sort of
/// all `(key, value)` pairs, at O(items + n) plus the sorts of the (small) groups: on the
/// million-vertex meshes one sort of all half-edges was most of `validate`'s time.
///
/// `items` must yield the same sequence on both calls (a count pass, then a fill pass).
///
/// # Panics
/// When a key is `>= n`: callers pass only the vertices of proper faces or the row and
/// column indices of a sparse pattern with `n` columns.
pub(crate) fn grouped<T: Ord + Copy + Default, I: Iterator<Item = (usize, T)>>(
    n: usize,
    items: impl Fn() -> I,
) -> (Vec<usize>, Vec<T>) {
    let mut start = vec![0usize; n + 1];
    for (k, _) in items() {
        start[k + 1] += 1;
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut values = vec![T::default(); start[n]];
    for (k, v) in items() {
        values[fill[k]] = v;
        fill[k] += 1;
    }
    for k in 0..n {
        values[start[k]..start[k + 1]].sort_unstable();
    }
    (start, values)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Grouping is one sort of all `(key, value)` pairs, cut at the keys.
    #[test]
    fn grouped_is_one_sort_of_the_pairs() {
        let pairs: Vec<(usize, (usize, bool))> =
            (0..500).map(|i| ((i * 7919) % 13, ((i * 104729) % 17, i % 3 == 0))).collect();
        let (start, values) = grouped(15, || pairs.iter().copied());
        let mut sorted = pairs.clone();
        sorted.sort_unstable();
        assert_eq!(values, sorted.iter().map(|p| p.1).collect::<Vec<_>>());
        for k in 0..15 {
            assert_eq!(start[k + 1] - start[k], pairs.iter().filter(|p| p.0 == k).count());
        }
        assert_eq!((start[13], start[15]), (500, 500), "keys 13 and 14 are empty");
    }
}
